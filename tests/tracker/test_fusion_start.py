"""The start-up's gravity (tracker/fusion/start.py) on a board that trembles about the shoulder.

The case worked by hand: the arm hangs, the board 0.3 m below the shoulder,
and trembles about the forward axis x by A sin(2 pi f t), A = 1.5 deg, f =
7.5 Hz (the issue's ranges: up to 2 deg, 3-12 Hz). The rate is w(t) = A 2 pi f
cos(2 pi f t), 1.234 rad/s at t = 0 and -1.234 rad/s at t = 1 s (7.5 cycles);
the board's velocity w x p is 0.370 m/s along y at t = 0 and -0.370 m/s at 1 s.
The plain mean of the accelerometer over the first second is therefore
gravity plus (v(1) - v(0)) / 1 s = -0.740 m/s^2 along y: a tilt of
atan(0.740 / 9.81) = 4.3 deg. Between two moments of equal rate it is
gravity alone.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tracker.fusion import make
from tracker.fusion.start import StartMean

RATE = 200.0
G = 9.81
A, F, LEVER = math.radians(1.5), 7.5, 0.3


def tremble(t: np.ndarray, phase: float = 0.0) -> tuple[np.ndarray, ...]:
    """Angle, rate and angular acceleration about x; the board's specific force in the world
    (m/s^2): its acceleration on the circle of radius LEVER about the shoulder plus gravity's
    reaction, worked from p = LEVER (0, sin th, -cos th)."""
    wt = 2 * math.pi * F * t + phase
    th, w, al = A * np.sin(wt), A * 2 * math.pi * F * np.cos(wt), -A * (2 * math.pi * F) ** 2 * np.sin(wt)
    # d2/dt2 of (0, sin th, -cos th) = (0, al cos th - w^2 sin th, al sin th + w^2 cos th)
    acc = LEVER * np.stack([0 * th, al * np.cos(th) - w ** 2 * np.sin(th), al * np.sin(th) + w ** 2 * np.cos(th)], 1)
    return th, w, al, acc + [0.0, 0.0, G]


def tilt_deg(v: np.ndarray) -> float:
    return math.degrees(math.atan2(math.hypot(v[0], v[1]), v[2]))


def test_the_hand_worked_boundary_term_tilts_a_plain_mean():
    t = np.arange(1, int(RATE) + 1) / RATE
    acc = tremble(t)[3]
    assert math.degrees(math.atan(2 * A * 2 * math.pi * F * LEVER / G)) == pytest.approx(4.31, abs=0.01)
    assert tilt_deg(acc.mean(0)) == pytest.approx(4.31, abs=0.15)  # the samples agree with the hand


def test_the_start_mean_ends_where_the_tremor_repeats_its_rate():
    for phase in np.linspace(0, 2 * math.pi, 7, endpoint=False):
        t = np.arange(1, int(RATE) + 1) / RATE
        _, w, _, acc = tremble(t, phase)
        start = StartMean()
        for i in range(len(t)):  # in the world frame: I is the world up to a turn about the vertical
            start.add(tuple(acc[i]), (float(w[i]), 0.0, 0.0), float(t[i]), 1.0)
        assert tilt_deg(np.array(start.gravity)) < 0.3, phase
        assert np.linalg.norm(np.array(start.gravity) - [0, 0, G]) < 0.05


def test_the_filter_starts_level_on_a_trembling_arm():
    # The sensor frame is the world turned by th about x; the filter (6D) sees R^T w and R^T f.
    t = np.arange(1, int(1.2 * RATE) + 1) / RATE
    th, w, _, f_world = tremble(t)
    c, s = np.cos(th), np.sin(th)
    acc = np.stack([f_world[:, 0], c * f_world[:, 1] + s * f_world[:, 2], -s * f_world[:, 1] + c * f_world[:, 2]], 1)
    flt = make("default")
    errors = []
    for i in range(len(t)):
        q = np.asarray(flt.update((float(w[i]), 0.0, 0.0), tuple(acc[i]), None, 1 / RATE))
        up = Rotation.from_quat([*q[1:], q[0]]).inv().apply([0.0, 0.0, 1.0])  # world up in the sensor frame
        errors.append(math.degrees(math.acos(np.clip(up @ [0.0, s[i], c[i]], -1, 1))))
    after = np.array(errors)[t > 1.0]  # the low-pass takes over from the start-up's gravity
    assert after.max() < 0.5, after.max()  # a plain mean would start it 4.3 deg off

