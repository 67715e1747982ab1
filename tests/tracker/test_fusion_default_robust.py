"""The default filter on a real player with a real board (issue 12): a gyro bias learned in play
(a tremor, sway, no clean hold, a warming board) and a magnetometer that never makes the heading
worse than none (hard iron, soft iron, an indoor disturbance), on simulated truth.

``python -m tests.tracker.test_fusion_default_robust`` prints the figures (heading error by time
for no magnetometer, a good one and bad ones; the bias's convergence from 5 deg/s).
"""

from __future__ import annotations

import dataclasses
import math
from functools import lru_cache
from typing import Callable

import numpy as np
import pytest

from tracker import quat as Q
from tracker.fusion import make
from tracker.fusion.default import MAG_WEAK, DefaultFilter, DefaultParams
from tracker.sim import MagneticErrors, Motion, Simulator, arm_chain, mpu9250

RATE = 200.0
DEG = math.pi / 180
BIAS0_DPS = np.array([2.9, -2.9, 2.9])  # 5 deg/s in all: the MPU-9250's zero-rate offset bound
WARMUP_DPS, WARMUP_TAU_S = 4.0, 150.0  # the worst warm-up, the sim's thermal time constant


def play(seed: int, duration: float, tremor_deg: float = 0.5, tremor_hz: float = 8.0,
         sway_deg: float = 2.0, speed: float = 1.0) -> Motion:
    """A player at play: the upper arm moves to a random pose (yaw, raise, twist) in 0.4-1.2 s
    (minimum jerk), holds it 0.3-1.5 s, and so on, both divided by ``speed``; a tremor about the
    arm's two swing axes and a slow sway (0.1-1 Hz) about all three ride on top. The elbow stays
    straight."""
    rng = np.random.default_rng(seed)
    times, poses, t = [0.0], [np.zeros(3)], 0.0
    while t < duration + 2.0:
        move, hold = rng.uniform(0.4, 1.2) / speed, rng.uniform(0.3, 1.5) / speed
        target = np.array([rng.uniform(-0.6, 0.6), rng.uniform(0.0, 1.6), rng.uniform(-0.5, 0.5)])
        times += [t + move, t + move + hold]
        poses += [target, target]
        t += move + hold
    knots, targets = np.array(times), np.array(poses)
    sway_hz, sway_phase = rng.uniform(0.1, 1.0, 3), rng.uniform(0, 2 * np.pi, 3)
    tremor_phase = rng.uniform(0, 2 * np.pi, 2)

    def root(tt: np.ndarray) -> np.ndarray:
        i = np.clip(np.searchsorted(knots, tt, side="right") - 1, 0, len(knots) - 2)
        s = np.clip((tt - knots[i]) / (knots[i + 1] - knots[i]), 0.0, 1.0)
        p = targets[i] + (targets[i + 1] - targets[i]) * (s**3 * (10 - 15 * s + 6 * s * s))[:, None]
        q = Q.multiply(Q.multiply(Q.from_axis_angle((0, 0, 1), p[:, 0]), Q.from_axis_angle((0, 1, 0), p[:, 1])),
                       Q.from_axis_angle((0, 0, 1), p[:, 2]))
        sway = sway_deg * DEG * np.sin(2 * np.pi * sway_hz * tt[:, None] + sway_phase)
        tremor = tremor_deg * DEG * np.sin(2 * np.pi * tremor_hz * tt[:, None] + tremor_phase)
        swing = np.stack([tremor[:, 0], tremor[:, 1], np.zeros_like(tt)], axis=1)
        return Q.multiply(Q.multiply(q, Q.from_rotvec(sway)), Q.from_rotvec(swing))

    return Motion(root, lambda tt: np.zeros((len(tt), 1)))


def gyro_bias(t: np.ndarray, warmup_dps: float) -> np.ndarray:
    """The true bias (rad/s): BIAS0 plus a warm-up of ``warmup_dps`` over 600 s, in all axes alike:
    w(t) = W (1 - exp(-t / tau)) / (1 - exp(-600 / tau)) (first-order heating)."""
    w = warmup_dps * (1 - np.exp(-t / WARMUP_TAU_S)) / (1 - math.exp(-600.0 / WARMUP_TAU_S))
    return np.radians(BIAS0_DPS[None, :] + w[:, None] / math.sqrt(3))


@lru_cache(maxsize=None)
def session(duration: float, warmup_dps: float, magnetic: MagneticErrors | None, seed: int = 0):
    """(measured gyro with the bias, acc, mag or None, true q_WS, true bias) of a simulated session."""
    errors = mpu9250(offset=False)
    if magnetic is not None:
        errors = dataclasses.replace(errors, magnetic=magnetic)
    d = Simulator(arm_chain(), play(seed, duration), errors, seed=seed).simulate(duration, RATE)
    bias = gyro_bias(d.t, warmup_dps)
    mag = d.mag[:, 0] if magnetic is not None else None
    return d.gyr[:, 0] + bias, d.acc[:, 0], mag, d.truth.q_sensors[:, 0], bias


REF = slice(int(20 * RATE), int(25 * RATE))  # where the heading's zero is taken


def heading_error_deg(q: np.ndarray, truth: np.ndarray, ref: slice = REF):
    """Signed heading error (deg) less its circular mean over ``ref``: the player's recentring
    after the wearing calibration (a 6D filter's heading is arbitrary). At 20-25 s a magnetometer
    has had its first check (``mag_on_t`` after the start), so a good one's heading is in use."""
    e = Q.multiply(q, Q.conjugate(truth))
    signed = 2 * np.arctan2(e[:, 3], e[:, 0])
    offset = math.atan2(np.sin(signed[ref]).mean(), np.cos(signed[ref]).mean()) if len(signed[ref]) else 0.0
    return np.degrees((signed - offset + np.pi) % (2 * np.pi) - np.pi)


def run(gyr, acc, mag, start: Callable[[DefaultFilter], None] | None = None,
        **params) -> tuple[np.ndarray, np.ndarray, np.ndarray, DefaultFilter]:
    """Quaternions, the bias estimate (rad/s) and the mag_unusable flag per sample, and the filter
    (``start`` prepares it first)."""
    f = make("default", **params)
    assert isinstance(f, DefaultFilter)
    if start is not None:
        start(f)
    n = len(gyr)
    q, bias, off = np.empty((n, 4)), np.empty((n, 3)), np.zeros(n, bool)
    g, a = gyr.tolist(), acc.tolist()
    m = mag.tolist() if mag is not None else [None] * n
    for i in range(n):
        q[i] = f.update(g[i], a[i], m[i], 1 / RATE)
        bias[i] = f.get_state().bias if i % 20 == 0 else bias[i - 1]
        off[i] = f.flags.mag_unusable
    return q, bias, off, f


# ----------------------------------------------------------------- the bias


def test_bias_converges_from_5_dps_in_play_with_tremor_and_sway():
    gyr, acc, _, _, bias = session(120.0, 0.0, None)
    _, est, _, f = run(gyr, acc, None)
    err = np.degrees(np.linalg.norm(est - bias, axis=1))
    assert err[0] == pytest.approx(5.0, abs=0.05)
    # No sample here is at rest (the arm never holds 1.5 s): all of it is learned in motion.
    # (The drift state lets the offset's convergence overshoot a little: 0.54 at 60 s on this seed.)
    assert err[int(60 * RATE):].max() < 0.6, err[int(60 * RATE):].max()
    assert err[-1] < 0.25, err[-1]
    # The fixed slow integral gain (Mahony's k_I = 0.01 / s, the filter before) is still far off.
    _, slow, _, _ = run(gyr, acc, None, bias_tau_min=100.0, bias_forget_t=1e9, drift_t=1e9)
    assert np.degrees(np.linalg.norm(slow[-1] - bias[-1])) > 1.0


def test_warm_up_drift_is_tracked_and_heading_holds_without_a_magnetometer():
    gyr, acc, _, truth, bias = session(600.0, WARMUP_DPS, None)
    q, est, _, _ = run(gyr, acc, None)
    err = np.degrees(np.linalg.norm(est - bias, axis=1))
    late = slice(int(300 * RATE), None)
    # The bias moved by 2.4 deg/s between 60 s and 600 s; the estimate follows within 0.2.
    assert np.degrees(np.linalg.norm(bias[-1] - bias[int(60 * RATE)])) > 2.0
    assert err[late].max() < 0.2, err[late].max()
    heading = heading_error_deg(q, truth)
    assert np.ptp(heading[late]) < 15.0, np.ptp(heading[late])
    # The filter before (slow fixed gain): the heading runs away over the same 5 minutes.
    q_slow, _, _, _ = run(gyr, acc, None, bias_tau_min=100.0, bias_forget_t=1e9, drift_t=1e9)
    assert np.ptp(heading_error_deg(q_slow, truth)[late]) > 2 * np.ptp(heading[late])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_bias_ramp_is_followed_without_the_lag_of_a_plain_integral_loop(seed):
    # A bias ramping at r = 0.01 deg/s per s (the fastest of a 4 deg/s warm-up is 0.027): a type-1
    # loop (the bias corrected in proportion to what it sees) lags a ramp by r tau, tau its time
    # constant; learning the ramp's rate as well (type 2) leaves r tau / (1 + drift_tau / drift_ti).
    gyr, acc, _, _, bias = session(300.0, 0.0, None, seed)
    t = np.arange(len(gyr)) / RATE
    ramp = np.radians(0.01) * t[:, None] * np.array([1.0, -1.0, 1.0]) / math.sqrt(3)
    late = slice(int(200 * RATE), None)
    lag = {}
    for name, params in (("type 2", {}), ("type 1", {"drift_t": 1e9})):
        _, est, _, _ = run(gyr + ramp, acc, None, **params)
        lag[name] = float(np.degrees(np.linalg.norm(est - bias - ramp, axis=1))[late].mean())
    assert lag["type 1"] > 0.15, lag  # r tau with tau of tens of seconds: the lag is real ...
    assert lag["type 2"] < 0.5 * lag["type 1"], lag  # ... and the drift term removes most of it


def test_power_on_makes_the_drift_as_unknown_as_the_warm_up_worked_by_hand():
    # P_dd += sqrt(2) / bias_tau_min^3 I (the steady-state two-state loop at bandwidth 1 / 3 s:
    # sqrt(2) / 27 = 0.05238), decayed as the warm-up's variance, exp(-2 age / drift_tau).
    f = make("default")
    assert isinstance(f, DefaultFilter)
    p = f.params
    assert f.get_state().drift_p == (0.0,) * 6
    f.power_on(0.0)
    xx, xy, xz, yy, yz, zz = f.get_state().drift_p
    assert (xy, xz, yz) == (0.0, 0.0, 0.0)
    assert xx == yy == zz == pytest.approx(0.05238, abs=1e-5)
    f.power_on(p.drift_tau)  # a board on for one thermal time constant adds e^-2 of that
    assert f.get_state().drift_p[0] == pytest.approx(0.05238 * (1 + math.exp(-2.0)), abs=1e-5)


def powered_on_heading_deg(seed: int, power_on: bool) -> float:
    """Mean |heading error| (deg) over the last 10 s of 150 s of play on a board warming by 4 deg/s
    from power-on, without a magnetometer; the bias known at the start (as "hold still" gives it)
    and the heading's zero taken in the first 2 s (the wearing calibration follows the hold)."""
    gyr, acc, _, truth, bias = session(150.0, WARMUP_DPS, None, seed)

    def start(f: DefaultFilter) -> None:
        state = f.get_state()
        state.bias = tuple(bias[0])
        f.set_state(state)
        if power_on:
            f.power_on(0.0)

    q = run(gyr, acc, None, start=start)[0]
    return float(np.abs(heading_error_deg(q, truth, slice(0, int(2 * RATE)))[-int(10 * RATE):]).mean())


def test_a_board_just_powered_on_holds_its_heading_through_the_warm_up():
    # The warm-up's ramp is steepest at power-on (0.027 deg/s per s here); a drift known to be
    # zero is learned only as the random walk lets it (tens of seconds), and the bias about the
    # vertical lags meanwhile: heading lost for good without a magnetometer (8.3 deg on average
    # over these seeds; 9.1, 15.4, 0.3). A drift as unknown as the warm-up makes it: 1.4.
    after = [powered_on_heading_deg(seed, True) for seed in (0, 1, 2)]
    before = [powered_on_heading_deg(seed, False) for seed in (0, 1, 2)]
    assert np.mean(after) < 2.5, after
    assert np.mean(before) > 3 * np.mean(after), (before, after)


def stepped_heading_deg(seed: int, settle_t: float) -> float:
    """Mean |heading error| (deg) over the last 10 s of 150 s of play without a magnetometer, on a
    board whose warm-up is calibrated (none left here), started with the bias off by 1 deg/s on
    each axis: a hold can leave such a step (``startup_bias`` accepts a turn its tilt does not explain
    of up to ``StartupParams.max_rate``, 1.15 deg/s)."""
    gyr, acc, _, truth, bias = session(150.0, 0.0, None, seed)

    def start(f: DefaultFilter) -> None:
        state = f.get_state()
        state.bias = tuple(bias[0] + np.radians(1.0) * np.array([1.0, -1.0, 1.0]))
        f.set_state(state)
        f.power_on(0.0, warmup_calibrated=True)

    q = run(gyr, acc, None, start=start, drift_settle_t=settle_t)[0]
    return float(np.abs(heading_error_deg(q, truth, slice(0, int(2 * RATE)))[-int(10 * RATE):]).mean())


def test_a_step_left_by_the_start_is_not_taken_for_a_ramp():
    # The true bias is constant; a two-state loop learning the drift from the start takes part of
    # the step for a ramp, which outlives it by drift_tau and turns the heading (11.9, 18.2, 0.2, 1.4
    # deg over these seeds). Learned once the loop has settled (drift_settle_t): 0.8, 0.6, 0.8, 5.6.
    settled = [stepped_heading_deg(seed, DefaultParams().drift_settle_t) for seed in range(4)]
    at_once = [stepped_heading_deg(seed, 0.0) for seed in range(4)]
    assert np.mean(settled) < 0.4 * np.mean(at_once), (settled, at_once)


def spun_up(t: np.ndarray, rate: float, ramp_s: float) -> np.ndarray:
    """q_WS of a board turned about world x from rest, its rate rising evenly to ``rate`` over ``ramp_s``."""
    angle = np.where(t < ramp_s, rate * t * t / (2.0 * ramp_s), rate * ramp_s / 2.0 + rate * (t - ramp_s))
    return np.stack([np.cos(angle / 2), np.sin(angle / 2), 0 * t, 0 * t], axis=-1)


def spun_tilt_errors_deg(acc_ahead_s: float, params: DefaultParams) -> tuple[float, float]:
    """A board spun up from rest to SPIN rad/s about world x in 1 s and kept turning, gravity alone,
    exact readings, its accelerometer's read ``acc_ahead_s`` after its rates: the tilt's mean error over
    the last 10 s of 30 against the orientation half a step on, and against that of the sample."""
    n, dt = int(30 * RATE), 1.0 / RATE
    t = np.arange(n) * dt
    q, ahead = spun_up(t, SPIN, 1.0), spun_up(t + dt / 2, SPIN, 1.0)
    acc = Q.rotate(Q.conjugate(spun_up(t + acc_ahead_s, SPIN, 1.0)), np.broadcast_to([0.0, 0.0, 9.81], (n, 3)))
    f = DefaultFilter(params)
    out = np.array([f.update((min(SPIN, SPIN * t[k]), 0.0, 0.0), tuple(acc[k]), None, dt) for k in range(n)])

    def tilt_error_deg(truth: np.ndarray) -> float:  # between the sensor-frame verticals
        up, est = Q.rotate(Q.conjugate(truth), [0.0, 0.0, 1.0]), Q.rotate(Q.conjugate(out), [0.0, 0.0, 1.0])
        return float(np.degrees(np.arccos(np.clip(np.sum(up * est, axis=1), -1, 1)))[-10 * int(RATE):].mean())

    return tilt_error_deg(ahead), tilt_error_deg(q)


SPIN = 5.0  # rad/s


def test_the_accelerometer_is_turned_by_the_orientation_of_its_own_instant():
    """The strapdown's sum of the rates runs (w_k + w_0) dt / 2 ahead of their integral (the rectangle
    rule), so the output is the orientation half a step on: 5 rad/s x 2.5 ms = 0.716 deg ahead, worked
    by hand. Its inclination must be that same orientation's: gravity turned by the orientation half a
    step on leans by just as much, and the inclination correction took it back, a tilt half a step
    behind the heading (the bug; the lean it left in a fast snap walked the heading)."""
    ahead, at_sample = spun_tilt_errors_deg(0.0, DefaultParams())
    assert ahead < 0.05
    assert at_sample == pytest.approx(math.degrees(SPIN * 0.5 / RATE), abs=0.02)


def test_an_accelerometer_read_more_recently_than_the_rates_is_turned_by_its_own_instant():
    """The MPU-9250's low-pass filters delay its accelerometer 1.02 ms less than its gyroscope at the
    firmware's 200 Hz setting (tracker.mpu_dlpf): told so, the filter's tilt is again the orientation
    half a step on; not told, it is 5 rad/s x 1.02 ms = 0.29 deg off it, worked by hand."""
    lead = 0.00102
    told, _ = spun_tilt_errors_deg(lead, DefaultParams(acc_lead_s=lead))
    untold, _ = spun_tilt_errors_deg(lead, DefaultParams())
    assert told < 0.05
    assert untold == pytest.approx(math.degrees(SPIN * lead), abs=0.02)


def test_a_tremor_at_rest_still_gives_the_bias_at_rest():
    # A long rest with a 1 deg tremor at 5 Hz (31 deg/s on the gyro, VQF's raw 2 deg/s test fails):
    # the low-passed rest test finds it, and the low-passed gyro gives all three axes, the vertical too.
    n = int(30 * RATE)
    t = np.arange(n) / RATE
    amp = 1.0 * DEG * 2 * np.pi * 5.0  # the rate amplitude 2 pi f A
    bias = np.radians([1.0, -2.0, 3.0])
    rng = np.random.default_rng(4)
    gyr = bias + np.outer(amp * np.cos(2 * np.pi * 5.0 * t), [1.0, 0.6, 0.0]) + rng.normal(0, 0.002, (n, 3))
    acc = np.tile([0.0, 0.0, 9.81], (n, 1)) + rng.normal(0, 0.02, (n, 3))
    f = make("default")
    rest = []
    for i in range(n):
        f.update(gyr[i], acc[i], None, 1 / RATE)
        rest.append(f.flags.rest)
    assert np.mean(rest[-int(20 * RATE):]) > 0.95
    np.testing.assert_allclose(f.get_state().bias, bias, atol=math.radians(0.05))


def raises(seed: int, duration: float) -> Motion:
    """The arm raised forward by 90 deg (about the board's x) and lowered again, each move 0.5-1 s
    (minimum jerk), each pose held 3-8 s: a player's aims and rests, without tremor or sway."""
    rng = np.random.default_rng(seed)
    knots, poses, t, up = [0.0], [0.0], 0.0, False
    while t < duration + 10.0:
        move, hold = rng.uniform(0.5, 1.0), rng.uniform(3.0, 8.0)
        up = not up
        knots += [t + move, t + move + hold]
        poses += [math.pi / 2 if up else 0.0] * 2
        t += move + hold
    k, p = np.array(knots), np.array(poses)

    def root(tt: np.ndarray) -> np.ndarray:
        i = np.clip(np.searchsorted(k, tt, side="right") - 1, 0, len(k) - 2)
        s = np.clip((tt - k[i]) / (k[i + 1] - k[i]), 0.0, 1.0)
        return Q.from_axis_angle((1, 0, 0), p[i] + (p[i + 1] - p[i]) * s**3 * (10 - 15 * s + 6 * s * s))

    return Motion(root, lambda tt: np.zeros((len(tt), 1)))


MISALIGNED = 0.002 * np.array([[0.0, 1.0, -1.0], [-1.0, 0.0, 1.0], [1.0, -1.0, 0.0]])  # the maker's worst left


@lru_cache(maxsize=None)
def raised_session(seed: int, misaligned: bool):
    """(gyro, acc, true q_WS) of 300 s of raises on a board without bias, its gyroscope's axes off by
    MISALIGNED (the cross-axis terms a maker's calibration leaves at worst, 0.2 %) or exact."""
    d = Simulator(arm_chain(), raises(seed, 300.0), mpu9250(offset=False), seed=seed).simulate(300.0, RATE)
    gyr = d.gyr[:, 0] @ (np.eye(3) + MISALIGNED).T if misaligned else d.gyr[:, 0]
    return gyr, d.acc[:, 0], d.truth.q_sensors[:, 0]


def raised(seed: int, misaligned: bool, turned_rate: float) -> tuple[float, float]:
    """The heading's error after 300 s (deg, from its value at 5 s) and the RMS of the bias learned
    about the board's y and z (deg/s; the true bias is 0) after the first 30 s."""
    gyr, acc, truth = raised_session(seed, misaligned)
    q, est, _, _ = run(gyr, acc, None, bias_turned_rate=turned_rate)
    heading = heading_error_deg(q, truth, slice(int(5 * RATE), int(5 * RATE) + 1))
    return float(heading[-1]), float(np.degrees(np.sqrt(np.mean(est[int(30 * RATE):, 1:] ** 2))))


def test_the_tilt_a_turn_leaves_is_not_learned_as_a_bias():
    # A raise by theta = 90 deg about x with the gyroscope's axes off by MISALIGNED tilts the strapdown
    # frame by |MISALIGNED x| theta = 0.0028 x 1.571 = 0.0044 rad; the accelerometer takes it out over
    # tau_acc (3 s), a correction rate of about 0.0044 / 3 = 0.084 deg/s, read as a bias about y and z.
    # Without bias_turned_rate (the filter before) that is what the bias learns, and the heading walks.
    before = [raised(seed, True, math.inf) for seed in range(3)]
    exact = [raised(seed, False, math.inf) for seed in range(3)]
    hand = math.degrees(np.linalg.norm(MISALIGNED[:, 0]) * math.pi / 2 / DefaultParams().tau_acc)
    assert hand == pytest.approx(0.084, abs=0.002)
    for (heading, learned), (_, clean) in zip(before, exact):
        assert 3 * clean < learned < hand, (learned, clean, hand)  # learned from the turns, below their rate
        assert heading < -3.0, heading
    # Weighed as the noise it is, the turn's tilt teaches the bias less and walks the heading less.
    now = [raised(seed, True, DefaultParams().bias_turned_rate) for seed in range(3)]
    for (heading, learned), (heading_before, learned_before) in zip(now, before):
        assert learned < 0.9 * learned_before, (learned, learned_before)
        assert abs(heading) < 0.9 * abs(heading_before), (heading, heading_before)


# ----------------------------------------------------------------- the magnetometer

BAD = {"hard iron 100 uT": MagneticErrors(hard_iron_ut=100.0),
       "soft iron 20 %": MagneticErrors(soft_iron=0.2),
       "disturbance 40 uT": MagneticErrors(disturbance_ut=40.0),
       "typical board (30 uT, 5 %, 5 uT)": MagneticErrors(30.0, 0.05, 5.0)}
MAG_SECONDS = 300.0


@lru_cache(maxsize=None)
def gyro_only_heading() -> np.ndarray:
    gyr, acc, _, truth, _ = session(MAG_SECONDS, WARMUP_DPS, None)
    return np.abs(heading_error_deg(run(gyr, acc, None)[0], truth))


def quarters(err: np.ndarray) -> np.ndarray:
    """Median |heading error| in each quarter of the session after the recentring."""
    return np.array([np.median(part) for part in np.array_split(np.abs(err[REF.stop:]), 4)])


def test_a_good_magnetometer_is_used_and_beats_the_gyroscope():
    gyr, acc, mag, truth, _ = session(MAG_SECONDS, WARMUP_DPS, MagneticErrors())
    q, _, off, f = run(gyr, acc, mag)
    assert not off.any() and f.status == "magnetometer on"
    # A magnetometer gives the heading itself: its error needs no recentring (the ref slice is empty).
    good, alone = quarters(heading_error_deg(q, truth, slice(0, 0))), quarters(gyro_only_heading())
    assert good.max() < 6.0 and good[-1] < 2.0, good
    assert good[-1] < alone[-1] / 5, (good, alone)


@pytest.mark.parametrize("name", list(BAD))
def test_a_bad_magnetometer_is_found_and_never_worse_than_none(name):
    gyr, acc, mag, truth, _ = session(MAG_SECONDS, WARMUP_DPS, BAD[name])
    q, _, off, f = run(gyr, acc, mag)
    err, alone = np.abs(heading_error_deg(q, truth)), gyro_only_heading()
    assert off[int(15 * RATE):].mean() > 0.8 and f.flags.mag_unusable
    assert f.status.startswith("magnetometer off: field strength changes as the board moves")
    assert np.all(quarters(err) <= quarters(alone) + 1.0), (quarters(err), quarters(alone))
    assert err[REF.stop:].max() <= alone[REF.stop:].max() + 2.0


def turning(seconds: float, hard_iron: np.ndarray, rate: float = 0.5):
    """A level board turning about its x axis at ``rate`` rad/s (exact readings), and its field
    with a hard-iron offset."""
    t = np.arange(int(seconds * RATE)) / RATE
    angle = rate * t
    c, s = np.cos(angle), np.sin(angle)
    up = np.stack([np.zeros_like(t), s, c], axis=1)  # R^T e_z for R = Rx(angle)
    field = np.array([0.0, 20.0, -40.0])
    mag = np.stack([np.full_like(t, field[0]), c * field[1] + s * field[2], -s * field[1] + c * field[2]], axis=1)
    return np.tile([rate, 0.0, 0.0], (len(t), 1)), 9.81 * up, mag + hard_iron


def test_the_field_comes_back_only_after_a_consistent_spell_of_turning():
    p = DefaultFilter.Params()
    f = make("default")
    gyr, acc, mag = turning(20.0, np.array([30.0, 20.0, 0.0]))
    for i in range(len(gyr)):
        f.update(gyr[i], acc[i], mag[i], 1 / RATE)
    assert f.flags.mag_unusable and f.status.startswith("magnetometer off")
    # Calibrated from now on (the same board after a calibration): held still, it stays off ...
    still_gyr, still_acc, still_mag = turning(2 * p.mag_on_t, np.zeros(3), rate=0.0)
    for i in range(len(still_gyr)):
        f.update(still_gyr[i], still_acc[i], still_mag[i], 1 / RATE)
    assert f.flags.mag_unusable
    # ... and turning, it comes back once the window forgot the bad field and mag_on_t passed.
    gyr, acc, mag = turning(4 * p.mag_on_t, np.zeros(3))
    back = None
    for i in range(len(gyr)):
        f.update(gyr[i], acc[i], mag[i], 1 / RATE)
        if back is None and not f.flags.mag_unusable:
            back = i / RATE
    assert back is not None and back >= p.mag_on_t, back
    assert f.status == "magnetometer on"


def swinging(seconds: float, swing_deg: float, rate: float = 0.5, k: float = 3.0):
    """:func:`turning`'s board (no hard iron) in a field whose horizontal part turns with the
    board, by ``swing_deg`` sin(k angle) east of north, its strength and dip unchanged: a
    disturbance that varies with position as a judge of strength and dip cannot see it."""
    gyr, acc, _ = turning(seconds, np.zeros(3), rate)
    angle = rate * np.arange(len(gyr)) / RATE
    return gyr, acc, field_seen(angle, np.radians(swing_deg) * np.sin(k * angle))


def field_seen(angle: np.ndarray, north: np.ndarray) -> np.ndarray:
    """The field (0, 20, -40) uT with its north turned ``north`` (rad) east, as :func:`turning`'s
    board reads it at ``angle``: R^T field, R = Rx(angle)."""
    c, s = np.cos(angle), np.sin(angle)
    wx, wy, wz = 20.0 * np.sin(north), 20.0 * np.cos(north), np.full_like(north, -40.0)  # the world field
    return np.stack([wx, c * wy + s * wz, -s * wy + c * wz], axis=1)


def refuted(refutations: int, north_deg: float, rate: float = 0.5):
    """:func:`turning`'s board (one unbroken turn) through a clean spell, then ``refutations``
    times a spell whose field gets :func:`turning`'s hard iron (found bad) and a clean spell long
    enough for the field to be checked again (``mag_on_t`` of turning once the bad window is
    forgotten), the last with the field's north turned ``north_deg`` east: gyroscope,
    accelerometer, magnetometer and the sample the last spell starts at."""
    clean, bad, last = 25.0, 10.0, 90.0
    spells = [(clean, False)] + [(bad, True), (clean + 15.0, False)] * refutations
    spells[-1] = (last, False)
    gyr, acc, _ = turning(sum(d for d, _ in spells), np.zeros(3), rate)
    n, last_start = len(gyr), int((sum(d for d, _ in spells) - last) * RATE)
    north = np.where(np.arange(n) >= last_start, math.radians(north_deg), 0.0)
    mag = field_seen(rate * np.arange(n) / RATE, north)
    at = 0
    for seconds, hard in spells:
        if hard:
            mag[at:at + int(seconds * RATE)] += np.array([30.0, 20.0, 0.0])
        at += int(seconds * RATE)
    return gyr, acc, mag, last_start


@pytest.mark.parametrize("refutations", [1, 3])
def test_a_field_found_bad_after_each_check_counts_less_each_time(refutations):
    # A field that passes its check and is found bad again n times counts 1 / (1 + n) as much: its
    # north turned 10 deg in the last spell (strength and dip the same, the gyroscope exact), the
    # heading follows from the field's return at the rate w / tau (probation's tau for mag_on_t,
    # then tau_mag) worked by hand, w = 1 / (1 + n): a first-order loop, as for a swinging field.
    # Counting a quarter (n = 3), less than a field spreading mag_weak_sd would, it is weak.
    p = DefaultFilter.Params()
    gyr, acc, mag, last_start = refuted(refutations, 10.0)
    f, heading, used = make("default"), np.empty(len(gyr)), np.zeros(len(gyr), bool)
    for i in range(len(gyr)):
        f.update(gyr[i], acc[i], mag[i], 1 / RATE)
        heading[i] = math.degrees(f.get_state().heading)
        used[i] = f.status in ("magnetometer on", MAG_WEAK)
    assert f.get_state().mag_refuted == refutations
    on = last_start + int(np.argmax(used[last_start:]))
    assert used[on:].all() and on > last_start
    w = 1.0 / (1.0 + refutations)
    rate = w * (p.mag_on_t / p.tau_mag_probation + ((len(gyr) - on) / RATE - p.mag_on_t) / p.tau_mag)
    assert heading[-1] - heading[on] == pytest.approx(10.0 * (1.0 - math.exp(-rate)), rel=0.05)
    assert (f.status == MAG_WEAK) == (refutations == 3) and f.flags.mag_unusable == (refutations == 3)


@pytest.mark.parametrize("trusted", [False, True])
def test_a_field_found_bad_before_it_is_trusted_leaves_the_heading_as_none_would(trusted):
    # The field passes its first check (north true, the gyroscope exact); 10 s into its use its
    # north turns 10 deg (a disturbance at the places the arm now goes: strength and dip the same)
    # and the heading follows; then the field gets turning's hard iron and is found bad. Found bad
    # after 22 s of use (past its slow mag_on_t, within mag_trust_t), all it turned is taken back:
    # the heading is the exact gyroscope's, 0, as without a magnetometer. Found bad after twice
    # mag_trust_t, it had proved itself: what it turned stays.
    p = DefaultFilter.Params()
    bad_after = 2 * p.mag_trust_t if trusted else 22.0
    assert p.mag_on_t < 22.0 < p.mag_trust_t
    gyr, acc, _ = turning(40.0 + bad_after + 10.0, np.zeros(3))
    n = len(gyr)
    f, heading, on, refuted_at = make("default"), np.empty(n), None, None
    hard = np.array([30.0, 20.0, 0.0])
    for i in range(n):
        in_use = None if on is None else (i - on) / RATE
        north = math.radians(10.0) if in_use is not None and in_use >= 10.0 else 0.0
        m = field_seen(np.array([0.5 * i / RATE]), np.array([north]))[0]
        f.update(gyr[i], acc[i], m + (hard if in_use is not None and in_use >= bad_after else 0.0), 1 / RATE)
        heading[i] = math.degrees(f.get_state().heading)
        if on is None and f.status in ("magnetometer on", MAG_WEAK):
            on = i
        if refuted_at is None and f.get_state().mag_refuted:
            refuted_at = i
    assert on is not None and refuted_at is not None and f.status.startswith("magnetometer off")
    assert (refuted_at - on) / RATE > bad_after and ((refuted_at - on) / RATE <= p.mag_trust_t) != trusted
    before = heading[refuted_at - 1]
    assert before > 2.0, before  # the field had turned the heading toward its north
    if trusted:
        assert heading[-1] == pytest.approx(before, abs=0.01)  # kept
    else:
        assert abs(heading[-1]) < 0.01, heading[-1]  # taken back: as the exact gyroscope left it


@pytest.mark.parametrize("referenced", [False, True])
def test_what_a_field_still_being_checked_settled_after_the_reference_is_given_back(referenced):
    # The field settles the heading before its first check (mag_on_t); the game takes "forward" at
    # 3 s (reference_taken). From 4 s to 8 s the field's north turns 10 deg east (a disturbance at the
    # places the arm now goes: strength and dip the same) and the heading follows; at 9 s the field
    # gets turning's hard iron and is found bad, still before its check. What it settled after the
    # reference is given back: the heading is the one the reference saw (the gyroscope is exact),
    # as without a magnetometer from then on. Never referenced (the tracker's own use) it stays.
    p = DefaultFilter.Params()
    gyr, acc, _ = turning(14.0, np.zeros(3))
    hard = np.array([30.0, 20.0, 0.0])
    f, heading, refuted_at, seen = make("default"), np.empty(len(gyr)), None, None
    for i in range(len(gyr)):
        t = i / RATE
        if referenced and i == int(3.0 * RATE):
            f.reference_taken()
            seen = f.get_state().heading
        north = math.radians(10.0) * min(1.0, max(0.0, (t - 4.0) / 4.0))
        m = field_seen(np.array([0.5 * t]), np.array([north]))[0] + (hard if t >= 9.0 else 0.0)
        f.update(gyr[i], acc[i], m, 1 / RATE)
        heading[i] = math.degrees(f.get_state().heading)
        if refuted_at is None and f.status.startswith("magnetometer off"):
            refuted_at = i
    assert refuted_at is not None and refuted_at / RATE < p.startup_t + p.mag_on_t  # before its check
    before = heading[refuted_at - 1]
    assert before > 2.0, before  # the field had settled the heading toward its north
    assert f.taken_back == int(referenced) and f.provisional_heading == 0.0
    if referenced:
        assert heading[-1] == pytest.approx(math.degrees(seen), abs=0.01)  # given back
    else:
        assert heading[-1] == pytest.approx(before, abs=0.01)  # kept


def heading_deg(q: np.ndarray) -> np.ndarray:
    """The heading of :func:`turning`'s board (its x axis stays horizontal): east of north, deg."""
    x = Q.rotate(q, np.array([1.0, 0.0, 0.0]))
    return np.degrees(np.arctan2(-x[:, 1], x[:, 0]))


SWING_DEG, SWING_RATE, SWING_K = 20.0, 0.5, 3.0


def swing_spread(p: DefaultFilter.Params) -> float:
    """The heading spread (rad) of :func:`swinging`'s field, worked by hand.

    The innovation swings as a sin(w t), a = SWING_DEG, w = SWING_K SWING_RATE; the Butterworth
    low-pass of time constant tau (cut-off sqrt(2) / tau rad/s) passes |H| = 1 / sqrt(1 + (w tau /
    sqrt(2))^4) of it. The unit vector exp(i a sin w t) = sum_n J_n(a) exp(i n w t) (the
    Jacobi-Anger expansion) has the mean J0(a) over whole periods, so the circular variance
    2 (1 - J0(a)) (Mardia and Jupp, sec. 2.3.1).
    """
    from scipy.special import j0
    gain = 1.0 / math.sqrt(1.0 + (SWING_K * SWING_RATE * p.mag_head_lp_tau / math.sqrt(2.0)) ** 4)
    return math.sqrt(2.0 * (1.0 - j0(math.radians(SWING_DEG) * gain)))


def test_a_swinging_field_heading_spread_is_the_circular_variance_worked_by_hand():
    gyr, acc, mag = swinging(40.0, SWING_DEG, SWING_RATE, SWING_K)
    f, spread = make("default"), []
    for i in range(len(gyr)):
        f.update(gyr[i], acc[i], mag[i], 1 / RATE)
        spread.append(f.heading_spread)
    assert np.median(spread[int(20 * RATE):]) == pytest.approx(swing_spread(f.params), rel=0.05)


@pytest.mark.parametrize("weighed", [True, False])
def test_a_field_turning_with_the_board_turns_the_heading_as_its_spread_allows(weighed):
    # Strength and dip stay the same, so the field is used; its heading swings +-20 deg about north
    # as the board turns (the gyroscope is exact: without a magnetometer the heading would stay).
    # From the field's first use, the heading error e0 that the start-up's one-second average left
    # decays at the rate w / tau (probation's tau for mag_on_t, then tau_mag): a first-order loop
    # whose weight w is mag_head_sd over the spread worked by hand (1 when not weighed).
    p = DefaultFilter.Params() if weighed else DefaultFilter.Params(mag_head_sd=math.pi)
    gyr, acc, mag = swinging(60.0, SWING_DEG, SWING_RATE, SWING_K)
    q, _, off, f = run(gyr, acc, mag, **({} if weighed else {"mag_head_sd": math.pi}))
    on = int(np.argmax([s != "magnetometer being checked" for s in statuses(gyr, acc, mag, p)]))
    heading = heading_deg(q)
    w = min(1.0, p.mag_head_sd / swing_spread(p))
    rate = w * (p.mag_on_t / p.tau_mag_probation + (len(q) - on) / RATE / p.tau_mag - p.mag_on_t / p.tau_mag)
    expected = heading[on] * (1.0 - math.exp(-rate))
    assert heading[on] - heading[-1] == pytest.approx(expected, rel=0.25, abs=0.3)
    if weighed:  # weak, and the HUD says so: the heading is mostly the gyroscope's
        assert f.status == MAG_WEAK and off[on:].all()
        assert abs(heading[-1] - heading[on]) < abs(heading[on]) / 3


def test_the_heading_settles_with_the_inclination_before_the_field_is_checked():
    # A level board held still in the field (0, 20, -40) uT; over the first second its accelerometer
    # reads tilted by 2 deg about north (what a tremor's acceleration leaves in the start's mean).
    # A tilt d about north turns the field's vertical part into east: the heading is off by
    # atan(tan(dip) sin d) = atan(2 sin 2 deg) = 3.99 deg. As the inclination settles (tau_acc),
    # the heading must settle with it (to a tenth), before the field's first check (mag_on_t after
    # the start), and teach the bias nothing (it stays what the filter without a field learns).
    p = DefaultFilter.Params()
    tilt = math.radians(2.0)
    f, alone = make("default"), make("default")
    n = int(12.0 * RATE)
    heading = np.empty(n)
    for i in range(n):
        acc = (9.81 * math.sin(tilt), 0.0, 9.81 * math.cos(tilt)) if i < p.startup_t * RATE else (0.0, 0.0, 9.81)
        f.update((0.0, 0.0, 0.0), acc, (0.0, 20.0, -40.0), 1 / RATE)
        alone.update((0.0, 0.0, 0.0), acc, None, 1 / RATE)
        heading[i] = math.degrees(f.get_state().heading)
    assert f.status == "magnetometer being checked"
    start = abs(heading[int(p.startup_t * RATE) - 1])
    assert start == pytest.approx(math.degrees(math.atan(2 * math.sin(tilt))), rel=0.1)
    assert abs(heading[-1]) < start / 10 and f.get_state().bias == alone.get_state().bias


def statuses(gyr, acc, mag, p: DefaultFilter.Params) -> list[str]:
    """The filter's status after each sample."""
    f = DefaultFilter(p)
    out = []
    for i in range(len(gyr)):
        f.update(gyr[i], acc[i], mag[i], 1 / RATE)
        out.append(f.status)
    return out


def test_status_without_a_magnetometer():
    f = make("default")
    f.update((0.0, 0.0, 0.0), (0.0, 0.0, 9.81), None, 0.005)
    assert f.status == "no magnetometer" and not f.flags.mag_unusable


# ----------------------------------------------------------------- figures


def figures() -> None:
    """Heading error (deg, median |error| per minute after the recentring; the good magnetometer's
    absolute) and the bias's convergence (printed)."""
    seconds = 600.0
    rows = {"gyro only": None, "good magnetometer": MagneticErrors(), **BAD}
    for name, magnetic in rows.items():
        gyr, acc, mag, truth, bias = session(seconds, WARMUP_DPS, magnetic)
        q, est, off, f = run(gyr, acc, mag)
        err = np.abs(heading_error_deg(q, truth, slice(0, 0) if name == "good magnetometer" else REF))
        minutes = [float(np.median(part)) for part in np.array_split(err[REF.stop:], 10)]
        print(f"{name:34s} heading |err| median by minute: {' '.join(f'{m:5.1f}' for m in minutes)}"
              f"   max {err[REF.stop:].max():5.1f}   off {100 * off.mean():3.0f}%   {f.status}")
    gyr, acc, _, _, bias = session(120.0, 0.0, None)
    err = np.degrees(np.linalg.norm(run(gyr, acc, None)[1] - bias, axis=1))
    for level in (1.0, 0.5, 0.2, 0.1):
        after = np.flatnonzero(err > level)
        print(f"bias error from 5 deg/s stays below {level} deg/s after {(after[-1] + 1) / RATE:5.1f} s")


def _turning_heading_error(params) -> float:
    """The heading's error (deg) after 40 s of a level board turning at 180 deg/s about the vertical in a
    clean field (60 deg of dip), ideal sensors at 200 Hz, the magnetometer's reading made at 100 Hz and
    sent twice, as the board does (the AK8963's continuous mode 2)."""
    w, dt, n = math.pi, 1.0 / RATE, int(40 * RATE)
    field = np.array([0.0, 25.0, -43.3])  # north and down (ENU), |B| = 50 uT
    f = DefaultFilter(params)
    for k in range(n):
        made = k - k % 2  # the reading of the latest 100 Hz tick
        mag = Q.rotate(Q.conjugate(Q.from_axis_angle((0, 0, 1), w * made * dt)), field)
        f.update((0.0, 0.0, w), (0.0, 0.0, 9.81), tuple(mag), dt)
    truth = Q.from_axis_angle((0, 0, 1), w * (n - 1) * dt)
    e = Q.multiply(np.array(f.quat), Q.conjugate(truth))
    return math.degrees(2 * math.atan2(e[3], e[0]))


def test_a_reading_sent_again_is_not_taken_for_a_new_one():
    # Worked by hand: a reading made 5 ms before the sample that sends it again, turned by that
    # sample's orientation, puts the field 180 deg/s x 5 ms = 0.9 deg off; every other reading is
    # fresh, so a filter that used each sample's would settle 0.45 deg off (the mean of 0 and 0.9),
    # the side the board turns from. Waiting for the next reading leaves only the fresh ones.
    used_again = _turning_heading_error(dataclasses.replace(DefaultFilter().params, mag_held_t=0.0))
    assert abs(used_again) == pytest.approx(0.45, abs=0.05)
    assert abs(_turning_heading_error(DefaultFilter().params)) < 0.05


if __name__ == "__main__":
    figures()
