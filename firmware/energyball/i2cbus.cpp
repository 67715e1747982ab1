#include "i2cbus.h"

#include <Arduino.h>

static const uint8_t SDA_MASK = _BV(PC4);
static const uint8_t SCL_MASK = _BV(PC5);
static const uint8_t CLEAR_CLOCKS = 9; /* UM10204 sec. 3.1.16: nine clock pulses */
/* Half an SCL period of 100 kHz: Standard-mode t_LOW >= 4.7 us, t_HIGH >= 4.0 us
 * (UM10204 table 10). */
static const uint8_t HALF_PERIOD_US = 5;

/* Open drain by hand: a line is pulled low by making its pin an output (PORT is 0),
 * and let go by making it an input; the breakout's pull-ups raise it. */
static void line_low(uint8_t mask)
{
    DDRC |= mask;
    delayMicroseconds(HALF_PERIOD_US);
}

static void line_release(uint8_t mask)
{
    DDRC &= (uint8_t)~mask;
    delayMicroseconds(HALF_PERIOD_US);
}

void i2cbus_pullups_off()
{
    PORTC &= (uint8_t)~(SDA_MASK | SCL_MASK);
}

void i2cbus_clear()
{
    TWCR = 0; /* the TWI lets go of the pins */
    i2cbus_pullups_off();
    line_release(SDA_MASK | SCL_MASK);
    for (uint8_t i = 0; i < CLEAR_CLOCKS; i++) {
        line_low(SCL_MASK);
        line_release(SCL_MASK);
    }
    /* STOP: SDA rises while SCL is high */
    line_low(SCL_MASK);
    line_low(SDA_MASK);
    line_release(SCL_MASK);
    line_release(SDA_MASK);
}
