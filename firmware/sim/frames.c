/*
 * frames.c - frame counting (see frames.h).
 */
#include "frames.h"

#include <string.h>

void frames_init(frame_counter_t *fc)
{
	memset(fc, 0, sizeof(*fc));
}

static void drop(frame_counter_t *fc, unsigned n)
{
	memmove(fc->buf, fc->buf + n, fc->len - n);
	fc->len -= n;
}

/*
 * Judge the buffer from its start. Returns 1 if it made progress (bytes
 * dropped or a frame accepted), 0 if it needs more bytes; *accepted is the
 * type of a frame accepted.
 */
static int scan_once(frame_counter_t *fc, int *accepted)
{
	if (fc->len < 2)
		return 0;
	if (fc->buf[0] != EB_SYNC0 || fc->buf[1] != EB_SYNC1) {
		drop(fc, 1);
		return 1;
	}
	if (fc->len < EB_HEADER_SIZE)
		return 0;
	uint8_t len = fc->buf[2], type = fc->buf[3];
	int expected = eb_payload_size(type);
	if (expected >= 0 && expected != len) {
		drop(fc, 1); /* step 2: a known type with another len is not a frame */
		return 1;
	}
	unsigned total = EB_FRAME_SIZE(len);
	if (fc->len < total)
		return 0;
	uint16_t crc = eb_crc16(fc->buf + 2, len + 2u, EB_CRC_INIT); /* len, type, payload */
	uint16_t sent = (uint16_t)(fc->buf[total - 2] | fc->buf[total - 1] << 8);
	if (crc != sent) {
		fc->crc_errors++;
		drop(fc, 1);
		return 1;
	}
	fc->frames++;
	fc->by_type[type]++;
	if (type == EB_HELLO) /* errors: the u16 at payload offset 12 */
		fc->hello_errors |= (uint16_t)(fc->buf[EB_HEADER_SIZE + 12] | fc->buf[EB_HEADER_SIZE + 13] << 8);
	*accepted = type;
	drop(fc, total);
	return 1;
}

int frames_feed(frame_counter_t *fc, uint8_t byte)
{
	int accepted = -1;
	fc->bytes++;
	if (fc->len == sizeof(fc->buf))
		drop(fc, 1); /* cannot happen: see frame_counter_t */
	fc->buf[fc->len++] = byte;
	while (scan_once(fc, &accepted))
		;
	return accepted;
}
