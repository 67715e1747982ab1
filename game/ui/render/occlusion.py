"""What hides what: sight lines from the camera through the town's boxes, and the fade of a box in the way.

Pure numpy, no pygame: the renderer asks it which boxes stand between the
camera's eye and a point (the player's body, a zombie's head, a spark), to
fade the boxes in front of the player (:func:`occluders`, :func:`ease`) and
to paint every actor before the boxes that cover it (:func:`covers`).

Boxes are axis-aligned, as the town's obstacles (:mod:`game.world.town`):
corners ``lo`` (x0, y0, 0) and ``hi`` (x1, y1, height), metres, world frame.
"""

from __future__ import annotations

import numpy as np

FADED_ALPHA = 0.3  # the opacity of a box between the camera and the player
FADE_S = 0.2  # the time a box takes to fade out fully, or back in


def covers(eye, points, lo, hi) -> np.ndarray:
    """Whether the segment from ``eye`` to each point passes through the box ``lo``..``hi`` paired with it
    (open boxes: a segment along a face, or ending on one, does not count; a point inside is covered).

    ``points`` (..., 3) and the corners ``lo``, ``hi`` (..., 3) broadcast
    together: ``points[:, None]`` against ``lo[None]`` gives every point
    against every box, (P, N). The slab method (Kay and Kajiya, "Ray tracing
    complex scenes", SIGGRAPH 1986; Ericson, Real-Time Collision Detection,
    sec. 5.3.3), for all pairs at once: on each axis the segment's parameter
    t (0 at the eye, 1 at the point) lies inside the slab between two
    values; the segment is inside the box where the three ranges and 0..1
    overlap. A segment parallel to an axis (its step there below 1e-12 m) is
    inside that slab throughout or never.
    """
    eye = np.asarray(eye, dtype=float).reshape(3)
    d = np.asarray(points, dtype=float) - eye
    a, b = np.asarray(lo, dtype=float) - eye, np.asarray(hi, dtype=float) - eye  # the eye at the origin
    flat = np.abs(d) < 1e-12
    inv = 1.0 / np.where(flat, 1.0, d)
    t0, t1 = a * inv, b * inv
    near, far = np.minimum(t0, t1), np.maximum(t0, t1)
    if flat.any():  # parallel to an axis: inside that slab throughout (-inf..inf) or never (inf..-inf)
        out = flat & ~((a < 0.0) & (0.0 < b))
        near = np.where(flat, np.where(out, np.inf, -np.inf), near)
        far = np.where(flat, np.where(out, -np.inf, np.inf), far)
    return np.asarray(np.maximum(near.max(axis=-1), 0.0) < np.minimum(far.min(axis=-1), 1.0))


def occluders(eye: np.ndarray, targets: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(N,) bools: the boxes that stand between the camera's ``eye`` and any of the ``targets`` (the
    player's body and arm, sampled as points): those to fade so that the player is never hidden."""
    targets = np.asarray(targets, dtype=float).reshape(-1, 3)
    return np.asarray(covers(eye, targets[:, None], np.reshape(lo, (1, -1, 3)), np.reshape(hi, (1, -1, 3))).any(axis=0))


def ease(alpha: np.ndarray, faded: np.ndarray, dt: float) -> np.ndarray:
    """Each box's opacity moved toward ``FADED_ALPHA`` (where ``faded``) or 1, at the rate that takes it
    all the way in ``FADE_S``: a box slides out of sight and back rather than blinking."""
    target = np.where(faded, FADED_ALPHA, 1.0)
    step = max(dt, 0.0) * (1.0 - FADED_ALPHA) / FADE_S
    return np.clip(target, alpha - step, alpha + step)
