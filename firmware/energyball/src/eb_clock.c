#include "eb_clock.h"

#define US_PER_S 1000000ul

void eb_grid_set(eb_grid_t *g, uint16_t rate_hz, uint32_t k)
{
    /* round(k * 1e6 / rate) = a * 1e6 + (b * 1e6 + rate / 2) / rate with k = a * rate + b:
     * every product fits 32 bits for rate <= 1000. */
    uint32_t a = k / rate_hz, b = k % rate_hz;
    uint32_t num = b * US_PER_S + rate_hz / 2;
    g->rate_hz = rate_hz;
    g->step_us = US_PER_S / rate_hz;
    g->step_rem = (uint16_t)(US_PER_S % rate_hz);
    g->t_us = a * US_PER_S + num / rate_hz;
    g->rem = (uint16_t)(num % rate_hz);
}

uint32_t eb_grid_first_after(uint16_t rate_hz, uint32_t now_us)
{
    /* floor(now * rate / 1e6) + 1, split so that no product exceeds 32 bits */
    uint32_t s = now_us / US_PER_S, us = now_us % US_PER_S;
    return s * rate_hz + us * rate_hz / US_PER_S + 1;
}

void eb_grid_advance(eb_grid_t *g)
{
    g->t_us += g->step_us;
    g->rem = (uint16_t)(g->rem + g->step_rem);
    if (g->rem >= g->rate_hz) {
        g->rem = (uint16_t)(g->rem - g->rate_hz);
        g->t_us++;
    }
}

void eb_timer_plan(eb_timer_plan_t *t, uint16_t rate_hz, uint32_t cpu_hz)
{
    /* Prescalers 8, 64, 256, 1024: CS1 = 2, 3, 4, 5 (ATmega328P datasheet, table 15-6). */
    static const uint16_t prescalers[] = {8, 64, 256, 1024};
    uint8_t i = 0;
    while (i < 3 && cpu_hz / prescalers[i] / rate_hz > 65535u)
        i++;
    t->prescaler_bits = (uint8_t)(i + 2);
    t->us_per_tick_x16 = (uint16_t)(prescalers[i] * (16000000ul / cpu_hz));
    t->ticks_per_s = cpu_hz / prescalers[i];
    t->period = (uint16_t)(t->ticks_per_s / rate_hz);
    t->period_rem = (uint16_t)(t->ticks_per_s % rate_hz);
    t->acc = 0;
    t->rate_hz = rate_hz;
}

uint16_t eb_timer_next_period(eb_timer_plan_t *t)
{
    t->acc = (uint16_t)(t->acc + t->period_rem);
    if (t->acc >= t->rate_hz) {
        t->acc = (uint16_t)(t->acc - t->rate_hz);
        return (uint16_t)(t->period + 1);
    }
    return t->period;
}

uint16_t eb_timer_ticks(const eb_timer_plan_t *t, uint32_t us)
{
    uint32_t ticks = us * 16u / t->us_per_tick_x16;
    if (ticks > 65535u)
        ticks = 65535u;
    return ticks ? (uint16_t)ticks : 1u;
}
