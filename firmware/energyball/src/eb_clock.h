/* The sample grid (PROTOCOL.md sec. 7.3) and the timer periods that follow it.
 *
 * Sample k is stamped t_us = round(k * 1e6 / rate) on the device clock, counted
 * from power-up; the grid advances with 32-bit integers only (a remainder
 * carried from step to step, as Bresenham's line), so it is exact forever and
 * costs no division on the AVR. Ties round up (Python's round() rounds them to
 * even: the two differ by 1 us at k * 1e6 / rate = n + 1/2 exactly).
 */
#ifndef EB_CLOCK_H
#define EB_CLOCK_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The protocol's range of rates (PROTOCOL.md sec. 6); eb_budget.h has what the board sustains. */
#define EB_MIN_RATE_HZ 1
#define EB_MAX_RATE_HZ 1000

typedef struct {
    uint32_t t_us; /* stamp of the next sample, modulo 2^32 */
    uint32_t step_us; /* 1e6 / rate, whole part */
    uint16_t step_rem; /* 1e6 % rate */
    uint16_t rem; /* (k * 1e6 + rate / 2) % rate */
    uint16_t rate_hz;
} eb_grid_t;

/* The grid at sample k (k from power-up). */
void eb_grid_set(eb_grid_t *g, uint16_t rate_hz, uint32_t k);
/* Index of the first grid point strictly after now_us (sec. 7.3: SET_RATE keeps the
 * clock; the next sample is the new rate's first grid point after the present). */
uint32_t eb_grid_first_after(uint16_t rate_hz, uint32_t now_us);
/* Move to the next sample. */
void eb_grid_advance(eb_grid_t *g);

/* Timer1 periods that keep the sample interrupt on the grid: the ATmega328P's
 * 16-bit timer at a prescaler chosen so one period fits in 65536 ticks, the
 * fractional part of the period spread over the samples (ticks_per_s % rate
 * extra ticks per second). */
typedef struct {
    uint8_t prescaler_bits; /* TCCR1B CS12:0 (datasheet table 15-6) */
    uint16_t us_per_tick_x16; /* tick length in units of 1/16 us: the prescaler */
    uint32_t ticks_per_s;
    uint16_t period; /* ticks_per_s / rate */
    uint16_t period_rem; /* ticks_per_s % rate */
    uint16_t acc;
    uint16_t rate_hz;
} eb_timer_plan_t;

/* cpu_hz must divide 16 MHz (16, 8, 4, 2 or 1 MHz): the tick length is kept in whole
 * 1/16 us, prescaler * (16 MHz / cpu_hz), which a 20 MHz clock would make 0 (and
 * eb_timer_ticks divide by zero) and a 12 MHz one wrong. The board's F_CPU is
 * checked here, at compile time. */
#if defined(F_CPU) && (16000000UL % (F_CPU) != 0)
#error "eb_clock: F_CPU must divide 16 MHz (the timer plan counts ticks in 1/16 us)"
#endif
void eb_timer_plan(eb_timer_plan_t *t, uint16_t rate_hz, uint32_t cpu_hz);
/* Length in ticks of the next timer period. */
uint16_t eb_timer_next_period(eb_timer_plan_t *t);
/* Microseconds to ticks of this plan (for the first, partial period), at least 1. */
uint16_t eb_timer_ticks(const eb_timer_plan_t *t, uint32_t us);

#ifdef __cplusplus
}
#endif

#endif
