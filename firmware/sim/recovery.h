/*
 * recovery.h - how long the board takes to send good samples again after a fault.
 *
 * Each fault (a host opening the port, an AVR reset, a drop-out of the IMU's
 * supply, a hung loop) is an event at a simulated time. The board has recovered
 * with the first RAW or FUSED frame whose sensors were read after the event, so a
 * frame read before a glitch and still on the wire after it does not count. When
 * a sample was read comes from the loop-phase pins (phases.h): the firmware hands
 * a sample to Serial (D10) right after reading it (D8), and at 500000 baud the
 * frame is on the wire (32 bytes, 0.64 ms) before the next read is over (at least
 * the MPU's burst, 1.9 ms at 100 kHz), so the sample frame that ends next is the
 * one handed last. Recovery time is from the event to the end of that frame on
 * the UART; samples lost are those the rate in force before the event would have
 * given between the last sample read before it and the first read after it.
 */
#ifndef BOARDSIM_RECOVERY_H
#define BOARDSIM_RECOVERY_H

#include <stdint.h>
#include <stdio.h>

#define RECOVERY_MAX_EVENTS 64 /* events past these are not followed (a run has a handful) */

typedef struct recovery_event {
	const char *kind;      /* "open", "reset", "glitch", "hang" */
	double at_s;           /* simulated time of the event */
	double last_read_s;    /* the newest sample before it was read then; < 0 none */
	double period_s;       /* the sample period in force before it; 0 unknown */
	double first_sample_s; /* the first good frame after it ended on the UART; < 0 not yet */
	double first_read_s;   /* and was read then */
} recovery_event_t;

typedef struct recovery {
	recovery_event_t ev[RECOVERY_MAX_EVENTS];
	int n;
	double last_read_s;    /* the newest sample frame's read time; < 0 none yet */
	double period_s;       /* between the two newest samples of one run of the sketch */
	int restarted;         /* no sample yet since the sketch restarted */
} recovery_t;

void recovery_init(recovery_t *r);
/* A fault at simulated time now; counts_lost: the samples before it were heard, so the
 * gap is samples lost (not for a host's open: nobody was listening). */
void recovery_event(recovery_t *r, const char *kind, double now, int counts_lost);
/* The AVR was reset: the next sample starts a new run of the sketch. */
void recovery_restart(recovery_t *r);
/* A RAW or FUSED frame read at read_s ended on the UART at simulated time now. */
void recovery_sample(recovery_t *r, double read_s, double now);
/* The events as a JSON array (recovery_s and samples_lost null where unknown). */
void recovery_json(FILE *f, const recovery_t *r);

#endif
