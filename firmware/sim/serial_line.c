/*
 * serial_line.c - baud rates and receiver tolerances of the board's serial line.
 * See serial_line.h and README.md ("The serial line").
 */
#include "serial_line.h"

#include <math.h>

#define CP2104_CLOCK_HZ 48e6       /* CP2104 data sheet sec. 6.1 */
#define CP2104_PRESCALE_BELOW 365.0 /* sec. 6.1 eq. 1: prescale 4 at or below this rate, else 1 */

double avr_uart_baud(double f_cpu, unsigned ubrr, int u2x)
{
	/* Table 20-1: BAUD = fosc / (16 (UBRR + 1)), or / (8 (UBRR + 1)) with U2X0. */
	return f_cpu / ((u2x ? 8.0 : 16.0) * (ubrr + 1.0));
}

double avr_rx_tolerance_pct(int u2x)
{
	/* 8 data bits, no parity: D = 8 in tables 20-3 (U2X0 = 1) and 20-2 (U2X0 = 0). */
	return u2x ? 1.5 : 2.0;
}

double cp2104_baud(double requested)
{
	double prescale = requested <= CP2104_PRESCALE_BELOW ? 4.0 : 1.0;
	double divider = round(CP2104_CLOCK_HZ / (2.0 * prescale * requested));
	if (divider < 1.0)
		divider = 1.0;
	return CP2104_CLOCK_HZ / (2.0 * prescale * divider);
}

double baud_mismatch_pct(double sender, double receiver)
{
	return 100.0 * (sender / receiver - 1.0);
}

/* xorshift64 (Marsaglia 2003): small, seedable, the same on every machine. */
static uint64_t next_random(uint64_t *state)
{
	uint64_t x = *state;
	x ^= x << 13;
	x ^= x >> 7;
	x ^= x << 17;
	return *state = x;
}

uint8_t garble_byte(uint64_t *rng, uint8_t byte)
{
	return byte ^ (uint8_t)(1u << (next_random(rng) % 8));
}
