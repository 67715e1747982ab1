/* MPU-9250 / AK8963 over I2C, written from the InvenSense register map (RM-MPU-9250A-00
 * rev. 1.6) and the AK8963 datasheet; see src/eb_sensors.h for the register list. */
#include "imu.h"

#include <Arduino.h>
#include <Wire.h>

#include "i2cbus.h"
#include "src/eb_budget.h"
#include "src/eb_protocol.h"

static const uint32_t I2C_CLOCK_HZ = EB_I2C_CLOCK_HZ; /* standard mode: why, in eb_budget.h */
/* Each of Wire's waits is bounded; the longest transfer, the 18-byte burst with its
 * address, is 19 x 9 clocks = 1.7 ms at 100 kHz. */
static const uint32_t I2C_TIMEOUT_US = 3000;
/* Start-up time for register read/write from power-up: 11 ms typical, 100 ms maximum
 * (PS-MPU-9250A-01 sec. 3.4.2); millis() starts 65 ms after power-up (the crystal's
 * start-up delay), so waiting until 100 ms on millis() covers it with room. */
static const uint32_t IMU_STARTUP_MS = 100;
static const uint8_t WHOAMI_RETRY_MS = 2;
/* The AK8963 measures at 100 Hz in continuous mode 2 (MS1356-E-02 sec. 6.4.3): it is
 * read once a period (at 100 kHz its 11 bytes take 1 ms of the sample's budget), and
 * a reading older than two and a half periods means it stopped. */
static const uint32_t MAG_PERIOD_MS = 10;
static const uint32_t MAG_FRESH_MS = 25;

/* Free the bus (a slave may hold SDA after an AVR reset) and start the TWI master. */
static void bus_begin()
{
    Wire.end();
    i2cbus_clear();
    Wire.begin();
    i2cbus_pullups_off();
    Wire.setClock(I2C_CLOCK_HZ);
    Wire.setWireTimeout(I2C_TIMEOUT_US, true);
}

/* After a failure Wire may have reset the TWI, which turns the pull-ups on again. */
static bool checked(bool ok)
{
    if (!ok)
        i2cbus_pullups_off();
    return ok;
}

static bool write_reg(uint8_t addr, uint8_t reg, uint8_t value)
{
    Wire.beginTransmission(addr);
    Wire.write(reg);
    Wire.write(value);
    return checked(Wire.endTransmission() == 0);
}

static bool read_regs(uint8_t addr, uint8_t reg, uint8_t *out, uint8_t n)
{
    Wire.beginTransmission(addr);
    Wire.write(reg);
    if (Wire.endTransmission(false) != 0) /* repeated start before the read */
        return checked(false);
    if (Wire.requestFrom(addr, n) != n)
        return checked(false);
    for (uint8_t i = 0; i < n; i++)
        out[i] = (uint8_t)Wire.read();
    return true;
}

/* WHO_AM_I, retried until the MPU's start-up time after its power-up (at millis()
 * powered_ms) has passed. */
static bool read_whoami(uint8_t *whoami, uint32_t powered_ms)
{
    while (!read_regs(MPU_ADDR, MPU_WHO_AM_I, whoami, 1)) {
        if (millis() - powered_ms >= IMU_STARTUP_MS)
            return false;
        delay(WHOAMI_RETRY_MS);
    }
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

uint16_t imu_init(Imu &imu, uint16_t rate_hz, uint32_t powered_ms)
{
    imu.whoami = imu.mag_whoami = 0;
    imu.mag_seen = false;
    bus_begin();
    if (!read_whoami(&imu.whoami, powered_ms) || !eb_imu_known(imu.whoami))
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

/* A supply glitch resets every register (RM-MPU-9250A-00: all 0 but PWR_MGMT_1 and
 * WHO_AM_I), and
 * the data still reads fine, at +-2 g / +-250 deg/s. So the burst starts at
 * INT_PIN_CFG (0x37, reset value 0; ours has BYPASS_EN): 0x37..0x3A, then the
 * 14 data bytes (accelerometer, TEMP_OUT, gyroscope: the temperature costs no extra
 * bus time). The check and the data come from one transfer, so no sample of
 * a reset chip is ever taken. */
ImuRead imu_read(int16_t acc[3], int16_t gyr[3], int16_t *temp)
{
    uint8_t burst[MPU_CHECKED_BURST_LEN];
    if (!read_regs(MPU_ADDR, MPU_INT_PIN_CFG, burst, MPU_CHECKED_BURST_LEN))
        return IMU_READ_FAILED;
    if (burst[0] != MPU_BYPASS_EN)
        return IMU_READ_RESET;
    eb_mpu_parse(burst + MPU_CHECKED_BURST_LEN - MPU_BURST_LEN, acc, gyr, temp);
    return IMU_READ_OK;
}

bool imu_read_mag(Imu &imu)
{
    if (imu.mag_seen && millis() - imu.mag_ms < MAG_PERIOD_MS)
        return true; /* its next measurement is not due yet */
    uint8_t data[AK_READ_LEN]; /* reading through ST2 ends the read (datasheet 6.4.3.2) */
    if (!read_regs(AK_ADDR, AK_ST1, data, AK_READ_LEN)) {
        imu.mag_seen = false; /* the held reading is not sent as valid any more */
        return false;
    }
    eb_mag_t m;
    eb_ak_parse(data, imu.asa, &m);
    if (m.ready) {
        imu.mag = m;
        imu.mag_seen = true;
        imu.mag_ms = millis();
    }
    return true;
}

bool imu_mag_valid(const Imu &imu)
{
    return imu.mag_seen && millis() - imu.mag_ms <= MAG_FRESH_MS;
}
