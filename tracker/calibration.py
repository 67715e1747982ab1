"""Calibration: rest detection, gyroscope bias, six-pose accelerometer calibration, board files.

What a board's sensors get wrong, measured here and undone before fusion
(ARCHITECTURE.md: ``tracker.protocol`` -> here -> ``tracker.fusion``). SI units
throughout: seconds, rad/s, m/s^2 (specific force, +g on the up axis at rest),
microtesla.

- :class:`RestDetector`: is the board lying still? The idea of VQF's rest
  detection: low-pass the gyroscope and the accelerometer, call a sample still
  while it stays near its low-passed value, and declare rest once the samples
  have been still for a minimum time.
- Gyroscope bias: :func:`startup_bias` ("hold still" at start-up: the bias from a
  hold in which a real arm trembles and sways, :func:`fit_hold`, refused only when
  the arm really moved), :class:`ContinuousBias` (re-estimated slowly during every
  rest phase) and :class:`ThresholdBias`, the IMU and infrared hand-tracking
  paper's method kept as the baseline.
- :func:`six_pose_calibration`: accelerometer offset, scale and, optionally, a
  small misalignment, from the board held still with each axis up and down.
- :class:`BoardCalibration`: all of it for one board, applied to samples, saved
  per board as JSON (atomically) and loaded with clear errors.

Sec. 6 of Zhu & Shi lists weaknesses this module answers in part: the yaw drift its
complementary filter cannot correct (a gyroscope bias about the vertical is what
drives it, so removing the bias slows it) and differences from board to board
(kept per board id).

References
    VQF: D. Laidig and T. Seel, "VQF: Highly Accurate IMU Orientation Estimation
    with Bias Estimation and Magnetic Disturbance Rejection", Information Fusion
    91 (2023) 187-204, doi:10.1016/j.inffus.2022.10.014; its rest detection,
    part of its rest bias estimation (defaults: 2 deg/s, 0.5 m/s^2, 1.5 s, 0.5 s).
    The hand-tracking paper (../shared/papers/002_*.txt), sec. 2.2 "Bias Offset Estimation", eq. 2.
    Tedaldi 2014: D. Tedaldi, A. Pretto and E. Menegatti, "A robust and easy to
    implement method for IMU calibration without external equipments", ICRA 2014:
    static poses, a triangular misalignment times a scale, and a cost that
    compares each calibrated pose's norm with g.
"""

from __future__ import annotations

import copy
import json
import math
import os
import re
import stat
from collections import deque
from dataclasses import Field, dataclass, field, fields, replace
from datetime import datetime
from pathlib import Path
from typing import Callable, NamedTuple, Sequence

import numpy as np
from mypy_extensions import mypyc_attr
from numpy.typing import ArrayLike, NDArray

from .atomic import atomic_write
from .lowpass import LowPass2
from . import quat
from .protocol import STANDARD_GRAVITY, Hello, RawSample, temp_c
from .userjson import JSONInputError, read_json

Array = NDArray[np.float64]
Vec = tuple[float, float, float]
Rows = tuple[Vec, Vec, Vec]  # a 3 x 3 matrix by rows

DEG = math.pi / 180.0  # rad per degree
MG = STANDARD_GRAVITY / 1000.0  # m/s^2 per milli-g
GRAVITY = 9.81  # m/s^2, the world gravity of ARCHITECTURE.md


def _vec3(x: ArrayLike) -> Array:
    v = np.asarray(x, dtype=np.float64)
    if v.shape != (3,):
        raise ValueError(f"expected 3 numbers, got shape {v.shape}")
    return v


def _rows(x: ArrayLike, what: str) -> Array:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{what} must be an (N, 3) array, got shape {a.shape}")
    return a


def _lowpass_gain(dt: float, tau: float) -> float:
    """Gain k of the first-order low-pass ``y += k (x - y)``: k = 1 - exp(-dt / tau)."""
    return 1.0 - math.exp(-dt / tau)


def _deg(v: Array) -> str:
    """A rate vector in rad/s, written in deg/s for the user."""
    return "(" + ", ".join(f"{x / DEG:+.3f}" for x in v) + ") deg/s"


@dataclass(frozen=True, eq=False)
class SampleArrays:
    """Raw samples as arrays: ``t`` (N,) s, ``acc`` m/s^2, ``gyr`` rad/s, ``mag`` uT, each (N, 3).

    ``mag`` rows are NaN where a sample had no magnetometer reading.
    """

    t: Array
    acc: Array
    gyr: Array
    mag: Array

    @classmethod
    def from_samples(cls, samples: Sequence[RawSample]) -> "SampleArrays":
        """Stack a list of samples (converted to SI by :class:`RawSample`)."""
        nan = (math.nan, math.nan, math.nan)
        return cls(np.array([s.t for s in samples], dtype=np.float64),
                   np.array([s.acc for s in samples], dtype=np.float64).reshape(-1, 3),
                   np.array([s.gyr for s in samples], dtype=np.float64).reshape(-1, 3),
                   np.array([s.mag or nan for s in samples], dtype=np.float64).reshape(-1, 3))


# ----------------------------------------------------------------- rest detection


@mypyc_attr(native_class=False)  # plain even when compiled: frozen, yet deep-copied with a state
@dataclass(frozen=True)
class RestParams:
    """Settings of :class:`RestDetector`; the defaults are VQF's rest-detection defaults.

    ``gyr_threshold``: a gyroscope sample is still while it stays this close (norm,
    rad/s) to its low-passed value (VQF: 2 deg/s). ``acc_threshold``: the same for
    the accelerometer, m/s^2 (VQF: 0.5 m/s^2). ``gyr_max_rate``: the low-passed rate
    must also stay below this on every axis (rad/s), so that a slow steady turn, which
    deviates from nothing, is not taken for rest (VQF's bias clip, 2 deg/s); feed
    bias-corrected rates, as :class:`ContinuousBias` does. ``min_duration``: seconds
    of stillness before rest is declared (VQF: 1.5 s). ``tau``: time constant of the
    low-pass, s (VQF: 0.5 s, second-order Butterworth as here).
    """

    gyr_threshold: float = 2.0 * DEG
    acc_threshold: float = 0.5
    gyr_max_rate: float = 2.0 * DEG
    min_duration: float = 1.5
    tau: float = 0.5


@mypyc_attr(serializable=True)  # copy.deepcopy works when compiled (its __init__ needs arguments)
@dataclass
class RestState:
    """What a :class:`RestDetector` remembers between samples."""

    gyr_lp: LowPass2  # low-pass of the gyroscope, rad/s
    acc_lp: LowPass2  # low-pass of the accelerometer, m/s^2
    still_for: float = 0.0  # seconds the samples have been still
    rest: bool = False


class RestDetector:
    """Streaming rest detection after the idea of VQF (Laidig & Seel 2023), own code.

    Each sample updates second-order low-passes of the gyroscope and accelerometer
    (:mod:`tracker.lowpass`); the sample is still when it is within the thresholds
    of them and the low-passed rate is small; rest is declared once the samples
    have been still for ``min_duration`` and ends with the first sample that is
    not. A non-finite sample or time step ends rest too. Plain floats throughout:
    the default filter runs one per sample.
    """

    def __init__(self, params: RestParams | None = None) -> None:
        self.params = params or RestParams()
        self._state = self._initial_state()

    def _initial_state(self) -> RestState:
        tau = self.params.tau
        return RestState(LowPass2(tau), LowPass2(tau))

    @property
    def state(self) -> RestState:
        """A copy of the state (changing it does not change the detector)."""
        return copy.deepcopy(self._state)

    @property
    def rest(self) -> bool:
        """Whether the last sample was at rest."""
        return self._state.rest

    @property
    def still_for(self) -> float:
        """Seconds the samples have been still (0 after a sample that was not)."""
        return self._state.still_for

    @property
    def gyr_lp(self) -> tuple[float, float, float] | None:
        """The low-passed gyroscope (rad/s), None before the first sample."""
        lp = self._state.gyr_lp
        return lp.y if lp.primed else None

    def reset(self) -> None:
        """Forget everything; the next sample starts afresh."""
        self._state = self._initial_state()

    def update(self, gyr: Sequence[float] | Array, acc: Sequence[float] | Array, dt: float) -> bool:
        """Feed one sample (rad/s, m/s^2, seconds since the last); whether the board is at rest."""
        s, p = self._state, self.params
        gx, gy, gz = float(gyr[0]), float(gyr[1]), float(gyr[2])
        ax, ay, az = float(acc[0]), float(acc[1]), float(acc[2])
        inf = math.inf  # chained comparisons: false for infinities and NaN alike, and cheap
        if not (-inf < gx < inf and -inf < gy < inf and -inf < gz < inf and -inf < ax < inf
                and -inf < ay < inf and -inf < az < inf and 0.0 < dt < inf):
            s.still_for, s.rest = 0.0, False
            return False
        (lx, ly, lz), (mx, my, mz) = s.gyr_lp.step((gx, gy, gz), dt), s.acc_lp.step((ax, ay, az), dt)
        ux, uy, uz = gx - lx, gy - ly, gz - lz  # the gyroscope's deviation from its low-pass
        vx, vy, vz = ax - mx, ay - my, az - mz  # the accelerometer's
        r = p.gyr_max_rate  # the low-passed rate below it on every axis (finite here: a
        # non-finite one failed the first test already)
        still = (ux * ux + uy * uy + uz * uz < p.gyr_threshold * p.gyr_threshold
                 and vx * vx + vy * vy + vz * vz < p.acc_threshold * p.acc_threshold
                 and -r < lx < r and -r < ly < r and -r < lz < r)
        s.still_for = s.still_for + dt if still else 0.0
        s.rest = s.still_for >= p.min_duration - 1e-9
        return s.rest


# ----------------------------------------------------------------- start-up hold


TREMOR_MIN_HZ = 3.0  # the slowest tremor a player may have: essential tremor 4-12 Hz, physiological
# 8-12 Hz (Deuschl, Bain & Brin, "Consensus statement of the Movement Disorder Society on tremor",
# Mov. Disord. 13 suppl. 3 (1998) 2-23, sec. 2 and 4), widened to the 3-12 Hz a player profile allows


ARM_RADIUS_M = 0.1  # the board's offset from the arm's axis is about the upper arm's radius, 4-6 cm
# (anthropometric mid-arm circumference 25-35 cm, CDC NHANES body measures): a prior of 0.1 m on it
FIT_NOISE = 2e-3  # what the hold's model leaves unexplained per low-passed sample, g: the
# accelerometer's noise (MPU-9250: 300 ug/sqrt(Hz)) after the low-pass and a real arm's soft tissue


def _covered(t: Array) -> float:
    """Seconds a window of sample times covers (each sample one median period)."""
    return float(t[-1] - t[0] + np.median(np.diff(t))) if len(t) > 1 else 0.0


@dataclass(frozen=True)
class StartupParams:
    """Settings of :func:`startup_bias`.

    ``duration``: seconds of the hold needed (the game holds 2.5 s; 5 s, :data:`LONGER_HOLD`, when
    that asks for more). ``max_bias``:
    a larger mean rate on any axis (rad/s) is refused: the MPU-9250's zero-rate output
    is within +-5 deg/s at 25 degC and moves by up to +-30 deg/s over its temperature
    range (PS-MPU-9250A-01 rev. 1.1, table 1; a profile's gyro_bias_dps allows 30), so
    35 deg/s means a steady turn or a faulty gyroscope. ``max_tilt`` (rad): a larger net
    tilt of the arm over the hold is a move: a sway of up to 4 deg peak (the issue's 0.1-1 Hz postural sway) swings the
    arm at most 8 deg peak to peak, so 8.5 deg. ``max_rate`` (rad/s): the low-passed
    rate that the tilt does not explain must stay under it. Measured with this low-pass
    on the real arm recording (../shared/data/real-arm, both upper arms, every 2 s
    window on a 0.1 s grid): still windows leave at most 1.09 deg/s, the slowest real
    movements at least 1.23 deg/s; 1.15 deg/s lies between (``tests/tracker/
    test_stillness_real.py`` keeps both sides). ``smoothing`` (s): length of the
    zero-phase Blackman low-pass (:func:`_blackman`); 3 / TREMOR_MIN_HZ puts its first
    zero at the slowest tremor, and its sidelobes (-58 dB) keep the tremor band out.
    """

    duration: float = 2.0
    max_bias: float = 35.0 * DEG
    max_tilt: float = 8.5 * DEG
    max_rate: float = 1.15 * DEG
    smoothing: float = 3.0 / TREMOR_MIN_HZ


HOLD_SLACK_S = 0.5
"""How much longer a hold the game asks for lasts than its judgement needs (``duration``): the first
hold asks 2.5 s and needs 2 s, the longer one asks 5 s in all and needs 4.5 s. A hold judged on
exactly what it asked for fails on a sample lost or late at its edge, or on a player who lets go a
moment early: a simulated player who held on 4.96 s of a 5 s hold was refused "only 4.96 s of
samples" before the longer hold needed 4.5 s (README, "The longer hold")."""

LONGER_HOLD = StartupParams(duration=4.5, max_rate=0.75 * DEG, smoothing=2.0)
"""The judgement of a hold twice as long, for an arm whose tremor a 2 s hold cannot tell from a move.

A tremor at the slowest 3 Hz spreads over 2-4 Hz (its components beat; the simulated player's
TREMOR_SPREAD_HZ), and the default 1 s low-pass, whose first zero is at 3 Hz, lets the 2 Hz part
through as an unexplained turn: 1 hold in 20 of the worst plausible player with a 3 Hz tremor was
refused at 1.3 deg/s. A 2 s low-pass (first zero at 1.5 Hz) stops it (at most 0.28 deg/s over 20
such 5 s holds) but lets more of a slow real move through, so its bound is lower: measured on the
real arm recording like ``max_rate`` (``tests/tracker/test_stillness_real.py``, every 5 s window),
still windows leave at most 0.64 deg/s and the movements at least 0.88; 0.75 lies between."""

LONGER_HOLD_S = LONGER_HOLD.duration + HOLD_SLACK_S
"""The whole longer hold the game asks for and judges, its first part included: 5 s."""


@dataclass(frozen=True, eq=False)
class BiasResult:
    """The outcome of a start-up bias estimate; ``message`` says what happened, for the user.

    ``bias`` and ``std_error`` (its standard error, :class:`HoldFit`) are rad/s per
    axis, zeros when ``ok`` is false; ``duration`` is the seconds used. ``hold_longer``:
    refused only for a turn its tilt does not explain, judged with a low-pass shorter than
    :data:`LONGER_HOLD`'s: a slow tremor does that too, so hold on and judge the longer hold.
    """

    ok: bool
    message: str
    bias: Array
    std_error: Array
    duration: float
    hold_longer: bool = False


@dataclass(frozen=True, eq=False)
class HoldFit:
    """What :func:`fit_hold` found in a hold.

    ``bias`` and ``std_error``: rad/s, sensor frame. ``tilt``: the arm's net rotation
    about horizontal axes from the (low-passed) start to the end of the hold, rad.
    ``rate``: the largest low-passed angular rate the model does not explain, rad/s,
    and ``rate_vertical`` whether its larger part was about the vertical (a turn the
    accelerometer cannot see). ``lever``: the fitted distance of the board below the
    point it rotates about, m. ``up``: the mean specific-force direction (sensor frame).
    """

    bias: Array
    std_error: Array
    tilt: float
    rate: float
    rate_vertical: bool
    lever: float
    up: Array


def _blackman(length: float, dt: float) -> tuple[Array, Array]:
    """A Blackman window of ``length`` seconds as a low-pass kernel (sum 1) and its time
    derivative (per second), sampled every ``dt``: w = 0.42 - 0.5 cos(2 pi x) + 0.08 cos(4 pi x)
    on x in (0, 1). Its spectrum is zero at 3 / length, its highest sidelobe is -58 dB and the
    sidelobes fall as f^-3 (F. J. Harris, "On the use of windows for harmonic analysis with the
    discrete Fourier transform", Proc. IEEE 66 (1978) 51-83, sec. V.E and table 1). A length
    of 3 / TREMOR_MIN_HZ keeps the tremor band out: a Hann window with the same first zero
    (2 / TREMOR_MIN_HZ long) lets its -31 dB sidelobes through, so a 2 deg tremor rocking the
    board on soft tissue near 5 Hz left up to 5 deg/s of apparent turn, as much as a real move."""
    m = max(3, round(length / dt))
    x = 2.0 * math.pi * (np.arange(m) + 0.5) / m
    k = 0.42 - 0.5 * np.cos(x) + 0.08 * np.cos(2.0 * x)
    dk = (0.5 * np.sin(x) - 0.16 * np.sin(2.0 * x)) * (2.0 * math.pi / (m * dt))
    return k / k.sum(), dk / k.sum()


def _smooth(x: Array, kernel: Array) -> Array:
    """``x`` (N,) or each column of ``x`` (N, 3) convolved with ``kernel`` where it fits
    (N - len(kernel) + 1 rows)."""
    m = len(kernel)
    return np.lib.stride_tricks.sliding_window_view(x, m, axis=0) @ kernel[::-1]


def _turned(t: Array, gyr: Array) -> Array:
    """The board's rotation since the first sample, (N, 4) quaternions q_0i (sensor frames),
    integrating q' = q (0, w) / 2 (Sola 2017, sec. 4.6) exactly per step with the step's mean
    rate: exact products keep a coning tremor from posing as a turn."""
    out = np.zeros((len(t), 4))
    w, x, y, z = 1.0, 0.0, 0.0, 0.0
    out[0, 0] = 1.0
    for i in range(1, len(t)):
        h = 0.25 * (float(t[i]) - float(t[i - 1]))  # half the step's angle per unit of summed rate
        ax = (float(gyr[i, 0]) + float(gyr[i - 1, 0])) * h
        ay = (float(gyr[i, 1]) + float(gyr[i - 1, 1])) * h
        az = (float(gyr[i, 2]) + float(gyr[i - 1, 2])) * h
        n = math.sqrt(ax * ax + ay * ay + az * az)
        c, s = math.cos(n), (math.sin(n) / n if n > 0.0 else 1.0)
        bx, by, bz = ax * s, ay * s, az * s
        w, x, y, z = (w * c - x * bx - y * by - z * bz, w * bx + x * c + y * bz - z * by,
                      w * by - x * bz + y * c + z * bx, w * bz + x * by - y * bx + z * c)
        out[i] = (w, x, y, z)
    return out


def _basis(up: Array) -> Array:
    """Rows e1, e2 = up x e1, up: two horizontal unit vectors and the vertical (sensor frame)."""
    seed = np.array([1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(up, seed)
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(up, e1), up])


class _RowNoise(NamedTuple):
    """How the raw samples' white noise w reaches a fit's low-passed rows, A w, without A (rows x
    samples) itself: its ``transpose`` (rows -> samples) and ``norm2`` = ||A||_F^2."""

    transpose: Callable[[Array], Array]
    norm2: float


def _solve(x: Array, g: Array, y: Array) -> tuple[Array, Array]:
    """The least-squares fit y ~ x s with g = pinv(x) (made once per design): s and the residual."""
    s: Array = g @ y
    return s, y - x @ s


def _std_errors(x: Array, g: Array, e: Array, noise: _RowNoise) -> Array:
    """Standard errors of the least-squares fit y ~ x s, s = g y (g = pinv(x)), whose residual is ``e``.

    The rows are low-passed, so their noise is correlated: y = x s + A w, with one unknown
    variance sigma^2 for w. With H = x g, E[e^T e] = sigma^2 tr(A^T (I - H) A) = sigma^2
    (||A||_F^2 - sum_j (A^T x_j) . (A^T g_j)), and Cov(s) = sigma^2 (g A)(g A)^T: least squares
    under correlated errors (the "sandwich", e.g. Greene, Econometric Analysis, 7th ed., sec.
    9.2), which counts the few degrees of freedom a low-pass leaves instead of taking every
    row for one."""
    ga = np.stack([noise.transpose(row) for row in g])  # g A, row by row
    kept = noise.norm2 - sum(float(noise.transpose(x[:, j]) @ ga[j]) for j in range(x.shape[1]))
    sigma2 = float(e @ e) / max(kept, 1e-300)
    return np.sqrt(sigma2 * np.sum(ga * ga, axis=1))


def _hold_noise(kernel: Array, n: int, dt: float) -> tuple[_RowNoise, _RowNoise]:
    """How white sensor noise reaches :func:`fit_hold`'s rows, horizontal and vertical.

    The low-pass K (n rows of n + m - 1 samples; row i the reversed kernel from sample
    i, :func:`_smooth`) has K^T y = y convolved with the reversed kernel and ||K||_F^2 =
    n sum k^2. The horizontal rows are K on each accelerometer axis, then the noiseless
    prior rows. The vertical rows are K applied to the integrated gyroscope, A = K L
    with L w = dt cumsum(w): A^T y = dt (reversed cumulative sum of K^T y); row i of A
    is dt for the i + 1 samples up to i, then dt C[m - 2], ..., dt C[0] (C the
    kernel's cumulative sum, the kernel symmetric), so ||A||_F^2 = dt^2 (n (n + 1) / 2
    + n sum_{s < m - 1} C[s]^2)."""
    flipped = kernel[::-1]

    def horizontal(y: Array) -> Array:
        return np.concatenate([np.convolve(y[:n], flipped), np.convolve(y[n:2 * n], flipped)])

    def vertical(y: Array) -> Array:
        return dt * np.cumsum(np.convolve(y, flipped)[::-1])[::-1]

    tail = np.cumsum(kernel)[:-1]
    return (_RowNoise(horizontal, 2.0 * n * float(kernel @ kernel)),
            _RowNoise(vertical, dt * dt * (n * (n + 1) / 2.0 + n * float(tail @ tail))))


def _lever_columns(gyr: Array, dw: Array, kernel: Array, basis: Array) -> Array:
    """(n, 2, 3): the low-passed specific force, over g and about e1 and e2, that a lever arm of
    1 m along each basis vector adds: w' x r + w x (w x r) (Seel et al. 2014, sec. 3.1, eq. 5)."""
    cols = []
    for r in basis:
        centripetal = gyr * (gyr @ r)[:, None] - np.outer(np.sum(gyr * gyr, axis=1), r)
        force = np.cross(dw, r) + _smooth(centripetal, kernel)
        cols.append(force @ basis[:2].T / GRAVITY)
    return np.stack(cols, axis=2)


def _roll_columns(gyr: Array, kernel: Array, basis: Array) -> Array:
    """(n, 3): the low-passed products w_up w_e1, w_up w_e2 and w_up^2 (rad^2/s^2, over g) of
    the rate about the vertical with each axis: what the board's roll on the soft tissue adds.

    A strap rocks the board about the arm's axis (Wakeling & Nigg 2001, J. Biomech. 34:
    soft-tissue vibrations, a damped oscillator the bone's tremor drives), the vertical while
    the arm hangs. The gyroscope reads that roll with the bone's swing, but the roll turns
    the board about the arm's axis, not about the shoulder, so the rigid lever terms of
    :func:`_lever_columns` computed with the whole rate are off by the roll rate times the
    swing rate and the roll rate squared, each times a length of the board's offset from the
    arm's axis (w x (w x r) expanded in w = w_bone + w_roll, Seel et al. 2014, eq. 5). Tremor
    near the strap's resonance rolls it by degrees at 10 Hz; its beating rectifies those
    products into a slow specific force that no tilt explains."""
    up = gyr @ basis[2]
    products = np.stack([up * (gyr @ basis[0]), up * (gyr @ basis[1]), up * up], axis=1)
    return _smooth(products, kernel) / GRAVITY


def fit_hold(t: ArrayLike, gyr: ArrayLike, acc: ArrayLike,
             params: StartupParams | None = None) -> HoldFit:
    """The gyroscope bias of a hold and how the arm moved during it (arrays as :func:`startup_bias`).

    While "still" a real arm trembles and sways, so the mean rate is the bias plus the
    arm's net rotation over the hold divided by its length. The accelerometer sees
    the rotation about horizontal axes: it reads g v(t) plus the acceleration of the
    board (Inertial Sensor Based Solution for Finger Motion Tracking, Computers
    9(2):40, 2020, sec. 2.1: a = R^T (p'' - g)), v the up direction in the sensor
    frame. The gyroscope, integrated exactly (:func:`_turned`, rotation q(t) since the
    start), predicts v(t) = q(t)^-1 v0 q(t); a bias error db left in the rates
    turns the prediction by db t, so a / g - v = t (db x v) + const + lever terms,
    whatever the tremor and sway. The board sits at r from the joint it turns about,
    so it feels w' x r + w x (w x r) (Seel, Raisch & Schauer, "IMU-based joint angle
    measurement for gait analysis", Sensors 14 (2014) 6891-6909, sec. 3.1, eq. 5,
    where it locates joints): r is fitted with db, so tremor of several g at the
    elbow is explained (r's horizontal part, the board's offset from the arm's axis,
    held near zero by a prior of ARM_RADIUS_M), and so is what the strap's roll about the
    arm's axis adds (:func:`_roll_columns`, lengths of the same size). About the vertical, which the
    accelerometer cannot see, the bias is the slope of the integrated rotation.

    Both sides are low-passed alike first (VQF judges rest on low-passed signals,
    Laidig & Seel 2023, sec. 3.3; here the whole hold is at hand, so a zero-phase
    Blackman window, :func:`_blackman`, without lag or start-up transient). The fit is
    linear least squares, done twice, integrating again with the bias found. The
    tilt is the angle between the low-passed, bias-corrected up direction at the
    first and last low-passed samples; the unexplained rate is the time derivative
    of the fit's residual (as an angle).
    """
    p = params or StartupParams()
    tt = np.asarray(t, dtype=np.float64)
    g, a = _rows(gyr, "gyr"), _rows(acc, "acc")
    dt = float(np.median(np.diff(tt)))
    kernel, dkernel = _blackman(p.smoothing, dt)
    basis = _basis(a.mean(axis=0) / float(np.linalg.norm(a.mean(axis=0))))
    tau = _smooth(tt - tt[0], kernel)
    n = len(tau)
    noise_h, noise_v = _hold_noise(kernel, n, dt)  # what white sensor noise does to the rows
    lever = _lever_columns(g, _smooth(g, dkernel), kernel, basis)
    roll = _roll_columns(g, kernel, basis)
    # unknowns: db_e1, db_e2, const_e1, const_e2, the lever arm r_e1, r_e2, r_up, then the roll's
    # three lengths on e1's rows and on e2's; a prior row (~0, ARM_RADIUS_M) for r_e and each length
    priors = [4, 5, *range(7, 13)]
    x_h = np.zeros((2 * n + len(priors), 13))
    x_h[n:2 * n, 0], x_h[:n, 1], x_h[:n, 2], x_h[n:2 * n, 3] = -tau, tau, 1.0, 1.0
    x_h[:n, 4:7], x_h[n:2 * n, 4:7] = lever[:, 0, :], lever[:, 1, :]
    x_h[:n, 7:10], x_h[n:2 * n, 10:13] = roll, roll
    x_h[2 * n + np.arange(len(priors)), priors] = math.sqrt(n) * FIT_NOISE / ARM_RADIUS_M
    x_v = np.stack([tau, np.ones(n)], axis=1)
    g_h, g_v = (np.linalg.pinv(x).astype(np.float64) for x in (x_h, x_v))  # the same in both passes
    bias = np.zeros(3)
    a_lp = _smooth(a, kernel)
    centre = (len(kernel) - 1) // 2  # the sample at the middle of each low-passed one
    for _ in range(2):
        q = _turned(tt, g - bias)
        start = np.sum(quat.rotate(q[centre:centre + n], a_lp), axis=0)  # taken back to the start
        v = _smooth(quat.rotate(quat.conjugate(q), start / np.linalg.norm(start)), kernel)
        d = (a_lp / GRAVITY - v) @ basis[:2].T
        s_h, e_h = _solve(x_h, g_h, np.concatenate([d[:, 0], d[:, 1], np.zeros(len(priors))]))
        s_v, e_v = _solve(x_v, g_v, _smooth(quat.to_rotvec(q), kernel) @ basis[2])
        step = s_h[0] * basis[0] + s_h[1] * basis[1] + s_v[0] * basis[2]
        bias = bias + step
    ends = v[[0, -1]] + np.outer(tau[[0, -1]], np.cross(step, basis[2]))
    tilt = math.atan2(float(np.linalg.norm(np.cross(ends[0], ends[1]))), float(ends[0] @ ends[1]))
    residual = np.stack([e_h[:n], e_h[n:2 * n], e_v], axis=1)
    rate = np.gradient(residual, tau, axis=0)
    norms = np.linalg.norm(rate, axis=1)
    worst = int(np.argmax(norms))
    se_h, se_v = _std_errors(x_h, g_h, e_h, noise_h), _std_errors(x_v, g_v, e_v, noise_v)
    std_error = np.sqrt(np.array([se_h[0], se_h[1], se_v[0]]) ** 2 @ basis ** 2)
    return HoldFit(bias, std_error, tilt, float(norms[worst]),
                   bool(abs(rate[worst, 2]) > math.hypot(rate[worst, 0], rate[worst, 1])),
                   float(-s_h[6]), basis[2].copy())


def _hold_problem(fit: HoldFit, p: StartupParams) -> str | None:
    """Why a fitted hold was not still, or None."""
    if fit.tilt > p.max_tilt:
        return (f"the arm tilted {fit.tilt / DEG:.1f} degrees during the hold (a still arm "
                f"sways less than {p.max_tilt / DEG:.1f})")
    if fit.rate > p.max_rate:
        what = ("the arm turned about the vertical" if fit.rate_vertical
                else "the arm moved more than its tilt shows (the body or shoulder moved?)")
        return (f"{what} at up to {fit.rate / DEG:.1f} deg/s (still means under "
                f"{p.max_rate / DEG:.1f} deg/s)")
    return None


def _startup_problem(t: Array, gyr: Array, acc: Array, p: StartupParams) -> str | None:
    """Why a start-up window cannot be judged at all, or None."""
    if not (len(t) == len(gyr) == len(acc)):
        return "the sample arrays differ in length"
    if len(t) < 2:
        return f"no samples; hold the board still for {p.duration:g} s"
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(gyr)) and np.all(np.isfinite(acc))):
        return "some readings are missing or not finite; try again"
    if not np.all(np.diff(t) > 0):
        return "the sample times do not increase; try again"
    if _covered(t) < max(p.duration, 2.0 * p.smoothing) - 1e-9:
        return (f"only {_covered(t):.2f} s of samples; hold the board still for "
                f"{p.duration:g} s")
    if np.linalg.norm(acc.mean(axis=0)) < 0.5 * GRAVITY:
        return "the accelerometer reads far less than gravity; is the board in free fall?"
    return None


def startup_bias(t: ArrayLike, gyr: ArrayLike, acc: ArrayLike,
                 params: StartupParams | None = None) -> BiasResult:
    """The gyroscope bias from a "hold still" window at start-up.

    ``t`` is (N,) seconds, ``gyr`` (N, 3) rad/s, ``acc`` (N, 3) m/s^2. At rest the
    gyroscope reads only bias plus noise (the hand-tracking paper, sec. 2.2); a person's arm also
    trembles and sways, which :func:`fit_hold` separates from the bias. The hold is
    refused, with the reason, when it is too short, when the arm tilted further
    than sway can (``max_tilt``), when it turned in a way its tilt does not explain
    (``max_rate``, a turn about the vertical for instance), or when the bias found is
    implausibly large (``max_bias``).
    """
    p = params or StartupParams()
    tt = np.asarray(t, dtype=np.float64)
    g, a = _rows(gyr, "gyr"), _rows(acc, "acc")
    problem = _startup_problem(tt, g, a, p)
    fit = None if problem else fit_hold(tt, g, a, p)
    if fit is not None:
        moved = _hold_problem(fit, p)
        if moved:
            problem = f"the board moved during start-up: {moved}; hold it still and try again"
        elif np.max(np.abs(fit.bias)) > p.max_bias:
            problem = (f"the gyroscope read {_deg(fit.bias)} while still, more than the "
                       f"{p.max_bias / DEG:g} deg/s a resting MPU-9250 can show: the board was "
                       f"turning slowly, or its gyroscope is faulty; hold it still and try again")
    if problem or fit is None:
        longer = (fit is not None and fit.tilt <= p.max_tilt and fit.rate > p.max_rate
                  and p.smoothing < LONGER_HOLD.smoothing)
        return BiasResult(False, problem or "", np.zeros(3), np.zeros(3), _covered(tt), longer)
    return BiasResult(True, f"gyroscope bias {_deg(fit.bias)} (+-{np.max(fit.std_error) / DEG:.2f}) "
                      f"from {_covered(tt):.1f} s still", fit.bias, fit.std_error, _covered(tt))


# ----------------------------------------------------------------- gyroscope bias in use


@dataclass(frozen=True)
class ContinuousBiasParams:
    """Settings of :class:`ContinuousBias`.

    ``tau``: time constant (s) of the running average during rest; with white noise
    of std sigma per sample and dt << tau the estimate's std is about
    sigma * sqrt(dt / (2 tau)). ``rest``: the rest detector's settings.
    """

    tau: float = 3.0
    rest: RestParams = field(default_factory=RestParams)


class ContinuousBias:
    """The gyroscope bias, re-estimated during every rest phase.

    After VQF's rest bias estimation (Laidig & Seel 2023), which averages the
    gyroscope while its rest detector says rest; there a Kalman filter, here a slow
    first-order average: ``b += k (omega - b)``, k = 1 - exp(-dt / tau). The rest
    detector sees the bias-corrected rate, so its ``gyr_max_rate`` bounds how far the
    bias can move between rest phases; a bigger jump needs :func:`startup_bias` again.
    """

    def __init__(self, bias: ArrayLike = (0.0, 0.0, 0.0),
                 params: ContinuousBiasParams | None = None) -> None:
        self.params = params or ContinuousBiasParams()
        self._bias = _vec3(bias).copy()
        self._detector = RestDetector(self.params.rest)

    @property
    def bias(self) -> Array:
        """The current estimate, rad/s (a copy)."""
        return self._bias.copy()

    @property
    def rest(self) -> bool:
        """Whether the last sample was at rest (and so went into the average)."""
        return self._detector.rest

    def update(self, gyr: ArrayLike, acc: ArrayLike, dt: float) -> Array:
        """Feed one sample; the bias-corrected rate omega_B = omega_0 - b (the hand-tracking paper, eq. 2)."""
        g = _vec3(gyr)
        if self._detector.update(g - self._bias, _vec3(acc), dt):
            self._bias += _lowpass_gain(dt, self.params.tau) * (g - self._bias)
        return g - self._bias


@dataclass(frozen=True)
class ThresholdBiasParams:
    """Settings of :class:`ThresholdBias` (the hand-tracking paper, sec. 2.2).

    ``threshold``: rate norm (rad/s) below which a sample counts; the paper gives no
    value: 6 deg/s sits above the MPU-9250's +-5 deg/s zero-rate offset, so a still
    but uncalibrated board qualifies. ``count``: consecutive samples averaged; the
    paper's 5 (250 ms at its rate; 25 ms at 200 Hz).
    """

    threshold: float = 6.0 * DEG
    count: int = 5


class ThresholdBias:
    """The hand-tracking paper's bias offset estimation (sec. 2.2, eq. 2), kept as the baseline.

    A new bias is the arithmetic mean of the last ``count`` consecutive samples whose
    rate is below ``threshold``; eq. 2 subtracts it: omega_B = omega_0 - b. Its
    weaknesses, which :class:`ContinuousBias` answers: a slow turn under the
    threshold is taken for bias, and a mean of five noisy samples is itself noisy
    (std sigma / sqrt(5)).
    """

    def __init__(self, params: ThresholdBiasParams | None = None,
                 bias: ArrayLike = (0.0, 0.0, 0.0)) -> None:
        self.params = params or ThresholdBiasParams()
        self._bias = _vec3(bias).copy()
        self._run: deque[Array] = deque(maxlen=self.params.count)

    @property
    def bias(self) -> Array:
        """The current estimate, rad/s (a copy)."""
        return self._bias.copy()

    def update(self, gyr: ArrayLike) -> Array:
        """Feed one sample; the bias-corrected rate (the hand-tracking paper, eq. 2)."""
        g = _vec3(gyr)
        if np.all(np.isfinite(g)) and np.linalg.norm(g) < self.params.threshold:
            self._run.append(g)
        else:
            self._run.clear()
        if len(self._run) == self.params.count:
            self._bias = np.mean(self._run, axis=0)
        return g - self._bias


# ----------------------------------------------------------------- six-pose accelerometer


POSE_LABELS = ("+x", "-x", "+y", "-y", "+z", "-z")  # which axis points up, in that order
_DIAGONAL = np.eye(3, dtype=bool)
_UPPER = np.triu(np.ones((3, 3), dtype=bool))


@mypyc_attr(native_class=False)  # a plain class even when compiled (README, "The compiled build")
@dataclass(frozen=True, eq=False)
class Pose:
    """One pose held still: accelerometer (N, 3) m/s^2 and gyroscope (N, 3) rad/s samples."""

    acc: Array
    gyr: Array

    def __post_init__(self) -> None:
        object.__setattr__(self, "acc", _rows(self.acc, "a pose's acc"))
        object.__setattr__(self, "gyr", _rows(self.gyr, "a pose's gyr"))

    @classmethod
    def from_samples(cls, samples: Sequence[RawSample]) -> "Pose":
        """A pose from the raw samples recorded while the user held it."""
        arrays = SampleArrays.from_samples(samples)
        return cls(arrays.acc, arrays.gyr)


@dataclass(frozen=True)
class PoseParams:
    """Settings of :func:`six_pose_calibration`.

    ``gravity``: the norm every calibrated pose should have, m/s^2. ``max_tilt``: an
    axis pose may lean this far (rad) from its axis. ``min_samples``: samples a pose
    needs. ``rest``: the stillness thresholds (see :func:`window_motion`).
    """

    gravity: float = GRAVITY
    max_tilt: float = 20.0 * DEG
    min_samples: int = 10
    rest: RestParams = field(default_factory=RestParams)


@dataclass(frozen=True, eq=False)
class SixPoseResult:
    """The outcome of :func:`six_pose_calibration`; ``message`` says what happened, for the user.

    The calibrated reading is ``misalignment @ (scale * (acc - offset))``; ``offset`` in
    m/s^2, ``scale`` unitless, ``misalignment`` 3x3 with unit diagonal (identity unless
    solved); ``residual`` is the RMS of |calibrated sample| - g over every sample of the
    poses, m/s^2 (the accelerometer's noise when the model fits and the poses were still). When ``ok`` is
    false the values are the identity calibration.
    """

    ok: bool
    message: str
    offset: Array
    scale: Array
    misalignment: Array
    residual: float


def pose_label(mean: Sequence[float] | Array) -> tuple[str, float]:
    """Which axis points up in a pose, and how far (rad) the pose leans from it (the first axis of the
    largest magnitude on a tie; a reading of no force at all leans 90 deg, from no face)."""
    x, y, z = float(mean[0]), float(mean[1]), float(mean[2])
    axis = 0 if abs(x) >= abs(y) and abs(x) >= abs(z) else 1 if abs(y) >= abs(z) else 2
    up, norm = (x, y, z)[axis], math.sqrt(x * x + y * y + z * z)
    if not norm > 0.0:
        return "+" + "xyz"[axis], math.pi / 2
    cos_tilt = abs(up) / norm
    return ("+" if up > 0 else "-") + "xyz"[axis], math.acos(min(1.0, cos_tilt))


def window_motion(gyr: Array, acc: Array, p: RestParams) -> str | None:
    """Why a window of samples is not still, or None.

    The window form of VQF's rest test: every sample must lie within the rest
    thresholds of the window's mean (the mean stands in for the low-pass).
    """
    dg = float(np.max(np.linalg.norm(gyr - gyr.mean(axis=0), axis=1)))
    da = float(np.max(np.linalg.norm(acc - acc.mean(axis=0), axis=1)))
    if dg >= p.gyr_threshold:
        return (f"the gyroscope strayed {dg / DEG:.1f} deg/s from its mean "
                f"(still means under {p.gyr_threshold / DEG:.1f} deg/s)")
    if da >= p.acc_threshold:
        return (f"the accelerometer strayed {da:.2f} m/s^2 from its mean "
                f"(still means under {p.acc_threshold:.2f} m/s^2)")
    return None


def _pose_problem(poses: Sequence[Pose], first: int, p: PoseParams) -> str | None:
    """Why a pose (numbered from ``first`` for the user) cannot be used, or None."""
    for number, pose in enumerate(poses, start=first):
        if len(pose.acc) < p.min_samples or len(pose.gyr) < p.min_samples:
            return f"pose {number} has too few samples; hold each pose for a second or two"
        if not (np.all(np.isfinite(pose.acc)) and np.all(np.isfinite(pose.gyr))):
            return f"pose {number} has missing or non-finite readings; record it again"
        moved = window_motion(pose.gyr, pose.acc, p.rest)
        if moved:
            return f"pose {number} was not still: {moved}; hold it still and record it again"
    return None


def _label_problem(means: Sequence[Array], p: PoseParams) -> str | None:
    """Why the axis poses are not one each of +x, -x, +y, -y, +z, -z (held flat), or None."""
    seen: dict[str, int] = {}
    for number, mean in enumerate(means, start=1):
        label, tilt = pose_label(mean)
        if tilt > p.max_tilt:
            return (f"pose {number} leans {tilt / DEG:.0f} deg from its nearest axis ({label} up); "
                    f"rest the board flat on one face (under {p.max_tilt / DEG:.0f} deg)")
        if label in seen:
            return (f"poses {seen[label]} and {number} both have {label} up; each axis must "
                    f"point up once and down once")
        seen[label] = number
    missing = [label for label in POSE_LABELS if label not in seen]
    if missing:
        return (f"pose{'s' if len(missing) > 1 else ''} with {', '.join(missing)} up "
                f"missing; six poses are needed, each axis up once and down once")
    return None


def _initial_guess(means: Sequence[Array], g: float) -> tuple[Array, Array]:
    """Offset and diagonal A from the classic six-position formulas.

    With u_i and d_i the axis-i readings with axis i up and down: offset_i =
    (u_i + d_i) / 2 and scale_i = 2 g / (u_i - d_i) (exact for level poses; the fit
    in :func:`_fit` removes the error that tilted poses leave).
    """
    by_label = {pose_label(m)[0]: m for m in means}
    up = np.array([by_label["+" + a][i] for i, a in enumerate("xyz")])
    down = np.array([by_label["-" + a][i] for i, a in enumerate("xyz")])
    return (up + down) / 2, np.diag(2 * g / (up - down))


def _residuals(a: Array, b: Array, A: Array, g: float,
               free: NDArray[np.bool_]) -> tuple[Array, Array]:
    """Residuals r_k = |A (a_k - b)| - g (Tedaldi 2014's cost, on norms) and their Jacobian.

    With d = a_k - b, v = A d and u = v / |v|: dr/db = -u^T A and dr/dA_ij = u_i d_j;
    the Jacobian's columns are b's three, then A's ``free`` entries in row order.
    """
    d = a - b
    v = d @ A.T
    n = np.linalg.norm(v, axis=1)
    u = v / n[:, None]
    jac_a = u[:, :, None] * d[:, None, :]
    return n - g, np.hstack([-(u @ A), jac_a[:, free]])


def _fit(a: Array, g: float, b: Array, A: Array,
         free: NDArray[np.bool_]) -> tuple[Array, Array, Array, Array]:
    """Gauss-Newton on sum_k (|A (a_k - b)| - g)^2 over b and A's ``free`` entries.

    Returns (b, A, residuals, Jacobian) at the solution.
    """
    for _ in range(50):
        r, jac = _residuals(a, b, A, g, free)
        step = np.linalg.lstsq(jac, -r, rcond=None)[0]
        b, A = b + step[:3], A.copy()
        A[free] += step[3:]
        if np.max(np.abs(step)) < 1e-12:
            break
    r, jac = _residuals(a, b, A, g, free)
    return b, A, r, jac


def _failed(message: str) -> SixPoseResult:
    return SixPoseResult(False, message, np.zeros(3), np.ones(3), np.eye(3), math.nan)


def six_pose_calibration(poses: Sequence[Pose], extra: Sequence[Pose] = (),
                         misalignment: bool = False,
                         params: PoseParams | None = None) -> SixPoseResult:
    """Accelerometer offset, scale and optional misalignment from still poses.

    ``poses``: six, each axis once up and once down, in any order (each is labelled
    by the axis its mean points along). The model (Tedaldi 2014) is
    ``a_true = A (a_raw - b)``; at rest |a_true| = g, so b and A minimise
    sum_k (|A (mean_k - b)| - g)^2 (:func:`_fit`, started from the six-position
    formulas of :func:`_initial_guess`). Without misalignment A is diagonal: six
    unknowns, solved exactly by six poses even when they lean a little. With
    ``misalignment=True`` A is upper triangular (the triangular form removes the
    rotation that the norm cannot see: the calibrated z axis follows the sensor's z
    axis and y stays in the sensor's y-z plane): nine unknowns, so ``extra`` must
    add at least three still poses in other orientations (tilted 45 deg, say).
    The triangular A is then turned to its symmetric polar factor P (A = Q P, Q a
    rotation: N. J. Higham, "Computing the polar decomposition - with applications",
    SIAM J. Sci. Stat. Comput. 7(4), 1986), the same norms in the frame nearest the
    sensor's axes: the triangular frame leans by as much as the skew, the symmetric one
    only by the skew's antisymmetric part, so a gyroscope calibrated in it
    (:mod:`tracker.gyro_scale`) keeps cross-axis terms near the data sheet's.
    A = misalignment @ diag(scale). Bad pose sets are refused with the reason: a
    pose missing, not still, leaning too far, or two poses the same.
    """
    p = params or PoseParams()
    problem = _pose_problem(poses, 1, p) or _pose_problem(extra, len(poses) + 1, p)
    means = [pose.acc.mean(axis=0) for pose in poses]
    problem = problem or _label_problem(means, p)
    if misalignment and not problem and len(extra) < 3:
        problem = (f"solving the misalignment needs at least 3 extra still poses in other "
                   f"orientations (got {len(extra)}); tilt the board about 45 deg for each")
    if problem:
        return _failed(problem)
    a = np.array(means + [pose.acc.mean(axis=0) for pose in extra])
    b, A = _initial_guess(means, p.gravity)
    b, A, r, jac = _fit(a, p.gravity, b, A, _UPPER if misalignment else _DIAGONAL)
    if np.linalg.matrix_rank(jac) < jac.shape[1]:
        return _failed("the extra poses do not pin down the misalignment; "
                       "tilt the board about different axes for them")
    if misalignment:
        u, sigma, vt = np.linalg.svd(A)
        A = (vt.T * sigma) @ vt  # the polar factor P = V S V^T of A = U S V^T
    scale = np.diag(A).copy()
    # Six poses fix six unknowns exactly, so the residual is judged on every sample the
    # poses held: the sensor's noise when the model fits and each pose was still.
    samples = np.vstack([pose.acc for pose in [*poses, *extra]])
    r = np.linalg.norm((samples - b) @ A.T, axis=1) - p.gravity
    residual = float(np.sqrt(np.mean(r ** 2)))
    return SixPoseResult(True, f"accelerometer offset ({', '.join(f'{x:+.3f}' for x in b)}) m/s^2, "
                         f"scale ({', '.join(f'{x:.4f}' for x in scale)}), residual "
                         f"{residual:.3f} m/s^2 over the {len(samples)} samples of {len(a)} poses",
                         b, scale, A / scale[None, :], residual)


# ----------------------------------------------------------------- board calibration


FORMAT = "energyball board calibration"
VERSION = 1
_BOARD_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,79}")
# The maker's procedures and the fields each fills (``armtracker calibrate accel|mag|thermal``, the game's
# Board setup); saving one keeps the other's fields. In the order they are shown.
PROCEDURES: dict[str, tuple[str, ...]] = {
    "accel": ("acc_offset", "acc_scale", "acc_misalignment", "gyro_scale", "acc_offset_ref_c", "pose_fields"),
    "mag": ("mag_hard_iron", "mag_soft_iron"),
    "thermal": ("gyro_thermal", "gyro_thermal_ref_c", "acc_thermal"),
}
PROCEDURE_TITLES: dict[str, str] = {"accel": "accelerometer", "mag": "magnetometer", "thermal": "warm-up drift"}
# Fields older files lack: they take their defaults.
_ADDED_LATER = ("gyro_thermal", "gyro_thermal_ref_c", "gyro_scale", "acc_thermal", "acc_offset_ref_c", "pose_fields")
POSE_ROWS = 16  # pose_fields' rows: the accelerometer procedure's poses it can keep (10 asked by default)
_FIGURE_NAME = re.compile(r"[a-z][a-z0-9_]{0,39}")
MAX_DAMAGED_COPIES = 20  # <name>.damaged, <name>.damaged.2, ... (then a save is refused)


@mypyc_attr(native_class=False)  # plain even when compiled: frozen, deep-copied with its owner
@dataclass(frozen=True)
class ProcedureRecord:
    """When a maker's procedure was done on a board, and what its fit said.

    ``name``: a key of :data:`PROCEDURES`. ``done_at``: the local time it was
    saved, ISO 8601 to the second with the UTC offset (``2025-03-01T14:03:09+01:00``).
    ``figures``: the fit's figures, each name ending in its unit (``residual_m_s2``;
    ``residual_ut``, ``strength_ut``, ``dip_deg``). A ValueError says what is wrong.
    """

    name: str
    done_at: str
    figures: tuple[tuple[str, float], ...] = ()

    def __post_init__(self) -> None:
        if self.name not in PROCEDURES:
            raise ValueError(f"unknown procedure {self.name!r} (known: {', '.join(PROCEDURES)})")
        if not isinstance(self.done_at, str) or _iso_time(self.done_at) is None:
            raise ValueError(f"{self.name}: done_at must be a date and time like 2025-03-01T14:03:09+01:00")
        for key, value in self.figures:
            if not _FIGURE_NAME.fullmatch(key) or key == "done_at":
                raise ValueError(f"{self.name}: {key!r} is not a figure's name")
            if not math.isfinite(value):
                raise ValueError(f"{self.name}: {key} must be a finite number")

    @classmethod
    def now(cls, name: str, figures: dict[str, float]) -> "ProcedureRecord":
        """A record of ``name`` done now (local time) with ``figures``."""
        done_at = datetime.now().astimezone().isoformat(timespec="seconds")
        return cls(name, done_at, tuple((k, float(v)) for k, v in figures.items()))

    @property
    def when(self) -> str:
        """``done_at`` as a person reads it: ``2025-03-01 14:03``."""
        t = _iso_time(self.done_at)
        return t.strftime("%Y-%m-%d %H:%M") if t is not None else self.done_at

    def to_json(self) -> dict:
        return {"done_at": self.done_at, **dict(self.figures)}

    @classmethod
    def from_json(cls, name: str, d: object) -> "ProcedureRecord":
        """Inverse of :meth:`to_json`; a ValueError naming what is wrong."""
        if not isinstance(d, dict) or not isinstance(d.get("done_at"), str):
            raise ValueError(f"procedures: {name} must be an object with done_at, a date and time")
        figures = [(k, v) for k, v in d.items() if k != "done_at"]
        for k, v in figures:
            if not isinstance(v, (int, float)) or isinstance(v, bool):
                raise ValueError(f"procedures: {name}: {k} must be a number")
        return cls(name, d["done_at"], tuple((str(k), float(v)) for k, v in figures))


def _iso_time(text: str) -> datetime | None:
    """The time ``text`` names in ISO 8601, None if it names none."""
    try:
        return datetime.fromisoformat(text)
    except ValueError:
        return None


class Corrected(NamedTuple):
    """Calibrated readings: ``acc`` m/s^2, ``gyr`` rad/s, ``mag`` uT or None.

    Arrays of shape (..., 3) from :meth:`BoardCalibration.apply_arrays`, 3-tuples of
    floats from :meth:`BoardCalibration.apply` (one sample; a named tuple is the
    cheapest record to make once per sample).
    """

    acc: Array | Vec
    gyr: Array | Vec
    mag: Array | Vec | None


@mypyc_attr(native_class=False)  # plain even when compiled: frozen, yet deep-copied with its owner
@dataclass(frozen=True)
class _PlainCalibration:
    """A :class:`BoardCalibration` as plain floats, for correcting one sample at a time.

    For three numbers numpy's per-call overhead costs far more than the arithmetic.
    A matrix is None where it is the identity, which then costs nothing.
    """

    gyro_bias: Vec
    acc_offset: Vec
    acc_scale: Vec
    acc_misalignment: Rows | None
    mag_hard_iron: Vec
    mag_soft_iron: Rows | None
    gyro_thermal: Vec | None  # None when there is no thermal calibration
    gyro_thermal_ref_c: float
    gyro_scale: Rows | None
    acc_thermal: Vec | None  # None unless both the slope and the offsets' temperature are known
    acc_offset_ref_c: float

    @classmethod
    def of(cls, cal: BoardCalibration) -> _PlainCalibration:
        """The plain-float copy of ``cal``'s arrays."""
        return cls(_floats(cal.gyro_bias), _floats(cal.acc_offset), _floats(cal.acc_scale),
                   _matrix(cal.acc_misalignment), _floats(cal.mag_hard_iron),
                   _matrix(cal.mag_soft_iron), _floats(cal.gyro_thermal) if cal.gyro_thermal_known else None,
                   float(cal.gyro_thermal_ref_c), _matrix(cal.gyro_scale),
                   _floats(cal.acc_thermal) if cal.acc_thermal_known else None, float(cal.acc_offset_ref_c))


def _floats(v: Array) -> Vec:
    """A 3-vector as a tuple of floats."""
    return (float(v[0]), float(v[1]), float(v[2]))


def _matrix(m: Array) -> Rows | None:
    """The rows of ``m`` as tuples of floats; None for the identity."""
    if np.array_equal(m, np.eye(3)):
        return None
    return (_floats(m[0]), _floats(m[1]), _floats(m[2]))


def _transform(m: Rows | None, x: float, y: float, z: float) -> Vec:
    """``m @ (x, y, z)``, with None standing for the identity."""
    if m is None:
        return (x, y, z)
    (a, b, c), (d, e, f), (g, h, i) = m
    return (a * x + b * y + c * z, d * x + e * y + f * z, g * x + h * y + i * z)


@mypyc_attr(native_class=False)  # a plain class even when compiled (README, "The compiled build")
@dataclass(frozen=True, eq=False)
class BoardCalibration:
    """Everything calibrated for one board; the defaults correct nothing.

    :meth:`apply_arrays` computes
        gyr_cal = gyro_scale @ (gyr - gyro_bias - gyro_thermal (T - gyro_thermal_ref_c))
                  (the hand-tracking paper, eq. 2, with the bias's linear temperature model of a thermal
                  calibration, :mod:`tracker.thermal`; T the die's temperature, the term left out
                  for a sample without one; gyro_scale the sensitivities the six-pose procedure's
                  turns measure, :mod:`tracker.gyro_scale`)
        acc_cal = acc_misalignment @ (acc_scale * (acc - acc_offset - acc_thermal (T - acc_offset_ref_c)))
                  (Tedaldi 2014, with the zero-g level's linear temperature model: the thermal
                  calibration's slope about the temperature the six-pose procedure measured the
                  offsets at; left out unless both are known and the sample has a temperature)
        mag_cal = mag_soft_iron @ (mag - mag_hard_iron)          (hard/soft iron)
    in rad/s, m/s^2 and uT. ``board_id`` names the board's file (see :func:`board_id_of`).
    ``procedures``: when each of the maker's procedures filled its fields
    (:data:`PROCEDURES`), at most one record each, in that order.
    Arrays are validated (shape, finite) on construction; a bad one is a ValueError.
    They are read-only, so that :meth:`apply`'s copy of them as floats stays true.
    """

    board_id: str = "default"
    gyro_bias: Array = field(default_factory=lambda: np.zeros(3))
    acc_offset: Array = field(default_factory=lambda: np.zeros(3))
    acc_scale: Array = field(default_factory=lambda: np.ones(3))
    acc_misalignment: Array = field(default_factory=lambda: np.eye(3))
    mag_hard_iron: Array = field(default_factory=lambda: np.zeros(3))
    mag_soft_iron: Array = field(default_factory=lambda: np.eye(3))
    gyro_thermal: Array = field(default_factory=lambda: np.zeros(3))  # rad/s per degC of the die
    gyro_thermal_ref_c: Array = field(default_factory=lambda: np.zeros(()))  # degC where it is zero
    gyro_scale: Array = field(default_factory=lambda: np.eye(3))  # true rate per reading (its diagonal fitted)
    acc_thermal: Array = field(default_factory=lambda: np.zeros(3))  # m/s^2 per degC: the zero-g level's slope
    acc_offset_ref_c: Array = field(default_factory=lambda: np.zeros(()))  # degC the offsets were measured
    # at (the six-pose procedure's poses); 0: not measured (a firmware without the TEMP frame)
    pose_fields: Array = field(default_factory=lambda: np.zeros((POSE_ROWS, 7)))  # the accelerometer procedure's
    # still poses, a row each: the magnetometer's mean raw reading (uT), gravity's calibrated direction, and 1
    # (0 in rows not used); the magnetometer's procedure turns its frame onto the accelerometer's from them
    # (tracker.mag_alignment). Not a correction: apply and apply_arrays leave it alone.
    procedures: tuple[ProcedureRecord, ...] = ()
    _plain: _PlainCalibration = field(init=False, repr=False)  # the arrays as floats, for apply

    def __post_init__(self) -> None:
        if not isinstance(self.board_id, str) or not _BOARD_ID.fullmatch(self.board_id):
            raise ValueError(f"board id {self.board_id!r} must be letters, digits, '.', '_' "
                             f"or '-' (see board_id_of)")
        for f in _array_fields():
            value = np.array(getattr(self, f.name), dtype=np.float64)
            factory = f.default_factory
            assert callable(factory)  # every array field has a default factory
            shape = np.shape(factory())
            if value.shape != shape or not np.all(np.isfinite(value)):
                raise ValueError(f"{f.name} must be {' x '.join(map(str, shape))} finite numbers")
            value.flags.writeable = False
            object.__setattr__(self, f.name, value)
        records = tuple(self.procedures)
        if not all(isinstance(r, ProcedureRecord) for r in records):
            raise ValueError("procedures must be ProcedureRecord values")
        names = [r.name for r in records]
        if len(set(names)) != len(names):
            raise ValueError("procedures: each procedure may be recorded once")
        in_order = tuple(r for name in PROCEDURES for r in records if r.name == name)  # (no closure:
        # mypyc cannot build a lambda in a non-native class's method)
        object.__setattr__(self, "procedures", in_order)
        object.__setattr__(self, "_plain", _PlainCalibration.of(self))

    @property
    def gyro_thermal_known(self) -> bool:
        """Whether a thermal calibration measured the gyroscope's warm-up: its bias slope, or (a record
        with zero slopes) that it is negligible (:mod:`tracker.thermal`)."""
        return bool(self.gyro_thermal.any()) or self.record("thermal") is not None

    @property
    def acc_offset_temperature_known(self) -> bool:
        """Whether the six-pose procedure knew the die's temperature (``acc_offset_ref_c`` 0: it did not)."""
        return float(self.acc_offset_ref_c) != 0.0

    @property
    def acc_thermal_known(self) -> bool:
        """Whether the accelerometer's offsets can follow the die's temperature: a thermal calibration
        measured their slope and the six-pose procedure the temperature they were measured at."""
        return bool(self.acc_thermal.any()) and self.acc_offset_temperature_known

    def record(self, name: str) -> ProcedureRecord | None:
        """When procedure ``name`` filled this board's fields; None if it never did."""
        return next((r for r in self.procedures if r.name == name), None)

    def with_procedure(self, fitted: "BoardCalibration", record: ProcedureRecord) -> "BoardCalibration":
        """This calibration with ``record``'s procedure's fields (:data:`PROCEDURES`) taken from
        ``fitted`` and its record replaced; every other field and record kept."""
        taken = {name: getattr(fitted, name) for name in PROCEDURES[record.name]}
        kept = tuple(r for r in self.procedures if r.name != record.name)
        return replace(self, procedures=kept + (record,), **taken)

    def apply_arrays(self, acc: ArrayLike, gyr: ArrayLike,
                     mag: ArrayLike | None = None, die_c: ArrayLike | None = None) -> Corrected:
        """Correct readings of shape (..., 3) (one sample or many; ``die_c`` (...) in degC, or None
        when the board sent no temperature); see the class doc."""
        a = np.asarray(acc, dtype=np.float64) - self.acc_offset
        if die_c is not None and self.acc_thermal_known:
            a = a - (np.asarray(die_c, dtype=np.float64)[..., None] - self.acc_offset_ref_c) * self.acc_thermal
        a = a * self.acc_scale
        m = None if mag is None else \
            (np.asarray(mag, dtype=np.float64) - self.mag_hard_iron) @ self.mag_soft_iron.T
        g = np.asarray(gyr, dtype=np.float64) - self.gyro_bias
        if die_c is not None:
            g = g - (np.asarray(die_c, dtype=np.float64)[..., None] - self.gyro_thermal_ref_c) * self.gyro_thermal
        return Corrected(a @ self.acc_misalignment.T, g @ self.gyro_scale.T, m)

    def apply(self, sample: RawSample) -> Corrected:
        """Correct one raw sample (its SI readings): :meth:`apply_arrays` on plain floats."""
        c = self._plain
        (ax, ay, az), (gx, gy, gz), mag = sample.acc, sample.gyr, sample.mag
        (ox, oy, oz), (sx, sy, sz), (bx, by, bz) = c.acc_offset, c.acc_scale, c.gyro_bias
        if sample.temp_counts is not None and (c.gyro_thermal is not None or c.acc_thermal is not None):
            die = temp_c(sample.temp_counts)
            if c.gyro_thermal is not None:
                dt = die - c.gyro_thermal_ref_c
                bx, by, bz = bx + c.gyro_thermal[0] * dt, by + c.gyro_thermal[1] * dt, bz + c.gyro_thermal[2] * dt
            if c.acc_thermal is not None:
                dt = die - c.acc_offset_ref_c
                ox, oy, oz = ox + c.acc_thermal[0] * dt, oy + c.acc_thermal[1] * dt, oz + c.acc_thermal[2] * dt
        acc = _transform(c.acc_misalignment, (ax - ox) * sx, (ay - oy) * sy, (az - oz) * sz)
        if mag is not None:
            (mx, my, mz), (hx, hy, hz) = mag, c.mag_hard_iron
            mag = _transform(c.mag_soft_iron, mx - hx, my - hy, mz - hz)
        return Corrected(acc, _transform(c.gyro_scale, gx - bx, gy - by, gz - bz), mag)

    def to_json(self) -> dict:
        """JSON-ready fields, with the file format and version."""
        return {"format": FORMAT, "version": VERSION, "board_id": self.board_id,
                **{f.name: getattr(self, f.name).tolist() for f in _array_fields()},
                "procedures": {r.name: r.to_json() for r in self.procedures}}

    @classmethod
    def from_json(cls, d: object) -> "BoardCalibration":
        """Inverse of :meth:`to_json`; a ValueError that says what is wrong."""
        if not isinstance(d, dict) or d.get("format") != FORMAT:
            raise ValueError("it is not an EnergyBall board calibration")
        if d.get("version") != VERSION:
            raise ValueError(f"it has format version {d.get('version')!r}, and this program "
                             f"reads version {VERSION}")
        defaults = {n: getattr(cls(), n).tolist() for n in _ADDED_LATER if n not in d}
        d = {**d, **defaults}
        names = ["board_id"] + [f.name for f in _array_fields()]
        missing = [n for n in names if n not in d]
        if missing:
            raise ValueError(f"it lacks {', '.join(missing)}")
        for n in names[1:]:
            if not _plain_numbers(d[n]):
                raise ValueError(f"{n} must be a list of numbers (or of lists of numbers)")
        try:
            return cls(**{n: d[n] for n in names}, procedures=_records(d.get("procedures", {})))
        except (TypeError, ValueError) as e:
            raise ValueError(str(e)) from None


def _records(d: object) -> tuple[ProcedureRecord, ...]:
    """The file's ``procedures`` object (absent in files saved before the procedures were recorded)."""
    if not isinstance(d, dict):
        raise ValueError(f"procedures must be an object of {' and '.join(PROCEDURES)}")
    return tuple(ProcedureRecord.from_json(str(name), value) for name, value in d.items())


def _plain_numbers(value: object) -> bool:
    """A number, a list of numbers or of lists of numbers, as :meth:`BoardCalibration.to_json` writes:
    no text, no true/false (which numpy would take for numbers)."""
    if not isinstance(value, list):
        value = [value]
    items: list[object] = []
    for v in value:
        items.extend(v if isinstance(v, list) else [v])
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in items)


def _array_fields() -> list[Field]:
    """BoardCalibration's array fields (the settings but board_id and procedures); each default
    gives its shape."""
    return [f for f in fields(BoardCalibration) if f.init and f.name not in ("board_id", "procedures")]


class CalibrationFileError(Exception):
    """A board calibration file that cannot be read or written, worded for the user.

    ``missing``: there is no file at all (nothing saved yet), as opposed to one
    that exists and cannot be used.
    """

    def __init__(self, path: Path, problem: str, missing: bool = False) -> None:
        super().__init__(f"board calibration {path}: {problem}")
        self.path = path
        self.missing = missing


def board_id_of(hello: Hello, virtual: bool = False) -> str:
    """The board's id, the name of its calibration file, from its HELLO: ``imu-71`` for an MPU-9250.

    A HELLO carries the protocol and firmware versions, the IMU's WHO_AM_I, the
    magnetometer's WIA, settings and error flags (PROTOCOL.md sec. 5.1); no serial
    number. What the calibration describes is the sensor chip, so the id is the
    IMU's WHO_AM_I alone: a new firmware keeps the calibration (raw samples are SI
    units whatever the firmware), and a magnetometer that fails to answer at one
    power-up (``mag_whoami`` 0, MAG_MISSING) does not hide the accelerometer's.
    The AK8963 lives in the MPU-9250's package, so the IMU's id names it too.
    Two boards of the same make therefore share one file: a maker who swaps
    boards calibrates again. The virtual board (``virtual``) sends the real
    firmware's HELLO; its file is ``virtual-imu-71``, so that calibrating or
    playing it never touches a real board's.
    """
    return ("virtual-" if virtual else "") + f"imu-{hello.imu_whoami:02x}"


def boards_dir() -> Path:
    """The per-user folder of board files: $XDG_CONFIG_HOME/energyball/boards (~/.config/...)."""
    base = os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config"
    return Path(base) / "energyball" / "boards"


def calibration_path(board_id: str, directory: str | os.PathLike | None = None) -> Path:
    """Where a board's calibration lives: ``<directory or boards_dir()>/<board_id>.json``."""
    if not _BOARD_ID.fullmatch(board_id):
        raise ValueError(f"board id {board_id!r} must be letters, digits, '.', '_' or '-'")
    return Path(directory if directory is not None else boards_dir()) / f"{board_id}.json"


def save(cal: BoardCalibration, directory: str | os.PathLike | None = None) -> Path:
    """Write a board's calibration atomically (tracker.atomic); the path written."""
    path = calibration_path(cal.board_id, directory)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(path, json.dumps(cal.to_json(), indent=2) + "\n")
    except OSError as e:
        raise CalibrationFileError(path, f"cannot write it: {e.strerror or e}") from None
    return path


def _read_json(path: Path) -> object:
    """The file's JSON, read with tracker.userjson's limits; CalibrationFileError otherwise."""
    try:
        return read_json(path)
    except FileNotFoundError:
        raise CalibrationFileError(path, "no calibration saved for this board yet (armtracker calibrate "
                                   "accel, then calibrate mag)", missing=True) from None
    except JSONInputError as e:
        raise CalibrationFileError(path, f"it is damaged ({e.problem}); delete it or calibrate again") \
            from None
    except OSError as e:
        raise CalibrationFileError(path, f"cannot read it: {e.strerror or e}") from None


def load(board_id: str, directory: str | os.PathLike | None = None) -> BoardCalibration:
    """Read a board's calibration; :class:`CalibrationFileError` says what is wrong."""
    path = calibration_path(board_id, directory)
    try:
        cal = BoardCalibration.from_json(_read_json(path))
    except ValueError as e:
        raise CalibrationFileError(path, f"{e}; delete it or calibrate again") from None
    if cal.board_id != board_id:
        raise CalibrationFileError(path, f"it holds board {cal.board_id!r}, not {board_id!r}")
    return cal


def done_text(cal: BoardCalibration) -> str:
    """Which procedures filled ``cal`` and when: ``accelerometer 2025-03-01 14:03, magnetometer not calibrated``."""
    return ", ".join(f"{PROCEDURE_TITLES[name]} {r.when}" if (r := cal.record(name)) else
                     f"{PROCEDURE_TITLES[name]} not calibrated" for name in PROCEDURES)


def load_or_default(board_id: str, directory: str | os.PathLike | None = None
                    ) -> tuple[BoardCalibration, str]:
    """A board's calibration and a notice for the user; the defaults when it cannot be loaded."""
    try:
        cal = load(board_id, directory)
    except CalibrationFileError as e:
        return BoardCalibration(board_id), f"{e}; using the default calibration"
    return cal, f"board calibration loaded from {calibration_path(board_id, directory)} ({done_text(cal)})"


def load_for_hello(hello: Hello | None, directory: str | os.PathLike | None = None, virtual: bool = False
                   ) -> tuple[BoardCalibration, str]:
    """The calibration saved for the board that sent ``hello`` (:func:`board_id_of`; ``virtual`` for the
    virtual board) and a one-line
    notice saying what was loaded, or why the defaults are used (no file, a damaged one, a board
    that did not identify itself). Never raises and never writes: for ``armtracker monitor`` and
    the game. ``cal.procedures`` is empty when no procedure was ever saved for the board."""
    if hello is None:
        return BoardCalibration(), ("the board did not identify itself (no HELLO: not the EnergyBall "
                                    "firmware?); using the default calibration")
    return load_or_default(board_id_of(hello, virtual), directory)


def _keep_damaged(path: Path) -> Path | None:
    """Before ``path`` is replaced: copy it to ``<name>.damaged`` (``.damaged.2``, ... when that name
    holds another copy); the copy's path (None when there is no file). An identical copy already
    beside it is reused. :class:`CalibrationFileError` when it cannot be copied: then it must not
    be replaced."""
    try:
        if not stat.S_ISREG(path.stat().st_mode):
            raise CalibrationFileError(path, "it is not a regular file; it is left as it is")
        data = path.read_bytes()
    except FileNotFoundError:
        return None
    except OSError as e:
        raise CalibrationFileError(path, f"cannot keep a copy of it ({e.strerror or e}); "
                                   f"it is left as it is") from None
    for n in range(1, MAX_DAMAGED_COPIES + 1):
        copy_path = path.with_name(f"{path.name}.damaged" + (f".{n}" if n > 1 else ""))
        try:
            if copy_path.read_bytes() == data:
                return copy_path
        except FileNotFoundError:
            try:
                atomic_write(copy_path, data)
            except OSError as e:
                raise CalibrationFileError(path, f"cannot keep a copy of it as {copy_path.name} "
                                           f"({e.strerror or e}); it is left as it is") from None
            return copy_path
        except OSError:
            continue  # that name is unusable (a folder, say): try the next
    raise CalibrationFileError(path, f"it is damaged and {MAX_DAMAGED_COPIES} damaged copies lie beside "
                               f"it already; it is left as it is")


def damage(board_id: str, directory: str | os.PathLike | None = None) -> str:
    """Why the board's existing file cannot be used ("" when it loads or there is none): what a
    procedure says before it starts, since saving will replace that file (keeping a copy)."""
    try:
        load(board_id, directory)
    except CalibrationFileError as e:
        return "" if e.missing else str(e)
    return ""


def save_procedure(board_id: str, fitted: BoardCalibration, record: ProcedureRecord,
                   directory: str | os.PathLike | None = None) -> tuple[Path, Path | None]:
    """Save procedure ``record.name``'s fields from ``fitted`` in the board's file, atomically.

    The file is read again now, so that what another procedure saved meanwhile
    (the other command, the game's Board setup) is kept: its fields, its record
    and the gyroscope bias. A file that exists but cannot be used is first copied
    to ``<name>.damaged`` (:func:`_keep_damaged`) and then replaced by the
    defaults with this procedure's fields. Returns the path written and the
    damaged copy's path (or None). :class:`CalibrationFileError` when nothing
    could be written; then nothing was.
    """
    path = calibration_path(board_id, directory)
    copied = None
    try:
        base = load(board_id, directory)
    except CalibrationFileError as e:
        if not e.missing:
            copied = _keep_damaged(path)
        base = BoardCalibration(board_id)
    return save(base.with_procedure(fitted, record), directory), copied


def saved_boards(directory: str | os.PathLike | None = None
                 ) -> list[BoardCalibration | CalibrationFileError]:
    """Every board file in the folder (``<id>.json``), by id: its calibration, or why it cannot be read."""
    folder = Path(directory if directory is not None else boards_dir())
    try:
        names = sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".json"))
    except FileNotFoundError:
        return []
    except OSError as e:
        raise CalibrationFileError(folder, f"cannot list the folder: {e.strerror or e}") from None
    out: list[BoardCalibration | CalibrationFileError] = []
    for name in names:
        if not _BOARD_ID.fullmatch(name):
            continue  # not one of ours: no board id makes that name
        try:
            out.append(load(name, folder))
        except CalibrationFileError as e:
            out.append(e)
    return out
