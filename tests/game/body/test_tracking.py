"""The tracking's start: the board's clock tells the filter how long ago it powered up."""

from __future__ import annotations

import math

import pytest

from game.body.tracking import Tracking
from tracker import protocol as P


def sample(t: float) -> P.RawSample:
    """A board lying flat and still (2048 counts = 1 g at +-16 g), ``t`` s after its power-up."""
    return P.RawSample(t, round(t * 1e6), 0, (0, 0, 2048), (0, 0, 0), None, 512)


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
