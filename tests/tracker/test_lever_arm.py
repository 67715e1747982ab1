"""tracker.lever_arm: the shoulder's position fitted from the board's own readings, checked by hand
and against the simulator's kinematics (a chain whose positions are differentiated numerically)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from game.sim.motion_model import PlayerProfile, session
from tracker import quat as Q
from tracker.lever_arm import GRAVITY, LeverArm

RATE = 200.0


def run(lever: LeverArm, gyr, acc, q) -> np.ndarray:
    """The specific force at the shoulder for every sample (the lever fed as the tracking feeds it)."""
    out = np.empty_like(np.asarray(acc, dtype=float))
    for i, (g, a, qq) in enumerate(zip(np.asarray(gyr).tolist(), np.asarray(acc).tolist(), np.asarray(q).tolist())):
        out[i] = lever.at_shoulder(tuple(g), tuple(a), tuple(qq), 1.0 / RATE)
    return out


def test_a_board_spun_round_a_post_worked_by_hand():
    """A board at L = 0.25 m from a vertical axis, its x toward the axis, spinning at W about it:
    it feels gravity and W^2 L toward the axis, (W^2 L, 0, g). Only o's x is then observable
    (z is along the spin, y has no lever), so the ridge's fit is exactly
    o = (W^4 (1 - e^-T/window) L / (W^4 (1 - e^-T/window) + ridge), 0, 0), and at the shoulder
    the board feels g alone."""
    L, W, T = 0.25, 3.0, 300.0
    n = int(T * RATE)
    t = np.arange(n) / RATE
    q = np.stack([np.cos(W * t / 2), np.zeros(n), np.zeros(n), np.sin(W * t / 2)], axis=1)
    lever = LeverArm()
    out = run(lever, np.tile([0.0, 0.0, W], (n, 1)), np.tile([W * W * L, 0.0, GRAVITY], (n, 1)), q)
    p = lever.params
    seen = W ** 4 * -math.expm1(-(n - n % 4) / RATE / p.window_t)  # the sums are updated every 4th sample
    assert lever.offset == pytest.approx((seen * L / (seen + p.ridge), 0.0, 0.0), rel=2e-3, abs=1e-12)
    assert np.allclose(out[-1], (0.0, 0.0, GRAVITY), atol=0.01 * W * W * L)


def test_the_correction_uses_the_rate_of_change_at_the_samples_own_instant():
    """A board turning about its z at w = c t^2, the shoulder o = (L, 0, 0) from it, sampled every 4
    and 6 ms in turn: the correction is w x (w x o) + w' x o with w' = 2 c t exactly (the three-point
    difference is exact for a quadratic), where two samples' difference gives 2 c (t - h / 2)."""
    c, L = 50.0, 0.3
    lever = LeverArm()
    lever.state.offset = (L, 0.0, 0.0)  # as if fitted (the fit is first solved after 1 s)
    up, t, out = (1.0, 0.0, 0.0, 0.0), 0.0, []
    for k in range(100):  # 0.5 s
        dt = 0.004 if k % 2 else 0.006
        t += dt
        w = c * t * t
        got = lever.at_shoulder((0.0, 0.0, w), (0.0, 0.0, GRAVITY), up, dt)
        out.append((got, (-w * w * L, 2.0 * c * t * L, GRAVITY)))  # w x (w x o) = -w^2 o; w' x o along y
    for got, expected in out[2:]:
        assert got == pytest.approx(expected, rel=1e-9, abs=1e-9)


def test_a_still_board_and_broken_readings_leave_the_fit_at_zero():
    lever = LeverArm()
    up = (1.0, 0.0, 0.0, 0.0)
    for _ in range(int(30 * RATE)):
        assert lever.at_shoulder((0.0, 0.0, 0.0), (0.0, 0.0, GRAVITY), up, 1.0 / RATE) == (0.0, 0.0, GRAVITY)
    assert lever.offset == (0.0, 0.0, 0.0)
    bad = (math.nan, 0.0, GRAVITY)
    out = lever.at_shoulder((0.0, 0.0, 0.0), bad, up, 1.0 / RATE)  # passes unchanged ...
    assert math.isnan(out[0]) and out[1:] == bad[1:]
    assert lever.at_shoulder((math.inf, 0.0, 0.0), (0.0, 0.0, GRAVITY), up, 0.005) == (0.0, 0.0, GRAVITY)
    assert lever.at_shoulder((0.0, 0.0, 0.0), (0.0, 0.0, GRAVITY), up, 0.0) == (0.0, 0.0, GRAVITY)
    assert all(math.isfinite(v) for v in lever.state.info + lever.state.rhs)  # ... and teaches nothing
    lever.reset()
    assert lever.state.info == (0.0,) * 6


@pytest.mark.parametrize("name, profile", [
    ("typical", PlayerProfile()),
    ("shaky, loose strap", PlayerProfile(tremor_deg=2.0, tremor_hz=4.0, sway_deg=4.0, wobble_deg=6.0,
                                         wobble_hz=5.0, twist_follow=0.4, slip_deg_per_min=4.0))])
def test_a_simulated_player_in_play_against_the_simulators_kinematics(name, profile):
    """Gestures, walks and fidgets of a simulated player whose shoulder rises with the arm and
    bounces as they walk, the board rocking on the soft tissue about a pivot of its own: the fit
    finds the shoulder within 4 cm of where the chain puts it (its mean over the session, sensor
    frame). For the typical player the accelerometer at the shoulder is left with under 60 %
    of the raw one's acceleration beside gravity (RMS, world frame, after the first minute); the
    shaky player's rocking (5 Hz, 6 deg, about the strap) is no shoulder's and stays."""
    script = session(profile, seed=5, gestures=12)
    truth = profile.simulator(script.motion, 5).truth(np.arange(0.0, script.duration_s, 1.0 / RATE))
    q, gyr, acc = truth.q_sensors[:, 0], truth.gyr[:, 0], truth.acc[:, 0]
    lever = LeverArm()
    out = run(lever, gyr, acc, q)
    shoulder = script.motion.shoulder(truth.t, truth.q_links[:, 0])
    o_true = Q.rotate(Q.conjugate(q), shoulder - truth.p_sensors[:, 0]).mean(axis=0)
    assert np.linalg.norm(np.array(lever.offset) - o_true) < 0.04, (lever.offset, o_true)
    after = truth.t > 60.0

    def beside_gravity(a: np.ndarray) -> float:
        return float(np.sqrt(np.mean(np.sum((Q.rotate(q, a)[after] - (0.0, 0.0, GRAVITY)) ** 2, axis=1))))

    if name == "typical":
        assert beside_gravity(out) < 0.6 * beside_gravity(acc), (beside_gravity(out), beside_gravity(acc))
