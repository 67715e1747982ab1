/* EnergyBall wire protocol v1, board side (firmware/PROTOCOL.md). */
#include "eb_protocol.h"

#include <math.h>
#include <string.h>

/* One byte of PROTOCOL.md sec. 2's CRC (polynomial P = x^16 + x^12 + x^5 + 1, MSB
 * first), the eight bitwise steps at once: crc' = (crc << 8) + x x^16 mod P with
 * x = (crc >> 8) ^ byte. As x^16 = x^12 + x^5 + 1 mod P, x x^16 = x (x^12 + x^5 + 1),
 * whose bits 16..19, (x >> 4) x^16, reduce the same way to below x^16; so
 * x x^16 mod P = y (x^12 + x^5 + 1) mod x^16 with y = x ^ (x >> 4). About 30 cycles a
 * byte on the AVR instead of 100 for the bit loop. */
static uint16_t eb_crc16_update(uint16_t crc, uint8_t byte)
{
    uint8_t x = (uint8_t)(crc >> 8) ^ byte;
    x ^= (uint8_t)(x >> 4);
    return (uint16_t)((crc << 8) ^ ((uint16_t)x << 12) ^ ((uint16_t)x << 5) ^ x);
}

uint16_t eb_crc16(const uint8_t *data, size_t n, uint16_t crc)
{
    while (n--)
        crc = eb_crc16_update(crc, *data++);
    return crc;
}

int eb_payload_size(uint8_t type)
{
    switch (type) {
    case EB_RAW: return EB_RAW_LEN;
    case EB_FUSED: return EB_FUSED_LEN;
    case EB_HELLO: return EB_HELLO_LEN;
    case EB_ACK: return EB_ACK_LEN;
    case EB_TEMP: return EB_TEMP_LEN;
    case EB_START: case EB_STOP: case EB_IDENTIFY: case EB_RESET: return 0;
    case EB_SET_RATE: return 2;
    case EB_SET_MODE: return 1;
    default: return -1;
    }
}

/* ------------------------------------------------------------- encoding */

static uint8_t *put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v; /* little endian, sec. 2 */
    p[1] = (uint8_t)(v >> 8);
    return p + 2;
}

static uint8_t *put_u32(uint8_t *p, uint32_t v)
{
    return put_u16(put_u16(p, (uint16_t)v), (uint16_t)(v >> 16));
}

static uint8_t *put_i16s(uint8_t *p, const int16_t *v, uint8_t n)
{
    while (n--)
        p = put_u16(p, (uint16_t)*v++);
    return p;
}

/* Sync, len and type before the payload; the CRC over len, type and payload after it. */
static size_t seal(uint8_t *out, uint8_t type, uint8_t len)
{
    out[0] = EB_SYNC0;
    out[1] = EB_SYNC1;
    out[2] = len;
    out[3] = type;
    put_u16(out + EB_HEADER_SIZE + len, eb_crc16(out + 2, (size_t)len + 2, EB_CRC_INIT));
    return EB_FRAME_SIZE(len);
}

size_t eb_encode_raw(uint8_t *out, const eb_raw_t *s)
{
    static const int16_t no_mag[3] = {0, 0, 0}; /* sec. 4.1: sent as 0 when not valid */
    uint16_t flags = (uint16_t)((s->flex_adc & 0x3FFu) | (uint16_t)(s->acc_fs & 3u) << 10 |
                                (uint16_t)(s->gyr_fs & 3u) << 12);
    if (s->mag_valid)
        flags |= 1u << 14;
    if (s->mag_overflow)
        flags |= 1u << 15;
    uint8_t *p = put_u16(put_u32(out + EB_HEADER_SIZE, s->t_us), s->seq);
    p = put_i16s(put_i16s(p, s->acc, 3), s->gyr, 3);
    put_u16(put_i16s(p, s->mag_valid ? s->mag : no_mag, 3), flags);
    return seal(out, EB_RAW, EB_RAW_LEN);
}

static int16_t saturating_round(float x)
{
    if (!(x == x))
        return 0; /* NaN */
    if (x >= 32767.0f)
        return 32767;
    if (x <= -32768.0f)
        return -32768;
    return (int16_t)lrintf(x); /* nearest, ties to even (the default rounding mode) */
}

int16_t eb_q14(float x) { return saturating_round(x * 16384.0f); }
int16_t eb_centi(float x) { return saturating_round(x * 100.0f); }

size_t eb_encode_fused(uint8_t *out, const eb_fused_t *s)
{
    int16_t v[5];
    for (uint8_t i = 0; i < 4; i++)
        v[i] = eb_q14(s->q[i]);
    v[4] = eb_centi(s->flex_deg);
    put_i16s(put_u16(put_u32(out + EB_HEADER_SIZE, s->t_us), s->seq), v, 5);
    return seal(out, EB_FUSED, EB_FUSED_LEN);
}

size_t eb_encode_hello(uint8_t *out, const eb_hello_t *h)
{
    uint8_t *p = out + EB_HEADER_SIZE;
    *p++ = EB_PROTOCOL_VERSION;
    *p++ = h->fw_major;
    *p++ = h->fw_minor;
    *p++ = h->fw_patch;
    *p++ = h->imu_whoami;
    *p++ = h->mag_whoami;
    p = put_u16(p, h->rate_hz);
    *p++ = h->mode;
    *p++ = h->streaming;
    *p++ = h->acc_fs;
    *p++ = h->gyr_fs;
    put_u16(p, h->errors);
    return seal(out, EB_HELLO, EB_HELLO_LEN);
}

size_t eb_encode_ack(uint8_t *out, uint8_t command, uint8_t status)
{
    out[EB_HEADER_SIZE] = command;
    out[EB_HEADER_SIZE + 1] = status;
    return seal(out, EB_ACK, EB_ACK_LEN);
}

size_t eb_encode_temp(uint8_t *out, uint32_t t_us, int16_t temp_counts)
{
    put_u16(put_u32(out + EB_HEADER_SIZE, t_us), (uint16_t)temp_counts);
    return seal(out, EB_TEMP, EB_TEMP_LEN);
}

/* ------------------------------------------------------------- decoding */

void eb_parser_init(eb_parser_t *p)
{
    p->n = 0;
}

void eb_parser_push(eb_parser_t *p, uint8_t byte)
{
    if (p->n == EB_PARSER_CAP) /* cannot happen: candidates longer than the cap are rejected */
        p->n = 0;
    p->buf[p->n++] = byte;
}

static void drop(eb_parser_t *p, uint8_t k)
{
    p->n = (uint8_t)(p->n - k);
    memmove(p->buf, p->buf + k, p->n);
}

/* Sec. 9.1 step 1: skip to the next A5 5A, keeping a final A5. */
static void find_sync(eb_parser_t *p)
{
    uint8_t i = 0;
    while (i < p->n && !(p->buf[i] == EB_SYNC0 && (i + 1 == p->n || p->buf[i + 1] == EB_SYNC1)))
        i++;
    drop(p, i);
}

static void decode_command(const uint8_t *frame, eb_command_t *cmd)
{
    cmd->type = frame[3];
    cmd->arg = 0;
    if (cmd->type == EB_SET_RATE)
        cmd->arg = (uint16_t)(frame[4] | frame[5] << 8);
    else if (cmd->type == EB_SET_MODE)
        cmd->arg = frame[4];
}

bool eb_parser_next(eb_parser_t *p, eb_command_t *cmd)
{
    for (;;) {
        find_sync(p);
        if (p->n < EB_HEADER_SIZE)
            return false;
        uint8_t len = p->buf[2], type = p->buf[3];
        int expected = eb_payload_size(type);
        unsigned size = EB_FRAME_SIZE(len);
        if ((expected >= 0 && expected != len) || size > EB_PARSER_CAP) {
            drop(p, 1); /* step 2: not a frame (or too long to hold): skip the A5 */
            continue;
        }
        if (p->n < size)
            return false; /* step 3: wait for the whole candidate */
        uint16_t crc = eb_crc16(p->buf + 2, (size_t)len + 2, EB_CRC_INIT);
        if (crc != (uint16_t)(p->buf[size - 2] | p->buf[size - 1] << 8)) {
            drop(p, 1); /* step 4: bad CRC, rescan from the next byte */
            continue;
        }
        bool is_command = type >= 0x80 && expected >= 0;
        if (is_command)
            decode_command(p->buf, cmd);
        drop(p, (uint8_t)size); /* step 5; board-to-host and unknown types are skipped */
        if (is_command)
            return true;
    }
}
