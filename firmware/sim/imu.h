/*
 * imu.h - a virtual MPU-9250 (I2C 0x68) and its AK8963 magnetometer (0x0C).
 *
 * Register-level models, independent of simavr: the I2C glue in boardsim.c
 * calls imu_start at each (repeated) START addressed to a device, then
 * imu_write / imu_read per data byte. Values come from a motion (motion.h) at
 * the simulated time the read starts.
 *
 * MPU-9250 (register map rev. 1.6): WHO_AM_I 0x75 = 0x71; PWR_MGMT_1 0x6B
 * (H_RESET bit 7, SLEEP bit 6), CONFIG 0x1A, SMPLRT_DIV 0x19, GYRO_CONFIG
 * 0x1B and ACCEL_CONFIG 0x1C (full scale in bits 4:3), ACCEL_CONFIG2 0x1D,
 * INT_PIN_CFG 0x37 (BYPASS_EN bit 1), USER_CTRL 0x6A (I2C_MST_EN bit 5);
 * data 0x3B..0x48 big endian, refreshed at the internal sample rate.
 *
 * AK8963 (data sheet MS1356): WIA 0x00 = 0x48, ST1 0x02 (DRDY bit 0, DOR
 * bit 1), HXL..HZH 0x03..0x08 little endian, ST2 0x09 (HOFL bit 3, BITM
 * bit 4), CNTL1 0x0A (MODE 3:0, BIT 4), CNTL2 0x0B (SRST), ASA 0x10..0x12
 * = 128. It answers only while the MPU's bypass is on and its I2C master off.
 *
 * Power: after power-on (time 0, or a supply glitch, imu_power_on) every
 * register of both chips is at its reset value and the MPU answers nothing
 * until its start-up time for register read/write has passed (PS-MPU-9250A-01
 * sec. 3.4.2 A.C. electrical characteristics: 11 ms typical, 100 ms
 * maximum).
 */
#ifndef BOARDSIM_IMU_H
#define BOARDSIM_IMU_H

#include <stdint.h>

#include "motion.h"
#include "noise.h"

#define MPU_ADDR 0x68
#define AK_ADDR 0x0C

/* MPU-9250 registers used by the model. */
enum {
	MPU_SMPLRT_DIV = 0x19,
	MPU_CONFIG = 0x1A,
	MPU_GYRO_CONFIG = 0x1B,
	MPU_ACCEL_CONFIG = 0x1C,
	MPU_ACCEL_CONFIG2 = 0x1D,
	MPU_INT_PIN_CFG = 0x37,
	MPU_INT_STATUS = 0x3A,
	MPU_ACCEL_XOUT_H = 0x3B,
	MPU_TEMP_OUT_H = 0x41,
	MPU_GYRO_XOUT_H = 0x43,
	MPU_USER_CTRL = 0x6A,
	MPU_PWR_MGMT_1 = 0x6B,
	MPU_WHO_AM_I = 0x75,
};

/* AK8963 registers. */
enum {
	AK_WIA = 0x00,
	AK_ST1 = 0x02,
	AK_HXL = 0x03,
	AK_HZH = 0x08,
	AK_ST2 = 0x09,
	AK_CNTL1 = 0x0A,
	AK_CNTL2 = 0x0B,
	AK_ASAX = 0x10,
	AK_ASAZ = 0x12,
};

#define MPU_WHOAMI_VALUE 0x71
#define AK_WIA_VALUE 0x48
#define IMU_TEMP_C 25.0 /* die temperature reported */
#define IMU_STARTUP_MAX_S 0.100 /* start-up time for register read/write, maximum */

/* One I2C target's register pointer protocol: first written byte = address. */
typedef struct regdev {
	uint8_t reg[128];
	uint8_t ptr;        /* register pointer, auto-incremented */
	int expect_pointer; /* the next written byte sets ptr */
} regdev_t;

typedef struct ak8963 {
	regdev_t r;
	double mode_t0;      /* when the current mode was set, s */
	long last_meas;      /* index of the last measurement made visible */
	int locked;          /* data read started: hold the data until ST2 is read */
} ak8963_t;

typedef struct imu {
	regdev_t mpu;
	ak8963_t ak;
	const motion_t *motion;
	noise_t noise;       /* the sensors' errors (noise.h) */
	double now;          /* simulated time of the current transaction, s */
	long mpu_sample_idx; /* index of the internal sample in the data registers */
	double powered_at;   /* last power-on, s */
	double startup_s;    /* start-up time for register read/write, s */
} imu_t;

/* Powered on at time 0 with the given start-up time (s); imu_power_on moves it. seed
 * and noise_on: the sensors' errors (noise.h); noise_on 0 is an ideal sensor. */
void imu_init(imu_t *imu, const motion_t *motion, double startup_s, uint64_t seed, int noise_on);

/* The supply came back at `now` (a glitch): reset values, start-up again. */
void imu_power_on(imu_t *imu, double now);

/* Whether the MPU answers on the bus at `now` (its start-up time has passed). */
int imu_mpu_ready(const imu_t *imu, double now);

/* Whether the AK8963 answers on the bus now (bypass on, MPU master off). */
int imu_ak_reachable(const imu_t *imu);

/* Transaction hooks for the device at 7-bit address addr (MPU_ADDR/AK_ADDR). */
void imu_start(imu_t *imu, uint8_t addr, int read, double now);
void imu_write(imu_t *imu, uint8_t addr, uint8_t value);
uint8_t imu_read(imu_t *imu, uint8_t addr);

#endif
