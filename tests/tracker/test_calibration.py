"""Calibration: rest detection, gyroscope bias, six-pose accelerometer fit, board files.

Synthetic signals use the MPU-9250 data-sheet noise densities (ARCHITECTURE.md):
gyroscope 0.01 deg/s/sqrt(Hz), accelerometer 300 ug/sqrt(Hz), sampled at 200 Hz.
White noise of density D over the Nyquist band fs/2 has std D * sqrt(fs / 2): 0.1 deg/s
(the data sheet's own total RMS figure) and 2.9e-2 m/s^2 per axis.
"""

import copy
import dataclasses
import json
import math

import numpy as np
import pytest
from scipy.linalg import polar
from scipy.spatial.transform import Rotation

from tracker import calibration as C
from tracker import protocol as P
from tracker import quat

FS = 200.0
DT = 1.0 / FS
G = C.GRAVITY
DEG = math.pi / 180
GYR_SIGMA = 0.01 * DEG * math.sqrt(FS / 2)
ACC_SIGMA = 300e-6 * P.STANDARD_GRAVITY * math.sqrt(FS / 2)
UP = np.array([0.0, 0.0, G])


def still(rng, seconds, bias=(0.0, 0.0, 0.0), up=UP):
    """(gyr, acc) of a board lying still: bias + noise, gravity + noise."""
    n = round(seconds * FS)
    gyr = np.asarray(bias) + rng.normal(0.0, GYR_SIGMA, (n, 3))
    acc = np.asarray(up) + rng.normal(0.0, ACC_SIGMA, (n, 3))
    return gyr, acc


def swinging(rng, seconds, bias=(0.0, 0.0, 0.0)):
    """(gyr, acc) of an arm swing: 45 deg/s at 0.5 Hz about z, 1 m/s^2 sideways, plus noise."""
    gyr, acc = still(rng, seconds, bias)
    phase = 2 * math.pi * 0.5 * DT * np.arange(len(gyr))
    gyr[:, 2] += 45 * DEG * np.sin(phase)
    acc[:, 0] += 1.0 * np.cos(phase)
    return gyr, acc


def join(*parts):
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def run(detector, gyr, acc):
    return np.array([detector.update(g, a, DT) for g, a in zip(gyr, acc)])


def times(n):
    return DT * np.arange(n)


# ----------------------------------------------------------------- rest detection


def test_rest_is_declared_after_the_minimum_duration_and_held():
    gyr, acc = still(np.random.default_rng(1), 3.0, bias=(0.3 * DEG, -0.2 * DEG, 0.1 * DEG))
    rest = run(C.RestDetector(), gyr, acc)
    first = int(np.argmax(rest))
    assert first * DT == pytest.approx(C.RestParams().min_duration - DT, abs=1.5 * DT)
    assert rest[first:].all()


def test_no_rest_during_motion_and_rest_again_after_it():
    rng = np.random.default_rng(2)
    gyr, acc = join(still(rng, 2.0), swinging(rng, 5.0), still(rng, 4.0))
    rest = run(C.RestDetector(), gyr, acc)
    start, stop = round(2.0 * FS), round(7.0 * FS)
    assert rest[start - 1]
    assert not rest[start + round(0.1 * FS):stop].any()
    back = (int(np.argmax(rest[stop:])) + 1) * DT
    assert 1.5 <= back <= 1.5 + 4 * C.RestParams().tau  # min duration + the low-pass settling


def test_a_slow_steady_turn_is_not_rest():
    gyr, acc = still(np.random.default_rng(3), 4.0, bias=(0.0, 0.0, 3.0 * DEG))
    assert not run(C.RestDetector(), gyr, acc).any()


def test_a_bad_sample_ends_rest_and_the_state_stays_finite():
    gyr, acc = still(np.random.default_rng(4), 2.0)
    detector = C.RestDetector()
    assert run(detector, gyr, acc)[-1]
    assert not detector.update((math.nan, 0, 0), UP, DT)
    assert not detector.update((0, 0, 0), UP, math.nan)
    state = detector.state
    assert state.still_for == 0
    assert np.isfinite(state.gyr_lp.y).all() and np.isfinite(state.acc_lp.y).all()


def test_state_is_read_only():
    detector = C.RestDetector()
    detector.update((0, 0, 0), UP, DT)
    detector.state.acc_lp.y = (99.0, 99.0, 99.0)
    assert detector.state.acc_lp.y == pytest.approx(UP)
    with pytest.raises(AttributeError):
        detector.rest = True


# ----------------------------------------------------------------- start-up bias


BIAS = np.array([1.5, -2.0, 0.7]) * DEG
SMOOTH = C.StartupParams().smoothing  # s, the hold's low-pass length


def test_startup_recovers_a_known_bias_within_the_noise():
    """A board lying still: the error is noise, bounded by hand.

    The fit works on the span T_v = T - SMOOTH the low-pass leaves (n samples).
    About the vertical it is the least-squares slope of the integrated gyroscope, a
    random walk: the slope's weights on the rates form a parabola of integral 1, and
    its variance is 1.2 sigma^2 dt / T_v (int_0^T (6/T^3)^2 (T^2/4 - x^2)^2 = 1.2 / T),
    std 1.1 sigma / sqrt(n). About horizontal axes the accelerometer's tilt (noise
    sigma_a / g per sample) is subtracted: a slope of white noise has std
    sigma sqrt(12 / (n T_v^2)), and the low-pass (weights >= 0, sum 1) cannot raise it
    (Young's inequality). Over 40 boards the reported standard error matches these.
    """
    span = 2.0 - SMOOTH
    n = round(span * FS)
    vertical = 1.1 * GYR_SIGMA / math.sqrt(n)  # 0.1 deg/s / sqrt(267): 0.0067 deg/s
    horizontal = ACC_SIGMA / G * math.sqrt(12 / (n * span ** 2))  # 0.027 deg/s
    bound = np.array([horizontal, horizontal, vertical])
    errors, std_errors = [], []
    for seed in range(40):
        gyr, acc = still(np.random.default_rng(100 + seed), 2.0, BIAS)
        result = C.startup_bias(times(len(gyr)), gyr, acc)
        assert result.ok, result.message
        assert "deg/s" in result.message
        errors.append(result.bias - BIAS)
        std_errors.append(result.std_error)
    assert np.all(np.abs(errors) < 4 * bound)
    assert np.all(np.std(errors, axis=0) < 1.3 * bound)
    assert np.all((0.5 * bound < np.mean(std_errors, axis=0)) & (np.mean(std_errors, axis=0) < 1.5 * bound))


def test_the_standard_errors_equal_the_dense_least_squares_under_correlated_noise():
    """The fit's standard errors, computed by convolutions, against the same least squares done
    with the low-pass written out as a matrix: A the rows' noise per raw sample, sigma^2 =
    e.e / tr(A^T (I - H) A), Cov(s) = sigma^2 G A A^T G^T (G = pinv(x), H = x G)."""
    rng = np.random.default_rng(3)
    kernel, _ = C._blackman(0.05, 0.005)  # 10 taps
    m, n, dt = len(kernel), 40, 0.005
    k = np.zeros((n, n + m - 1))
    for i in range(n):
        k[i, i:i + m] = kernel[::-1]
    noise_h, noise_v = C._hold_noise(kernel, n, dt)
    a_h = np.zeros((2 * n + 2, 2 * (n + m - 1)))
    a_h[:n, :n + m - 1], a_h[n:2 * n, n + m - 1:] = k, k
    a_v = k @ (dt * np.tril(np.ones((n + m - 1, n + m - 1))))
    for a, noise in ((a_h, noise_h), (a_v, noise_v)):
        x = rng.normal(size=(a.shape[0], 3))
        y = x @ [1.0, -2.0, 0.5] + a @ rng.normal(size=a.shape[1])
        g = np.linalg.pinv(x)
        e = y - x @ (g @ y)
        sigma2 = (e @ e) / np.trace(a.T @ (np.eye(len(y)) - x @ g) @ a)
        dense = np.sqrt(sigma2 * np.diag(g @ a @ a.T @ g.T))
        s, residual = C._solve(x, g, y)
        se = C._std_errors(x, g, residual, noise)
        assert noise.norm2 == pytest.approx(np.sum(a * a), rel=1e-12)
        assert np.allclose(s, np.linalg.lstsq(x, y, rcond=None)[0]) and np.allclose(residual, e)
        assert np.allclose(se, dense, rtol=1e-10)


def test_a_minute_long_hold_is_judged_like_a_short_one():
    """Any length of hold is taken (the fit never forms the low-pass as a matrix, which for a
    minute at 200 Hz would be 12,000 x 24,000 numbers): the bias within its noise bound, which
    shrinks as the hold grows. Over a minute the gyroscope's own random walk, 1.1 sigma /
    sqrt(n) (the still-board test above), outweighs the accelerometer's tilt noise about the
    horizontal axes too (the tilt the gyroscope predicts wanders with it): the bound there is
    both in quadrature."""
    gyr, acc = still(np.random.default_rng(9), 60.0, BIAS)
    result = C.startup_bias(times(len(gyr)), gyr, acc)
    assert result.ok, result.message
    span = 60.0 - SMOOTH
    n = round(span * FS)
    walk = 1.1 * GYR_SIGMA / math.sqrt(n)
    horizontal = math.hypot(ACC_SIGMA / G * math.sqrt(12 / (n * span ** 2)), walk)
    bound = np.array([horizontal, horizontal, walk])
    assert np.all(np.abs(result.bias - BIAS) < 4 * bound)
    assert np.all(result.std_error < 1.5 * bound)


def test_moving_during_startup_is_rejected_with_a_reason():
    rng = np.random.default_rng(6)
    gyr, acc = join(still(rng, 0.8, BIAS), swinging(rng, 0.5, BIAS), still(rng, 0.8, BIAS))
    result = C.startup_bias(times(len(gyr)), gyr, acc)
    assert not result.ok
    assert "moved" in result.message and "hold it still" in result.message
    assert not result.bias.any()


@pytest.mark.parametrize("seconds, bias, words", [
    (0.5, BIAS, "only 0.50 s"),
    (2.0, (0.0, 0.0, 40 * DEG), "turning slowly"),  # a steady turn: beyond any MPU-9250's offset
])
def test_startup_rejects_short_windows_and_implausible_biases(seconds, bias, words):
    gyr, acc = still(np.random.default_rng(7), seconds, bias)
    result = C.startup_bias(times(len(gyr)), gyr, acc)
    assert not result.ok and words in result.message


def test_startup_from_raw_samples():
    samples = [P.RawSample(i * DT, i * 5000, i, (0, 0, 2048), (3, -2, 1), None, 400)
               for i in range(400)]
    arrays = C.SampleArrays.from_samples(samples)
    result = C.startup_bias(arrays.t, arrays.gyr, arrays.acc)
    assert result.ok and result.bias == pytest.approx(samples[0].gyr)
    assert np.isnan(arrays.mag).all()


# ----------------------------------------------------------------- a person's hold


ELBOW_M = 0.30  # the board as far from the shoulder as it gets, where tremor shakes it most
MOUNT = Rotation.from_euler("zyx", [30, -10, 20], degrees=True)  # the board worn askew
HOLD_BIAS = np.array([0.8, -1.2, 0.5]) * DEG


def arm_hold(angles, seconds, seed=0):
    """(t, gyr, acc) of a board on a hanging arm turning by ``angles(t)`` (rotation vectors, world
    frame, about the shoulder), from exact kinematics plus the MPU-9250's noise and HOLD_BIAS.

    The arm's rotation R(t) = exp(angles(t)); the board, ELBOW_M below the shoulder, is
    turned by MOUNT: q_WS = R MOUNT. gyr = the board's body rate (R_WS^T R_WS')^v and
    acc = R_WS^T (p'' - g) (Inertial Sensor Based Solution for Finger Motion Tracking, Computers 9(2):40,
    2020, sec. 2.1), both by central differences of step 1e-4 s (error O(h^2 w^3), under 1e-6 here)."""
    h = 1e-4
    t = np.arange(round(seconds * FS)) / FS
    board = lambda x: Rotation.from_rotvec(angles(x)) * MOUNT
    rate = ((board(t).inv() * board(t + h)).as_rotvec() - (board(t).inv() * board(t - h)).as_rotvec()) / (2 * h)
    where = lambda x: Rotation.from_rotvec(angles(x)).apply([0.0, 0.0, -ELBOW_M])
    accel = (where(t + h) - 2 * where(t) + where(t - h)) / h ** 2
    acc = board(t).inv().apply(accel + [0.0, 0.0, G])
    rng = np.random.default_rng(seed)
    return (t, rate + HOLD_BIAS + rng.normal(0, GYR_SIGMA, rate.shape),
            acc + rng.normal(0, ACC_SIGMA, acc.shape))


def swing(amplitude_deg, hz, phase=0.0, axis=(1.0, 0.0, 0.0)):
    """A sine of ``amplitude_deg`` about ``axis`` (world) as rotation vectors of t."""
    return lambda t: np.outer(amplitude_deg * DEG * np.sin(2 * np.pi * hz * np.asarray(t) + phase), axis)


def together(*motions):
    return lambda t: sum(m(t) for m in motions)


def raise_arm(degrees, start, seconds):
    """A minimum-jerk raise about the world x axis (Flash & Hogan 1985: 10 s^3 - 15 s^4 + 6 s^5)."""
    def angles(t):
        x = np.clip((np.asarray(t) - start) / seconds, 0.0, 1.0)
        return np.outer(degrees * DEG * (10 * x ** 3 - 15 * x ** 4 + 6 * x ** 5), (1.0, 0.0, 0.0))
    return angles


Y, Z = (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)


@pytest.mark.parametrize("name, motion", [
    ("1 deg tremor at 5 Hz", together(swing(1, 5), swing(1, 5, 1.0, Y), swing(0.5, 5, 2.0, Z))),
    ("2 deg tremor at 12 Hz", together(swing(2, 12), swing(2, 12, 1.0, Y), swing(1, 12, 2.0, Z))),
    ("2 deg tremor at 3 Hz", together(swing(2, 3), swing(2, 3, 1.0, Y), swing(1, 3, 2.0, Z))),
    ("3 deg sway at 0.3 Hz", swing(3, 0.3, 0.5)),
    ("4 deg sway at 1 Hz and a 2 deg tremor", together(swing(4, 1.0, 0.3, Y), swing(2, 8), swing(1, 8, 1, Z))),
])
def test_a_trembling_and_swaying_arm_is_still(name, motion):
    t, gyr, acc = arm_hold(motion, 2.0)
    result = C.startup_bias(t, gyr, acc)
    assert result.ok, f"{name}: {result.message}"


def test_a_4_deg_sway_passes_at_every_frequency_and_phase():
    """The worst 4 deg sway within 0.1-1 Hz, and the margin it leaves.

    A sway of peak A swings the arm at most 2 A = 8 deg between any two instants, so
    the net tilt (between the low-passed start and end of the hold) is at most 8 deg
    for any frequency and phase; the worst on this grid (a half period across the
    hold, at 0.25-0.4 Hz) reaches about 7.7. max_tilt = 8.5 deg leaves 0.5 deg for the
    error of the fitted bias times the hold's length, and a 10 deg move 1.5 deg.
    """
    worst = 0.0
    for hz in (0.1, 0.2, 0.25, 0.3, 0.4, 0.5, 0.7, 1.0):
        for phase in np.linspace(0, 2 * np.pi, 8, endpoint=False):
            t, gyr, acc = arm_hold(swing(4, hz, phase), 2.0, seed=int(hz * 10))
            fit = C.fit_hold(t, gyr, acc)
            assert C.startup_bias(t, gyr, acc).ok, (hz, phase)
            worst = max(worst, fit.tilt)
    assert 7.0 * DEG < worst <= 8.0 * DEG
    assert C.StartupParams().max_tilt == pytest.approx(8.0 * DEG + 0.5 * DEG)


@pytest.mark.parametrize("seconds, start", [(2.0, 0.25), (1.0, 0.75)])
def test_a_slow_10_deg_raise_is_refused_and_named(seconds, start):
    t, gyr, acc = arm_hold(together(raise_arm(10, start, seconds), swing(1, 5, 0, Y)), 2.5)
    result = C.startup_bias(t, gyr, acc)
    assert not result.ok and result.message.startswith("the board moved during start-up: the arm tilted")
    assert not result.hold_longer  # a tilt is no tremor: no longer hold tells it apart
    tilted = float(result.message.split("tilted ")[1].split(" degrees")[0])
    assert 9.0 <= tilted <= 10.5  # the low-passed ends see nearly all of the raise


def test_a_turn_about_the_vertical_is_refused_and_named():
    t, gyr, acc = arm_hold(lambda x: raise_arm(10, 0.25, 2.0)(x)[:, [1, 2, 0]], 2.5)  # about world z
    result = C.startup_bias(t, gyr, acc)
    assert not result.ok and "turned about the vertical" in result.message


def blackman_gain(x):
    """The gain of a Blackman window of length L at frequency f, x = f L: the window is
    0.42 + 0.5 cos(2 pi u) + 0.08 cos(4 pi u) on |u| < 1/2, so its transform is sincs shifted by
    0, +-1 and +-2 bins with those weights halved (Harris 1978, sec. V.E), over 0.42 at x = 0."""
    return abs(0.42 * np.sinc(x) + 0.25 * (np.sinc(x - 1) + np.sinc(x + 1))
               + 0.04 * (np.sinc(x - 2) + np.sinc(x + 2))) / 0.42


def test_the_bias_under_tremor_and_sway_is_within_its_derived_bound():
    """A 1 deg tremor at 5.5 Hz (swing and, half as much, twist) and a 3 deg sway at 0.3 Hz.

    About the vertical the accelerometer sees nothing, so the twist's tremor is left
    to the low-pass: the Blackman window of length L passes a sine of frequency f with
    gain :func:`blackman_gain` (f L), here 5.5 between its zeros at 5 and 6, and a
    least-squares slope over the span T_v of a signal bounded by B is at most
    B sum|t - mean| / sum (t - mean)^2 = 3 B / T_v. About horizontal axes the
    accelerometer's tilt and the lever-arm term cancel the swing and sway to first
    order; what is left is second order in the angle, at most theta^2 with theta =
    4 deg, so at most 3 theta^2 / T_v. Each also carries the noise of a still board
    (test above), taken at 4 sigma.
    """
    twist = 0.5
    motion = together(swing(1, 5.5, 0.0), swing(twist, 5.5, 1.0, Z), swing(3, 0.3, 0.4, Y))
    t, gyr, acc = arm_hold(motion, 2.0, seed=7)
    result = C.startup_bias(t, gyr, acc)
    assert result.ok, result.message
    span = 2.0 - SMOOTH
    n = round(span * FS)
    vertical = 3 * twist * DEG * blackman_gain(5.5 * SMOOTH) / span + 4 * 1.1 * GYR_SIGMA / math.sqrt(n)
    horizontal = 3 * (4 * DEG) ** 2 / span + 4 * ACC_SIGMA / G * math.sqrt(12 / (n * span ** 2))
    up = C.fit_hold(t, gyr, acc).up
    error = result.bias - HOLD_BIAS
    assert abs(error @ up) < vertical
    assert np.linalg.norm(error - (error @ up) * up) < horizontal


def test_the_hold_low_pass_is_a_blackman_window_with_its_first_zero_at_the_slowest_tremor():
    """The fit's low-pass against the window's transform worked by hand: unit gain at 0 Hz,
    zeros from 3 Hz (TREMOR_MIN_HZ) on, and at most -58 dB beyond (Harris 1978, table 1)."""
    kernel, _ = C._blackman(SMOOTH, DT)
    for f in (0.0, 0.5, 1.0, 2.0, 3.0, 3.5, 4.0, 5.5, 8.0, 12.0, 25.0):
        gain = abs(np.sum(kernel * np.exp(-2j * np.pi * f * DT * np.arange(len(kernel)))))
        assert gain == pytest.approx(blackman_gain(f * SMOOTH), abs=2e-4)
        if f >= C.TREMOR_MIN_HZ:
            assert gain < 10 ** (-58 / 20)
    assert SMOOTH * C.TREMOR_MIN_HZ == pytest.approx(3.0)


def test_a_board_rocking_about_the_vertical_in_the_tremor_band_is_still():
    """A board rocking 3 deg about the hanging humerus (the vertical) at 3.5 Hz, as a strap on soft
    tissue does with a tremor: a turn the accelerometer cannot see, with no net turn. The
    low-pass leaves at most 2 pi f A blackman_gain(f L) = 0.08 deg/s of it (a Hann window with
    the same first zero left 1.7 deg/s, near the 2 deg/s of a real slow move); with the still
    board's own unexplained rate (noise) the hold is judged still, its bias as a still board's."""
    rocking = 2 * np.pi * 3.5 * 3.0 * blackman_gain(3.5 * SMOOTH)
    assert rocking < 0.1
    t, gyr, acc = arm_hold(swing(3, 3.5, 0.7, Z), 2.0, seed=11)
    t0, gyr0, acc0 = arm_hold(lambda x: np.zeros((len(np.atleast_1d(x)), 3)), 2.0, seed=11)
    fit, calm = C.fit_hold(t, gyr, acc), C.fit_hold(t0, gyr0, acc0)
    assert fit.rate < calm.rate + 2 * rocking * DEG
    result = C.startup_bias(t, gyr, acc)
    assert result.ok, result.message
    assert np.all(np.abs(result.bias - HOLD_BIAS) < 4 * result.std_error + 0.05 * DEG)


def test_a_slow_rocking_asks_for_the_longer_hold_which_tells_it_from_a_turn():
    """A board rocking 2 deg about the vertical at 2 Hz: the lowest part of the slowest tremor (3 Hz,
    whose beating components spread it by 1 Hz). The hold's 1 s low-pass passes it with the gain
    blackman_gain(2) = 0.04 / 0.42 (only the window's outer terms reach 2 bins), so 2 pi f A times
    that, 2.4 deg/s, looks like a turn: refused, and the result asks for the longer hold. The
    longer hold's 2 s low-pass has a zero there (4 bins): over 5 s the same rocking is still and
    its bias a still board's. A 10 deg turn about the vertical inside those 5 s is still refused,
    and a hold judged with the longer low-pass asks for no longer one."""
    left = 2 * np.pi * 2.0 * 2.0 * blackman_gain(2.0 * SMOOTH)
    assert left == pytest.approx(2 * np.pi * 4.0 * 0.04 / 0.42) and left > C.StartupParams().max_rate / DEG
    assert blackman_gain(2.0 * C.LONGER_HOLD.smoothing) < 1e-12
    rocking = swing(2, 2.0, 0.7, Z)
    t, gyr, acc = arm_hold(rocking, 2.5, seed=12)
    short = C.startup_bias(t, gyr, acc)
    assert not short.ok and "turned about the vertical" in short.message and short.hold_longer
    t, gyr, acc = arm_hold(rocking, C.LONGER_HOLD_S, seed=12)
    longer = C.startup_bias(t, gyr, acc, C.LONGER_HOLD)
    assert longer.ok, longer.message
    assert np.all(np.abs(longer.bias - HOLD_BIAS) < 4 * longer.std_error + 0.05 * DEG)
    turned = together(rocking, lambda x: raise_arm(10, 1.5, 2.0)(x)[:, [1, 2, 0]])  # about world z
    t, gyr, acc = arm_hold(turned, C.LONGER_HOLD_S, seed=12)
    moved = C.startup_bias(t, gyr, acc, C.LONGER_HOLD)
    assert not moved.ok and "turned about the vertical" in moved.message and not moved.hold_longer


def test_the_longer_hold_keeps_the_first_holds_slack():
    """The game asks 2.5 s for the first hold and judges it on at least 2 s; the longer hold, 5 s in
    all, on at least 4.5 s (HOLD_SLACK_S): a player who lets go of it 40 ms early, or a sample lost
    at its edge, is no reason to refuse it. 993 samples at 200 Hz cover 993 / 200 = 4.965 s: judged.
    Less than 4.5 s is refused, saying how much there was and how long to hold."""
    assert C.StartupParams().duration + C.HOLD_SLACK_S == 2.5 and C.LONGER_HOLD_S == 5.0
    rng = np.random.default_rng(4)
    gyr, acc = still(rng, 993 / FS, BIAS)
    t = np.arange(len(gyr)) / FS
    held = C.startup_bias(t, gyr, acc, C.LONGER_HOLD)
    assert held.ok, held.message
    assert held.duration == pytest.approx(4.965)
    short = C.startup_bias(t[:880], gyr[:880], acc[:880], C.LONGER_HOLD)
    assert not short.ok and short.message == "only 4.40 s of samples; hold the board still for 4.5 s"


# ----------------------------------------------------------------- continuous bias


def test_continuous_bias_tracks_a_changed_bias_and_holds_during_motion():
    rng = np.random.default_rng(8)
    new = BIAS + np.array([0.5, -0.5, 0.5]) * DEG  # a temperature drift, under gyr_max_rate
    estimator = C.ContinuousBias(BIAS)
    for g, a in zip(*join(still(rng, 3.0, BIAS), swinging(rng, 2.0, new))):
        estimator.update(g, a, DT)
    assert not estimator.rest
    before = estimator.bias
    gyr, acc = still(rng, 25.0, new)
    corrected = np.array([estimator.update(g, a, DT) for g, a in zip(gyr, acc)])
    assert estimator.rest
    assert np.abs(before - BIAS).max() < 0.02 * DEG  # motion did not move it
    # left after 23.5 s of rest at tau = 3 s: 0.5 deg/s * exp(-23.5 / 3) < 2e-4 deg/s; noise
    # std sigma * sqrt(dt / (2 tau)) = 2.9e-3 deg/s: 0.02 deg/s is about 7 sigma.
    assert np.abs(estimator.bias - new).max() < 0.02 * DEG
    assert corrected[-1] == pytest.approx(gyr[-1] - estimator.bias)


def test_threshold_baseline_finds_a_bias_at_rest():
    baseline = C.ThresholdBias()
    for g in still(np.random.default_rng(9), 0.5, BIAS)[0]:
        baseline.update(g)
    # a mean of 5 samples: std 0.1 deg/s / sqrt(5) = 0.045 deg/s
    assert np.abs(baseline.bias - BIAS).max() < 4 * GYR_SIGMA / math.sqrt(5)


def worst_error(rng, gyr, acc, bias):
    """The largest bias error of the baseline (the IMU and infrared hand-tracking paper's) and of ContinuousBias."""
    baseline, continuous = C.ThresholdBias(bias=bias), C.ContinuousBias(bias)
    worst = np.zeros(2)
    for g, a in zip(gyr, acc):
        baseline.update(g)
        continuous.update(g, a, DT)
        errors = [np.abs(e.bias - bias).max() for e in (baseline, continuous)]
        worst = np.maximum(worst, errors)
    return worst


def test_threshold_baseline_takes_swing_reversals_and_slow_turns_for_bias():
    """The hand-tracking paper's weakness: slow rates while moving become bias; VQF-style rest does not."""
    rng = np.random.default_rng(10)
    baseline, continuous = worst_error(rng, *swinging(rng, 3.0, BIAS), BIAS)
    assert baseline > 1.0 * DEG and continuous == 0  # the swing's reversals pass under 6 deg/s
    turn = BIAS + np.array([0, 0, 3.0]) * DEG
    baseline, continuous = worst_error(rng, *still(rng, 4.0, turn), BIAS)
    assert baseline > 2.5 * DEG and continuous == 0  # the 3 deg/s turn became "bias"


# ----------------------------------------------------------------- six-pose accelerometer


AXES = {"+x": (0, 1.0), "-x": (0, -1.0), "+y": (1, 1.0), "-y": (1, -1.0),
        "+z": (2, 1.0), "-z": (2, -1.0)}
OFFSET = np.array([0.3, -0.4, 0.5])  # m/s^2, within the data sheet's +-60 mg
GAIN = np.array([1.02, 0.98, 1.01])  # raw / true
TRUE_MISALIGNMENT = np.array([[1.0, 0.012, -0.008], [0.0, 1.0, 0.015], [0.0, 0.0, 1.0]])


def pose(rng, force, misalignment=np.eye(3), wobble=None):
    """A pose of 2 s: raw = (misalignment diag(1/gain))^-1 force + offset + noise."""
    A = misalignment @ np.diag(1 / GAIN)
    gyr, acc = still(rng, 2.0, up=np.linalg.solve(A, force) + OFFSET)
    if wobble is not None:
        acc[len(acc) // 2:] += wobble
    return C.Pose(acc, gyr)


def axis_force(rng, label, tilt_deg=3.0):
    """Specific force with ``label`` up, leaning by up to ``tilt_deg``."""
    axis, sign = AXES[label]
    f = np.zeros(3)
    f[axis] = sign * G
    lean = quat.from_rotvec(rng.uniform(-1, 1, 3) * tilt_deg * DEG / math.sqrt(3))
    return quat.rotate(lean, f)


def six(rng, labels=tuple(AXES), misalignment=np.eye(3)):
    return [pose(rng, axis_force(rng, label), misalignment) for label in labels]


def test_six_poses_recover_offset_and_scale_even_when_leaning():
    rng = np.random.default_rng(10)
    poses = six(rng)
    rng.shuffle(poses)
    result = C.six_pose_calibration(poses)
    assert result.ok, result.message
    # each pose mean has std 2.9e-2 / sqrt(400) = 1.5e-3 m/s^2 per axis
    assert result.offset == pytest.approx(OFFSET, abs=0.01)
    assert result.scale == pytest.approx(1 / GAIN, abs=1e-3)
    assert result.misalignment == pytest.approx(np.eye(3))


def test_six_poses_plus_tilted_ones_recover_the_misalignment():
    rng = np.random.default_rng(11)
    tilted = [pose(rng, G * d / np.linalg.norm(d), TRUE_MISALIGNMENT)
              for d in rng.normal(size=(6, 3))]
    result = C.six_pose_calibration(six(rng, misalignment=TRUE_MISALIGNMENT), tilted,
                                    misalignment=True)
    assert result.ok, result.message
    assert result.offset == pytest.approx(OFFSET, abs=0.01)
    assert result.scale == pytest.approx(1 / GAIN, abs=2e-3)
    # the norms fix A up to a rotation; the result is in the symmetric frame: scipy's polar factor of the truth
    _, symmetric = polar(TRUE_MISALIGNMENT @ np.diag(1 / GAIN))
    assert result.misalignment * result.scale[None, :] == pytest.approx(symmetric, abs=2e-3)
    assert result.misalignment == pytest.approx(symmetric / np.diag(symmetric)[None, :], abs=2e-3)
    # over every sample, a fit that is right leaves the noise along gravity: one axis's sigma
    assert result.residual == pytest.approx(ACC_SIGMA, rel=0.1)


def test_misalignment_needs_extra_poses():
    result = C.six_pose_calibration(six(np.random.default_rng(12)), misalignment=True)
    assert not result.ok and "3 extra still poses" in result.message


def bad_pose_sets(rng):
    good = six(rng)
    moved = list(good)
    moved[2] = pose(rng, axis_force(rng, "+y"), wobble=np.array([0.0, 0.0, 1.5]))
    leaning = list(good)
    leaning[4] = pose(rng, quat.rotate(quat.from_rotvec([0.0, 35 * DEG, 0.0]), [0, 0, G]))
    return {
        "missing": (good[:5], "-z up missing"),
        "twice": (good[:5] + [good[0]], "poses 1 and 6 both have +x up"),
        "moved": (moved, "pose 3 was not still"),
        "leaning": (leaning, "pose 5 leans 35 deg"),
    }


@pytest.mark.parametrize("case", ["missing", "twice", "moved", "leaning"])
def test_bad_pose_sets_are_rejected_with_a_reason(case):
    poses, words = bad_pose_sets(np.random.default_rng(13))[case]
    result = C.six_pose_calibration(poses)
    assert not result.ok
    assert words in result.message
    assert result.scale == pytest.approx(np.ones(3))


# ----------------------------------------------------------------- board calibration


def calibrated():
    return C.BoardCalibration(
        "fw-1.0_alice", gyro_bias=BIAS, acc_offset=OFFSET, acc_scale=1 / GAIN,
        acc_misalignment=TRUE_MISALIGNMENT, mag_hard_iron=[10.0, -5.0, 3.0],
        mag_soft_iron=np.diag([1.1, 0.9, 1.0]))


def test_defaults_correct_nothing_and_apply_undoes_the_sensor_model():
    acc, gyr, mag = UP, BIAS, np.array([20.0, 5.0, -40.0])
    plain = C.BoardCalibration().apply_arrays(acc, gyr, mag)
    assert plain.acc == pytest.approx(acc) and plain.gyr == pytest.approx(gyr)
    assert plain.mag == pytest.approx(mag)
    cal = calibrated()
    raw = np.linalg.solve(TRUE_MISALIGNMENT @ np.diag(1 / GAIN), acc) + OFFSET
    out = cal.apply_arrays(raw, gyr, mag)
    assert out.acc == pytest.approx(acc) and out.gyr == pytest.approx(np.zeros(3))
    assert out.mag == pytest.approx(np.diag([1.1, 0.9, 1.0]) @ (mag - [10.0, -5.0, 3.0]))


@pytest.mark.parametrize("cal", [calibrated(), C.BoardCalibration(acc_offset=[0.1, -0.2, 0.3])],
                         ids=["full", "identity-matrices"])
def test_apply_works_on_one_sample_and_on_arrays_alike(cal):
    samples = [P.RawSample(0.0, 0, i, (i, -200, 2048), (10, -5, i), (100, 200, -300), 400)
               for i in range(4)]
    batch = C.SampleArrays.from_samples(samples)
    many = cal.apply_arrays(batch.acc, batch.gyr, batch.mag)
    for i, s in enumerate(samples):
        one = cal.apply(s)
        for got, want in zip(one, (many.acc[i], many.gyr[i], many.mag[i])):
            assert type(got) is tuple and all(type(x) is float for x in got)  # plain floats
            assert got == pytest.approx(want, abs=1e-12)
    no_mag = P.RawSample(0.0, 0, 0, (0, 0, 2048), (0, 0, 0), None, 400)
    assert cal.apply(no_mag).mag is None


def test_the_accelerometers_offsets_follow_the_die_where_their_slope_and_temperature_are_known():
    # Worked by hand: a zero-g slope of (1.5, -1, 0.5) mg per degC, the offsets measured at 25 degC;
    # at 35 degC the readings sit (15, -10, 5) mg further off, which the calibration takes off too.
    slope = np.array([1.5, -1.0, 0.5]) * C.MG
    cal = C.BoardCalibration(acc_offset=OFFSET, acc_thermal=slope, acc_offset_ref_c=25.0)
    assert cal.acc_thermal_known
    assert cal.apply_arrays(UP + OFFSET + 10.0 * slope, np.zeros(3), None, 35.0).acc == pytest.approx(UP)
    assert cal.apply_arrays(UP + OFFSET, np.zeros(3), None, 25.0).acc == pytest.approx(UP)
    warm = P.RawSample(0.0, 0, 0, (100, -200, 2048), (10, -5, 3), None, 400, temp_counts=P.temp_counts(35.0))
    assert cal.apply(warm).acc == pytest.approx(tuple(cal.apply_arrays(warm.acc, warm.gyr, None, warm.die_c).acc),
                                                abs=1e-12)
    assert cal.apply(warm).acc != pytest.approx(tuple(cal.apply_arrays(warm.acc, warm.gyr).acc), abs=1e-3)
    # Without the offsets' temperature (a six-pose run on a firmware without TEMP frames), or without
    # the sample's, the slope is left out.
    unknown = dataclasses.replace(cal, acc_offset_ref_c=0.0)
    assert not unknown.acc_thermal_known
    assert unknown.apply(warm).acc == pytest.approx(tuple(unknown.apply_arrays(warm.acc, warm.gyr).acc), abs=1e-12)
    assert cal.apply(warm._replace(temp_counts=None)).acc == pytest.approx(
        tuple(cal.apply_arrays(warm.acc, warm.gyr).acc), abs=1e-12)
    again = C.BoardCalibration.from_json(cal.to_json())
    assert again.acc_thermal == pytest.approx(slope) and float(again.acc_offset_ref_c) == 25.0
    older = {k: v for k, v in cal.to_json().items() if k not in ("acc_thermal", "acc_offset_ref_c")}
    assert not C.BoardCalibration.from_json(older).acc_thermal_known  # a file from before: nothing to apply


def test_apply_follows_a_replaced_or_reloaded_calibration():
    sample = P.RawSample(0.0, 0, 0, (100, -200, 2048), (10, -5, 3), (100, 200, -300), 400)
    cal = calibrated()
    for other in (dataclasses.replace(cal, gyro_bias=[0.0, 0.0, 0.0]),
                  C.BoardCalibration.from_json(cal.to_json()), copy.deepcopy(cal)):
        want = other.apply_arrays(sample.acc, sample.gyr, sample.mag)
        for got, expected in zip(other.apply(sample), want):
            assert got == pytest.approx(expected, abs=1e-12)
    with pytest.raises(ValueError, match="read-only"):  # so apply's copy cannot go stale
        cal.gyro_bias[0] = 1.0


def test_bad_values_are_refused():
    with pytest.raises(ValueError, match="acc_scale"):
        C.BoardCalibration(acc_scale=[1.0, math.nan, 1.0])
    with pytest.raises(ValueError, match="board id"):
        C.BoardCalibration("../escape")


def test_save_and_load_round_trip_atomically(tmp_path):
    cal = calibrated()
    path = C.save(cal, tmp_path / "boards")
    assert path == tmp_path / "boards" / "fw-1.0_alice.json"
    C.save(cal, tmp_path / "boards")  # overwriting leaves nothing behind either
    assert [p.name for p in path.parent.iterdir()] == [path.name]
    back = C.load("fw-1.0_alice", tmp_path / "boards")
    assert back.to_json() == cal.to_json()
    assert json.loads(path.read_text())["version"] == C.VERSION


def test_default_folder_is_per_user(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))
    assert C.calibration_path("b1") == tmp_path / "energyball" / "boards" / "b1.json"
    monkeypatch.delenv("XDG_CONFIG_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert C.boards_dir() == tmp_path / "home" / ".config" / "energyball" / "boards"


def write(tmp_path, text):
    (tmp_path / "b1.json").write_text(text)


def edited(**changes):
    """Board b1's default file text with some fields changed."""
    return json.dumps({**C.BoardCalibration("b1").to_json(), **changes})


@pytest.mark.parametrize("text, words", [
    (None, "no calibration saved"),
    ('{"format": "energyball board calibration", "vers', "damaged (not valid JSON"),
    ("[1, 2]", "not an EnergyBall board calibration"),
    (edited(version=2), "format version 2"),
    (edited(acc_scale=[1, 2]), "acc_scale must be 3"),
    (edited(board_id="b2"), "holds board 'b2'"),
])
def test_unreadable_files_give_a_clear_error(tmp_path, text, words):
    if text is not None:
        write(tmp_path, text)
    with pytest.raises(C.CalibrationFileError, match="board calibration .*b1.json") as e:
        C.load("b1", tmp_path)
    assert words in str(e.value)
    assert e.value.path == tmp_path / "b1.json"


def test_load_or_default_gives_defaults_and_a_notice(tmp_path):
    write(tmp_path, "{not json")
    cal, notice = C.load_or_default("b1", tmp_path)
    assert cal.to_json() == C.BoardCalibration("b1").to_json()
    assert "damaged" in notice and "using the default calibration" in notice
    C.save(calibrated(), tmp_path)
    cal, notice = C.load_or_default("fw-1.0_alice", tmp_path)
    assert cal.to_json() == calibrated().to_json() and "loaded" in notice


def test_lost_samples_neither_fake_rest_in_motion_nor_end_rest():
    # Every 20th sample lost (dt twice as long there): the swing is still motion throughout,
    # and the still stretches are still rest. Restarting the low-passes at each gap (as the
    # detector once did) made every gap look still for a moment and forgot the learnt mean.
    rng = np.random.default_rng(7)
    gyr, acc = join(still(rng, 2.0), swinging(rng, 5.0), still(rng, 4.0))
    keep = np.arange(len(gyr)) % 20 != 7
    t = times(len(gyr))[keep]
    detector = C.RestDetector()
    rest = np.array([detector.update(g, a, dt) for g, a, dt in
                     zip(gyr[keep], acc[keep], np.diff(t, prepend=-DT))])
    moving = (t > 2.1) & (t < 7.0)
    assert not rest[moving].any()
    assert rest[(t > 1.6) & (t < 2.0)].all() and rest[t > 7.0 + 1.5 + 4 * C.RestParams().tau].all()
    still_gyr = gyr[keep][rest & (t > 9.0)]
    assert detector.gyr_lp == pytest.approx(still_gyr.mean(axis=0), abs=0.2 * DEG)


def test_the_poses_fields_round_trip_default_in_an_older_file_and_a_wrong_shape_is_one_clear_error():
    """``pose_fields`` (the accelerometer procedure's poses, for the magnetometer's alignment): saved and read
    back as written, zeros in a file from before it was kept, and refused with its name and shape when wrong;
    no correction reads it."""
    rows = np.zeros((C.POSE_ROWS, 7))
    rows[:2] = [[20.0, -5.0, 40.0, 0.0, 0.0, 1.0, 1.0], [-3.0, 22.0, -41.0, 0.6, 0.0, 0.8, 1.0]]
    cal = C.BoardCalibration(acc_offset=OFFSET, pose_fields=rows)
    assert np.array_equal(C.BoardCalibration.from_json(cal.to_json()).pose_fields, rows)
    older = {k: v for k, v in cal.to_json().items() if k != "pose_fields"}
    assert not C.BoardCalibration.from_json(older).pose_fields.any()
    with pytest.raises(ValueError, match=f"pose_fields must be {C.POSE_ROWS} x 7 finite numbers"):
        C.BoardCalibration.from_json({**cal.to_json(), "pose_fields": rows[:3].tolist()})
    sample = P.RawSample(0.0, 0, 0, (100, -200, 2048), (10, -5, 3), (100, 200, -300), 400)
    plain = C.BoardCalibration(acc_offset=OFFSET)
    for got, want in zip(cal.apply(sample), plain.apply(sample)):
        assert got == pytest.approx(want, abs=0.0)
