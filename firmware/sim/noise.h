/*
 * noise.h - the sensor errors of the virtual MPU-9250 and AK8963, seeded.
 *
 * Figures from the MPU-9250 product specification PS-MPU-9250A-01 rev. 1.1:
 *   gyroscope rate noise spectral density 0.01 deg/s/sqrt(Hz)      (sec. 3.1, table 1)
 *   gyroscope initial zero-rate output (ZRO) tolerance +-5 deg/s    (sec. 3.1, table 1)
 *   gyroscope start-up time from sleep 35 ms                       (sec. 3.1, table 1)
 *   accelerometer noise power spectral density 300 ug/sqrt(Hz)     (sec. 3.2, table 2)
 * White noise of standard deviation density * sqrt(bandwidth), the bandwidth being
 * the DLPF's the firmware configured (register map RM-MPU-9250A-00 sec. 4.6 and 4.8).
 *
 * The start-up transient is a model, not a data-sheet curve: when the gyroscope
 * (re)starts (H_RESET, or a PWR_MGMT_1 write that leaves it awake) its zero-rate
 * output starts off by an error drawn within the ZRO tolerance and decays
 * exponentially, reaching a fifth of it (1 deg/s of the worst 5 deg/s) at the
 * 35 ms start-up time: tau = 35 ms / ln 5 = 21.7 ms.
 *
 * The AK8963 data sheet (MS1356-E-02) gives no noise figure; the model uses
 * 0.3 uT rms per axis (2 LSB in 16-bit output), an assumption of this simulator.
 *
 * Every draw is a hash of (seed, stream, index), so a register read twice within
 * one internal sample returns the same value, and a run is reproducible.
 */
#ifndef BOARDSIM_NOISE_H
#define BOARDSIM_NOISE_H

#include <stdint.h>

#define NOISE_GYR_DENSITY_DPS 0.01   /* deg/s/sqrt(Hz) */
#define NOISE_GYR_ZRO_DPS 5.0        /* +- deg/s */
#define NOISE_GYR_STARTUP_S 35e-3    /* s */
#define NOISE_ACC_DENSITY_G 300e-6   /* g/sqrt(Hz) */
#define NOISE_MAG_UT 0.3             /* uT rms (assumption, see above) */

typedef struct noise {
	uint64_t seed;
	int on;                 /* 0: an ideal sensor (no noise, no offset, no transient) */
	double gyr_zro[3];      /* rad/s: this chip's zero-rate output */
	double start_t;         /* s: when the gyroscope last (re)started */
	double start_err[3];    /* rad/s: its zero-rate error at that moment */
	uint64_t starts;        /* (re)starts so far: each draws its own error */
} noise_t;

void noise_init(noise_t *n, uint64_t seed, int on);
/* The gyroscope (re)starts at time now (s). */
void noise_gyro_start(noise_t *n, double now);
/* Error to add to the true rate (rad/s) of internal sample idx at time t. */
double noise_gyro(const noise_t *n, int axis, long idx, double t, double bandwidth_hz);
/* Error to add to the true specific force (m/s^2) of internal sample idx. */
double noise_acc(const noise_t *n, int axis, long idx, double bandwidth_hz);
/* Error to add to the true field (uT) of magnetometer measurement k. */
double noise_mag(const noise_t *n, int axis, long k);

#endif
