/* MPU-9250 / AK8963 over I2C, written from the InvenSense register map (RM-MPU-9250A-00
 * rev. 1.6) and the AK8963 datasheet; see src/eb_sensors.h for the register list. */
#include "imu.h"

#include <Arduino.h>
#include <Wire.h>

#include "src/eb_budget.h"
#include "src/eb_protocol.h"

static const uint32_t I2C_CLOCK_HZ = EB_I2C_CLOCK_HZ; /* the rate limits follow it (eb_budget.h) */
static const uint32_t I2C_TIMEOUT_US = 2000; /* a 14-byte burst takes about 0.4 ms */

void imu_bus_begin()
{
    Wire.begin();
    Wire.setClock(I2C_CLOCK_HZ);
    Wire.setWireTimeout(I2C_TIMEOUT_US, true);
}

static bool write_reg(uint8_t addr, uint8_t reg, uint8_t value)
{
    Wire.beginTransmission(addr);
    Wire.write(reg);
    Wire.write(value);
    return Wire.endTransmission() == 0;
}

static bool read_regs(uint8_t addr, uint8_t reg, uint8_t *out, uint8_t n)
{
    Wire.beginTransmission(addr);
    Wire.write(reg);
    if (Wire.endTransmission(false) != 0) /* repeated start before the read */
        return false;
    if (Wire.requestFrom(addr, n) != n)
        return false;
    for (uint8_t i = 0; i < n; i++)
        out[i] = (uint8_t)Wire.read();
    return true;
}

bool imu_set_rate(uint16_t rate_hz)
{
    uint8_t dlpf = eb_dlpf_for_rate(rate_hz);
    return write_reg(MPU_ADDR, MPU_CONFIG, dlpf) && write_reg(MPU_ADDR, MPU_ACCEL_CONFIG2, dlpf);
}

/* Register map sec. 4: reset, clock from the gyro PLL, all axes on, the internal
 * 1 kHz rate undivided (SMPLRT_DIV 0: the data registers are never more than 1 ms
 * old when the sample timer reads them; the DLPF band-limits them for our rate),
 * boot full scales, bypass to the AK8963 with the MPU's own I2C master off. */
static bool configure_mpu(uint16_t rate_hz)
{
    if (!write_reg(MPU_ADDR, MPU_PWR_MGMT_1, MPU_H_RESET))
        return false;
    delay(100); /* start-up after reset (product specification table 1: 100 ms max) */
    return write_reg(MPU_ADDR, MPU_PWR_MGMT_1, MPU_CLKSEL_PLL) &&
           write_reg(MPU_ADDR, MPU_PWR_MGMT_2, 0) && write_reg(MPU_ADDR, MPU_SMPLRT_DIV, 0) &&
           imu_set_rate(rate_hz) &&
           write_reg(MPU_ADDR, MPU_GYRO_CONFIG, eb_fs_register(EB_GYR_FS)) &&
           write_reg(MPU_ADDR, MPU_ACCEL_CONFIG, eb_fs_register(EB_ACC_FS)) &&
           write_reg(MPU_ADDR, MPU_USER_CTRL, 0) &&
           write_reg(MPU_ADDR, MPU_INT_PIN_CFG, MPU_BYPASS_EN);
}

static bool ak_mode(uint8_t mode)
{
    bool ok = write_reg(AK_ADDR, AK_CNTL1, mode);
    delay(1); /* AK8963 datasheet 6.4.1: at least 100 us between mode changes */
    return ok;
}

/* AK8963 datasheet sec. 6.4 and 8.3.11: read the fuse ROM's ASA values in fuse-ROM
 * mode, then continuous measurement mode 2 (100 Hz) with 16-bit output. */
static bool configure_ak(Imu &imu)
{
    return ak_mode(AK_MODE_POWER_DOWN) && ak_mode(AK_MODE_FUSE_ROM) &&
           read_regs(AK_ADDR, AK_ASAX, imu.asa, 3) && ak_mode(AK_MODE_POWER_DOWN) &&
           ak_mode(AK_MODE_CONT2_16BIT);
}

uint16_t imu_init(Imu &imu, uint16_t rate_hz)
{
    imu.whoami = imu.mag_whoami = 0;
    imu.mag_seen = false;
    if (!read_regs(MPU_ADDR, MPU_WHO_AM_I, &imu.whoami, 1) || !eb_imu_known(imu.whoami))
        return EB_ERR_IMU_MISSING;
    if (!configure_mpu(rate_hz))
        return EB_ERR_I2C_FAILURE;
    uint8_t wia = 0;
    if (!read_regs(AK_ADDR, AK_WIA, &wia, 1) || wia != AK_WIA_VALUE)
        return EB_ERR_MAG_MISSING; /* e.g. an MPU-6500: no magnetometer inside */
    if (!configure_ak(imu))
        return EB_ERR_I2C_FAILURE | EB_ERR_MAG_MISSING;
    imu.mag_whoami = wia;
    return 0;
}

bool imu_read(int16_t acc[3], int16_t gyr[3])
{
    uint8_t burst[MPU_BURST_LEN];
    if (!read_regs(MPU_ADDR, MPU_ACCEL_XOUT_H, burst, MPU_BURST_LEN))
        return false;
    eb_mpu_parse(burst, acc, gyr);
    return true;
}

bool imu_read_mag(Imu &imu)
{
    uint8_t data[AK_READ_LEN]; /* reading through ST2 ends the read (datasheet 6.4.3.2) */
    if (!read_regs(AK_ADDR, AK_ST1, data, AK_READ_LEN))
        return false;
    eb_mag_t m;
    eb_ak_parse(data, imu.asa, &m);
    if (m.ready) {
        imu.mag = m;
        imu.mag_seen = true;
    }
    return true;
}
