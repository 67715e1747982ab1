/* The sample clock: Timer1 in CTC mode (ATmega328P datasheet sec. 15.9.2) raises
 * an interrupt at every sample instant of the grid (src/eb_clock.h), the fractional
 * part of the period spread over the samples, and counts the samples due; the loop
 * takes them. */
#ifndef SAMPLER_H
#define SAMPLER_H

#include <stdint.h>

/* Start the timer at rate_hz: the first interrupt after first_us microseconds, then
 * every period; due_now counts one sample due at once. */
void sampler_start(uint16_t rate_hz, uint32_t first_us, bool due_now);
/* The number of samples that fell due since the last call (and reset it). */
uint16_t sampler_take();

#endif
