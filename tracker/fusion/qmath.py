"""Scalar quaternion math on plain tuples, for filters updated from a Python loop.

The same conventions as :mod:`tracker.quat` (Hamilton product, scalar first,
``q_WS`` maps sensor to world, world East-North-Up), but on 4-tuples of floats:
a streaming filter handles one sample at a time, where numpy's per-call overhead
(about a microsecond) would cost more than the arithmetic. Tests check every
function against :mod:`tracker.quat`.

Lengths are taken with :func:`math.hypot`, which neither overflows nor
underflows, so 1e-200 and 1e300 behave like 1; a zero or non-finite input gives
the identity where a function documents it, never an exception.

The helpers below serve several filters: each filter's docstring says which
paper equation a call stands for.
"""

from __future__ import annotations

import math
from typing import Iterable

Quat = tuple[float, float, float, float]
Vec = tuple[float, float, float]

IDENTITY: Quat = (1.0, 0.0, 0.0, 0.0)
EAST: Vec = (1.0, 0.0, 0.0)  # world x
NORTH: Vec = (0.0, 1.0, 0.0)  # world y
UP: Vec = (0.0, 0.0, 1.0)  # world z

_TINY = 1e-12
_HALF_PI = 0.5 * math.pi


# ------------------------------------------------------------ quaternions


def as_quat(q: Iterable[float]) -> Quat:
    """Any four numbers (a list, an array row, a tuple of numpy floats) as a Quat of floats."""
    w, x, y, z = q
    return (float(w), float(x), float(y), float(z))


def mul(p: Quat, q: Quat) -> Quat:
    """Hamilton product p * q."""
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return (pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw)


def conj(q: Quat) -> Quat:
    return (q[0], -q[1], -q[2], -q[3])


def add(p: Quat, q: Quat) -> Quat:
    """Component sum p + q (e.g. summing the gradients of stacked objectives)."""
    return (p[0] + q[0], p[1] + q[1], p[2] + q[2], p[3] + q[3])


def normalize(q: Quat) -> Quat:
    """q / |q|; the identity for a zero or non-finite q (a filter must stay usable)."""
    w, x, y, z = q
    n = math.hypot(w, x, y, z)
    if 1e-300 < n < math.inf:
        return (w / n, x / n, y / n, z / n)
    # A norm that overflows, or subnormal components (hypot keeps few of their bits):
    # scale by the largest component first.
    m = max(abs(w), abs(x), abs(y), abs(z))
    if 0.0 < m < math.inf:
        w, x, y, z = w / m, x / m, y / m, z / m
        n = math.hypot(w, x, y, z)
        return (w / n, x / n, y / n, z / n)
    return IDENTITY  # zero, or an infinite or NaN component


def rotate(q: Quat, v: Vec) -> Vec:
    """q * v * conj(q): a sensor-frame vector in the world frame, for unit q."""
    w, x, y, z = q
    vx, vy, vz = v
    # t = 2 (q_vec x v);  v' = v + w t + q_vec x t
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (vx + w * tx + y * tz - z * ty,
            vy + w * ty + z * tx - x * tz,
            vz + w * tz + x * ty - y * tx)


def rotate_inverse(q: Quat, v: Vec) -> Vec:
    """conj(q) * v * q: a world-frame vector in the sensor frame, for unit q."""
    return rotate(conj(q), v)


def from_rotvec(x: float, y: float, z: float) -> Quat:
    """Unit quaternion of the rotation vector (x, y, z) (angle = norm, radians).

    The identity where the angle is not finite (an infinite or NaN component, or
    a norm beyond the float range); any finite angle, however large, is reduced
    exactly by :func:`math.sin` and :func:`math.cos`.
    """
    angle = math.hypot(x, y, z)
    if _TINY <= angle < math.inf:
        half = 0.5 * angle
        s = math.sin(half) / angle
        return (math.cos(half), x * s, y * s, z * s)
    if angle < _TINY:
        return normalize((1.0, 0.5 * x, 0.5 * y, 0.5 * z))
    return IDENTITY


def integrate(q: Quat, omega: Vec, dt: float) -> Quat:
    """``q (x) exp(omega dt / 2)``: q advanced by the body rate ``omega`` (rad/s) held for
    ``dt`` seconds (the exact rotation for a constant rate; not renormalised)."""
    return mul(q, from_rotvec(omega[0] * dt, omega[1] * dt, omega[2] * dt))


def about_z(angle: float) -> Quat:
    """The rotation by ``angle`` radians about world z (up): a heading change."""
    half = 0.5 * angle
    return (math.cos(half), 0.0, 0.0, math.sin(half))


def power(q: Quat, k: float) -> Quat:
    """``q^k`` for unit q: the same axis, k times the angle.

    Follows the arc q describes: the shorter one for ``w >= 0`` (as :func:`between`
    returns). ``k = 1`` and a rotation under 1e-12 rad return q itself.
    """
    s = math.hypot(q[1], q[2], q[3])
    if k == 1.0 or s < _TINY:
        return q
    scale = 2.0 * k * math.atan2(s, q[0]) / s
    return from_rotvec(q[1] * scale, q[2] * scale, q[3] * scale)


def slerp(p: Quat, q: Quat, t: float) -> Quat:
    """Spherical linear interpolation from p (t = 0) to q (t = 1), for unit p and q.

    ``(p sin((1 - t) W) + q sin(t W)) / sin(W)`` with ``cos(W) = p . q`` (Shoemake
    1985), along the shorter arc (q and -q are one rotation), and the linear blend
    where W < 1e-6. Not renormalised: that blend is unit only to about W^2.
    """
    cos_w = p[0] * q[0] + p[1] * q[1] + p[2] * q[2] + p[3] * q[3]
    sign = 1.0 if cos_w >= 0.0 else -1.0
    omega = math.acos(min(1.0, sign * cos_w))
    if omega < 1e-6:
        a, b = 1.0 - t, t
    else:
        a, b = math.sin((1.0 - t) * omega) / math.sin(omega), math.sin(t * omega) / math.sin(omega)
    b *= sign
    return (a * p[0] + b * q[0], a * p[1] + b * q[1], a * p[2] + b * q[2], a * p[3] + b * q[3])


# ------------------------------------------------------------ vectors

def as_vec(v: Iterable[float]) -> Vec:
    """Any three numbers (a list, an array row, a tuple of numpy floats) as a Vec of floats."""
    x, y, z = v
    return (float(x), float(y), float(z))


def norm3(v: Vec) -> float:
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


def unit(v: Vec) -> Vec:
    """v / |v| for a finite, non-zero v (as base.Filter.update passes); hypot neither
    overflows nor underflows, so 1e-200 and 1e300 scale to unit length too."""
    n = math.hypot(v[0], v[1], v[2])
    return (v[0] / n, v[1] / n, v[2] / n)


def cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a: Vec, b: Vec) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


# ------------------------------------------------------------ rotations between directions

def between(u: Vec, v: Vec, half_turn_axis: Vec | None = None) -> Quat:
    """The shortest rotation taking the direction of u onto that of v (any lengths).

    The half-angle form ``H(u x v, |u||v| + u . v)`` normalised (no trigonometry),
    evaluated on the unit directions. Where u and v are opposite (``1 + u.v``
    under 1e-12 for the unit vectors; the formula is 0/0 at exactly opposite) the
    rotation is a half-turn about ``half_turn_axis`` if given (the caller's
    choice, perpendicular to u), else about ``u x e_x`` (``u x e_y`` where u is
    near the x axis). The identity where u or v is zero.
    """
    nu = math.hypot(u[0], u[1], u[2])
    nv = math.hypot(v[0], v[1], v[2])
    if not (0.0 < nu < math.inf and 0.0 < nv < math.inf):
        return IDENTITY
    ux, uy, uz = u[0] / nu, u[1] / nu, u[2] / nu
    vx, vy, vz = v[0] / nv, v[1] / nv, v[2] / nv
    w = 1.0 + ux * vx + uy * vy + uz * vz
    if w <= _TINY:
        if half_turn_axis is not None:
            return normalize((0.0, half_turn_axis[0], half_turn_axis[1], half_turn_axis[2]))
        c = cross((ux, uy, uz), EAST if abs(ux) < 0.6 else NORTH)
        return normalize((0.0, c[0], c[1], c[2]))
    return normalize((w, uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx))


def tilt_to_up(v: Vec, fraction: float = 1.0) -> Vec:
    """Rotation vector of ``fraction`` of the shortest rotation taking world vector v onto up (+z).

    The rotation of :func:`between` ``(v, UP)`` in angle-axis form, for callers
    that want its angle (a part of it, or a rate): the axis ``v x UP = (v_y, -v_x, 0)``
    is horizontal, so only the inclination changes; the angle is
    ``atan2(|v x UP|, v . UP)``, the same as ``arccos(v_z / |v|)`` but accurate
    near 0. Where v is vertical (``|v_xy| <= 1e-12 |v|``): no rotation when it
    points up (or is zero), a half-turn about EAST when it points down.
    """
    vx, vy, vz = v
    s = math.hypot(vx, vy)  # |v x UP|
    phi = math.atan2(s, vz)
    if s <= _TINY * math.hypot(vx, vy, vz):
        if phi < _HALF_PI:
            return (0.0, 0.0, 0.0)
        return (fraction * phi, 0.0, 0.0)
    k = fraction * phi / s
    return (vy * k, -vx * k, 0.0)


def align_heading(q: Quat, vec_s: Vec, ref_w: Vec) -> Quat:
    """``q`` turned about world up so that ``q vec_s q*`` and ``ref_w`` share a horizontal direction.

    The turn is the signed angle from the one horizontal part to the other, in
    (-pi, pi]. Leaves ``q`` unchanged where either vector is vertical (horizontal
    part under 1e-6 of its length) and so tells no heading.
    """
    hx, hy, hz = rotate(q, vec_s)
    rx, ry, rz = ref_w
    r = math.hypot(rx, ry)
    if math.hypot(hx, hy) <= 1e-6 * math.hypot(hx, hy, hz) or r <= 1e-6 * math.hypot(rx, ry, rz):
        return q
    rx, ry = rx / r, ry / r  # so that the products below neither overflow nor underflow
    return mul(about_z(math.atan2(hx * ry - hy * rx, hx * rx + hy * ry)), q)
