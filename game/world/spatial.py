"""Which of the town's obstacles lie near a point, a box or a segment: a uniform spatial hash.

The town's square area (``-half_size_m`` to ``half_size_m`` on x and y,
metres, x east, y north) is cut into square cells of ``cell_m``; each cell
lists the obstacles whose footprint, grown by ``reach_m`` on every side,
overlaps it. A query about a circle of radius up to ``reach_m`` then reads
one cell, whatever the number of obstacles in the town; collision
(:mod:`game.world.collision`) and sight (:mod:`game.world.sight`) ask it
instead of testing every obstacle. Points outside the area use the nearest
edge cell. Built once per town (:attr:`game.world.town.Town.grid`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Sequence

if TYPE_CHECKING:
    from .town import Obstacle


class ObstacleGrid:
    """The spatial hash of a town's obstacles (see the module's docstring)."""

    BLOCKS_KEPT = 4096  # the blocks of cells whose obstacles :meth:`in_box` keeps

    def __init__(self, obstacles: Sequence[Obstacle], half_size_m: float, cell_m: float = 2.0,
                 reach_m: float = 0.5) -> None:
        if not (cell_m > 0.0 and reach_m >= 0.0 and half_size_m > 0.0):
            raise ValueError(f"the grid needs cell_m > 0, reach_m >= 0 and half_size_m > 0, not "
                             f"{cell_m!r}, {reach_m!r}, {half_size_m!r}")
        self.obstacles = tuple(obstacles)
        self.origin = -half_size_m
        self.cell_m = cell_m
        self.reach_m = reach_m
        self.n = max(1, math.ceil(2.0 * half_size_m / cell_m))
        self._inv = 1.0 / cell_m
        members: list[list[int]] = [[] for _ in range(self.n * self.n)]
        for k, o in enumerate(self.obstacles):
            i0, i1 = self.column(o.x0 - reach_m), self.column(o.x1 + reach_m)
            j0, j1 = self.column(o.y0 - reach_m), self.column(o.y1 + reach_m)
            for j in range(j0, j1 + 1):
                for i in range(i0, i1 + 1):
                    members[j * self.n + i].append(k)
        self._members = [tuple(m) for m in members]
        self._cells = [tuple(self.obstacles[k] for k in m) for m in members]
        self._blocks: dict[tuple[int, int, int, int], tuple[Obstacle, ...]] = {}

    def column(self, coordinate: float) -> int:
        """The cell index (0 to n - 1) of a coordinate, on either axis; clamped to the area."""
        i = math.floor((coordinate - self.origin) / self.cell_m)
        return 0 if i < 0 else self.n - 1 if i >= self.n else i

    def near(self, x: float, y: float) -> tuple[Obstacle, ...]:
        """The obstacles within ``reach_m`` of the point's cell (a superset of those within ``reach_m`` of it)."""
        n, inv, origin = self.n, self._inv, self.origin  # column(), inlined: this runs per body and step
        i, j = int((x - origin) * inv), int((y - origin) * inv)  # truncation: only negatives, clamped to 0, differ
        i = 0 if i < 0 else n - 1 if i >= n else i
        j = 0 if j < 0 else n - 1 if j >= n else j
        return self._cells[j * n + i]

    def in_box(self, x0: float, y0: float, x1: float, y1: float) -> tuple[Obstacle, ...]:
        """The obstacles of the cells the box overlaps, each once, in the town's order.

        A superset of the obstacles within ``reach_m`` of the box. Kept per
        block of cells (a ball's step and a zombie's look at the player ask
        for the same blocks step after step), at most ``BLOCKS_KEPT``.
        """
        i0, i1, j0, j1 = self.column(x0), self.column(x1), self.column(y0), self.column(y1)
        if i0 == i1 and j0 == j1:
            return self._cells[j0 * self.n + i0]
        key = (i0, i1, j0, j1)
        found = self._blocks.get(key)
        if found is None:
            members: set[int] = set()
            for j in range(j0, j1 + 1):
                for i in range(i0, i1 + 1):
                    members.update(self._members[j * self.n + i])
            if len(self._blocks) >= self.BLOCKS_KEPT:
                self._blocks.clear()
            found = self._blocks[key] = tuple(self.obstacles[k] for k in sorted(members))
        return found

    def along(self, ax: float, ay: float, bx: float, by: float) -> Sequence[Obstacle]:
        """The obstacles of the cells the segment ab crosses, each once, in the order the segment meets
        the cells (from a): a line-of-sight test can stop at the first that blocks. A segment that
        leaves the area gets the obstacles of every cell its box overlaps, in the town's order.

        Walks the cells with Amanatides and Woo's traversal ("A fast voxel
        traversal algorithm for ray tracing", Eurographics 1987): at each step
        the segment leaves its cell across the nearer of the next x and y cell
        boundaries.
        """
        n, size, low, high = self.n, self.cell_m, self.origin, self.origin + self.n * self.cell_m
        if not (low <= min(ax, ay, bx, by) and max(ax, ay, bx, by) < high):  # leaves the area: every cell it may touch
            return self.in_box(min(ax, bx), min(ay, by), max(ax, bx), max(ay, by))
        i, j = self.column(ax), self.column(ay)
        i_end, j_end = self.column(bx), self.column(by)
        dx, dy = bx - ax, by - ay
        step_i = 1 if dx > 0.0 else -1
        step_j = 1 if dy > 0.0 else -1
        # the parameter t (0 at a, 1 at b) of the next x and y boundaries, and the t per cell
        if dx != 0.0:
            next_x = self.origin + (i + (1 if dx > 0.0 else 0)) * size
            t_x, dt_x = (next_x - ax) / dx, size / abs(dx)
        else:
            t_x, dt_x = math.inf, math.inf
        if dy != 0.0:
            next_y = self.origin + (j + (1 if dy > 0.0 else 0)) * size
            t_y, dt_y = (next_y - ay) / dy, size / abs(dy)
        else:
            t_y, dt_y = math.inf, math.inf
        seen: set[int] = set()
        found: list[Obstacle] = []
        while True:
            for k in self._members[j * n + i]:
                if k not in seen:
                    seen.add(k)
                    found.append(self.obstacles[k])
            if (i == i_end and j == j_end) or min(t_x, t_y) > 1.0:
                return found
            if t_x < t_y:
                i += step_i
                t_x += dt_x
            else:
                j += step_j
                t_y += dt_y
            if not (0 <= i < n and 0 <= j < n):
                return found
