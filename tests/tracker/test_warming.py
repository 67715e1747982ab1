"""The die's rate of warming (tracker.warming), against lines and a warm-up curve worked by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tracker.protocol import temp_c, temp_counts
from tracker.sim import ROOM_C, warmup_curve
from tracker.warming import DieWarming, WarmingParams


def _fed(warming: DieWarming, times, temps) -> DieWarming:
    for t, c in zip(times, temps):
        warming.update(float(t), float(c))
    return warming


def test_a_steady_warming_of_3_degc_a_minute_is_measured_exactly_once_10_s_are_seen():
    warming = DieWarming()
    times = np.arange(0.0, 9.5, 0.005)  # 200 samples a second: one point a second is kept
    _fed(warming, times, 25.0 + 0.05 * times)  # 0.05 degC/s = 3 degC a minute
    assert warming.rate is None and not warming.settled and warming.measured_s == pytest.approx(9.0, abs=0.01)
    _fed(warming, times + 9.5, 25.0 + 0.05 * (times + 9.5))
    assert warming.rate == pytest.approx(3.0, rel=1e-9) and not warming.settled


def test_the_temp_frames_resolution_leaves_the_slope_nearly_exact():
    # TEMP_OUT counts 333.87 per degC (PS-MPU-9250A-01 sec. 3.4.2): a rate of 0.6 degC a minute read
    # through it, one frame a second, over 30 s
    times = np.arange(0.0, 40.0, 1.0)
    warming = _fed(DieWarming(), times, [temp_c(temp_counts(30.0 + 0.01 * t)) for t in times])
    assert warming.rate == pytest.approx(0.6, abs=0.01) and warming.settled


def test_a_warm_up_curve_slows_below_the_limit_where_its_derivative_says():
    # the die's warm-up on tracker.sim's curve: T = ROOM + R (1 - exp(-t / tau)) / (1 - exp(-600 / tau)), whose
    # derivative R exp(-t / tau) / (tau (1 - exp(-600 / tau))) falls to 1 degC a minute at
    # t* = tau ln(60 R / (tau (1 - exp(-600 / tau)))); the slope over the window's 30 s is that at its middle
    rise, tau = 12.0, 150.0
    times = np.arange(6000) / 10.0
    temps = ROOM_C + rise * warmup_curve(times, tau)
    warming, settled_at, checked = DieWarming(), None, 0
    for k, (t, c) in enumerate(zip(times, temps)):
        warming.update(float(t), float(c))
        if settled_at is None and warming.settled:
            settled_at = t
        if k in (1000, 3000):
            derivative = 60.0 * rise * math.exp(-(t - 15.0) / tau) / (tau * -math.expm1(-600.0 / tau))
            assert warming.rate == pytest.approx(derivative, rel=0.01)
            checked += 1
    assert checked == 2
    t_star = tau * math.log(60.0 * rise / (tau * -math.expm1(-600.0 / tau)))
    assert settled_at == pytest.approx(t_star + 15.0, abs=1.5)


def test_a_board_cooling_as_fast_waits_too_and_a_clock_going_back_starts_again():
    times = np.arange(0.0, 20.0, 0.5)
    warming = _fed(DieWarming(), times, 40.0 - 0.05 * times)
    assert warming.rate == pytest.approx(-3.0) and not warming.settled
    warming.update(1.0, 39.0)  # the board powered up again: its clock restarted
    assert warming.rate is None and warming.measured_s == 0.0


@pytest.mark.parametrize("settings", [{"window_s": 5.0}, {"step_s": 0.0}, {"max_c_per_min": 0.0}])
def test_settings_out_of_order_are_refused_by_name(settings):
    with pytest.raises(ValueError, match="WarmingParams need 0 < step_s <= min_span_s <= window_s"):
        WarmingParams(**settings)
