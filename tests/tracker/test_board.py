"""The virtual board's physics and quantisation, checked against first principles."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tracker import protocol as P
from tracker.board import quantise
from tracker.motion import GRAVITY, ScriptedArm, SensorReading, paper_flex_adc


def rotation(q):
    w, x, y, z = q
    return Rotation.from_quat([x, y, z, w])


@pytest.mark.parametrize("t", [0.0, 0.37, 1.0, 2.2, 3.9])
def test_scripted_arm_rates_and_forces_match_numerical_derivatives(t):
    arm = ScriptedArm()
    h = 1e-5
    r0, r1, rm = arm.reading(t), arm.reading(t + h), arm.reading(t - h)
    # Body rate from the orientation's derivative: R(t)^T R(t+h) ~ exp(omega h).
    omega = (rotation(rm.q).inv() * rotation(r1.q)).as_rotvec() / (2 * h)
    assert r0.gyr == pytest.approx(omega, abs=1e-6)
    # Specific force: second derivative of the sensor position, minus gravity, in S.
    pos = lambda r: rotation(r.q).apply([0, 0, -arm.upper_arm_m])
    accel = (pos(r1) - 2 * pos(r0) + pos(rm)) / h**2
    f_world = accel + [0, 0, GRAVITY]
    assert r0.acc == pytest.approx(rotation(r0.q).inv().apply(f_world), abs=1e-3)
    # The magnetometer sees the fixed earth field.
    assert rotation(r0.q).apply(r0.mag) == pytest.approx([0, 20, -40], abs=1e-9)


def test_arm_starting_to_swing_from_hanging_worked_by_hand():
    # At t = 0 the arm hangs with zero rate but angular acceleration A w^2, so the
    # sensor L below the shoulder accelerates forward (+y) by A w^2 L on top of 1 g up.
    arm = ScriptedArm()
    w = 2 * math.pi / arm.raise_period_s
    r = arm.reading(0.0)
    assert r.gyr == pytest.approx((0, 0, 0))
    assert r.acc == pytest.approx((0, arm.raise_amplitude_rad * w**2 * arm.upper_arm_m, GRAVITY))


def test_paper_flex_map_inverts_seed_000():
    # seed 000 sec. 4: theta = -(adc - 390) / 3
    for theta in (0.0, 30.0, 90.0):
        adc = paper_flex_adc(theta)
        assert -(adc - 390) / 3 == pytest.approx(theta, abs=1 / 3)


def test_quantise_matches_the_mpu9250_scales_worked_by_hand():
    # 1 g at +-16 g full scale is 32768 / 16 = 2048 counts; 1 rad/s at +-2000 deg/s is
    # 32768 / 2000 * 57.2958 = 938.7 counts; 15 uT is 100 counts at 0.15 uT/count.
    r = SensorReading(acc=(P.STANDARD_GRAVITY, 0, -1000.0), gyr=(1.0, 0, 0), mag=(15.0, 0, 0),
                      flex_deg=0, flex_adc=390, q=(1, 0, 0, 0))
    s = quantise(r, 0.0, 0, 0, 16, 2000)
    assert s.acc_counts == (2048, 0, -32768)  # saturates at the rail
    assert s.gyr_counts[0] == round(32768 / 2000 * math.degrees(1.0))
    assert s.mag_counts == (100, 0, 0)
    assert s.acc[0] == pytest.approx(P.STANDARD_GRAVITY)
    assert np.allclose(s.gyr, (1.0, 0, 0), atol=math.radians(2000) / 32768)
