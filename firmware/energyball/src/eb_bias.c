#include "eb_bias.h"

#include <math.h>

#include "eb_protocol.h"

void eb_still_init(eb_still_t *s)
{
    for (uint8_t i = 0; i < 6; i++)
        s->sum[i] = s->sq[i] = 0;
    s->n = 0;
}

void eb_still_add(eb_still_t *s, const int16_t gyr[3], const int16_t acc[3])
{
    if (s->n >= EB_BIAS_SAMPLES)
        return;
    for (uint8_t i = 0; i < 6; i++) {
        int16_t v = i < 3 ? gyr[i] : acc[i - 3];
        if (s->n == 0)
            s->first[i] = v;
        int32_t d = (int32_t)v - s->first[i];
        if (d > EB_STILL_CLAMP)
            d = EB_STILL_CLAMP;
        if (d < -EB_STILL_CLAMP)
            d = -EB_STILL_CLAMP;
        s->sum[i] += d;
        s->sq[i] += d * d;
    }
    s->n++;
}

bool eb_still_is_still(const eb_still_t *s)
{
    if (s->n < EB_BIAS_SAMPLES)
        return false;
    for (uint8_t i = 0; i < 6; i++) {
        float mean = (float)s->sum[i] / s->n;
        float variance = (float)s->sq[i] / s->n - mean * mean;
        float limit = i < 3 ? EB_STILL_GYR_SD : EB_STILL_ACC_SD;
        if (variance > limit * limit)
            return false;
        if (i < 3 && fabsf((float)s->first[i] + mean) > EB_STILL_GYR_MEAN_MAX)
            return false;
    }
    return true;
}

void eb_still_mean(const eb_still_t *s, int16_t bias[3])
{
    int32_t n = s->n ? s->n : 1;
    for (uint8_t i = 0; i < 3; i++) {
        int32_t sum = s->sum[i];
        int32_t mean = (sum >= 0 ? sum + n / 2 : sum - n / 2) / n; /* half away from 0 */
        bias[i] = (int16_t)(s->first[i] + mean);
    }
}

void eb_bias_pack(uint8_t out[EB_BIAS_RECORD_SIZE], const int16_t bias[3])
{
    out[0] = 'E';
    out[1] = 'B';
    out[2] = 1;
    out[3] = 0;
    for (uint8_t i = 0; i < 3; i++) {
        out[4 + 2 * i] = (uint8_t)bias[i];
        out[5 + 2 * i] = (uint8_t)((uint16_t)bias[i] >> 8);
    }
    uint16_t crc = eb_crc16(out, EB_BIAS_RECORD_SIZE - 2, EB_CRC_INIT);
    out[EB_BIAS_RECORD_SIZE - 2] = (uint8_t)crc;
    out[EB_BIAS_RECORD_SIZE - 1] = (uint8_t)(crc >> 8);
}

bool eb_bias_unpack(const uint8_t rec[EB_BIAS_RECORD_SIZE], int16_t bias[3])
{
    uint16_t crc = eb_crc16(rec, EB_BIAS_RECORD_SIZE - 2, EB_CRC_INIT);
    if (rec[0] != 'E' || rec[1] != 'B' || rec[2] != 1 ||
        crc != (uint16_t)(rec[EB_BIAS_RECORD_SIZE - 2] | rec[EB_BIAS_RECORD_SIZE - 1] << 8))
        return false;
    for (uint8_t i = 0; i < 3; i++)
        bias[i] = (int16_t)(rec[4 + 2 * i] | rec[5 + 2 * i] << 8);
    return true;
}
