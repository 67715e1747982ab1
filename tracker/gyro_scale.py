"""The gyroscope's sensitivities, from the turns between the six-pose calibration's faces.

Why. The MPU-9250's gyroscope reads within +-3 % of its nominal sensitivity
(PS-MPU-9250A-01, table 1): 3 % of a 60 deg swing of the arm is 1.8 deg of
aim, made again at every swing until the magnetometer or gravity pulls it
back, and never pulled back about the vertical without a usable field. A
turntable measures it; a maker has none, but the six-pose procedure
(:mod:`tracker.accel_procedure`) turns the board from face to face by 90 and
180 deg, and between two still poses gravity says how far it turned.

How. Between two captured poses i and j the procedure keeps the gyroscope's
rates; at j it takes the bias as moving linearly from pose i's mean rate to
pose j's (the board is still on a face, so its mean rate is the bias there;
the warm-up moves it meanwhile) and integrates the corrected rates sample by
sample into the turn R0 (trapezoidal rates, each step's exact rotation, so a
tip followed by a turn on the table is composed as it happened, not summed).
Where the true rates are 1 + d_x, 1 + d_y, 1 + d_z times the readings, each
step turns by a further diag(d) dtheta, which the rest of the turn carries
to its end: E = sum over the steps of R_after^T diag(dtheta), so that the true
turn is R0 exp(E d) to first order in d (a few percent: the second order is
below 0.1 % of the sensitivity). Gravity, fixed in the room, turns in the
board's frame as g_j = R^T g_i (Sola, "Quaternion kinematics for the
error-state Kalman filter", 2017, sec. 4.3, the right perturbation and its
transport), so each turn gives two equations in d (a direction) and the five
or more turns of the procedure ten or more for the three, which Gauss-Newton
fits from d = 0. The turns about the vertical (the new heading the maker
gives the board) are not seen by gravity and need not be: they enter R0 and
E alike. The cross-axis terms (up to +-2 %, the same table) are not fitted:
five directions hold the diagonal well, the nine entries poorly.

A fit with fewer than ``min_turns`` linked turns, or whose residual is beyond
``max_residual_deg`` (a turn that was not about one axis, the board bumped
between the poses), is refused: the sensitivities stay 1, and the accelerometer
calibration is kept either way.
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
    iterations: int = 10
    max_turn_samples: int = 12_000  # a minute at 200 Hz: a longer wait between two poses links no turn


@dataclass(frozen=True)
class Turn:
    """One turn between two poses (module docstring): ``rotation`` R0 (3 x 3, the end in the start's
    frame), ``jacobian`` E (3 x 3: column i the end's rotation per unit of d_i), gravity's unit
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
    steps' sum E = sum_k (T_k+1 ... T_N)^T diag(dtheta_k) (module docstring) is
    R_N^T sum_k R_k diag(dtheta_k), since T_k+1 ... T_N = R_k^T R_N: every R_k at once
    (:func:`_running_products`), no loop over the steps.
    """
    span = t[-1] - t[0]
    share = (t - t[0]) / span if span > 0 else np.zeros_like(t)
    rates = gyr - (bias0 + share[:, None] * (bias1 - bias0))
    steps = 0.5 * (rates[1:] + rates[:-1]) * np.diff(t)[:, None]
    if len(steps) == 0:
        return np.eye(3), np.zeros((3, 3))
    so_far = _running_products(quat.to_matrix(quat.from_rotvec(steps)))
    rotation = so_far[-1]
    return rotation, rotation.T @ (so_far * steps[:, None, :]).sum(axis=0)


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
    """``scale`` (true rate = scale x (reading - bias), per axis), the directions' RMS misfit, the turns
    used, and why the fit was refused ("" when it was not; then ``scale`` is 1)."""

    scale: Array = field(default_factory=lambda: np.ones(3))
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
    """The three sensitivities from the ``turns`` (module docstring); refused below the params' bounds."""
    n = len(turns)
    if n < params.min_turns:
        return SensitivityFit(turns=n, problem=f"only {n} turns between poses (the gyroscope's fit needs "
                                               f"{params.min_turns})")
    seen = np.array([tr.rotation.T @ tr.before for tr in turns])  # gravity where R0 alone puts it
    after = np.array([tr.after for tr in turns])
    jac = np.array([tr.jacobian for tr in turns])

    def residuals(d: Array) -> Array:
        return (after - rotate_back(jac @ d, seen)).ravel()

    d = np.zeros(3)
    for _ in range(params.iterations):
        r = residuals(d)
        step = np.column_stack([(residuals(d + e) - r) / 1e-7 for e in np.eye(3) * 1e-7])
        delta = np.linalg.lstsq(step, -r, rcond=None)[0]
        d = d + delta
        if np.max(np.abs(delta)) < 1e-10:
            break
    rms = math.degrees(float(np.sqrt(np.mean(residuals(d) ** 2) * 3.0)))  # each direction's misfit, as an angle
    if rms > params.max_residual_deg or not np.all(np.abs(d) < 0.2):
        return SensitivityFit(residual_deg=rms, turns=n, problem=(
            f"the turns between the poses misfit the gyroscope by {rms:.2f} deg (at most "
            f"{params.max_residual_deg:g}): was the board bumped between two poses?"))
    return SensitivityFit(1.0 + d, rms, n)
