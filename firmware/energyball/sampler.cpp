#include "sampler.h"

#include <Arduino.h>
#include <util/atomic.h>

#include "src/eb_clock.h"

static volatile uint16_t due;
static eb_timer_plan_t plan;

ISR(TIMER1_COMPA_vect)
{
    if (due != UINT16_MAX)
        due++;
    /* CTC: the counter has just restarted at 0, so the next TOP can be set now */
    OCR1A = eb_timer_next_period(&plan) - 1;
}

void sampler_start(uint16_t rate_hz, uint32_t first_us, bool due_now)
{
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        TCCR1B = 0; /* stop; init() left Timer1 in 8-bit PWM mode for analogWrite */
        TCCR1A = 0;
        TCNT1 = 0;
        eb_timer_plan(&plan, rate_hz, F_CPU);
        OCR1A = eb_timer_ticks(&plan, first_us) - 1;
        due = due_now ? 1 : 0;
        TIFR1 = _BV(OCF1A);
        TIMSK1 = _BV(OCIE1A);
        TCCR1B = _BV(WGM12) | plan.prescaler_bits; /* CTC, TOP = OCR1A */
    }
}

uint16_t sampler_take()
{
    uint16_t n;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        n = due;
        due = 0;
    }
    return n;
}
