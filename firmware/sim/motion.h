/*
 * motion.h - what the virtual sensors feel, as a function of simulated time.
 *
 * A motion is a table of rows read from a CSV file with the header
 *   t,gx,gy,gz,ax,ay,az[,mx,my,mz][,flex_mv]
 * (seconds, rad/s, m/s^2, microtesla, millivolts; columns in any order),
 * sampled by linear interpolation or sample-and-hold. Without a file the
 * board lies still: gravity on +z, no rotation, a constant field.
 * Units and frames follow /ARCHITECTURE.md (sensor frame, specific force).
 */
#ifndef BOARDSIM_MOTION_H
#define BOARDSIM_MOTION_H

#include <stddef.h>

/* The true quantities at one instant, in the sensor (accelerometer) frame. */
typedef struct truth {
	double gyr[3];  /* rad/s */
	double acc[3];  /* m/s^2, specific force (+9.81 on the up axis at rest) */
	double mag[3];  /* microtesla */
	double flex_mv; /* flex divider output, millivolts; < 0: not given */
} truth_t;

typedef enum { MOTION_LINEAR = 0, MOTION_HOLD } motion_interp_t;

typedef struct motion {
	double *t;      /* row times, strictly increasing */
	truth_t *rows;
	size_t n;
	motion_interp_t interp;
} motion_t;

/* Defaults of a board lying still (ARCHITECTURE.md: z up, g = 9.81 m/s^2). */
#define MOTION_GRAVITY 9.81
#define MOTION_FIELD_X 0.0   /* ENU mid-latitude field, as tracker/motion.py */
#define MOTION_FIELD_Y 20.0
#define MOTION_FIELD_Z (-40.0)
#define MOTION_VCC_MV 5000u /* the board's supply and ADC reference: flex_mv is 0..this */

/* A board lying still (one row). */
void motion_still(motion_t *m);

/*
 * Load a CSV file. On error returns -1 and writes a one-line message
 * (without trailing newline) to err.
 */
int motion_load(motion_t *m, const char *path, char *err, size_t errlen);

/* The truth at time t (seconds); before the first row / after the last, held. */
void motion_at(const motion_t *m, double t, truth_t *out);

void motion_free(motion_t *m);

#endif
