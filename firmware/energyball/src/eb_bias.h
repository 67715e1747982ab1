/* Gyroscope bias at boot (the idea of seed 002, eq. 2: at rest the gyroscope's
 * mean is its offset; rest judged by a threshold on the readings), and the record
 * that keeps it in EEPROM, checked by a CRC, for boots when the board is moving.
 */
#ifndef EB_BIAS_H
#define EB_BIAS_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define EB_BIAS_SAMPLES 128
/* Rest thresholds, peak to peak over the samples, in counts at the boot full scales:
 * 16 counts = 1 deg/s at +-2000 deg/s (the noise is about 1 count rms with the DLPF
 * at 41 Hz), 41 counts = 20 mg at +-16 g. */
#define EB_STILL_GYR_SPAN 16
#define EB_STILL_ACC_SPAN 41

typedef struct {
    int32_t sum[3];
    int16_t lo[6], hi[6]; /* gyro xyz, accel xyz */
    uint8_t n;
} eb_still_t;

void eb_still_init(eb_still_t *s);
void eb_still_add(eb_still_t *s, const int16_t gyr[3], const int16_t acc[3]);
/* Whether EB_BIAS_SAMPLES samples were added and every axis stayed within its span. */
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
