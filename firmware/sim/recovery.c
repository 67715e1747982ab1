/*
 * recovery.c - recovery after faults (see recovery.h).
 */
#include "recovery.h"

#include <math.h>
#include <string.h>

void recovery_init(recovery_t *r)
{
	memset(r, 0, sizeof(*r));
	r->last_read_s = -1.0;
}

void recovery_event(recovery_t *r, const char *kind, double now, int counts_lost)
{
	if (r->n == RECOVERY_MAX_EVENTS)
		return;
	recovery_event_t *e = &r->ev[r->n++];
	e->kind = kind;
	e->at_s = now;
	e->last_read_s = counts_lost ? r->last_read_s : -1.0;
	e->period_s = r->period_s;
	e->first_sample_s = -1.0;
	e->first_read_s = -1.0;
}

void recovery_restart(recovery_t *r)
{
	r->restarted = 1;
}

void recovery_sample(recovery_t *r, double read_s, double now)
{
	for (int i = 0; i < r->n; i++) {
		recovery_event_t *e = &r->ev[i];
		if (e->first_sample_s < 0 && read_s > e->at_s) {
			e->first_sample_s = now;
			e->first_read_s = read_s;
		}
	}
	if (!r->restarted && r->last_read_s >= 0 && read_s > r->last_read_s)
		r->period_s = read_s - r->last_read_s;
	r->restarted = 0;
	r->last_read_s = read_s;
}

void recovery_json(FILE *f, const recovery_t *r)
{
	fputc('[', f);
	for (int i = 0; i < r->n; i++) {
		const recovery_event_t *e = &r->ev[i];
		fprintf(f, "%s{\"kind\": \"%s\", \"at_s\": %.6f, ", i ? ", " : "", e->kind, e->at_s);
		if (e->first_sample_s < 0) {
			fprintf(f, "\"recovery_s\": null, \"samples_lost\": null}");
			continue;
		}
		fprintf(f, "\"recovery_s\": %.6f, ", e->first_sample_s - e->at_s);
		if (e->last_read_s >= 0 && e->period_s > 0)
			fprintf(f, "\"samples_lost\": %ld}",
				lround((e->first_read_s - e->last_read_s) / e->period_s) - 1);
		else
			fprintf(f, "\"samples_lost\": null}");
	}
	fputc(']', f);
}
