"""Scalar quaternion math on plain tuples, for filters updated from a Python loop.

The same conventions as :mod:`tracker.quat` (Hamilton product, scalar first,
``q_WS`` maps sensor to world), but on 4-tuples of floats: a streaming filter
handles one sample at a time, where numpy's per-call overhead (about a
microsecond) would cost more than the arithmetic. Tests check every function
against :mod:`tracker.quat`.
"""

from __future__ import annotations

import math

Quat = tuple[float, float, float, float]
Vec = tuple[float, float, float]

IDENTITY: Quat = (1.0, 0.0, 0.0, 0.0)


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


def normalize(q: Quat) -> Quat:
    """q / |q|; the identity for a zero or non-finite q (a filter must stay usable)."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if not 0.0 < n < math.inf:
        return IDENTITY
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


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
    """Unit quaternion of the rotation vector (x, y, z) (angle = norm, radians)."""
    angle = math.sqrt(x * x + y * y + z * z)
    if angle < 1e-12:
        return normalize((1.0, 0.5 * x, 0.5 * y, 0.5 * z))
    s = math.sin(0.5 * angle) / angle
    return (math.cos(0.5 * angle), x * s, y * s, z * s)


def norm3(v: Vec) -> float:
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


def cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a: Vec, b: Vec) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
