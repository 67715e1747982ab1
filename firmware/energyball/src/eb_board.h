/* The board's protocol state and its answers to commands (PROTOCOL.md sec. 6-7),
 * as tracker/board.py (the virtual board) behaves; the sketch does the hardware
 * side of each action. Also the error bookkeeping and the status LED's patterns.
 */
#ifndef EB_BOARD_H
#define EB_BOARD_H

#include <stdbool.h>
#include <stdint.h>

#include "eb_protocol.h"

#ifdef __cplusplus
extern "C" {
#endif

#define EB_FW_MAJOR 1
#define EB_FW_MINOR 0
#define EB_FW_PATCH 0
#define EB_BOOT_RATE_HZ 200

typedef struct {
    uint16_t rate_hz;
    uint8_t mode;
    bool streaming;
    uint16_t seq; /* samples taken since power-up or RESET, wrapping */
    uint16_t raw_sent; /* RAW frames sent since (and with) the last one a TEMP frame went
                          before; 0: none since power-up, RESET, START or a mode switch */
} eb_state_t;

/* Sec. 7.1: 200 Hz, RAW, streaming on, seq 0. */
void eb_state_power_up(eb_state_t *s);

/* Whether a TEMP frame goes right before the next RAW frame (sec. 4.3), with its t_us:
 * before the first RAW frame sent after power-up, RESET, START (even while streaming) or
 * a switch into RAW mode, and then before every rate_hz-th, once a second of samples.
 * No side effect: a RAW frame not sent leaves it due for the next one. */
bool eb_temp_due(const eb_state_t *s);

/* Count a RAW frame handed to the UART; after_temp: a TEMP frame was due before it (and
 * offered to the UART, which drops it like a sample frame when full), which starts the
 * count again at 1. Counted apart from seq, so its wrapping does not
 * matter. SET_RATE does not start the count again: the next TEMP frame is due once
 * rate_hz RAW frames (at the new rate) have been sent since the last one went, at once if
 * that many have been already (a lower rate). */
void eb_count_raw(eb_state_t *s, bool after_temp);

enum { EB_ACTION_NONE, EB_ACTION_RETIME, EB_ACTION_MODE, EB_ACTION_RESET };

typedef struct {
    bool ack; /* send ACK(command, status) first */
    uint8_t status;
    uint8_t action; /* then do this (EB_ACTION_RESET: return to the power-up state) */
    bool hello; /* then send a HELLO */
} eb_reply_t;

/* Apply a command to the state (sec. 6) and say what to send and do. */
eb_reply_t eb_execute(eb_state_t *s, const eb_command_t *c);

/* Error bits: conditions hold while true; events (I2C_FAILURE, OVERRUN) are latched
 * until reported. While any of EB_STATUS_BITS is set the board sends a HELLO once a
 * second; MAG_MISSING alone does not (an MPU-6500 has no magnetometer by design). */
#define EB_EVENT_BITS (EB_ERR_I2C_FAILURE | EB_ERR_OVERRUN)
#define EB_STATUS_BITS (EB_ERR_IMU_MISSING | EB_ERR_FLEX_RAIL | EB_EVENT_BITS)
#define EB_STATUS_PERIOD_MS 1000u

/* Flex circuit fault: every reading near a rail for as long as eb_flex_rail_seconds says. */
typedef struct {
    uint16_t run; /* consecutive readings at a rail */
} eb_rail_t;
bool eb_rail_update(eb_rail_t *r, uint16_t adc, uint16_t rate_hz);

/* Status LED (D13) patterns: whether the LED is lit at time ms. */
enum {
    EB_LED_CALIBRATING, /* steady: measuring the gyroscope bias, keep still */
    EB_LED_STREAMING, /* heartbeat: 50 ms flash a second */
    EB_LED_IDLE, /* slow blink: stopped, waiting for the host */
    EB_LED_ERROR /* fast blink, 5 Hz: IMU missing or failing */
};
bool eb_led_on(uint8_t pattern, uint32_t ms);

#ifdef __cplusplus
}
#endif

#endif
