/*
 * imu.c - register models of the MPU-9250 and the AK8963 (see imu.h).
 */
#define _GNU_SOURCE
#include "imu.h"

#include <math.h>
#include <string.h>

#define STANDARD_GRAVITY 9.80665  /* m/s^2 per g, as tracker/protocol.py */
#define TEMP_SENSITIVITY 333.87   /* LSB per degC (MPU-9250 data sheet 3.4.2) */
#define TEMP_ROOM_OFFSET 21.0     /* degC at 0 LSB */
#define AK_MEAS_TIME 7.2e-3       /* s, one measurement (AK8963 data sheet 6.4.3.2) */
#define AK_LIMIT_16 32760         /* measurement range, 16-bit output */
#define AK_LIMIT_14 8190          /* measurement range, 14-bit output */

/* ------------------------------------------------------------ conversions */

/* Counts as tracker/board.py quantise makes them: round half even, saturate int16. */
static int16_t imu_counts(double value, double lsb)
{
	double c = nearbyint(value / lsb); /* default rounding: half to even, as numpy rint */
	if (c > 32767.0)
		return 32767;
	if (c < -32768.0)
		return -32768;
	return (int16_t)c;
}

/* m/s^2 per count */
static double imu_acc_lsb(int fs_code)
{
	int fs_g = 2 << (fs_code & 3);
	return fs_g * STANDARD_GRAVITY / 32768.0;
}

/* rad/s per count */
static double imu_gyr_lsb(int fs_code)
{
	int fs_dps = 250 << (fs_code & 3);
	return fs_dps * (M_PI / 180.0) / 32768.0; /* math.radians(fs) / 32768 */
}

static void put_be16(uint8_t *p, int16_t v)
{
	p[0] = (uint8_t)((uint16_t)v >> 8);
	p[1] = (uint8_t)v;
}

static void put_le16(uint8_t *p, int16_t v)
{
	p[0] = (uint8_t)v;
	p[1] = (uint8_t)((uint16_t)v >> 8);
}

/* ------------------------------------------------------------ MPU-9250 */

static void mpu_reset(regdev_t *d)
{
	memset(d->reg, 0, sizeof(d->reg));
	d->reg[MPU_PWR_MGMT_1] = 0x01;
	d->reg[MPU_WHO_AM_I] = MPU_WHOAMI_VALUE;
	d->ptr = 0;
	d->expect_pointer = 1;
}

/* Read-only registers: interrupt status, sensor data, external data, identity. */
static int mpu_writable(uint8_t reg)
{
	return !(reg >= MPU_INT_STATUS && reg <= 0x60) && reg != MPU_WHO_AM_I;
}

/*
 * The internal sample period: SMPLRT_DIV applies when the DLPF is on
 * (0 < DLPF_CFG < 7 and FCHOICE_B = 0, register map 4.4-4.6); else 8 kHz.
 */
static double mpu_sample_period(const regdev_t *d)
{
	int dlpf = d->reg[MPU_CONFIG] & 7;
	int fchoice_b = d->reg[MPU_GYRO_CONFIG] & 3;
	if (dlpf >= 1 && dlpf <= 6 && fchoice_b == 0)
		return (1.0 + d->reg[MPU_SMPLRT_DIV]) / 1000.0;
	return 1.0 / 8000.0;
}

/* DLPF bandwidths, Hz (register map 4.6: gyro DLPF_CFG, FCHOICE_B; 4.8: accel
 * A_DLPF_CFG, ACCEL_FCHOICE_B): the noise's bandwidth. */
static double mpu_gyr_bandwidth(const regdev_t *d)
{
	static const double hz[8] = { 250, 184, 92, 41, 20, 10, 5, 3600 };
	if (d->reg[MPU_GYRO_CONFIG] & 3)
		return d->reg[MPU_GYRO_CONFIG] & 1 ? 8800 : 3600;
	return hz[d->reg[MPU_CONFIG] & 7];
}

static double mpu_acc_bandwidth(const regdev_t *d)
{
	static const double hz[8] = { 218.1, 218.1, 99, 44.8, 21.2, 10.2, 5.05, 420 };
	if (d->reg[MPU_ACCEL_CONFIG2] & 0x08)
		return 1046;
	return hz[d->reg[MPU_ACCEL_CONFIG2] & 7];
}

/* Refresh the data registers with the truth (and the sensors' errors) at the latest
 * internal sample. */
static void mpu_sample(imu_t *imu)
{
	regdev_t *d = &imu->mpu;
	if (d->reg[MPU_PWR_MGMT_1] & 0x40)
		return; /* asleep: the registers keep their last values */
	double period = mpu_sample_period(d);
	long idx = (long)floor(imu->now / period);
	truth_t tr;
	motion_at(imu->motion, idx * period, &tr);
	double acc_lsb = imu_acc_lsb(d->reg[MPU_ACCEL_CONFIG] >> 3);
	double gyr_lsb = imu_gyr_lsb(d->reg[MPU_GYRO_CONFIG] >> 3);
	double t = idx * period, acc_bw = mpu_acc_bandwidth(d), gyr_bw = mpu_gyr_bandwidth(d);
	for (int i = 0; i < 3; i++) {
		double acc = tr.acc[i] + noise_acc(&imu->noise, i, idx, acc_bw);
		double gyr = tr.gyr[i] + noise_gyro(&imu->noise, i, idx, t, gyr_bw);
		put_be16(&d->reg[MPU_ACCEL_XOUT_H + 2 * i], imu_counts(acc, acc_lsb));
		put_be16(&d->reg[MPU_GYRO_XOUT_H + 2 * i], imu_counts(gyr, gyr_lsb));
	}
	double temp = (IMU_TEMP_C - TEMP_ROOM_OFFSET) * TEMP_SENSITIVITY;
	put_be16(&d->reg[MPU_TEMP_OUT_H], imu_counts(temp, 1.0));
	if (idx != imu->mpu_sample_idx)
		d->reg[MPU_INT_STATUS] |= 0x01; /* RAW_DATA_RDY_INT: a new sample */
	imu->mpu_sample_idx = idx;
}

static void mpu_write_reg(imu_t *imu, uint8_t reg, uint8_t v)
{
	regdev_t *d = &imu->mpu;
	if (reg == MPU_PWR_MGMT_1 && (v & 0x80)) {
		mpu_reset(d); /* H_RESET: every register to its default; the bit clears itself */
		noise_gyro_start(&imu->noise, imu->now);
		return;
	}
	if (mpu_writable(reg))
		d->reg[reg] = v;
	if (reg == MPU_PWR_MGMT_1 && !(v & 0x40))
		noise_gyro_start(&imu->noise, imu->now); /* awake, on a (new) clock: the gyro starts */
}

static uint8_t mpu_read_reg(imu_t *imu, uint8_t reg)
{
	uint8_t v = imu->mpu.reg[reg];
	if (reg == MPU_INT_STATUS)
		imu->mpu.reg[reg] = 0; /* reading INT_STATUS clears it (INT_ANYRD_2CLEAR = 0) */
	return v;
}

/* ------------------------------------------------------------ AK8963 */

static void ak_reset(ak8963_t *ak)
{
	memset(ak->r.reg, 0, sizeof(ak->r.reg));
	ak->r.reg[AK_WIA] = AK_WIA_VALUE;
	ak->r.reg[0x01] = 0x9A; /* INFO: device information, value not specified */
	for (int i = AK_ASAX; i <= AK_ASAZ; i++)
		ak->r.reg[i] = 128; /* sensitivity adjustment: none */
	ak->r.ptr = 0;
	ak->r.expect_pointer = 1;
	ak->mode_t0 = 0.0;
	ak->last_meas = -1;
	ak->locked = 0;
}

static int ak_mode(const ak8963_t *ak)
{
	return ak->r.reg[AK_CNTL1] & 0x0F;
}

/* Completion time of measurement k in the current mode; < 0 if there is none. */
static double ak_meas_time(const ak8963_t *ak, long k)
{
	switch (ak_mode(ak)) {
	case 0x1: /* single measurement */
	case 0x8: /* self-test: one measurement */
		return k == 0 ? ak->mode_t0 + AK_MEAS_TIME : -1.0;
	case 0x2: /* continuous 1, 8 Hz */
		return ak->mode_t0 + AK_MEAS_TIME + k / 8.0;
	case 0x6: /* continuous 2, 100 Hz */
		return ak->mode_t0 + AK_MEAS_TIME + k / 100.0;
	default:  /* power-down, external trigger, fuse ROM */
		return -1.0;
	}
}

/* Index of the latest measurement completed by time t, or -1. */
static long ak_latest(const ak8963_t *ak, double t)
{
	int mode = ak_mode(ak);
	double first = ak_meas_time(ak, 0);
	if (first < 0 || t < first)
		return -1;
	if (mode == 0x1 || mode == 0x8)
		return 0;
	double period = mode == 0x2 ? 1.0 / 8.0 : 1.0 / 100.0;
	return (long)floor((t - first) / period);
}

/* Write one axis in AK8963 counts; returns 1 on overflow. */
static int ak_put_axis(uint8_t *p, double ut, int bit16)
{
	double lsb = bit16 ? 0.15 : 0.6;
	int limit = bit16 ? AK_LIMIT_16 : AK_LIMIT_14;
	double c = nearbyint(ut / lsb);
	int over = fabs(c) > limit;
	if (c > limit)
		c = limit;
	if (c < -limit)
		c = -limit;
	put_le16(p, (int16_t)c);
	return over;
}

/*
 * Make measurement k visible: the AK8963's axes are the accelerometer's
 * with x and y swapped and z reversed (PROTOCOL.md 4.1), so H = (m_y, m_x, -m_z).
 */
static void ak_latch(imu_t *imu, long k)
{
	ak8963_t *ak = &imu->ak;
	uint8_t *reg = ak->r.reg;
	truth_t tr;
	motion_at(imu->motion, ak_meas_time(ak, k), &tr);
	int bit16 = (reg[AK_CNTL1] & 0x10) != 0;
	double m[3];
	for (int i = 0; i < 3; i++)
		m[i] = tr.mag[i] + noise_mag(&imu->noise, i, k);
	int over = ak_put_axis(&reg[AK_HXL], m[1], bit16);
	over |= ak_put_axis(&reg[AK_HXL + 2], m[0], bit16);
	over |= ak_put_axis(&reg[AK_HXL + 4], -m[2], bit16);
	reg[AK_ST2] = (uint8_t)((bit16 ? 0x10 : 0) | (over ? 0x08 : 0));
	if (reg[AK_ST1] & 0x01)
		reg[AK_ST1] |= 0x02; /* DOR: the previous data was never read */
	reg[AK_ST1] |= 0x01;     /* DRDY */
	ak->last_meas = k;
	if (ak_mode(ak) == 0x1 || ak_mode(ak) == 0x8)
		reg[AK_CNTL1] &= 0xF0; /* a single measurement ends in power-down */
}

static void ak_update(imu_t *imu)
{
	ak8963_t *ak = &imu->ak;
	if (ak->locked)
		return; /* data protection: a read is in progress */
	long k = ak_latest(ak, imu->now);
	if (k > ak->last_meas)
		ak_latch(imu, k);
}

static void ak_write_reg(imu_t *imu, uint8_t reg, uint8_t v)
{
	ak8963_t *ak = &imu->ak;
	if (reg == AK_CNTL2) {
		if (v & 0x01)
			ak_reset(ak); /* SRST */
		return;
	}
	if (reg == AK_CNTL1) {
		ak->r.reg[AK_CNTL1] = v & 0x1F;
		ak->mode_t0 = imu->now;
		ak->last_meas = -1;
		ak->locked = 0;
		return;
	}
	if (reg == 0x0C || reg == 0x0F) /* ASTC, I2CDIS */
		ak->r.reg[reg] = v;
}

static uint8_t ak_read_reg(imu_t *imu, uint8_t reg)
{
	ak8963_t *ak = &imu->ak;
	uint8_t v = ak->r.reg[reg];
	if (reg >= AK_HXL && reg <= AK_HZH) {
		ak->locked = 1;
		ak->r.reg[AK_ST1] &= (uint8_t)~0x01; /* reading data clears DRDY */
	} else if (reg == AK_ST2) {
		ak->locked = 0;
		ak->r.reg[AK_ST1] &= (uint8_t)~0x03; /* ST2 ends the read: DRDY, DOR clear */
	}
	return v;
}

/* ------------------------------------------------------------ bus side */

void imu_power_on(imu_t *imu, double now)
{
	imu->powered_at = now;
	imu->mpu_sample_idx = -1;
	mpu_reset(&imu->mpu);
	ak_reset(&imu->ak);
}

void imu_init(imu_t *imu, const motion_t *motion, double startup_s, uint64_t seed, int noise_on)
{
	memset(imu, 0, sizeof(*imu));
	imu->motion = motion;
	imu->startup_s = startup_s;
	noise_init(&imu->noise, seed, noise_on);
	imu_power_on(imu, 0.0);
}

int imu_mpu_ready(const imu_t *imu, double now)
{
	return now >= imu->powered_at + imu->startup_s;
}

int imu_ak_reachable(const imu_t *imu)
{
	const uint8_t *r = imu->mpu.reg;
	return (r[MPU_INT_PIN_CFG] & 0x02) && !(r[MPU_USER_CTRL] & 0x20);
}

static regdev_t *dev_of(imu_t *imu, uint8_t addr)
{
	return addr == AK_ADDR ? &imu->ak.r : &imu->mpu;
}

void imu_start(imu_t *imu, uint8_t addr, int read, double now)
{
	regdev_t *d = dev_of(imu, addr);
	imu->now = now;
	d->expect_pointer = !read;
	if (!read)
		return;
	if (addr == AK_ADDR)
		ak_update(imu);
	else
		mpu_sample(imu);
}

void imu_write(imu_t *imu, uint8_t addr, uint8_t value)
{
	regdev_t *d = dev_of(imu, addr);
	if (d->expect_pointer) {
		d->ptr = value & 0x7F;
		d->expect_pointer = 0;
		return;
	}
	if (addr == AK_ADDR)
		ak_write_reg(imu, d->ptr, value);
	else
		mpu_write_reg(imu, d->ptr, value);
	d->ptr = (d->ptr + 1) & 0x7F;
}

uint8_t imu_read(imu_t *imu, uint8_t addr)
{
	regdev_t *d = dev_of(imu, addr);
	uint8_t v = addr == AK_ADDR ? ak_read_reg(imu, d->ptr) : mpu_read_reg(imu, d->ptr);
	d->ptr = (d->ptr + 1) & 0x7F;
	return v;
}
