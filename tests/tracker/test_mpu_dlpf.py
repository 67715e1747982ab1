"""The MPU-9250's low-pass filters in the simulator: the setting the firmware picks, and its delays.

Each against a case worked by hand or an oracle: every setting's response is late
by the register map's delay; its gain and phase are scipy's first-order low-pass
and a dead time; a vibration near the sample rate arrives as attenuated as that;
the simulated board's gyroscope and accelerometer read the truth that many
milliseconds ago (the simulator's own truth at the earlier time as the oracle),
while the truth it reports stays the present one.
"""

import math

import numpy as np
import pytest

from scipy import signal

from tracker.mpu_dlpf import (ACCEL_BANDWIDTH_HZ, ACCEL_DELAY_MS, GYRO_BANDWIDTH_HZ, GYRO_DELAY_MS, INTERNAL_HZ,
                             Dlpf, Response, dlpf_for_rate)
from tracker.sim import Motion, SensorErrors, Simulator, arm_chain, arm_swing, realistic_errors


@pytest.mark.parametrize("rate, code", [(1000, 0), (999, 1), (736, 1), (735, 2), (368, 2), (367, 3),
                                        (200, 3), (164, 3), (163, 4), (80, 4), (79, 5), (40, 5), (39, 6),
                                        (1, 6)])
def test_the_widest_bandwidth_at_most_a_quarter_of_the_rate(rate, code):
    # Worked by hand from the register map's bandwidths 250, 184, 92, 41, 20, 10, 5 Hz:
    # 4 x 250 = 1000, 4 x 184 = 736, 4 x 92 = 368, 4 x 41 = 164, 4 x 20 = 80, 4 x 10 = 40.
    assert dlpf_for_rate(rate) == code


def test_the_games_rate_reads_the_gyroscope_5_9_ms_and_the_accelerometer_4_88_ms_late():
    d = Dlpf.for_rate(200)  # register map RM-MPU-9250A-00 sec. 4.6 and 4.8, DLPF_CFG = 3
    assert (d.code, d.gyro_hz, d.accel_hz) == (3, 41.0, 44.8)
    assert d.gyro_delay_s == pytest.approx(0.0059) and d.accel_delay_s == pytest.approx(0.00488)


SETTINGS = [(GYRO_BANDWIDTH_HZ[c], GYRO_DELAY_MS[c]) for c in range(7)] + [
    (ACCEL_BANDWIDTH_HZ[c], ACCEL_DELAY_MS[c]) for c in range(7)]


@pytest.mark.parametrize("bandwidth, delay_ms", SETTINGS)
def test_every_setting_reads_late_by_the_register_maps_delay(bandwidth, delay_ms):
    r = Response(bandwidth, delay_ms / 1000.0)
    w = r.weights()
    # A first-order low-pass delays slow signals by its time constant 1 / (2 pi f); the rest is dead time.
    assert r.time_constant_s == pytest.approx(1.0 / (2.0 * math.pi * bandwidth))
    assert 0.0 <= r.dead_time_s < 2.2e-3  # the rest is a conversion latency of 0.3-2.2 ms at every setting
    assert w.sum() == pytest.approx(1.0, abs=1e-12) and np.all(w >= 0.0)
    # The response's first moment, the delay of a slow signal, is the register map's (within 0.01 %: the
    # tail left out, e^-12 of the response, TAIL).
    assert np.sum(w * np.arange(len(w))) / INTERNAL_HZ == pytest.approx(delay_ms / 1000.0, rel=1e-4)
    # Nothing read ahead: a ramp reads as the ramp that many ms ago.
    t = np.arange(2000) / INTERNAL_HZ
    last = np.arange(r.taps, 2000)
    assert np.allclose(r.read(0.3 + 2.0 * t, last), 0.3 + 2.0 * (t[last] - delay_ms / 1000.0), rtol=0,
                       atol=2.0 * 1e-4 * delay_ms / 1000.0)


@pytest.mark.parametrize("freq", [1.0, 10.0, 25.0, 41.0, 100.0])
def test_the_gain_and_phase_are_a_first_order_low_pass_and_a_dead_time(freq):
    # The oracle: scipy's response of 1 / (1 + s T), times exp(-i 2 pi f D), times sinc^2 (f h) for the
    # straight lines joining the internal samples (the Fourier transform of the hat function).
    r = Dlpf.for_rate(200.0).gyro
    w = r.weights()
    got = np.sum(w * np.exp(-2j * math.pi * freq * np.arange(len(w)) / INTERNAL_HZ))
    _, h = signal.freqs([1.0], [r.time_constant_s, 1.0], worN=[2 * math.pi * freq])
    want = h[0] * np.exp(-2j * math.pi * freq * r.dead_time_s) * np.sinc(freq / INTERNAL_HZ) ** 2
    assert abs(got) == pytest.approx(abs(want), rel=2e-3)
    assert np.angle(got / want) == pytest.approx(0.0, abs=math.radians(0.2))
    if freq == 41.0:
        assert abs(got) == pytest.approx(1.0 / math.sqrt(2.0), rel=0.01)  # 3 dB down at the bandwidth


def amplitude(x: np.ndarray, t: np.ndarray, freq: float) -> float:
    """The amplitude of the sine at ``freq`` fitted to x(t) by least squares."""
    w = 2 * math.pi * freq * t
    a, b = np.linalg.lstsq(np.column_stack([np.sin(w), np.cos(w)]), x, rcond=None)[0]
    return math.hypot(a, b)


def test_a_vibration_near_the_sample_rate_reaches_the_samples_as_the_low_pass_lets_it():
    # A 195 Hz vibration read at 200 Hz aliases to 5 Hz. Read at the samples' instants it would arrive
    # whole; through the chip's 41 Hz low-pass it is 1 / sqrt(1 + (195 / 41)^2) = 0.206 of itself, and
    # the straight lines between the internal samples take sinc^2(0.195) = 0.885 of that: 0.182.
    r = Dlpf.for_rate(200.0).gyro
    t = np.arange(20000) / INTERNAL_HZ
    last = np.arange(r.taps, 20000, 5)  # every fifth internal sample: 200 Hz
    got = r.read(np.sin(2 * math.pi * 195.0 * t), last)
    assert amplitude(got, t[last], 5.0) == pytest.approx(0.182, abs=0.003)


@pytest.mark.parametrize("freq, gain", [(5.0, 1.000), (10.0, 1.000), (12.0, 0.999), (25.0, 0.993)])
def test_the_lead_gives_a_tremor_back_its_amplitude(freq, gain):
    # Read at 200 Hz through the 41 Hz low-pass a sine keeps 1 / sqrt(1 + (f / 41)^2) of itself (0.971 at
    # 10 Hz); led by L, w_k + (L / dt) (w_k - w_k-1), its gain is |C H| = sqrt(|C|^2 |H|^2), |C|^2 = 1 + 2
    # (l + l^2) (1 - cos W dt), l = L / dt (worked by hand: 0.9998 at 10 Hz, 0.993 at 25 Hz), fitted here
    # to the readings by least squares (the hat's sinc^2 takes 0.06 % more at 25 Hz).
    r = Dlpf.for_rate(200.0).gyro
    t = np.arange(20000) / INTERNAL_HZ
    last = np.arange(r.taps, 20000, 5)
    read = r.read(np.sin(2 * math.pi * freq * t), last)
    led = read[1:] + r.amplitude_lead_s(200.0) * 200.0 * np.diff(read)
    ts = t[last[1:]]
    assert amplitude(led, ts, freq) == pytest.approx(gain, abs=0.002)
    assert amplitude(read[1:], ts, freq) == pytest.approx(1.0 / math.sqrt(1.0 + (freq / 41.0) ** 2), abs=0.002)


def test_a_response_that_cannot_be_is_a_clear_error():
    with pytest.raises(ValueError, match="bandwidth > 0"):
        Response(0.0, 0.005)
    with pytest.raises(ValueError, match="delay >= 1 / \\(2 pi bandwidth\\)"):
        Response(41.0, 0.001)  # a 41 Hz low-pass alone delays 3.9 ms


def test_the_simulated_board_reads_its_imu_late_and_reports_the_present_truth():
    sim = Simulator(arm_chain(), arm_swing(), SensorErrors(dlpf=True), seed=1)  # no other error
    rate = 200.0
    data = sim.simulate(4.0, rate)
    t = np.arange(len(data.t)) / rate
    earlier = lambda d: sim.truth(np.maximum(t - d, 0.0))  # noqa: E731  (the first sample held before 0)
    late = t >= 0.02
    assert np.allclose(data.gyr[late], earlier(0.0059).gyr[late], rtol=0, atol=2e-3 * np.abs(data.gyr).max())
    assert np.allclose(data.acc[late], earlier(0.00488).acc[late], rtol=0, atol=2e-3 * np.abs(data.acc).max())
    assert np.array_equal(data.truth.gyr, sim.truth(t).gyr)  # the truth is not delayed
    # To first order the reading errs by -d times the rate's rate of change (central differences).
    lag = -0.0059 * np.gradient(data.truth.gyr, 1.0 / rate, axis=0)
    assert np.abs(lag).max() > 0.005  # rad/s: the swing changes its rate enough to see it
    assert np.allclose((data.gyr - data.truth.gyr)[late], lag[late], rtol=0, atol=0.1 * np.abs(lag).max())


def test_the_typical_board_has_the_filters_and_the_papers_chip_does_not():
    assert realistic_errors().dlpf
    assert not SensorErrors().dlpf


def test_a_still_board_is_not_changed_by_the_filters():
    still = Motion(lambda t: np.broadcast_to([1.0, 0.0, 0.0, 0.0], (len(t), 4)), lambda t: np.zeros((len(t), 1)))
    on = Simulator(arm_chain(), still, SensorErrors(dlpf=True), seed=2).simulate(1.0, 200.0)
    off = Simulator(arm_chain(), still, SensorErrors(), seed=2).simulate(1.0, 200.0)
    assert np.allclose(on.gyr, off.gyr, rtol=0, atol=1e-12) and np.allclose(on.acc, off.acc, rtol=0, atol=1e-12)
