"""Quaternion and rotation math, vectorised over leading axes.

Convention (docs ARCHITECTURE.md): Hamilton product, scalar first ``(w, x, y, z)``,
unit norm. ``q_WS`` rotates a vector from frame S into frame W:
``v_W = q_WS * v_S * conj(q_WS)``. Quaternions are arrays of shape ``(..., 4)``,
vectors ``(..., 3)``; leading axes broadcast. Inputs may be lists or tuples;
results are float64 arrays. Angles are radians unless a name says degrees.

Reference: J. Sola, "Quaternion kinematics for the error-state Kalman filter",
arXiv:1711.02508 (2017), cited below as "Sola 2017".
"""

from __future__ import annotations

from functools import reduce
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]

_EYE = np.eye(3)
_CONJUGATE = np.array([1.0, -1.0, -1.0, -1.0])
_GIMBAL_EPS = 1e-7  # |cos(middle angle)| below which an Euler triple is in gimbal lock


def _f(x: ArrayLike) -> Array:
    return np.asarray(x, dtype=np.float64)


def _quat(w: ArrayLike, v: ArrayLike) -> Array:
    """Quaternion from scalar part w (...) and vector part v (..., 3), broadcast."""
    return _join(w, *_parts(_f(v)))


def _parts(x: Array) -> tuple[Array, ...]:
    """The components of x (..., n) along its last axis."""
    return tuple(x[..., i] for i in range(x.shape[-1]))


def _join(*parts: ArrayLike) -> Array:
    """The array (..., n) whose last axis holds the n ``parts``, broadcast."""
    out = np.empty(np.broadcast(*parts).shape + (len(parts),))
    for i, part in enumerate(parts):
        out[..., i] = part
    return out


def _cross(a: Sequence[Array], b: Sequence[Array]) -> tuple[Array, Array, Array]:
    """The components of a x b, from the components of a and b."""
    (ax, ay, az), (bx, by, bz) = a, b
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


def _unit(x: ArrayLike, what: str) -> Array:
    x = _f(x)
    n = np.linalg.norm(x, axis=-1, keepdims=True)
    if not np.all(np.isfinite(n) & (n > 0)):
        raise ValueError(f"cannot normalise a zero or non-finite {what}")
    return x / n


def identity(shape: tuple[int, ...] = ()) -> Array:
    """Identity quaternion(s) of the given leading shape."""
    return _quat(np.ones(shape), np.zeros(3))


def multiply(p: ArrayLike, q: ArrayLike) -> Array:
    """Hamilton product p * q (Sola 2017, sec. 1.2.2): rotating by q, then by p."""
    (pw, *pv), (qw, *qv) = _parts(_f(p)), _parts(_f(q))
    (px, py, pz), (qx, qy, qz) = pv, qv
    cx, cy, cz = _cross(pv, qv)
    return _join(pw * qw - (px * qx + py * qy + pz * qz),
                 pw * qx + qw * px + cx, pw * qy + qw * py + cy, pw * qz + qw * pz + cz)


def conjugate(q: ArrayLike) -> Array:
    """Conjugate (w, -x, -y, -z): the inverse of a unit quaternion."""
    return _f(q) * _CONJUGATE


def normalize(q: ArrayLike) -> Array:
    """Scale to unit norm; ValueError for a zero or non-finite quaternion."""
    return _unit(q, "quaternion")


def canonical(q: ArrayLike) -> Array:
    """The sign of q (q and -q are the same rotation) with w > 0, or where w == 0,
    with its first non-zero component positive: a unique representative."""
    q = _f(q)
    lead = np.take_along_axis(q, np.argmax(q != 0, axis=-1)[..., None], axis=-1)
    return np.where(lead < 0, -q, q)


def rotate(q: ArrayLike, v: ArrayLike) -> Array:
    """Rotate v by unit q: q * (0, v) * conj(q), as v + w t + u x t with t = 2 u x v."""
    (w, *u), v = _parts(_f(q)), _parts(_f(v))
    t = tuple(2.0 * c for c in _cross(u, v))
    return _join(*(vi + w * ti + ci for vi, ti, ci in zip(v, t, _cross(u, t))))


def exp(v: ArrayLike) -> Array:
    """Exponential of the pure quaternion (0, v): (cos|v|, sin|v| v/|v|) (Sola 2017, sec. 1.3.4).

    The result rotates by 2|v| about v, so ``exp(v) == from_rotvec(2 v)``.
    """
    v = _f(v)
    theta = np.linalg.norm(v, axis=-1)
    return _quat(np.cos(theta), np.sinc(theta / np.pi)[..., None] * v)


def _axis_half_angle(q: Array) -> tuple[Array, Array]:
    """Unit axis (+x where undefined) and half-angle atan2(|u|, w) in [0, pi] of q = (w, u)."""
    u = q[..., 1:]
    s = np.linalg.norm(u, axis=-1, keepdims=True)
    axis = np.divide(u, s, out=np.broadcast_to(_EYE[0], u.shape).copy(), where=s > 0)
    return axis, np.arctan2(s[..., 0], q[..., 0])


def log(q: ArrayLike) -> Array:
    """Logarithm of unit q as a 3-vector, the inverse of ``exp`` (Sola 2017, sec. 1.3.6).

    Keeps the sign of q (``exp(log(q)) == q``), so |log q| lies in [0, pi];
    ``to_rotvec(q) == 2 log(canonical(q))``.
    """
    axis, half = _axis_half_angle(_f(q))
    return axis * half[..., None]


def from_rotvec(rv: ArrayLike) -> Array:
    """Rotation vector (axis times angle) to quaternion (Sola 2017, sec. 2.4)."""
    return exp(0.5 * _f(rv))


def to_rotvec(q: ArrayLike) -> Array:
    """Quaternion to rotation vector with angle in [0, pi] (Sola 2017, sec. 2.4)."""
    return 2.0 * log(canonical(q))


def from_axis_angle(axis: ArrayLike, angle: ArrayLike) -> Array:
    """Rotation by angle about axis (normalised here) (Sola 2017, sec. 2.4)."""
    half = 0.5 * _f(angle)
    return _quat(np.cos(half), np.sin(half)[..., None] * _unit(axis, "axis"))


def to_axis_angle(q: ArrayLike) -> tuple[Array, Array]:
    """(unit axis, angle in [0, pi]); the axis is +x where the angle is zero."""
    axis, half = _axis_half_angle(canonical(q))
    return axis, 2.0 * half


def _perpendicular(a: Array) -> Array:
    """A unit vector perpendicular to unit a, via the basis axis least aligned with it."""
    return _unit(np.cross(a, _EYE[np.argmin(np.abs(a), axis=-1)]), "vector")


def from_two_vectors(a: ArrayLike, b: ArrayLike) -> Array:
    """Shortest rotation taking direction a to direction b.

    Angle atan2(|a x b|, a . b) about a x b; the axis is made exactly perpendicular
    to a, so nearly opposite vectors stay accurate, and for exactly opposite ones
    any perpendicular axis is used (the half-turn is then not unique).
    """
    a, b = np.broadcast_arrays(_unit(a, "vector"), _unit(b, "vector"))
    c = np.cross(a, b)
    n = c - np.sum(c * a, axis=-1, keepdims=True) * a
    norm = np.linalg.norm(n, axis=-1, keepdims=True)
    axis = np.divide(n, norm, out=_perpendicular(a), where=norm > 0)
    angle = np.arctan2(np.linalg.norm(c, axis=-1), np.sum(a * b, axis=-1))
    return from_axis_angle(axis, angle)


def slerp(q0: ArrayLike, q1: ArrayLike, t: ArrayLike) -> Array:
    """Spherical linear interpolation q0 (q0^-1 q1)^t along the shorter arc.

    Shoemake 1985, "Animating rotation with quaternion curves"; Sola 2017, sec. 2.7.
    Written with exp/log, so it stays exact for nearly equal q0 and q1; t broadcasts
    against the leading axes of q0 and q1.
    """
    q0 = _f(q0)
    delta = canonical(multiply(conjugate(q0), q1))
    return multiply(q0, exp(_f(t)[..., None] * log(delta)))


def angle_between(p: ArrayLike, q: ArrayLike) -> Array:
    """Rotation angle of p^-1 q in [0, pi]; the same for either sign of p or q."""
    d = multiply(conjugate(p), q)
    return 2.0 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), np.abs(d[..., 0]))


def to_matrix(q: ArrayLike) -> Array:
    """Rotation matrix (..., 3, 3) of unit q; its columns are the rotated basis vectors."""
    return np.swapaxes(rotate(_f(q)[..., None, :], _EYE), -1, -2)


def from_matrix(m: ArrayLike) -> Array:
    """Quaternion (w >= 0) of rotation matrix m, by Shepperd's method.

    Each row of the symmetric matrix below is 4 q_i q (Shepperd 1978, "Quaternion
    from rotation matrix", J. Guidance and Control 1(3)); the row with the largest
    diagonal entry 4 q_i^2 is the best conditioned and is normalised.
    """
    m = _f(m)
    (a, b, c), (d, e, f), (g, h, i) = np.moveaxis(m, (-2, -1), (0, 1))
    k = np.stack(
        [
            np.stack([1 + a + e + i, h - f, c - g, d - b], axis=-1),
            np.stack([h - f, 1 + a - e - i, b + d, c + g], axis=-1),
            np.stack([c - g, b + d, 1 - a + e - i, f + h], axis=-1),
            np.stack([d - b, c + g, f + h, 1 - a - e + i], axis=-1),
        ],
        axis=-2,
    )
    best = np.argmax(np.diagonal(k, axis1=-2, axis2=-1), axis=-1)
    row = np.take_along_axis(k, best[..., None, None], axis=-2)[..., 0, :]
    return canonical(normalize(row))


def _sequence(order: str) -> tuple[tuple[int, ...], bool]:
    """Axes of a Tait-Bryan order as an intrinsic sequence, and whether it was extrinsic.

    Extrinsic "abc" with angles (1, 2, 3) is intrinsic "CBA" with angles (3, 2, 1).
    """
    one_case = order.isupper() or order.islower()
    if not (len(order) == 3 and one_case and set(order.lower()) == set("xyz")):
        raise ValueError(
            f"unsupported Euler order {order!r}: use three distinct axes of 'xyz', "
            "upper case for intrinsic (rotating) or lower case for extrinsic (fixed) axes"
        )
    axes = tuple("xyz".index(c) for c in order.lower())
    return (axes, False) if order.isupper() else (axes[::-1], True)


def from_euler(angles: ArrayLike, order: str) -> Array:
    """Quaternion from Euler angles (..., 3) in radians, with scipy's naming.

    Upper case is intrinsic: "ZYX" with (yaw, pitch, roll) is qz(yaw) qy(pitch) qx(roll).
    Lower case is extrinsic: "xyz" with (a, b, c) is qz(c) qy(b) qx(a), i.e. "ZYX" with
    the angles reversed. Any of the 12 Tait-Bryan orders (three distinct axes).
    """
    axes, extrinsic = _sequence(order)
    angles = _f(angles)
    if extrinsic:
        angles = angles[..., ::-1]
    turns = (from_axis_angle(_EYE[ax], angles[..., n]) for n, ax in enumerate(axes))
    return reduce(multiply, turns)


def to_euler(q: ArrayLike, order: str) -> Array:
    """Euler angles (..., 3) of unit q, the inverse of ``from_euler``.

    For the intrinsic sequence R = Ri(a) Rj(b) Rk(c), with s = +1 when (i, j, k) is a
    cyclic permutation of (x, y, z) and -1 otherwise, R[i, k] = s sin b and
    a = atan2(-s R[j, k], R[k, k]), c = atan2(-s R[i, j], R[i, i]); the middle angle
    lies in [-pi/2, pi/2], the others in (-pi, pi]. In gimbal lock (|cos b| < 1e-7) the
    third angle is set to 0 and the first read from column j = Ri(a) e_j.
    """
    (i, j, k), extrinsic = _sequence(order)
    r = to_matrix(q)
    s = 1.0 if (j - i) % 3 == 1 else -1.0
    cos_b = np.hypot(r[..., i, i], r[..., i, j])
    lock = cos_b < _GIMBAL_EPS
    b = np.arctan2(s * r[..., i, k], cos_b)
    a = np.where(
        lock,
        np.arctan2(s * r[..., k, j], r[..., j, j]),
        np.arctan2(-s * r[..., j, k], r[..., k, k]),
    )
    c = np.where(lock, 0.0, np.arctan2(-s * r[..., i, j], r[..., i, i]))
    angles = np.stack([a, b, c], axis=-1)
    return angles[..., ::-1] if extrinsic else angles


def unity_euler(x_deg: ArrayLike, y_deg: ArrayLike, z_deg: ArrayLike) -> Array:
    """Unity's ``Quaternion.Euler(x, y, z)``: about z, then x, then y (fixed axes), degrees.

    That is q = qy * qx * qz, the intrinsic "YXZ" sequence. The components equal
    Unity's (x, y, z, w) result reordered to (w, x, y, z); Unity reads them in its
    left-handed frame, mapping frames is the renderer's business. The paper's
    avatar turns the forearm by ``Euler(flex, -flex, 0)``.
    """
    x, y, z = np.broadcast_arrays(_f(x_deg), _f(y_deg), _f(z_deg))
    return from_euler(np.radians(np.stack([y, x, z], axis=-1)), "YXZ")
