"""The streaming Butterworth low-pass against scipy's design and filtering."""

import math

import numpy as np
import pytest
from scipy import signal

from tracker.lowpass import LowPass2

TAU, DT = 0.5, 0.005


def test_design_is_scipys_second_order_butterworth_at_the_vqf_cutoff():
    fc = math.sqrt(2.0) / (2.0 * math.pi * TAU)  # VQF sec. 3.2
    b, a = signal.butter(2, fc, fs=1.0 / DT)
    lp = LowPass2.design(TAU, DT)
    assert [lp.b0, lp.b1, lp.b2] == pytest.approx(b, rel=1e-9)
    assert [1.0, lp.a1, lp.a2] == pytest.approx(a, rel=1e-9)


def test_filtering_matches_lfilter_started_settled_at_the_first_input():
    x = np.random.default_rng(0).normal(0.0, 1.0, (400, 3)) + [1.0, -2.0, 9.81]
    lp = LowPass2.design(TAU, DT)
    got = np.array([lp(tuple(row)) for row in x.tolist()])
    b, a = [lp.b0, lp.b1, lp.b2], [1.0, lp.a1, lp.a2]
    want = np.column_stack([signal.lfilter(b, a, x[:, i], zi=signal.lfilter_zi(b, a) * x[0, i])[0]
                            for i in range(3)])
    assert got == pytest.approx(want, abs=1e-9)
    assert lp.y == tuple(got[-1])


def test_a_sample_after_lost_ones_counts_for_each_period_it_stands_for():
    from tracker.lowpass import periods
    assert periods(0.005, 0.005) == 1 and periods(0.0150001, 0.005) == 3
    assert periods(0.0075, 0.005) == 0 and periods(0.001, 0.005) == 0  # a new rate, not a loss
    a, b = LowPass2.design(0.5, 0.005), LowPass2.design(0.5, 0.005)
    for x in ((1.0, 2.0, 3.0), (2.0, 2.0, 2.0)):
        a(x), b(x)
    held = a.held((5.0, 0.0, -1.0), 3)
    for _ in range(3):
        each = b((5.0, 0.0, -1.0))
    assert held == each
