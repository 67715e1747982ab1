"""Line of sight through the town: does an obstacle hide one point from another? Pure logic.

Frames and units as :mod:`game.world.town`. Only obstacles whose kind hides
(:attr:`~game.world.town.KindSpec.hides`: all but the thin lamp post) block
sight. :func:`line_of_sight` looks at the ground plan (every such obstacle
blocks, however low); :func:`line_of_sight_3d` takes heights into account,
so an eye at 1.6 m sees a zombie's chest over a low wall or a car near
neither. The obstacles are read from the town's spatial hash in the order
the line meets them, and the test stops at the first that blocks.
:func:`open_yaw` is where a view from a point reaches farthest: the way the
player faces at the start, down a street rather than at a wall.
"""

from __future__ import annotations

import math

from .collision import Vec3, segment_box
from .town import Point, Town

EYE_HEIGHT_M = 1.6  # a standing player's eyes
CHEST_HEIGHT_M = 1.2  # a zombie's chest (1.8 m tall), where the bot aims


def line_of_sight(town: Town, a: Point, b: Point) -> bool:
    """Whether the ground-plan segment ab crosses no obstacle that hides (heights ignored).

    A segment that only touches a footprint's edge is not blocked.
    """
    ax, ay = a
    dx, dy = b[0] - ax, b[1] - ay
    inf = math.inf
    for o in town.grid.along(ax, ay, b[0], b[1]):
        if o.hides and segment_box(ax, ay, 0.0, dx, dy, 0.0, o.x0, o.y0, -inf, o.x1, o.y1, inf) < inf:
            return False
    return True


def clear_distance(town: Town, origin: Point, yaw: float, reach: float) -> float:
    """How far (m, at most ``reach``) the ground plan is clear of obstacles that hide, from ``origin``
    toward ``yaw`` (the arena's yaw: 0 faces +y, positive turns left, so the way is (-sin, cos))."""
    ox, oy = origin
    dx, dy = -math.sin(yaw) * reach, math.cos(yaw) * reach
    inf = math.inf
    first = min((segment_box(ox, oy, 0.0, dx, dy, 0.0, o.x0, o.y0, -inf, o.x1, o.y1, inf)
                 for o in town.grid.along(ox, oy, ox + dx, oy + dy) if o.hides), default=inf)
    return reach * min(first, 1.0)


def open_yaw(town: Town, origin: Point) -> float:
    """Of the eight compass yaws, the one whose view from ``origin`` is clear the farthest within the
    town's half size; of equals, along the town's axes (its streets) before the diagonals, and the
    first from north turning left (radians, in (-pi, pi])."""
    def view(k: int) -> tuple[float, int, int]:
        return -clear_distance(town, origin, k * math.pi / 4.0, town.half_size_m), k % 2, k

    k = min(range(8), key=view)
    return k * math.pi / 4.0 if k <= 4 else (k - 8) * math.pi / 4.0


def line_of_sight_3d(town: Town, eye: Vec3, target: Vec3) -> bool:
    """Whether the segment from ``eye`` to ``target`` passes through no obstacle that hides (boxes
    from the ground to their height)."""
    x, y, z = eye
    dx, dy, dz = target[0] - x, target[1] - y, target[2] - z
    for o in town.grid.along(x, y, target[0], target[1]):
        if o.hides and segment_box(x, y, z, dx, dy, dz, o.x0, o.y0, 0.0, o.x1, o.y1, o.height) < math.inf:
            return False
    return True


def sees(town: Town, viewer: Point, target: Point, eye_m: float = EYE_HEIGHT_M,
         target_m: float = CHEST_HEIGHT_M) -> bool:
    """Whether a person standing at ``viewer`` sees the chest of one standing at ``target`` (ground points)."""
    return line_of_sight_3d(town, (viewer[0], viewer[1], eye_m), (target[0], target[1], target_m))
