"""The tracking's start: the board's clock tells the filter how long ago it powered up, and its
calibration whether its warm-up is corrected."""

from __future__ import annotations

import math

import numpy as np
import pytest

from game.body.tracking import Tracking
from tracker import protocol as P
from tracker.calibration import BoardCalibration, ProcedureRecord


def sample(t: float, temp_counts: int | None = None) -> P.RawSample:
    """A board lying flat and still (2048 counts = 1 g at +-16 g), ``t`` s after its power-up."""
    return P.RawSample(t, round(t * 1e6), 0, (0, 0, 2048), (0, 0, 0), None, 512, temp_counts=temp_counts)


@pytest.mark.parametrize("age_s", [0.0, 300.0])
def test_the_first_sample_gives_the_filter_the_boards_age(age_s):
    # DefaultFilter.power_on: P_dd = sqrt(2) / bias_tau_min^3 exp(-2 age / drift_tau), worked by
    # hand: sqrt(2) / 27 = 0.05238 at power-up, times e^-2 = 0.00709 one thermal time constant on.
    tracking = Tracking(use_magnetometer=False)
    tracking.feed(sample(age_s))
    expected = 0.05238 * math.exp(-2.0 * age_s / 300.0)
    assert tracking.filter.get_state().drift_p[0] == pytest.approx(expected, rel=1e-3, abs=1e-6)
    # Only the first sample after a start says so: the next one adds no second prior.
    tracking.feed(sample(age_s + 0.005))
    assert tracking.filter.get_state().drift_p[0] == pytest.approx(expected, rel=1e-3, abs=1e-6)


@pytest.mark.parametrize("slope, recorded, temp_counts, calibrated", [
    ((0.001, -0.002, 0.0005), True, 1200, True),  # a thermal calibration, and the die's temperature to use it
    ((0.001, -0.002, 0.0005), True, None, False),  # a firmware without TEMP frames: the slope cannot be used
    ((0.0, 0.0, 0.0), False, 1200, False),  # no thermal calibration: the whole warm-up is left to learn
    ((0.0, 0.0, 0.0), True, 1200, True),  # one that found the warm-up negligible (tracker.thermal)
])
def test_the_filter_is_told_whether_the_warm_up_is_calibrated(slope, recorded, temp_counts, calibrated):
    records = (ProcedureRecord.now("thermal", {"rise_c": 0.4}),) if recorded else ()
    board = BoardCalibration("imu-1", gyro_thermal=np.array(slope), gyro_thermal_ref_c=np.array(30.0),
                             procedures=records)
    tracking = Tracking(use_magnetometer=False, board=board)
    tracking.feed(sample(0.0, temp_counts))
    assert tracking.filter.get_state().warmup_calibrated is calibrated


def test_the_filter_is_told_the_accelerometer_reads_more_recently_than_the_gyroscope():
    # RM-MPU-9250A-00 sec. 4.6 and 4.8 at the firmware's setting for 200 Hz (DLPF_CFG 3): the gyroscope
    # delayed 5.9 ms, the accelerometer 4.88 ms
    assert Tracking().filter.params.acc_lead_s == pytest.approx(5.9e-3 - 4.88e-3)
