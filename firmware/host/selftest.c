/* A C smoke test of the portable code, run by `make host-test`: the check values
 * of PROTOCOL.md (sec. 2 and 11). The thorough tests, against tracker/protocol.py
 * and the Python filter, are tests/firmware/test_firmware_host.py. */
#include <stdio.h>
#include <string.h>

#include "eb_protocol.h"

static int failures;

static void check(int ok, const char *what)
{
    if (!ok) {
        printf("FAIL: %s\n", what);
        failures++;
    }
}

int main(void)
{
    static const uint8_t ack_200[] = {0xa5, 0x5a, 0x02, 0x04, 0x83, 0x00, 0xa3, 0xfb};
    static const uint8_t raw_11_1[] = {
        0xa5, 0x5a, 0x1a, 0x01, 0x87, 0xd6, 0x12, 0x00, 0x2a, 0x00, 0x78, 0x00, 0xac, 0xfe, 0x00, 0x08,
        0xfb, 0xff, 0x11, 0x00, 0x03, 0x00, 0xc8, 0x00, 0x6a, 0xff, 0xca, 0xfe, 0x86, 0x7d, 0x5f, 0x88};
    eb_raw_t raw = {1234567, 42, {120, -340, 2048}, {-5, 17, 3}, {200, -150, -310}, 390, 3, 3, true, false};
    uint8_t out[EB_MAX_BOARD_FRAME];

    check(eb_crc16((const uint8_t *)"123456789", 9, EB_CRC_INIT) == 0x29B1, "CRC check value");
    check(eb_crc16(NULL, 0, EB_CRC_INIT) == 0xFFFF, "CRC of nothing");
    check(eb_encode_ack(out, EB_SET_RATE, EB_ACK_OK) == sizeof ack_200 &&
          memcmp(out, ack_200, sizeof ack_200) == 0, "ACK(SET_RATE, OK), sec. 11.2");
    check(eb_encode_raw(out, &raw) == sizeof raw_11_1 && memcmp(out, raw_11_1, sizeof raw_11_1) == 0,
          "RAW frame, sec. 11.1");
    printf("%s\n", failures ? "host self-test FAILED" : "host self-test passed");
    return failures != 0;
}
