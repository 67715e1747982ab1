/* MPU-9250 / AK8963 register map and the pure parts of reading them, plus the
 * flex sensor's conversions. I/O over I2C lives in the sketch (imu.cpp); all
 * here is arithmetic, tested on the host.
 *
 * References: InvenSense "MPU-9250 Register Map and Descriptions" RM-MPU-9250A-00
 * rev. 1.6 (register numbers below, sec. 4), "MPU-9250 Product Specification"
 * PS-MPU-9250A-01 rev. 1.1, and the AK8963 datasheet (sec. 8: registers, 8.3.11
 * sensitivity adjustment). Zhu & Shi, sec. 4: the flex circuit and eq. 3.
 */
#ifndef EB_SENSORS_H
#define EB_SENSORS_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* MPU-9250 (I2C address 0x68 with AD0 low). */
#define MPU_ADDR 0x68
#define MPU_SMPLRT_DIV 0x19 /* sample rate = internal rate / (1 + div) */
#define MPU_CONFIG 0x1A /* DLPF_CFG bits 2:0 */
#define MPU_GYRO_CONFIG 0x1B /* GYRO_FS_SEL bits 4:3, FCHOICE_B bits 1:0 */
#define MPU_ACCEL_CONFIG 0x1C /* ACCEL_FS_SEL bits 4:3 */
#define MPU_ACCEL_CONFIG2 0x1D /* ACCEL_FCHOICE_B bit 3, A_DLPF_CFG bits 2:0 */
#define MPU_INT_PIN_CFG 0x37 /* BYPASS_EN bit 1 */
#define MPU_ACCEL_XOUT_H 0x3B /* 14 bytes: accel xyz, temperature, gyro xyz, big endian */
#define MPU_USER_CTRL 0x6A /* I2C_MST_EN bit 5 (must be 0 for bypass) */
#define MPU_PWR_MGMT_1 0x6B /* H_RESET bit 7, CLKSEL bits 2:0 */
#define MPU_PWR_MGMT_2 0x6C /* 0: all axes on */
#define MPU_WHO_AM_I 0x75
#define MPU_BURST_LEN 14
#define MPU_CHECKED_BURST_LEN 18 /* from INT_PIN_CFG: 0x37..0x3A, then the 14 data bytes */
#define MPU_BYPASS_EN 0x02
#define MPU_H_RESET 0x80
#define MPU_CLKSEL_PLL 0x01 /* auto-select the gyro PLL when ready */

/* WHO_AM_I values (register map sec. 4.32; the MPU-9255 and MPU-6500 answer other values). */
#define WHOAMI_MPU9250 0x71
#define WHOAMI_MPU9255 0x73
#define WHOAMI_MPU6500 0x70

/* AK8963 magnetometer, reached through bypass mode at 0x0C. */
#define AK_ADDR 0x0C
#define AK_WIA 0x00 /* device ID, 0x48 */
#define AK_ST1 0x02 /* DRDY bit 0, DOR bit 1 */
#define AK_CNTL1 0x0A /* BIT (output width) bit 4, MODE bits 3:0 */
#define AK_ASAX 0x10 /* ASAX, ASAY, ASAZ: fuse ROM sensitivity adjustment */
#define AK_READ_LEN 8 /* ST1, HXL..HZH (little endian), ST2 */
#define AK_WIA_VALUE 0x48
#define AK_MODE_POWER_DOWN 0x00
#define AK_MODE_FUSE_ROM 0x0F
#define AK_MODE_CONT2_16BIT 0x16 /* continuous measurement mode 2 (100 Hz), 16-bit output */

/* Full-scale codes of the boot configuration: +-16 g, +-2000 deg/s (PROTOCOL.md 7.1). */
#define EB_ACC_FS 3
#define EB_GYR_FS 3

/* Whether WHO_AM_I names a chip of the MPU-9250 / MPU-6500 family this firmware runs. */
bool eb_imu_known(uint8_t whoami);
/* ACCEL_CONFIG / GYRO_CONFIG value for a full-scale code (FCHOICE_B = 0: DLPF used). */
uint8_t eb_fs_register(uint8_t fs_code);
/* DLPF_CFG for a sample rate: the widest gyroscope bandwidth (250, 184, 92, 41, 20,
 * 10, 5 Hz for codes 0..6, register map sec. 4.6) at most a quarter of the rate, so
 * what is sampled is band-limited well below Nyquist; code 6 (5 Hz) at the least. */
uint8_t eb_dlpf_for_rate(uint16_t rate_hz);

/* Accelerometer, temperature and gyroscope counts from the 14-byte burst at ACCEL_XOUT_H.
 * temp is TEMP_OUT (0x41-0x42) as the chip delivers it: degC = temp / 333.87 + 21
 * (RM-MPU-9250A-00 TEMP_OUT; PS-MPU-9250A-01 sec. 3.4.2), sent in TEMP frames. */
void eb_mpu_parse(const uint8_t burst[MPU_BURST_LEN], int16_t acc[3], int16_t gyr[3], int16_t *temp);

/* One AK8963 read (ST1 .. ST2). */
typedef struct {
    int16_t mag[3]; /* in the accelerometer/gyroscope frame, sensitivity-adjusted */
    bool ready; /* ST1 DRDY: a new measurement */
    bool overflow; /* ST2 HOFL */
} eb_mag_t;

/* H * ((ASA - 128) / 256 + 1), rounded, saturated to int16 (AK8963 datasheet 8.3.11). */
int16_t eb_mag_adjust(int16_t h, uint8_t asa);
/* Parse ST1..ST2; the field goes to the accel/gyro frame, (h_y, h_x, -h_z)
 * (PROTOCOL.md sec. 4.1, product specification sec. 9.1 axis figure). */
void eb_ak_parse(const uint8_t data[AK_READ_LEN], const uint8_t asa[3], eb_mag_t *m);

/* Zhu & Shi, eq. 3: theta = -(adc - 390) / 3 degrees (0 = straight). */
float eb_flex_deg(float adc);
/* How long (s) a 10-bit flex reading must stay where it is to mean a fault; 0 where it
 * is no sign of one. Zhu & Shi's circuit (firmware/README.md, tracker/flex.py) gives at
 * most Vref = 2.5 V (512 counts, a shorted sensor): a reading within EB_FLEX_RAIL_BAND
 * of 1023 is a broken circuit, flagged after 1 s. The low rail is where an unplugged
 * sensor drives the output, but also where a bend past Rflex = Rf = 51 kOhm takes it
 * (130 degrees at the paper's 0.299 kOhm a degree from 12 kOhm; an elbow flexes to about
 * 145): a reading within the band of 0 is flagged only after EB_FLEX_LOW_RAIL_S, longer
 * than a bend is held in play. The band covers an op-amp whose output stops up to
 * 8 counts (39 mV) from a rail; the paper's full bend (50 kOhm) reads 10 counts, above it. */
#define EB_FLEX_RAIL_BAND 8
#define EB_FLEX_LOW_RAIL_S 10
uint8_t eb_flex_rail_seconds(uint16_t adc);
/* Gyroscope counts less the bias, saturated to int16: a reading at full scale stays at
 * full scale instead of wrapping to the other sign. */
int16_t eb_gyr_unbiased(int16_t counts, int16_t bias);

/* Counts to SI units (PROTOCOL.md sec. 8). */
float eb_gyr_rad_s(int16_t counts, uint8_t fs_code);
float eb_acc_m_s2(int16_t counts, uint8_t fs_code);

#ifdef __cplusplus
}
#endif

#endif
