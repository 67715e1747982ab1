/*
 * frames.c - frame counting (see frames.h).
 */
#include "frames.h"

#include <string.h>

void frames_init(frame_counter_t *fc)
{
	memset(fc, 0, sizeof(*fc));
}

uint16_t frames_crc16(uint16_t crc, const uint8_t *data, unsigned n)
{
	for (unsigned i = 0; i < n; i++) {
		crc ^= (uint16_t)(data[i] << 8);
		for (int b = 0; b < 8; b++)
			crc = (crc & 0x8000) ? (uint16_t)((crc << 1) ^ 0x1021) : (uint16_t)(crc << 1);
	}
	return crc;
}

static void drop(frame_counter_t *fc, unsigned n)
{
	memmove(fc->buf, fc->buf + n, fc->len - n);
	fc->len -= n;
}

/*
 * Judge the buffer from its start. Returns 1 if it made progress (bytes
 * dropped or a frame accepted), 0 if it needs more bytes.
 */
static int scan_once(frame_counter_t *fc)
{
	if (fc->len < 2)
		return 0;
	if (fc->buf[0] != 0xA5 || fc->buf[1] != 0x5A) {
		drop(fc, 1);
		return 1;
	}
	if (fc->len < 4)
		return 0;
	unsigned total = fc->buf[2] + 6u;
	if (fc->len < total)
		return 0;
	uint16_t crc = frames_crc16(0xFFFF, fc->buf + 2, total - 4);
	uint16_t sent = (uint16_t)(fc->buf[total - 2] | fc->buf[total - 1] << 8);
	if (crc != sent) {
		fc->crc_errors++;
		drop(fc, 1);
		return 1;
	}
	fc->frames++;
	fc->by_type[fc->buf[3]]++;
	drop(fc, total);
	return 1;
}

void frames_feed(frame_counter_t *fc, uint8_t byte)
{
	fc->bytes++;
	if (fc->len == sizeof(fc->buf))
		drop(fc, 1); /* cannot happen: a candidate is at most FRAME_MAX bytes */
	fc->buf[fc->len++] = byte;
	while (scan_once(fc))
		;
}
