/* EnergyBall wire protocol v1, board side: CRC, frame encoders, command parser.
 *
 * The normative text is firmware/PROTOCOL.md; tracker/protocol.py is the host
 * side and the reference these encoders match byte for byte (tests/firmware).
 * Portable C99: compiled by avr-gcc for the board and by gcc for host tests.
 */
#ifndef EB_PROTOCOL_H
#define EB_PROTOCOL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define EB_PROTOCOL_VERSION 1
#define EB_SYNC0 0xA5
#define EB_SYNC1 0x5A
#define EB_HEADER_SIZE 4 /* sync (2), len, type */
#define EB_CRC_SIZE 2

/* Frame types (PROTOCOL.md sec. 3). */
enum {
    EB_RAW = 0x01, EB_FUSED = 0x02, EB_HELLO = 0x03, EB_ACK = 0x04, EB_TEMP = 0x05,
    EB_START = 0x81, EB_STOP = 0x82, EB_SET_RATE = 0x83, EB_SET_MODE = 0x84,
    EB_IDENTIFY = 0x85, EB_RESET = 0x86
};

/* Payload and whole-frame sizes of the board's frames. */
#define EB_RAW_LEN 26
#define EB_FUSED_LEN 16
#define EB_HELLO_LEN 14
#define EB_ACK_LEN 2
#define EB_TEMP_LEN 6
#define EB_FRAME_SIZE(len) ((len) + EB_HEADER_SIZE + EB_CRC_SIZE)
#define EB_MAX_BOARD_FRAME EB_FRAME_SIZE(EB_RAW_LEN) /* 32 bytes */

enum { EB_MODE_RAW = 0, EB_MODE_FUSED = 1 };
enum { EB_ACK_OK = 0, EB_ACK_BAD_ARGUMENT = 1 };

/* Error bits of the HELLO frame (PROTOCOL.md sec. 5.1). */
enum {
    EB_ERR_IMU_MISSING = 0x01, EB_ERR_I2C_FAILURE = 0x02, EB_ERR_MAG_MISSING = 0x04,
    EB_ERR_FLEX_RAIL = 0x08, EB_ERR_OVERRUN = 0x10
};

/* CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, MSB first), PROTOCOL.md sec. 2. */
#define EB_CRC_INIT 0xFFFFu
uint16_t eb_crc16(const uint8_t *data, size_t n, uint16_t crc);

/* Payload length of a known type, or -1 for an unknown type. */
int eb_payload_size(uint8_t type);

/* A RAW sample (sec. 4.1): counts as the chips deliver them (mag already mapped). */
typedef struct {
    uint32_t t_us;
    uint16_t seq;
    int16_t acc[3], gyr[3], mag[3];
    uint16_t flex_adc; /* 0..1023 */
    uint8_t acc_fs, gyr_fs; /* full-scale codes 0..3 */
    bool mag_valid, mag_overflow;
} eb_raw_t;

/* A FUSED sample (sec. 4.2): q_WS scalar first, elbow angle in degrees. */
typedef struct {
    uint32_t t_us;
    uint16_t seq;
    float q[4];
    float flex_deg;
} eb_fused_t;

/* The HELLO payload (sec. 5.1). */
typedef struct {
    uint8_t fw_major, fw_minor, fw_patch;
    uint8_t imu_whoami, mag_whoami;
    uint16_t rate_hz;
    uint8_t mode, streaming, acc_fs, gyr_fs;
    uint16_t errors;
} eb_hello_t;

/* Encoders: write one whole frame to out (EB_FRAME_SIZE(len) bytes), return its size. */
size_t eb_encode_raw(uint8_t *out, const eb_raw_t *s);
size_t eb_encode_fused(uint8_t *out, const eb_fused_t *s);
size_t eb_encode_hello(uint8_t *out, const eb_hello_t *h);
size_t eb_encode_ack(uint8_t *out, uint8_t command, uint8_t status);
/* TEMP (sec. 4.3): the MPU-9250's TEMP_OUT as read in the burst of the sample stamped t_us. */
size_t eb_encode_temp(uint8_t *out, uint32_t t_us, int16_t temp_counts);

/* round(x * 16384) and round(x * 100), ties to even as Python's round(), saturated
 * to int16 (sec. 4.2). */
int16_t eb_q14(float x);
int16_t eb_centi(float x);

/* A host command (sec. 6); arg is the rate (SET_RATE) or the mode (SET_MODE). */
typedef struct {
    uint8_t type;
    uint16_t arg;
} eb_command_t;

/* The board's incremental decoder (sec. 9.1, accept_commands). It buffers at most
 * EB_PARSER_CAP bytes: a candidate longer than that (only an unknown type with a
 * large len can be; no command is) is not waited for but rejected like a bad CRC,
 * so garbage never delays a command by more than EB_PARSER_CAP bytes. CRC-valid
 * frames of board-to-host or unknown types are skipped. */
#define EB_PARSER_CAP 40
typedef struct {
    uint8_t buf[EB_PARSER_CAP];
    uint8_t n;
} eb_parser_t;

void eb_parser_init(eb_parser_t *p);
/* Append one received byte. */
void eb_parser_push(eb_parser_t *p, uint8_t byte);
/* Take the next complete command from the buffer; false when there is none yet. */
bool eb_parser_next(eb_parser_t *p, eb_command_t *cmd);

#ifdef __cplusplus
}
#endif

#endif
