/*
 * frames.h - counts the EnergyBall frames in the bytes the board sends.
 *
 * A small incremental scanner after firmware/PROTOCOL.md section 9.1: find
 * the sync A5 5A, reject a known type whose len is not its payload length,
 * wait for the whole frame, check the CRC over len, type and payload; accept,
 * or skip one byte and search again. The sync bytes, sizes, types and CRC are
 * the firmware's own (energyball/src/eb_protocol.h). It only counts (the host
 * decoder in tracker/protocol.py is the real one).
 */
#ifndef BOARDSIM_FRAMES_H
#define BOARDSIM_FRAMES_H

#include <stdint.h>

#include "eb_protocol.h"

#define FRAME_MAX EB_FRAME_SIZE(255) /* the longest candidate: len is one byte */

typedef struct frame_counter {
	/* An incomplete candidate is shorter than FRAME_MAX bytes and anything else
	 * is judged as soon as it arrives, so with the byte being added the buffer
	 * never holds more than FRAME_MAX. */
	uint8_t buf[FRAME_MAX];
	unsigned len;
	uint64_t bytes;
	uint64_t frames;
	uint64_t crc_errors;
	uint64_t by_type[256];
	uint16_t hello_errors; /* every HELLO's error bits (PROTOCOL.md 5.1), or-ed */
} frame_counter_t;

void frames_init(frame_counter_t *fc);
/* Take one byte; returns the type of the frame it completed, or -1. */
int frames_feed(frame_counter_t *fc, uint8_t byte);

#endif
