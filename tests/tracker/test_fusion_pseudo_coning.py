"""The default filter's lead of the rates (``gyro_lead_s``) against pseudo-coning, worked by hand.

An arm whose rotation vector is (a cos Wt, b sin Wt, 0) comes back to where it was
every period, yet its gyroscope reads a mean rate a b W / 2 about -z (Bortz 1971: the
body rate is dtheta/dt - theta x dtheta/dt / 2 + ..., and theta x dtheta/dt = (0, 0, a b W)):
the oscillations, integrated, take it back. Read through the chip's low-pass the
oscillations arrive |H| their size and take back only |H|^2 of it, so the readings,
integrated, drift at a b W (1 - |H|^2) / 2 (Mark and Tazartes 2000): with the
first-order low-pass of :mod:`tracker.mpu_dlpf`, |H|^2 = 1 / (1 + (f / 41 Hz)^2). The
same rates sampled without the low-pass are the reference: whatever the 200 Hz
integration itself gets wrong, they get wrong alike.
"""

import math

import numpy as np
import pytest

from tracker import quat
from tracker.fusion.default import DefaultFilter, DefaultParams, for_mpu9250
from tracker.mpu_dlpf import INTERNAL_HZ, Dlpf

RATE = 200.0
A, B = math.radians(1.5), math.radians(1.0)  # the tremor's two swings, a quarter period apart


def coning_rates(freq: float, seconds: float) -> np.ndarray:
    """The body rates of the rotation vector (A cos Wt, B sin Wt, 0) at the chip's 1 kHz (rad/s):
    2 vec(q* dq/dt), the derivative by central differences of 1 microsecond."""
    w = 2.0 * math.pi * freq
    t = np.arange(round(seconds * INTERNAL_HZ)) / INTERNAL_HZ

    def q(at: np.ndarray) -> np.ndarray:
        return quat.from_rotvec(np.stack([A * np.cos(w * at), B * np.sin(w * at), np.zeros_like(at)], axis=-1))

    h = 1e-6
    dq = (q(t + h) - q(t - h)) / (2.0 * h)
    return 2.0 * quat.multiply(quat.conjugate(q(t)), dq)[:, 1:]


def drift_dps(rates: np.ndarray, lead_s: float, periods_from: int, period: int) -> float:
    """The turn about z (deg/s) of a filter fed ``rates`` (no accelerometer: the strapdown alone)
    between two samples a whole number of the motion's periods apart, where the arm is where it was."""
    f = DefaultFilter(DefaultParams(gyro_lead_s=lead_s))
    qs = [f.update(tuple(r), None, None, 1.0 / RATE) for r in rates]
    k0 = periods_from * period
    k1 = k0 + ((len(qs) - k0 - 1) // period) * period
    turn = quat.to_rotvec(quat.multiply(qs[k1], quat.conjugate(qs[k0])))
    return math.degrees(turn[2]) * RATE / (k1 - k0)


@pytest.mark.parametrize("freq", [5.0, 10.0])
def test_the_lead_takes_out_the_drift_the_low_pass_gives_a_tremors_coning(freq):
    rates = coning_rates(freq, 30.0)
    every = round(INTERNAL_HZ / RATE)
    gyro = Dlpf.for_rate(RATE).gyro
    last = np.arange(gyro.taps, len(rates), every)
    read, raw = gyro.read(rates, last), rates[last]
    period = round(RATE / freq)
    reference = drift_dps(raw, 0.0, 4, period)
    unled = drift_dps(read, 0.0, 4, period) - reference
    led = drift_dps(read, gyro.amplitude_lead_s(RATE), 4, period) - reference
    # By hand: -a b W (1 - |H|^2) / 2, |H|^2 = 1 / (1 + (f / 41)^2): -0.006 deg/s at 5 Hz, -0.046 at 10 Hz.
    h2 = 1.0 / (1.0 + (freq / gyro.bandwidth_hz) ** 2)
    expected = -math.degrees(A * B * 2.0 * math.pi * freq * (1.0 - h2) / 2.0)
    assert unled == pytest.approx(expected, rel=0.1)
    assert abs(led) < 0.05 * abs(expected)


def test_the_lead_adds_no_turn_of_its_own():
    # A turn about one axis that starts and ends at rest: the lead's increments L (w_k - w_k-1) sum to
    # L (w_end - w_first) = 0, so the angle is the rates' integral, whatever the lead (worked by hand).
    t = np.arange(400) / RATE
    w = np.where((t > 0.2) & (t < 1.6), np.sin(math.pi * (t - 0.2) / 1.4) ** 2 * 3.0, 0.0)
    rates = np.stack([np.zeros_like(t), np.zeros_like(t), w], axis=-1)
    for lead in (0.0, 0.002, 0.005):
        f = DefaultFilter(DefaultParams(gyro_lead_s=lead))
        for r in rates:
            q = f.update(tuple(r), None, None, 1.0 / RATE)
        assert quat.to_rotvec(q)[2] == pytest.approx(np.sum(w) / RATE, abs=1e-9)


def test_the_games_filter_leads_the_rates_as_the_firmwares_low_pass_asks():
    # At 200 Hz the firmware sets the 41 Hz low-pass: T = 1 / (2 pi 41) s, and L solves
    # L / dt + (L / dt)^2 = (T / dt)^2, dt = 5 ms: L = 2.117 ms (worked by hand).
    ratio = 200.0 / (2.0 * math.pi * 41.0)
    lead = for_mpu9250(200.0).params.gyro_lead_s
    assert lead == pytest.approx((math.sqrt(1 + 4 * ratio ** 2) - 1) / 400.0)
    assert lead == pytest.approx(2.117e-3, abs=1e-6)
    assert DefaultParams().gyro_lead_s == 0.0  # a recording of another board: its rates as read
