/*
 * i2cbus.h - the electrical side of the I2C bus that simavr 1.6's TWI leaves out.
 *
 * * Bit timing: simavr 1.6 finishes every TWI byte in 9 us whatever TWBR says.
 *   Each byte's completion is moved to 9 SCL periods after it started, with
 *   SCL = F_CPU / (16 + 2 * TWBR * 4^TWPS) (ATmega328P data sheet DS40002061,
 *   TWI "Bit Rate Generator Unit"), so the firmware waits as long as on the real bus.
 * * A slave holding SDA low: after an AVR reset in the middle of a read, the
 *   slave is still sending a byte and drives SDA low for its 0 bits; nothing
 *   the TWI does can get through (every transaction fails). It lets go once
 *   it has seen nine SCL clocks, the rest of its byte and the acknowledge slot
 *   (NXP UM10204 rev. 7, sec. 3.1.16 "Bus clear"); the model takes the
 *   strictest reading: SDA stays low for all nine, and the bus is free again
 *   only after a STOP. SCL and SDA are seen as GPIO (PC5, PC4) while the TWI
 *   is off, open drain: a pin pulls its line low when DDR = 1 and PORT = 0,
 *   else the breakout's pull-up holds it high. PINC shows the lines' levels.
 * * The AVR's internal pull-ups on PC4/PC5 (PORT = 1, DDR = 0): 20-50 kOhm to
 *   the AVR's 5 V (DS40002061, DC characteristics: R_PU), which a 3.3 V breakout
 *   without level shifting must not see; counted per simulated millisecond.
 */
#ifndef BOARDSIM_I2CBUS_H
#define BOARDSIM_I2CBUS_H

#include <stdint.h>

#include <sim_avr.h>
#include <sim_io.h>

#define I2CBUS_RELEASE_CLOCKS 9 /* UM10204 sec. 3.1.16: nine clock pulses */

typedef struct i2cbus {
	avr_io_t io;             /* registered with the AVR: reset() runs at every AVR reset */
	avr_t *avr;
	void *twi;               /* simavr's TWI (the param of its completion timer) */
	uint64_t byte_start;     /* cycle the byte in flight started */
	void (*on_reset)(void *param); /* told of every AVR reset (power-up, watchdog, --reset-at) */
	void *param;
	/* a slave holding SDA low */
	int sda_held;            /* the slave drives SDA low */
	int awaiting_stop;       /* let go after nine clocks: free at the next STOP */
	int clocks;              /* SCL rising edges since SDA was held */
	int scl, sda;            /* line levels seen from the GPIO side (1 = high) */
	uint64_t stuck, cleared; /* times the bus was stuck, and freed by a bus clear */
	uint64_t pullup_ms;      /* simulated ms with an internal pull-up on SDA or SCL */
} i2cbus_t;

/* Hook the bus to the AVR: TWI, port C, and a reset callback. */
int i2cbus_attach(i2cbus_t *bus, avr_t *avr, void (*on_reset)(void *param), void *param);

/* A slave starts holding SDA low (a reset caught it in the middle of a read). */
void i2cbus_hold_sda(i2cbus_t *bus);

/* Whether SDA is held or the bus has not seen its STOP yet: the TWI cannot use it. */
int i2cbus_blocked(const i2cbus_t *bus);

/* The TWI has put an address or data byte on the bus: it takes 9 SCL periods. */
void i2cbus_byte(i2cbus_t *bus);

/* The SCL period in CPU cycles for the TWI's present TWBR and prescaler. */
uint32_t i2cbus_scl_cycles(const avr_t *avr);

/* Once per simulated millisecond: count the internal pull-ups. */
void i2cbus_tick_ms(i2cbus_t *bus);

#endif
