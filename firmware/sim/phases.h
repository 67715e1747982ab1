/*
 * phases.h - cycles spent in each loop phase, from the firmware's pin toggles.
 *
 * The firmware raises a pin for the duration of a phase (PB0 = D8 reading
 * the sensors, PB1 = D9 computing/encoding, PB2 = D10 handing bytes to
 * Serial). Each rising edge opens an occurrence, the falling edge closes it.
 * Cycles the simulated I2C bus spent inside the reading phase are counted
 * apart (simavr's I2C timing is not the real bus's).
 */
#ifndef BOARDSIM_PHASES_H
#define BOARDSIM_PHASES_H

#include <stdint.h>

enum { PHASE_READ = 0, PHASE_COMPUTE, PHASE_SEND, PHASE_COUNT };

typedef struct phase {
	const char *name;
	const char *pin;      /* e.g. "PB0" */
	int high;
	uint64_t since;       /* cycle of the rising edge */
	uint64_t count;       /* completed occurrences */
	uint64_t total;       /* cycles high, completed occurrences */
	uint64_t max;
	uint64_t bus_total;   /* of which simulated I2C bus time */
	uint64_t bus_at_rise; /* bus-time counter at the rising edge */
	uint64_t real_bus_total;   /* the same bytes at the real bus clock (TWBR) */
	uint64_t real_bus_at_rise;
} phase_t;

typedef struct phases {
	phase_t p[PHASE_COUNT];
} phases_t;

void phases_init(phases_t *ph);

/* A pin edge at cycle `now`; bus_cycles is the running I2C bus-time counter (simavr's),
 * real_bus_cycles the same transfers timed at the bus clock the firmware set. */
void phases_edge(phase_t *p, int level, uint64_t now, uint64_t bus_cycles, uint64_t real_bus_cycles);

#endif
