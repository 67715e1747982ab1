"""tracker.lever_arm: the shoulder's position fitted from the board's own readings, checked by hand
and against the simulator's kinematics (a chain whose positions are differentiated numerically)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from game.sim.motion_model import PlayerProfile, session
from tracker import quat as Q
from tracker.fusion.qmath import integrate, normalize
from tracker.lever_arm import GRAVITY, LeverArm, LeverArmParams

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


def rocking(freq: float, amp: float, pivot: np.ndarray, seconds: float) -> tuple[np.ndarray, np.ndarray]:
    """A board rocking about its z on the strap, theta = amp sin(2 pi f t), about a pivot ``pivot``
    (seen from the board): rate and specific force, worked by hand. The board's position is
    R (-pivot) from the pivot, so its acceleration is -R K pivot with K = [w]x^2 + [w']x; about z,
    K p = (-w^2 p_x - w' p_y, -w^2 p_y + w' p_x, 0), and gravity stays along z."""
    t = np.arange(int(seconds * RATE)) / RATE
    om = 2.0 * math.pi * freq
    w, wd = amp * om * np.cos(om * t), -amp * om * om * np.sin(om * t)
    kp = np.stack([-w * w * pivot[0] - wd * pivot[1], -w * w * pivot[1] + wd * pivot[0], 0.0 * t], axis=1)
    return np.stack([0.0 * t, 0.0 * t, w], axis=1), np.array([0.0, 0.0, GRAVITY]) - kp


@pytest.mark.parametrize("freq", [5.0, 12.0, 23.5])
def test_a_strap_rocking_on_its_own_pivot_averages_to_gravity_in_the_filters_frame(freq):
    """A strap rocking 5 deg at 5-23.5 Hz about a pivot 2 cm under it, the fit's shoulder 0.3 m away:
    the correction takes off the shoulder's lever, not the pivot's, so every sample is wrong by up
    to w'^2 A L, but turned into the filter's frame I as DefaultFilter turns a reading (the
    rates integrated sample by sample, the reading turned back by h = dt / 2 - acc_lead_s) it is
    the change of R (w x o), which a bounded rocking does not change on average: the corrected
    reading averages to gravity over 40 s, within the ends' 2 A w L / 40 s. (w' at each sample's
    instant from the last three rates, 15 % too large at 23.5 Hz and 200 Hz, averaged 2 m/s^2 off.)"""
    amp, L, lead = math.radians(5.0), 0.3, 0.00102
    seconds = 40.0
    gyr, acc = rocking(freq, amp, np.array([0.0, -0.02, 0.0]), seconds)
    lever = LeverArm(LeverArmParams(solve_t=1e9))  # solved never: o stays as set
    lever.state.offset = (L, 0.0, 0.0)
    q, dt, frame_i = (1.0, 0.0, 0.0, 0.0), 1.0 / RATE, []
    for g, a in zip(gyr.tolist(), acc.tolist()):
        q = normalize(integrate(q, tuple(g), dt))
        f = np.array(lever.at_shoulder(tuple(g), tuple(a), q, dt, lead))
        frame_i.append(Q.rotate(np.array(q), f - (0.5 * dt - lead) * np.cross(g, f)))
    om = 2.0 * math.pi * freq
    assert np.allclose(np.mean(frame_i, axis=0), (0.0, 0.0, GRAVITY), atol=2.0 * amp * om * L / seconds)
    assert np.abs(np.array(frame_i) - (0.0, 0.0, GRAVITY)).max() > 0.5 * om * om * amp * L  # wrong sample by sample


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
