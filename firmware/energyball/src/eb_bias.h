/* Gyroscope bias at boot (the idea of the IMU and infrared hand-tracking paper's
 * eq. 2: at rest the gyroscope's mean is its offset; rest judged by the readings'
 * spread), and the record that keeps it in EEPROM, checked by a CRC, for boots when
 * the board is moving.
 */
#ifndef EB_BIAS_H
#define EB_BIAS_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define EB_BIAS_SAMPLES 128
/* Wait after configuring the MPU-9250 before measuring: the gyroscope's start-up time
 * (35 ms, product specification PS-MPU-9250A-01 sec. 3.1 table 1) and several of the
 * DLPF's delays (5.9 ms at 41 Hz, register map RM-MPU-9250A-00 sec. 4.6), with margin. */
#define EB_BIAS_SETTLE_MS 100
/* Rest: every axis's standard deviation over the samples within 4 times the data
 * sheet's noise at the boot configuration (+-2000 deg/s, +-16 g, DLPF 41 / 44.8 Hz):
 * gyroscope 0.01 deg/s/sqrt(Hz) x sqrt(41 Hz) x 16.4 LSB/(deg/s) = 1.05 counts
 * (PS-MPU-9250A-01 table 1), accelerometer 300 ug/sqrt(Hz) x sqrt(44.8 Hz) x 2048 LSB/g
 * = 4.1 counts (table 2). In counts at the boot full scales. */
#define EB_STILL_GYR_SD 4.2f
#define EB_STILL_ACC_SD 16.4f
/* A steady turn has no spread: a mean rate beyond the chip's zero-rate output tolerance,
 * +-5 deg/s at 25 degC and up to +-30 deg/s more over -40..85 degC (PS-MPU-9250A-01
 * table 1), so 35 deg/s x 16.4 LSB/(deg/s), is a board turning, not a bias (the host's
 * start-up hold draws the same line, tracker/calibration.py max_bias). */
#define EB_STILL_GYR_MEAN_MAX 574
/* Deviations from the first sample are clamped to this before squaring, so the sums
 * fit 32 bits; any axis that moves so far is far from still anyway. */
#define EB_STILL_CLAMP 2047

typedef struct {
    int16_t first[6]; /* gyro xyz, accel xyz: the first sample */
    int32_t sum[6], sq[6]; /* deviations from it, and their squares */
    uint8_t n;
} eb_still_t;

void eb_still_init(eb_still_t *s);
void eb_still_add(eb_still_t *s, const int16_t gyr[3], const int16_t acc[3]);
/* Whether EB_BIAS_SAMPLES samples were added, every axis's spread is within its limit and
 * the gyroscope's mean within EB_STILL_GYR_MEAN_MAX. */
bool eb_still_is_still(const eb_still_t *s);
/* The mean gyroscope reading, rounded: the bias in counts. */
void eb_still_mean(const eb_still_t *s, int16_t bias[3]);

/* EEPROM record: "EB", version 1, 0, bias xyz (int16 LE), CRC-16 (LE) of the 10 bytes before. */
#define EB_BIAS_RECORD_SIZE 12
void eb_bias_pack(uint8_t out[EB_BIAS_RECORD_SIZE], const int16_t bias[3]);
/* False (and bias untouched) when the record is blank or corrupt. */
bool eb_bias_unpack(const uint8_t rec[EB_BIAS_RECORD_SIZE], int16_t bias[3]);

#ifdef __cplusplus
}
#endif

#endif
