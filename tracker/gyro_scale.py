"""The gyroscope's sensitivity matrix, from the turns between the accelerometer calibration's poses.

Why. The MPU-9250's gyroscope reads within +-3 % of its nominal sensitivity,
and each axis reads up to +-2 % of the rates about the other two
(PS-MPU-9250A-01, table 1): 3 % of a 60 deg swing of the arm is 1.8 deg of
aim, 2 % of it 1.2 deg about another axis, made again at every swing until
the magnetometer or gravity pulls it back, and never pulled back about the
vertical without a usable field. A turntable measures it; a maker has none,
but the accelerometer's procedure (:mod:`tracker.accel_procedure`) turns the
board from pose to pose by 45 to 180 deg, and between two still poses
gravity says how far it turned.

How. Between two captured poses i and j the procedure keeps the gyroscope's
rates; at j it takes the bias as moving linearly from pose i's mean rate to
pose j's (the board is still on a face, so its mean rate is the bias there;
the warm-up moves it meanwhile) and integrates the corrected rates sample by
sample into the turn R0 (trapezoidal rates, each step's exact rotation, so a
tip followed by a turn on the table is composed as it happened, not summed).
The true rate is M = I + D times the reading: D holds the sensitivities'
errors on its diagonal (+-3 %, table 1) and off it the cross-axis
sensitivities (+-2 %, the same table), which also turn the gyroscope's frame
against the accelerometer's. Each step then turns by a further D dtheta,
which the rest of the turn carries to its end: E(D) = sum over the steps of
R_after^T D dtheta, linear in D's nine entries (entry ij contributes
sum R_after^T e_i dtheta_j), so that the true turn is R0 exp(E(D)) to first
order in D (a few percent: the second order is below 0.1 % of the
sensitivity). Gravity, fixed in the room, turns in the board's frame as
g_j = R^T g_i (Sola, "Quaternion kinematics for the error-state Kalman
filter", 2017, sec. 4.3, the right perturbation and its transport), so each
turn gives two equations in D (a direction). The procedure's nine or more
turns (six faces and the leaning poses, :mod:`tracker.accel_procedure`) give
eighteen or more for the nine entries, which Gauss-Newton fits from D = 0
with the data sheets' tolerances as a prior: each entry a Gaussian of the
standard deviation of a uniform draw within its tolerance (bound / sqrt 3),
each direction's misfit one of ``direction_noise_deg``. The matrix maps the
gyroscope into the accelerometer's calibrated frame, which its own cross-axis
terms turn from the sensor's by their antisymmetric part (up to 2 %, table
2; :func:`tracker.calibration.six_pose_calibration`'s symmetric frame): an
off-diagonal entry is the sum of the two, its prior the sum's spread
(variances 0.02^2 / 3 and 0.02^2 / 6) and its bound 4 %. A maximum a
posteriori fit (Bishop, "Pattern Recognition and Machine Learning", 2006,
sec. 3.3: the prior as added rows of the least squares) keeps a combination
the turns barely see near the data sheet's zero instead of fitting it to
noise. The turns about the vertical (the new heading the maker gives the
board) are not seen by gravity and need not be: they enter R0 and E alike.

A fit with fewer than ``min_turns`` linked turns, whose residual is beyond
``max_residual_deg`` (a turn that was not about one axis, the board bumped
between the poses), or with an entry beyond its bound by a quarter
again (``max_over_tolerance``: with few turns a bump hides in the
cross-axis terms rather than in the residual) is refused: the matrix stays
the identity, and the accelerometer calibration is kept either way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from . import quat

Array = NDArray[np.float64]


@dataclass(frozen=True)
class SensitivityParams:
    """Settings of :func:`fit_sensitivity` (module docstring)."""

    min_turns: int = 3
    max_residual_deg: float = 1.0  # a still pose's gravity is known to 0.01 deg: 1 deg is a turn gone wrong
    scale_tolerance: float = 0.03  # the prior: D's diagonal within +-this (PS-MPU-9250A-01, table 1)
    cross_axis_tolerance: float = 0.02  # ... and its off-diagonals within +-this (the same table)
    frame_tolerance: float = 0.02  # ... plus the accelerometer's frame's turn, its own cross-axis (table 2)
    direction_noise_deg: float = 0.05  # one direction's misfit: the pose's noise and the turn's integrated noise
    max_over_tolerance: float = 1.25  # an entry beyond its bound by a quarter again is a turn gone wrong
    iterations: int = 10
    max_turn_samples: int = 12_000  # a minute at 200 Hz: a longer wait between two poses links no turn


@dataclass(frozen=True)
class Turn:
    """One turn between two poses (module docstring): ``rotation`` R0 (3 x 3, the end in the start's
    frame), ``jacobian`` E (3 x 3 x 3: [:, i, j] the end's rotation per unit of D_ij), gravity's unit
    direction ``before`` and ``after`` (raw: :meth:`tracker.accel_procedure.AccelProcedure.gyro_fit`
    calibrates them)."""

    rotation: Array
    jacobian: Array
    before: Array
    after: Array


def integrate_turn(t: Array, gyr: Array, bias0: Array, bias1: Array) -> tuple[Array, Array]:
    """R0 and E (:class:`Turn`) of the rates ``gyr`` (N, 3) at times ``t``, the bias moving linearly from
    ``bias0`` at t[0] to ``bias1`` at t[-1].

    With T_k each step's rotation and R_k = T_1 ... T_k the turn so far, R0 = R_N, and the
    steps' sum E[:, i, j] = sum_k (T_k+1 ... T_N)^T J_k e_i dtheta_kj (module docstring) is
    R_N^T sum_k (R_k J_k)[:, i] dtheta_kj, since T_k+1 ... T_N = R_k^T R_N: every R_k at once
    (:func:`_running_products`), no loop over the steps. J_k = I - [dtheta_k]x / 2 is the
    right Jacobian of SO(3) to first order in the step (Sola, Deray and Atchuthan, "A micro
    Lie theory for state estimation in robotics", 2018, app. B): exp(theta + delta) =
    exp(theta) exp(J delta), which a perturbation off the step's own axis (a cross-axis
    term's) needs and one along it (a sensitivity's) does not.
    """
    span = t[-1] - t[0]
    share = (t - t[0]) / span if span > 0 else np.zeros_like(t)
    rates = gyr - (bias0 + share[:, None] * (bias1 - bias0))
    steps = 0.5 * (rates[1:] + rates[:-1]) * np.diff(t)[:, None]
    if len(steps) == 0:
        return np.eye(3), np.zeros((3, 3, 3))
    so_far = _running_products(quat.to_matrix(quat.from_rotvec(steps)))
    rotation = so_far[-1]
    x, y, z, zero = steps[:, 0], steps[:, 1], steps[:, 2], np.zeros(len(steps))
    skew = np.stack([zero, -z, y, z, zero, -x, -y, x, zero], axis=1).reshape(-1, 3, 3)
    return rotation, np.einsum("ab,kai,kj->bij", rotation, so_far - 0.5 * so_far @ skew, steps)


def _running_products(m: Array) -> Array:
    """M_1 M_2 ... M_k for every k (an inclusive scan of ``m`` (N, 3, 3) in log2 N batched products:
    W. D. Hillis and G. L. Steele, "Data parallel algorithms", CACM 29(12), 1986)."""
    out, shift = m.copy(), 1
    while shift < len(out):
        out[shift:] = out[:-shift] @ out[shift:]
        shift *= 2
    return out


@dataclass(frozen=True)
class SensitivityFit:
    """``matrix`` M (true rate = M (reading - bias)), the directions' RMS misfit, the turns used, and
    why the fit was refused ("" when it was not; then ``matrix`` is the identity)."""

    matrix: Array = field(default_factory=lambda: np.eye(3))
    residual_deg: float = 0.0
    turns: int = 0
    problem: str = ""

    @property
    def ok(self) -> bool:
        return not self.problem


def rotate_back(theta: Array, u: Array) -> Array:
    """R(theta)^T u for rotation vectors ``theta`` (N, 3) and vectors ``u`` (N, 3), by Rodrigues' formula:
    a direction fixed in the room, seen from a board that turned by theta."""
    angle = np.linalg.norm(theta, axis=1, keepdims=True)
    k = np.divide(theta, angle, out=np.zeros_like(theta), where=angle > 0)
    cos, sin = np.cos(angle), np.sin(angle)
    return u * cos - np.cross(k, u) * sin + k * np.sum(k * u, axis=1, keepdims=True) * (1 - cos)


def fit_sensitivity(turns: list[Turn], params: SensitivityParams = SensitivityParams()) -> SensitivityFit:
    """The sensitivity matrix from the ``turns`` (module docstring); refused below the params' bounds."""
    n = len(turns)
    if n < params.min_turns:
        return SensitivityFit(turns=n, problem=f"only {n} turns between poses (the gyroscope's fit needs "
                                               f"{params.min_turns})")
    seen = np.array([tr.rotation.T @ tr.before for tr in turns])  # gravity where R0 alone puts it
    after = np.array([tr.after for tr in turns])
    jac = np.array([tr.jacobian.reshape(3, 9) for tr in turns])  # D's entries row by row
    noise = math.radians(params.direction_noise_deg)
    diagonal = np.eye(3).ravel() > 0
    prior = np.where(diagonal, params.scale_tolerance / math.sqrt(3.0),
                     math.sqrt(params.cross_axis_tolerance**2 / 3.0 + params.frame_tolerance**2 / 6.0))
    bound = np.where(diagonal, params.scale_tolerance, params.cross_axis_tolerance + params.frame_tolerance)

    def residuals(d: Array) -> Array:
        return (after - rotate_back(jac @ d, seen)).ravel()

    d = np.zeros(9)
    for _ in range(params.iterations):
        r = residuals(d)
        step = np.column_stack([(residuals(d + e) - r) / 1e-7 for e in np.eye(9) * 1e-7])
        delta = np.linalg.lstsq(np.vstack([step / noise, np.diag(1.0 / prior)]),
                                np.concatenate([-r / noise, -d / prior]), rcond=None)[0]
        d = d + delta
        if np.max(np.abs(delta)) < 1e-10:
            break
    rms = math.degrees(float(np.sqrt(np.mean(residuals(d) ** 2) * 3.0)))  # each direction's misfit, as an angle
    if rms > params.max_residual_deg:
        return SensitivityFit(residual_deg=rms, turns=n, problem=(
            f"the turns between the poses misfit the gyroscope by {rms:.2f} deg (at most "
            f"{params.max_residual_deg:g}): was the board bumped between two poses?"))
    beyond = np.abs(d) / bound  # each entry over its bound
    if np.max(beyond) > params.max_over_tolerance:
        worst = int(np.argmax(beyond))
        return SensitivityFit(residual_deg=rms, turns=n, problem=(
            f"the turns ask for a gyroscope entry {worst // 3}{worst % 3} of {d[worst] * 100:+.1f} % (the data "
            f"sheets allow {bound[worst] * 100:g}): was the board bumped between two poses?"))
    return SensitivityFit(np.eye(3) + d.reshape(3, 3), rms, n)
