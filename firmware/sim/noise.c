/*
 * noise.c - seeded sensor errors (see noise.h).
 */
#define _GNU_SOURCE
#include "noise.h"

#include <math.h>

#define STANDARD_GRAVITY 9.80665
#define DEG (M_PI / 180.0)

enum { STREAM_ZRO, STREAM_START, STREAM_GYR, STREAM_ACC, STREAM_MAG };

/* SplitMix64's finaliser: a well-mixed 64-bit hash. */
static uint64_t mix(uint64_t x)
{
	x += 0x9E3779B97F4A7C15ull;
	x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
	x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
	return x ^ (x >> 31);
}

/* Uniform in (0, 1], a function of (seed, stream, axis, index) only. */
static double uniform(const noise_t *n, int stream, int axis, uint64_t index)
{
	uint64_t h = mix(n->seed ^ mix((uint64_t)(stream * 8 + axis) ^ mix(index)));
	return ((h >> 11) + 1) * (1.0 / 9007199254740992.0); /* 2^-53 */
}

/* Standard normal (Box-Muller). */
static double gauss(const noise_t *n, int stream, int axis, uint64_t index)
{
	double u = uniform(n, stream, axis, 2 * index), v = uniform(n, stream, axis, 2 * index + 1);
	return sqrt(-2.0 * log(u)) * cos(2.0 * M_PI * v);
}

/* Uniform in [-1, 1). */
static double symmetric(const noise_t *n, int stream, int axis, uint64_t index)
{
	return 2.0 * uniform(n, stream, axis, index) - 1.0;
}

void noise_init(noise_t *n, uint64_t seed, int on)
{
	n->seed = seed;
	n->on = on;
	n->starts = 0;
	n->start_t = 0.0;
	for (int i = 0; i < 3; i++) {
		n->gyr_zro[i] = on ? NOISE_GYR_ZRO_DPS * DEG * symmetric(n, STREAM_ZRO, i, 0) : 0.0;
		n->start_err[i] = 0.0;
	}
}

void noise_gyro_start(noise_t *n, double now)
{
	if (!n->on)
		return;
	n->start_t = now;
	for (int i = 0; i < 3; i++)
		n->start_err[i] = NOISE_GYR_ZRO_DPS * DEG * symmetric(n, STREAM_START, i, n->starts);
	n->starts++;
}

double noise_gyro(const noise_t *n, int axis, long idx, double t, double bandwidth_hz)
{
	if (!n->on)
		return 0.0;
	double tau = NOISE_GYR_STARTUP_S / log(5.0);
	double since = t > n->start_t ? t - n->start_t : 0.0;
	double transient = n->start_err[axis] * exp(-since / tau);
	double white = NOISE_GYR_DENSITY_DPS * DEG * sqrt(bandwidth_hz) *
		       gauss(n, STREAM_GYR, axis, (uint64_t)idx);
	return n->gyr_zro[axis] + transient + white;
}

double noise_acc(const noise_t *n, int axis, long idx, double bandwidth_hz)
{
	if (!n->on)
		return 0.0;
	return NOISE_ACC_DENSITY_G * STANDARD_GRAVITY * sqrt(bandwidth_hz) *
	       gauss(n, STREAM_ACC, axis, (uint64_t)idx);
}

double noise_mag(const noise_t *n, int axis, long k)
{
	return n->on ? NOISE_MAG_UT * gauss(n, STREAM_MAG, axis, (uint64_t)k) : 0.0;
}
