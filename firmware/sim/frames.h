/*
 * frames.h - counts the EnergyBall frames in the bytes the board sends.
 *
 * A small incremental scanner after firmware/PROTOCOL.md section 9.1: find
 * the sync A5 5A, wait for len + 6 bytes, check the CRC-16/CCITT-FALSE over
 * len, type and payload; accept, or skip one byte and search again. It only
 * counts (the host decoder in tracker/protocol.py is the real one).
 */
#ifndef BOARDSIM_FRAMES_H
#define BOARDSIM_FRAMES_H

#include <stdint.h>

#define FRAME_MAX 261 /* 4 header + 255 payload + 2 CRC */

typedef struct frame_counter {
	uint8_t buf[2 * FRAME_MAX];
	unsigned len;
	uint64_t bytes;
	uint64_t frames;
	uint64_t crc_errors;
	uint64_t by_type[256];
} frame_counter_t;

void frames_init(frame_counter_t *fc);
void frames_feed(frame_counter_t *fc, uint8_t byte);

/* CRC-16/CCITT-FALSE (poly 0x1021, init given, MSB first, no final xor). */
uint16_t frames_crc16(uint16_t crc, const uint8_t *data, unsigned n);

#endif
