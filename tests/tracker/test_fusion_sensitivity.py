"""The gyroscope's residual sensitivity learned in play (tracker.fusion.sensitivity), on simulated
truth: a board whose gyroscope reads (I + M) times the true rate, with the accelerometer at the
shoulder (what the game's lever-arm correction gives the filter, tracker.lever_arm).

The truth worked by hand: the filter's D maps the reading back to the true rate, D = (I + M)^-1 - I,
which to first order in M (0.2 %) is -M; numpy's inverse gives it exactly.

With D learned there, the bias loop's turn gates open wider (``SHOULDER_TURN_RATE``): a fast
player's bias is learned against its simulated truth.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest
from scipy.signal import lfilter

from tracker.fusion.default import SHOULDER_SENS_PRIOR, SHOULDER_TURN_RATE, DefaultParams, for_mpu9250
from tracker.fusion.sensitivity import Sensitivity
from tracker.sim import Simulator, arm_chain, mpu9250

from .test_fusion_default_robust import BIAS0_DPS, MISALIGNED, RATE, heading_error_deg, play, raises, run

START = DefaultParams().sens_start_t  # the residual is learned from then on
SECONDS = START + 300.0
# As the game's tracking has it (the accelerometer at the shoulder, for_mpu9250).
ON = {"sens_prior": SHOULDER_SENS_PRIOR, "bias_turn_rate": SHOULDER_TURN_RATE, "bias_turned_rate": SHOULDER_TURN_RATE}
OFF = {"sens_prior": 0.0}  # nothing learned: the filter's default, fed a raw accelerometer
# Every entry off by the 0.2 % a maker's calibration leaves at worst (README, the maker table).
RESIDUAL = 0.002 * np.array([[1.0, 1.0, -1.0], [-1.0, -1.0, 1.0], [1.0, -1.0, 1.0]])


def truth_of(m: np.ndarray) -> np.ndarray:
    return np.linalg.inv(np.eye(3) + m) - np.eye(3)


@lru_cache(maxsize=None)
def shoulder_session(motion: str, seed: int):
    """(true rates, accelerometer, true q_WS) of ``motion`` on a board at the shoulder."""
    mo = raises(seed, SECONDS) if motion == "raises" else play(seed, SECONDS, tremor_deg=0.0, sway_deg=0.0)
    d = Simulator(arm_chain(sensor_m=0.0), mo, mpu9250(offset=False), seed=seed).simulate(SECONDS, RATE)
    return d.gyr[:, 0], d.acc[:, 0], d.truth.q_sensors[:, 0]


def learned(motion: str, seed: int, m: np.ndarray, params: dict = ON) -> tuple[np.ndarray, float]:
    """D learned over 300 s, and the heading's error then (deg, from its value when learning began)."""
    gyr, acc, truth = shoulder_session(motion, seed)
    q, _, _, f = run(gyr @ (np.eye(3) + m).T, acc, None, **params)
    heading = heading_error_deg(q, truth, slice(int(START * RATE), int(START * RATE) + 1))
    return np.array(f.get_state().sens.d).reshape(3, 3), float(heading[-1])


@pytest.mark.parametrize("seed", range(3))
def test_play_teaches_every_entry_of_the_residual(seed):
    d, _ = learned("play", seed, RESIDUAL)
    true = truth_of(RESIDUAL)
    assert np.linalg.norm(d - true) < 0.5 * np.linalg.norm(true), (d, true)
    assert np.all(np.sign(d) == np.sign(true)), (d, true)
    exact, _ = learned("play", seed, np.zeros((3, 3)))  # a gyroscope without one: D stays small
    assert np.linalg.norm(exact) < 0.2 * np.linalg.norm(true), exact


@pytest.mark.parametrize("seed", range(3))
def test_raises_no_longer_walk_the_heading(seed):
    # Raises by 90 deg about the board's x excite D's first column only: the cross-axis entries are
    # learned, the scale (exact) stays near 0, the columns never turned about stay about where they began.
    d, heading = learned("raises", seed, MISALIGNED)
    true = truth_of(MISALIGNED)
    np.testing.assert_allclose(d[1:, 0], true[1:, 0], rtol=0.35)
    assert abs(d[0, 0]) < 0.15 * abs(true[1, 0])
    assert np.abs(d[:, 1:]).max() < 0.05 * abs(true[1, 0])  # (the sensor noise turns it a little)
    _, before = learned("raises", seed, MISALIGNED, OFF)
    assert before < -3.0 and abs(heading) < 0.25 * abs(before), (heading, before)


def test_the_correction_is_i_plus_d_and_each_entry_stays_within_its_limit():
    s = Sensitivity(tau=3.0, prior=1.0, limit=0.005)
    s.d = tuple(RESIDUAL.ravel())
    w = (0.3, -1.2, 2.0)
    np.testing.assert_allclose(s.correct(w), (np.eye(3) + RESIDUAL) @ w, rtol=1e-12)
    s.regress(((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)), w, 0.02)  # turning about all three
    ph, spread = s.row((1.0, 0.0, 0.0))
    s.learn(ph, spread, 100.0, 1.0)  # an innovation far beyond any residual's
    assert max(abs(v) for v in s.d) == pytest.approx(0.005)


def test_it_is_learned_only_where_the_accelerometer_is_at_the_centre_of_rotation():
    # A raw accelerometer feels every move's tangential acceleration, which correlates with the rate:
    # the filter's default learns nothing, the board's filter at the shoulder (the game's) does.
    assert DefaultParams().sens_prior == 0.0
    assert for_mpu9250(200.0).params.sens_prior == 0.0
    assert for_mpu9250(200.0, at_shoulder=True).params.sens_prior == SHOULDER_SENS_PRIOR > 0.0
    d, _ = learned("raises", 0, MISALIGNED, OFF)
    assert not d.any()
    assert (DefaultParams().bias_turn_rate, DefaultParams().bias_turned_rate) == (0.25, 0.25)
    shoulder = for_mpu9250(200.0, at_shoulder=True).params
    assert shoulder.bias_turn_rate == shoulder.bias_turned_rate == SHOULDER_TURN_RATE == 0.5


# ----------------------------------------------------------------- a fast player's bias

FAST, FAST_SECONDS = 2.0, 180.0  # twice the typical speed (the profiles' range: 0.25-4), three minutes


@lru_cache(maxsize=None)
def fast_session(seed: int):
    """(gyro reading, accelerometer, true rate, true bias) of fast play at the shoulder with tremor and
    sway, the gyroscope 5 deg/s off (no start-up hold took it out) and its sensitivity off by RESIDUAL."""
    mo = play(seed, FAST_SECONDS, sway_deg=1.0, speed=FAST)
    d = Simulator(arm_chain(sensor_m=0.0), mo, mpu9250(offset=False), seed=seed).simulate(FAST_SECONDS, RATE)
    bias = np.radians(BIAS0_DPS)
    return d.gyr[:, 0] @ (np.eye(3) + RESIDUAL).T + bias, d.acc[:, 0], d.gyr[:, 0], bias


@pytest.mark.parametrize("seed", range(3))
def test_a_fast_players_bias_is_learned_through_the_wider_turn_gates(seed):
    gyr, acc, rate, bias = fast_session(seed)
    # The player turns faster than the default's gate most of the time (the true rate through a
    # first-order low-pass over rest_lp_tau, 1 s, near the filter's own), where it weighs what motion
    # tells of the bias at 1 / (1 + |w|^2 / 0.25^2): a fifth at 0.5 rad/s, against a half at the
    # shoulder's gate.
    k = 1.0 / (DefaultParams().rest_lp_tau * RATE)
    lp = np.linalg.norm(lfilter([k], [1.0, k - 1.0], rate, axis=0), axis=1)
    assert np.mean(lp > DefaultParams().bias_turn_rate) > 0.75
    late = slice(int(FAST_SECONDS / 2 * RATE), None)
    error = {}
    for gate in (DefaultParams().bias_turn_rate, SHOULDER_TURN_RATE):
        _, est, _, _ = run(gyr, acc, None, **{**ON, "bias_turn_rate": gate, "bias_turned_rate": gate})
        error[gate] = np.degrees(np.sqrt(np.mean(np.sum((est[late] - bias) ** 2, axis=1))))
    assert error[SHOULDER_TURN_RATE] < 0.8 * error[DefaultParams().bias_turn_rate], error
