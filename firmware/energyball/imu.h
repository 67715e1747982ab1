/* MPU-9250 and its AK8963 over I2C (Arduino Wire, interrupt-driven TWI, with the
 * core's bus timeout so a missing or stuck device returns an error, never hangs).
 * Register values and parsing are in src/eb_sensors.{h,c}. */
#ifndef IMU_H
#define IMU_H

#include <stdint.h>

#include "src/eb_sensors.h"

struct Imu {
    uint8_t whoami; /* WHO_AM_I as read, 0 when nothing answered */
    uint8_t mag_whoami; /* AK8963 WIA, 0 when there is no magnetometer */
    uint8_t asa[3]; /* AK8963 fuse-ROM sensitivity adjustment */
    eb_mag_t mag; /* the latest magnetometer reading (held between its 100 Hz updates) */
    bool mag_seen; /* a reading has arrived since start-up, and no read has failed since */
    uint32_t mag_ms; /* millis() when it arrived */
};

/* What a sensor read found. */
enum ImuRead {
    IMU_READ_OK,
    IMU_READ_FAILED, /* the transfer failed (NACK, timeout) */
    IMU_READ_RESET, /* the MPU answered with its reset configuration: it lost power */
};

/* Identify and configure the IMU (and the AK8963 if present), after freeing and
 * starting the bus; returns error bits (EB_ERR_IMU_MISSING, EB_ERR_I2C_FAILURE,
 * EB_ERR_MAG_MISSING). powered_ms: millis() when the IMU was last powered up (0 at
 * boot, the time its reset was seen after a supply drop-out): WHO_AM_I is retried
 * until the MPU's start-up time after it has passed. */
uint16_t imu_init(Imu &imu, uint16_t rate_hz, uint32_t powered_ms);
/* The digital low-pass filter for a sample rate (eb_dlpf_for_rate). */
bool imu_set_rate(uint16_t rate_hz);
/* Burst-read accelerometer, gyroscope and temperature (TEMP_OUT) counts, checked
 * against a configuration register read in the same burst. */
ImuRead imu_read(int16_t acc[3], int16_t gyr[3], int16_t *temp);
/* Read the AK8963 (ST1..ST2) if its next measurement is due; a new measurement
 * replaces imu.mag. A failed read makes the held one invalid. */
bool imu_read_mag(Imu &imu);
/* Whether imu.mag is a valid recent measurement (the RAW frame's mag_valid). */
bool imu_mag_valid(const Imu &imu);

#endif
