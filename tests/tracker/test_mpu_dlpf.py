"""The MPU-9250's low-pass filters in the simulator: the setting the firmware picks, and its delays.

Each against a case worked by hand: a signal that is a cubic in time is delayed
exactly; a sine's reading lags by the register map's delay, 2 pi f d of phase;
the simulated board's gyroscope and accelerometer read the truth that many
milliseconds ago (the simulator's own truth at the earlier time as the oracle),
while the truth it reports stays the present one.
"""

import math

import numpy as np
import pytest

from tracker.mpu_dlpf import Dlpf, FractionalDelay, dlpf_for_rate
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


@pytest.mark.parametrize("delay_s, rate", [(0.0059, 200.0), (0.00488, 200.0), (0.00097, 1000.0),
                                           (0.03348, 10.0), (0.0, 200.0), (0.01, 100.0)])
def test_a_cubic_in_time_is_delayed_exactly(delay_s, rate):
    f = FractionalDelay.of(delay_s, rate)
    t = np.arange(-f.reach, 400) / rate
    cubic = lambda t: 0.3 - 2.0 * t + 1.5 * t ** 2 - 0.7 * t ** 3  # noqa: E731
    assert np.allclose(f.apply(cubic(t)), cubic(t[f.reach:] - delay_s), rtol=0, atol=1e-9)
    assert max(f.offsets) <= 0 and sum(f.weights) == pytest.approx(1.0)  # nothing read ahead


@pytest.mark.parametrize("freq", [1.0, 10.0, 25.0])
def test_a_sine_lags_by_the_delay_within_the_interpolations_bound(freq):
    rate, delay = 200.0, 0.0059
    f = FractionalDelay.of(delay, rate)
    t = np.arange(-f.reach, 2000) / rate
    got = f.apply(np.sin(2 * math.pi * freq * t))
    want = np.sin(2 * math.pi * freq * (t[f.reach:] - delay))
    bound = (2 * math.pi * freq / rate) ** 4 / 24  # FractionalDelay's docstring
    assert np.max(np.abs(got - want)) <= bound
    # Its phase against the undelayed sine, by least squares: 2 pi f d (a tenth of a degree at 25 Hz).
    s, c = np.sin(2 * math.pi * freq * t[f.reach:]), np.cos(2 * math.pi * freq * t[f.reach:])
    a, b = np.linalg.lstsq(np.column_stack([s, c]), got, rcond=None)[0]
    assert math.atan2(-b, a) == pytest.approx(2 * math.pi * freq * delay, abs=math.radians(0.2))


def test_a_bad_delay_is_a_clear_error():
    with pytest.raises(ValueError, match="delay >= 0"):
        FractionalDelay.of(-0.001, 200.0)
    with pytest.raises(ValueError, match="rate > 0"):
        FractionalDelay.of(0.005, 0.0)


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
