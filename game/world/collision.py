"""Bodies against the town's obstacles: circles pushed out of them, spheres swept into them. Pure logic.

Frames and units as :mod:`game.world.town`: metres, x east, y north, z up;
an obstacle is the box ``x0..x1`` x ``y0..y1`` x ``0..height``.

:func:`push_out` is for walking bodies (the player, the zombies: a circle
on the ground); :func:`sweep_sphere` for flying ones (the energy balls).
Both ask the town's spatial hash (:attr:`~game.world.town.Town.grid`) for
the nearby obstacles, so a query costs the same in a town of any size.
"""

from __future__ import annotations

import math

from .town import Obstacle, Town

Vec3 = tuple[float, float, float]
PASSES = 6  # push_out's rounds over the nearby obstacles (a push out of one can press into another)
SKIN_M = 1e-4  # after the first round, bodies are pushed this much beyond touching (see push_out)
WEDGED_M = 1e-7  # still this deep in an obstacle after every round: wedged (the fallback's test)


def push_out(town: Town, x: float, y: float, radius: float,
             fallback: tuple[float, float] | None = None) -> tuple[float, float]:
    """The centre of a circle of ``radius`` at (x, y) moved out of every obstacle it overlaps, and
    into the town's area (at least ``radius`` in from its edge); where no place near is out of them
    all (a gap between two obstacles narrower than the body), ``fallback``: the body stays where it
    was.

    Against one box: the circle's centre is moved away from the box's
    closest point to it until it is ``radius`` away, so only the component
    of a walk that presses into a face is taken back and the walk along the
    face is kept: the body slides along walls. Several boxes (a corner) are
    worked through in turn, for up to ``PASSES`` rounds, until none
    overlaps. A centre inside a box leaves it across the nearest face; a
    walking body, pushed out every step, never gets its centre inside one
    (deep inside a row of touching buildings that face may lead into the next).
    Wedged in a notch (a corner beside a face less than a body's width away),
    pushes out of one and the other in turn only approach the resting place
    (geometrically, more slowly the narrower the notch); so rounds after the
    first push ``SKIN_M`` beyond touching, which ends the see-saw in a round
    or two.
    """
    grid, h = town.grid, town.half_size_m - radius
    reach, touching = radius, (radius - 1e-9) ** 2  # a rounding error's overlap is not one
    for _ in range(PASSES):
        x = -h if x < -h else h if x > h else x
        y = -h if y < -h else h if y > h else y
        nearby = grid.near(x, y) if radius <= grid.reach_m else grid.in_box(x - radius, y - radius,
                                                                            x + radius, y + radius)
        moved = False
        for o in nearby:
            cx = o.x0 if x < o.x0 else o.x1 if x > o.x1 else x  # the box's closest point
            cy = o.y0 if y < o.y0 else o.y1 if y > o.y1 else y
            dx, dy = x - cx, y - cy
            d2 = dx * dx + dy * dy
            if d2 >= touching:
                continue
            moved = True
            if d2 > 0.0:
                k = reach / math.sqrt(d2)
                x, y = cx + dx * k, cy + dy * k
            else:  # the centre is inside: out across the nearest face
                gaps = (x - o.x0, o.x1 - x, y - o.y0, o.y1 - y)
                face = gaps.index(min(gaps))
                if face == 0:
                    x = o.x0 - reach
                elif face == 1:
                    x = o.x1 + reach
                elif face == 2:
                    y = o.y0 - reach
                else:
                    y = o.y1 + reach
        if not moved:
            break
        reach = radius + SKIN_M
    else:  # every round moved it: it may be wedged where it does not fit
        if fallback is not None and inside(town, x, y, radius, WEDGED_M):
            return fallback
    return (-h if x < -h else h if x > h else x), (-h if y < -h else h if y > h else y)


def inside(town: Town, x: float, y: float, radius: float, tolerance: float) -> bool:
    """Whether a circle of ``radius`` at (x, y) overlaps an obstacle by more than ``tolerance`` (m)."""
    grid = town.grid
    nearby = grid.near(x, y) if radius <= grid.reach_m else grid.in_box(x - radius, y - radius,
                                                                        x + radius, y + radius)
    limit = (radius - tolerance) ** 2
    for o in nearby:
        cx = o.x0 if x < o.x0 else o.x1 if x > o.x1 else x
        cy = o.y0 if y < o.y0 else o.y1 if y > o.y1 else y
        if (x - cx) ** 2 + (y - cy) ** 2 < limit:
            return True
    return False


def sweep_sphere(town: Town, p0: Vec3, p1: Vec3, radius: float) -> tuple[float, Obstacle] | None:
    """The first obstacle a sphere of ``radius`` meets moving from ``p0`` to ``p1``: ``(t, obstacle)``,
    the sphere's centre touching it at ``p0 + t (p1 - p0)``, t in [0, 1); None if it meets none.

    Each box is grown by ``radius`` on every side (the bottom too) and the
    centre's segment clipped against it by the slab method (Kay and Kajiya,
    "Ray tracing complex scenes", SIGGRAPH 1986; Ericson, Real-Time
    Collision Detection, sec. 5.3.3), so no sphere passes through a thin
    wall however far it moves in one step. The grown box has square edges
    where the true swept shape is rounded: a sphere that passes within
    ``radius`` of an edge or a corner, but not of a face, counts as a hit
    (at most ``radius * (sqrt(3) - 1)`` early). Touching a grown face
    without entering it (a graze) is not a hit; a sphere that starts
    inside a grown box hits it at t = 0.
    """
    x0, y0, z0 = p0
    dx, dy, dz = p1[0] - x0, p1[1] - y0, p1[2] - z0
    grid = town.grid
    nearby = grid.in_box(min(x0, p1[0]) - radius, min(y0, p1[1]) - radius,
                         max(x0, p1[0]) + radius, max(y0, p1[1]) + radius)
    best_t, best = 1.0, None
    for o in nearby:
        t = segment_box(x0, y0, z0, dx, dy, dz, o.x0 - radius, o.y0 - radius, -radius,
                        o.x1 + radius, o.y1 + radius, o.height + radius)
        if t < best_t:
            best_t, best = t, o
    return None if best is None else (best_t, best)


def segment_box(x: float, y: float, z: float, dx: float, dy: float, dz: float, lo_x: float, lo_y: float,
                lo_z: float, hi_x: float, hi_y: float, hi_z: float) -> float:
    """Where the segment from (x, y, z) along (dx, dy, dz) (parameter 0 to 1) first enters the open box
    lo..hi: its parameter, 0 if it starts inside, or ``math.inf`` if it does not enter it.

    The slab method: on each axis the segment is inside the slab between two
    parameters; it is inside the box where all three ranges overlap, from
    the largest entry to the smallest exit. A segment parallel to an axis is
    inside that slab throughout or never (on a face counts as outside).
    Infinite bounds are allowed (a 2D test: ``lo_z = -inf``, ``hi_z = inf``, ``dz = 0``).
    """
    enter, leave = 0.0, 1.0
    for p, d, lo, hi in ((x, dx, lo_x, hi_x), (y, dy, lo_y, hi_y), (z, dz, lo_z, hi_z)):
        if d == 0.0:
            if not lo < p < hi:
                return math.inf
            continue
        t0, t1 = (lo - p) / d, (hi - p) / d
        if t0 > t1:
            t0, t1 = t1, t0
        if t0 > enter:
            enter = t0
        if t1 < leave:
            leave = t1
        if enter >= leave:
            return math.inf
    return enter
