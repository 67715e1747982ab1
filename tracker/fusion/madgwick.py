"""Madgwick's gradient-descent orientation filter, IMU and MARG forms, in ENU.

References:

- [M10] S. Madgwick, "An efficient orientation filter for inertial and
  inertial/magnetic sensor arrays", internal report, University of Bristol, 2010:
  sec. 3.1 (orientation from angular rate), sec. 3.2 (orientation from vector
  observations: objective function, Jacobian, gradient descent), sec. 3.3 (fusion:
  the normalised gradient scaled by beta), sec. 3.4 (magnetic distortion
  compensation: the reference field rebuilt from the measurement).
- [M11] S. Madgwick, A. Harrison, R. Vaidyanathan, "Estimation of IMU and MARG
  orientation using a gradient descent algorithm", ICORR 2011 (the same filter).
- Inertial Sensor Based Solution for Finger Motion Tracking (Computers 9(2):40,
  2020; ``/work/shared/papers/003_*.txt``), sec. 2.3, which restates the filter: eq.
  (9) q_dot = 1/2 q (x) omega, eq. (11) the objective function, eq. (18) q_dot =
  q_dot_omega - beta grad/|grad|, eqs. (15) and (19) the Euler step and the
  renormalisation. (The text copy drops equation labels; the finger-tracking paper's
  numbers here and in :mod:`.switching`/:mod:`.hinge` follow its own
  cross-references. [M10] is cited by section only.)
Convention. Madgwick's quaternion ``S_E q`` satisfies ``v_S = q* (x) v_E (x) q``, so
it is numerically our ``q_WS`` (``v_W = q v_S q*``); no conversion is needed.

Frame. Madgwick writes the earth field as ``b = (0, b_x, 0, b_z)``: his earth x axis
is magnetic north and z is up (NWU-like). Our world is ENU (x east, y north, z up),
so the objective functions here are derived for ENU directly: the gravity
reference is up, ``(0, 0, 1)`` (the normalised accelerometer reads +1 on the up
axis at rest), and the field reference is ``b = (0, b_y, b_z)`` with the
horizontal component along north = y. Rather than one hand-expanded Jacobian per
reference, :func:`gradient` evaluates ``J^T f`` for any reference direction ``d``
in closed form ([M10] sec. 3.2 gives the general ``f(q, d, s)`` and ``J(q, d)``
before specialising them): with ``q = (w, u)``,

    f(q, d, s) = q* d q - s = d + 2 w (d x u) + 2 (u . d) u - 2 |u|^2 d - s
    J^T f      = ( 2 f . (d x u),
                   2 [ w (f x d) + (u . d) f + (u . f) d - 2 (f . d) u ] )

which, for ``d = (0, 0, 1)``, expands to Madgwick's gravity Jacobian term by term
(the tests check it against finite differences). The reusable pieces
(:func:`gradient`, :func:`descend`, :func:`heading_reference`, :func:`level`)
serve :mod:`.hinge` and :mod:`.switching` too; the vector and quaternion helpers
(:func:`.qmath.unit`, :func:`.qmath.add`, :func:`.qmath.between`,
:func:`.qmath.align_heading`) are shared with the other filters.

Fast start: on the first sample with a usable accelerometer the estimate is set
straight from the measurement, not converged to at beta rad/s: the inclination
from gravity (:func:`level`) and, with a magnetometer, the heading that points the
horizontal field north (:func:`.qmath.align_heading`). Without a magnetometer the
heading starts at the shortest rotation from the sensor frame (arbitrary, as in
any 6D filter).

Timing: as published, the gradient is taken at the previous estimate against the
current measurement, so during a turn the correction pulls towards a vector up to
one sample's rotation ahead: with exact data the estimate leads the truth by up to
``|omega| dt`` (plus the ``2 beta dt`` chatter of the normalised step). Taking
the gradient after the gyro step instead scored no better on BROAD at 286 Hz.

Not implemented: [M10] sec. 3.5's gyroscope bias drift compensation (the tracker
calibrates the bias at rest upstream).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from . import qmath as Q
from .base import Filter
from .qmath import Quat, Vec

UP: Vec = Q.UP  # the gravity reference, ENU (module docstring)
NORTH: Vec = Q.NORTH  # the horizontal direction of the field reference b
ZERO_QUAT: Quat = (0.0, 0.0, 0.0, 0.0)


def gradient(q: Quat, ref: Vec, meas: Vec) -> Quat:
    """``J^T f`` for the objective ``f = q* ref q - meas`` ([M10] sec. 3.2; the finger-tracking paper, eq. (11)).

    ``ref`` is a unit direction in the world frame, ``meas`` the unit direction the
    sensor sees for it; both in the module docstring's closed form. The result is
    the gradient of ``|f|^2 / 2`` with respect to the four components of ``q``.
    """
    w, ux, uy, uz = q
    dx, dy, dz = ref
    ud = ux * dx + uy * dy + uz * dz
    uu = ux * ux + uy * uy + uz * uz
    # f = d + 2 w (d x u) + 2 (u . d) u - 2 |u|^2 d - s
    cx, cy, cz = dy * uz - dz * uy, dz * ux - dx * uz, dx * uy - dy * ux  # d x u
    k = 1.0 - 2.0 * uu
    fx = k * dx + 2.0 * (w * cx + ud * ux) - meas[0]
    fy = k * dy + 2.0 * (w * cy + ud * uy) - meas[1]
    fz = k * dz + 2.0 * (w * cz + ud * uz) - meas[2]
    uf = ux * fx + uy * fy + uz * fz
    fd2 = 2.0 * (fx * dx + fy * dy + fz * dz)
    return (2.0 * (fx * cx + fy * cy + fz * cz),
            2.0 * (w * (fy * dz - fz * dy) + ud * fx + uf * dx - fd2 * ux),
            2.0 * (w * (fz * dx - fx * dz) + ud * fy + uf * dy - fd2 * uy),
            2.0 * (w * (fx * dy - fy * dx) + ud * fz + uf * dz - fd2 * uz))


def descend(q: Quat, gyr: Vec, grad: Quat, beta: float, dt: float) -> Quat:
    """One filter step: the finger-tracking paper, eq. (18) and [M10] sec. 3.3, then eqs. (15), (19).

    ``q_dot = 1/2 q (x) (0, gyr) - beta grad/|grad|`` (no correction where the
    gradient vanishes), ``q + q_dot dt``, renormalised.
    """
    w, x, y, z = q
    gx, gy, gz = gyr
    # 1/2 q (x) (0, omega): [M10] sec. 3.1, the finger-tracking paper, eq. (9)
    dw = 0.5 * (-x * gx - y * gy - z * gz)
    dx = 0.5 * (w * gx + y * gz - z * gy)
    dy = 0.5 * (w * gy - x * gz + z * gx)
    dz = 0.5 * (w * gz + x * gy - y * gx)
    n = math.sqrt(grad[0] * grad[0] + grad[1] * grad[1] + grad[2] * grad[2] + grad[3] * grad[3])
    if n > 0.0:
        s = beta / n
        dw, dx, dy, dz = dw - s * grad[0], dx - s * grad[1], dy - s * grad[2], dz - s * grad[3]
    return Q.normalize((w + dw * dt, x + dx * dt, y + dy * dt, z + dz * dt))


def heading_reference(q: Quat, meas_unit: Vec, toward: Vec) -> Vec:
    """The world reference for ``meas_unit`` that corrects the heading only.

    [M10] sec. 3.4's magnetic distortion compensation: with ``h = q m q*`` the
    measurement in the world, the reference is ``(0, sqrt(h_x^2 + h_y^2), h_z)``
    (ENU; Madgwick's ``(0, |h_xy|, 0, h_z)`` has north along x), so the second
    vector cannot tilt the estimate, only turn it about up. Here the horizontal
    part goes along the unit horizontal direction ``toward``: north for the
    magnetometer, the hinge axis for :mod:`.hinge`.
    """
    hx, hy, hz = Q.rotate(q, meas_unit)
    horizontal = math.hypot(hx, hy)
    return (horizontal * toward[0], horizontal * toward[1], hz)


def level(q: Quat, acc: Vec) -> Quat:
    """``q`` turned by the smallest world-frame rotation that makes ``acc`` point up.

    The accelerometer at rest gives the inclination only (the finger-tracking paper, sec. 2.2.2: the
    slow-motion estimate from gravity); the turn is about a horizontal axis, so
    the heading of ``q`` is kept. ``level(IDENTITY, acc)`` is the pure inclination
    estimate. The shortest arc from ``v = q acc q*`` to up is
    ``(1 + v . up, v x up)`` normalised for unit v (:func:`.qmath.between`);
    upside down it is a half-turn about east.
    """
    return Q.normalize(Q.mul(Q.between(Q.rotate(q, acc), UP, Q.EAST), q))


@dataclass
class MadgwickParams:
    """Settings of the Madgwick filter.

    beta: the gradient step in rad/s ([M10] sec. 3.3, the finger-tracking paper, eq. (18)); Madgwick
    relates it to the gyroscope error as ``beta = sqrt(3/4) * omega_err``. Default
    0.1, Madgwick's own, is the best 9D setting on the BROAD trials in
    ../shared/data/broad (mean total RMSE 3.65 deg over the 9 trials; 0.06: 3.83,
    0.08: 3.66, 0.12: 3.74, 0.15: 3.97). The IMU form prefers a smaller step
    (inclination RMSE 2.16 deg at 0.04, 2.58 at 0.08, 2.85 at 0.1): pass
    ``beta=0.04`` when there is no magnetometer.
    """

    beta: float = 0.1


@dataclass
class MadgwickState:
    q: Quat = Q.IDENTITY
    initialised: bool = False  # set by the fast start on the first accelerometer sample


class Madgwick(Filter[MadgwickParams, MadgwickState]):
    """Gradient-descent filter: gravity plus, in the MARG form, the Earth field.

    The IMU form runs when ``mag`` is None or unusable; then the heading is free.
    Subclasses change the second reference through :meth:`_second_pair`.
    """

    name = "madgwick"
    Params = MadgwickParams
    State = MadgwickState

    def _second_pair(self, q: Quat, mag: Vec | None) -> tuple[Vec, Vec] | None:
        """(world reference, sensor measurement) of the second vector: the Earth field."""
        if mag is None:
            return None
        m = Q.unit(mag)
        return heading_reference(q, m, NORTH), m

    def _step(self, gyr: Vec, acc: Vec | None, mag: Vec | None, dt: float) -> Quat:
        s = self._state
        if not s.initialised and acc is not None:
            s.q = level(Q.IDENTITY, acc)
            pair = self._second_pair(s.q, mag)
            if pair is not None:  # the second vector's horizontal part onto its reference's
                s.q = Q.align_heading(s.q, pair[1], pair[0])
            s.initialised = True
            return s.q
        grad = gradient(s.q, UP, Q.unit(acc)) if acc is not None else ZERO_QUAT
        pair = self._second_pair(s.q, mag)
        if pair is not None:  # stacked objectives: the gradients add ([M10] sec. 3.2)
            grad = Q.add(grad, gradient(s.q, *pair))
        s.q = descend(s.q, gyr, grad, self.params.beta, dt)
        return s.q


FILTER_CLASS = Madgwick
