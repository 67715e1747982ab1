/* The I2C bus below the Wire library: freeing a bus that a slave holds, and the
 * AVR's internal pull-ups kept off. */
#ifndef I2CBUS_H
#define I2CBUS_H

#include <stdint.h>

/* Bus clear (NXP UM10204 rev. 7, sec. 3.1.16), with the TWI off: nine SCL clocks
 * as GPIO, then a STOP, so a slave caught in the middle of sending (the AVR was
 * reset during a read; the slave was not) lets go of SDA. Harmless when the bus is
 * idle: a slave not addressed ignores clocks without a START. */
void i2cbus_clear();

/* The AVR's internal pull-ups on SDA/SCL off: they pull to 5 V through 20-50 kOhm
 * (ATmega328P data sheet DS40002061, DC characteristics: R_PU), which a 3.3 V
 * breakout without level shifting must not see. Wire turns them on in every
 * begin() and after every timeout (its TWI reset calls twi_init again). */
void i2cbus_pullups_off();

#endif
