/*
 * serial_line.h - the serial line between the board's USB bridge (a CP2104 on
 * the Metro Mini) and the ATmega328P's UART0: each end's real baud rate and
 * whether the receiving end can read the other's bytes.
 *
 * No simavr in here: boardsim.c reads UBRR0 / U2X0 and the host's requested
 * rate and asks these functions.
 */
#ifndef BOARDSIM_SERIAL_LINE_H
#define BOARDSIM_SERIAL_LINE_H

#include <stdint.h>

/*
 * The bridge's receiver: CP2104 data sheet rev. 1.1 sec. 6.1 gives no
 * receiver figure of its own, only the rule of thumb that each end's baud
 * error stay within +-2%.
 */
#define CP2104_RX_TOLERANCE_PCT 2.0

/* The AVR's rate for UBRR0 and U2X0 (DS40002061 sec. 20.3.1, table 20-1). */
double avr_uart_baud(double f_cpu, unsigned ubrr, int u2x);

/* The AVR receiver's recommended max error for 8N1 frames (sec. 20.8.3, tables 20-2 and 20-3). */
double avr_rx_tolerance_pct(int u2x);

/* The rate the CP2104 makes of a requested one (sec. 6.1, equations 1 and 2). */
double cp2104_baud(double requested);

/* How far the sender's rate is off the receiver's, in percent of the receiver's. */
double baud_mismatch_pct(double sender, double receiver);

/*
 * A byte as the receiver reads it when the rates disagree by more than it
 * tolerates: one bit flipped, chosen by the seeded generator *rng.
 */
uint8_t garble_byte(uint64_t *rng, uint8_t byte);

#endif
