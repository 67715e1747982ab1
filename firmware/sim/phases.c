/*
 * phases.c - loop phase accounting (see phases.h).
 */
#include "phases.h"

#include <string.h>

void phases_init(phases_t *ph)
{
	static const char *const names[PHASE_COUNT] = { "read", "compute", "send" };
	static const char *const pins[PHASE_COUNT] = { "PB0", "PB1", "PB2" };
	memset(ph, 0, sizeof(*ph));
	for (int i = 0; i < PHASE_COUNT; i++) {
		ph->p[i].name = names[i];
		ph->p[i].pin = pins[i];
	}
}

void phases_edge(phase_t *p, int level, uint64_t now, uint64_t bus_cycles, uint64_t real_bus_cycles)
{
	level = level != 0;
	if (level == p->high)
		return; /* not an edge (simavr also reports writes of the same level) */
	p->high = level;
	if (level) {
		p->since = now;
		p->bus_at_rise = bus_cycles;
		p->real_bus_at_rise = real_bus_cycles;
		return;
	}
	uint64_t d = now - p->since;
	p->count++;
	p->total += d;
	p->bus_total += bus_cycles - p->bus_at_rise;
	p->real_bus_total += real_bus_cycles - p->real_bus_at_rise;
	if (d > p->max)
		p->max = d;
}
