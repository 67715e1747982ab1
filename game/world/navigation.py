"""Ways through the town for the zombies: free regions, a flow field over them, a waypoint per zombie. Pure logic.

Frames and units as :mod:`game.world.town`: metres, x east, y north.

The budget: some 60 zombies steer 120 times a second, and a headless match
runs at 50 times real time or more in pure Python, so a zombie's step may
cost a few microseconds and the field to the player must not be rebuilt
on every step of his. A flow field on the cells of a fine grid (the usual
design) costs some 10 ms per rebuild here (Dijkstra on 9,000 cells), and a
walking player enters a new 0.5 m cell six times a second. So the field
works on regions instead:

Regions. The town's ground is cut into square cells of ``cell_m`` (0.5 m).
A cell is free when all of it lies at least ``agent_radius_m`` (a zombie's
0.35 m) outside every obstacle's footprint (a square margin around each box)
and inside the town's area by as much: a zombie's centre anywhere in a free
cell keeps its body clear of every obstacle. The free cells are merged,
greedily in rows, into rectangles of at most ``region_max_m`` a side: the
regions. A region is convex, so a zombie walks in a straight line between
any two points of it, and two regions that share a stretch of edge (a
portal) are joined through it. A 2.5 m street leaves a 1.8 m strip for the
centres, at least two whole cells: streets stay open.

The flow field. For the player's region, Dijkstra over the portals (the
length between two portals of a region: their midpoints' distance) gives
every portal its way's length to the player's region, and every region
its exit: the portal that minimises the way from the region's centre
through it. It is rebuilt only when the player walks into another region
(at most about once a second at walking pace) and kept for when he comes
back.

A zombie's waypoint (:meth:`Navigator.waypoint`, O(1)): in the player's
region, the player himself; else half a cell past its region's exit, at
the point where its line to the way beyond (the next region's exit, or the
player) crosses the exit (kept a margin in from the portal's ends). When
the straight walk there would cross the portal's line outside the portal,
it first walks to the same point half a cell before the portal. Every such
straight walk stays inside the region and the next one, so a zombie that
follows its waypoints never touches an obstacle; pushes from the crowd
(the arena's separation) and :func:`game.world.collision.push_out` do the
rest. The ways bend a little at the regions' edges: round a single wall
some 16% longer than the shortest.

Lost zombies. A body fits through gaps the grid leaves closed (a 0.7 m
body through a 1.3 m gap whose free strip spans no whole 0.5 m cell),
and the crowd pushes zombies, or they follow the player, into pockets
that have no way out on the grid. A zombie in a region with no way to
the goal asks a finer navigator (cells half as wide, built the first time
one is needed), which sees such gaps open; only where that too knows no
way does it head straight for the goal.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

from .town import Rect, Town

UNREACHABLE = -1  # a region with no way to the goal (its zombies head straight for it)
GOAL = -2  # the goal's own region


@dataclass(frozen=True)
class NavSettings:
    """Every tunable of the navigation, with its default.

    ``agent_radius_m`` 0.35: the walkers' radius (a zombie's,
    ``ArenaSettings.zombie_radius_m``): a free cell keeps a body this wide
    clear of the obstacles.
    ``cell_m`` 0.5: the side of a grid cell; a passage is open when at least
    ``cell_m`` of its width is left for the centres (over 1.2 m wide;
    worst case on the grid, 2 * agent_radius_m + 2 * cell_m, 1.7 m).
    ``region_max_m`` 4: the longest side of a region; smaller regions give
    straighter ways at the cost of a longer rebuild.
    """

    agent_radius_m: float = 0.35
    cell_m: float = 0.5
    region_max_m: float = 4.0

    def __post_init__(self) -> None:
        for name in ("agent_radius_m", "cell_m", "region_max_m"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (0.0 < value < math.inf):
                raise ValueError(f"{name} must be a finite number more than 0, not {value!r}")
        if self.region_max_m < self.cell_m:
            raise ValueError(f"region_max_m ({self.region_max_m}) must be at least cell_m ({self.cell_m})")


@dataclass(frozen=True)
class Portal:
    """The stretch of edge two regions share: on the line ``x = line`` (``vertical``) or ``y = line``,
    from ``lo`` to ``hi`` along it; ``low`` is the region on its lower-coordinate side, ``high`` the other."""

    low: int
    high: int
    vertical: bool
    line: float
    lo: float
    hi: float

    @property
    def mid(self) -> tuple[float, float]:
        """Its midpoint (m)."""
        along = (self.lo + self.hi) / 2.0
        return (self.line, along) if self.vertical else (along, self.line)


class Navigator:
    """The regions of one town and the flow field to a goal (the player); see the module's docstring.

    Build it once per town (tens of milliseconds), call :meth:`set_goal`
    with the player's position every step (O(1) unless he entered another
    region), then :meth:`waypoint` for each walking zombie.
    """

    def __init__(self, town: Town, settings: NavSettings | None = None, finer: bool = True) -> None:
        """``finer``: lost zombies ask a navigator on cells half as wide (see the module's docstring)."""
        self.town = town
        self.settings = s = settings if settings is not None else NavSettings()
        self._finer: Navigator | None = None
        self._has_finer = finer
        self.origin = -town.half_size_m
        self.n = max(1, math.floor(2.0 * town.half_size_m / s.cell_m))
        self._inv, self._half = 1.0 / s.cell_m, s.cell_m / 2.0
        free = self._free_cells()
        self.free = free
        self.regions: list[Rect] = []  # in metres
        region_of = self._merge(free)  # per cell: its region, -1 if blocked
        self.portals: list[Portal] = []
        self.region_portals: list[list[int]] = [[] for _ in self.regions]
        self._find_portals(region_of)
        self.cell_region = self._nearest_regions(region_of)  # per cell: its region, or the nearest free cell's
        self.centres = [((r[0] + r[2]) / 2.0, (r[1] + r[3]) / 2.0) for r in self.regions]
        self._fields: dict[int, tuple[list[int], list[float], list[int]]] = {}
        self.goal = (0.0, 0.0)
        self.goal_region = -1
        self._exits: list[int] = []
        self._lengths: list[float] = []
        self._entries: list[int] = []
        # per portal, what waypoint() reads: (vertical, line, lo, hi, margin, low region, high region)
        half = s.cell_m / 2.0
        self._steer = [(p.vertical, p.line, p.lo, p.hi, min(half, (p.hi - p.lo) / 2.0), p.low, p.high)
                       for p in self.portals]
        self._mids = [p.mid for p in self.portals]
        self._links = [(self._neighbours(k, p.low), self._neighbours(k, p.high)) for k, p in enumerate(self.portals)]
        self.set_goal(*town.start)

    # ------------------------------------------------------------ building

    def _free_cells(self) -> bytearray:
        """1 for each free cell (row-major, row j from the south, column i from the west), else 0."""
        s, n, c, o = self.settings, self.n, self.settings.cell_m, self.origin
        r, h = s.agent_radius_m, self.town.half_size_m
        free = bytearray(n * n)
        first = math.ceil(r / c - 1e-9)  # the first cell whose low edge is r in from the town's
        last = math.floor((2.0 * h - r) / c + 1e-9) - 1  # the last whose high edge is r in
        for j in range(first, last + 1):
            free[j * n + first:j * n + last + 1] = b"\x01" * (last + 1 - first)
        for ob in self.town.obstacles:
            i0 = max(0, math.floor((ob.x0 - r - o) / c))
            i1 = min(n, math.ceil((ob.x1 + r - o) / c))
            j0 = max(0, math.floor((ob.y0 - r - o) / c))
            j1 = min(n, math.ceil((ob.y1 + r - o) / c))
            for j in range(j0, j1):
                free[j * n + i0:j * n + i1] = bytes(max(0, i1 - i0))
        return free

    def _merge(self, free: bytearray) -> list[int]:
        """Merge the free cells into rectangles (greedily: along a row, then up while the whole span is free)."""
        n, c, o = self.n, self.settings.cell_m, self.origin
        most = max(1, math.floor(self.settings.region_max_m / c + 1e-9))
        region_of = [-1] * (n * n)
        for j in range(n):
            for i in range(n):
                k = j * n + i
                if not free[k] or region_of[k] >= 0:
                    continue
                w = 1
                while w < most and i + w < n and free[k + w] and region_of[k + w] < 0:
                    w += 1
                h = 1
                while h < most and j + h < n and all(free[(j + h) * n + i + a] and region_of[(j + h) * n + i + a] < 0
                                                     for a in range(w)):
                    h += 1
                index = len(self.regions)
                self.regions.append((o + i * c, o + j * c, o + (i + w) * c, o + (j + h) * c))
                for b in range(h):
                    row = (j + b) * n + i
                    region_of[row:row + w] = [index] * w
        return region_of

    def _find_portals(self, region_of: list[int]) -> None:
        """The portals: runs of cells along a region's east and north edges whose neighbours all belong
        to one other region (the west and south edges are the neighbours' east and north)."""
        n, c, o = self.n, self.settings.cell_m, self.origin
        for index, (x0, y0, x1, y1) in enumerate(self.regions):
            i0, j0 = round((x0 - o) / c), round((y0 - o) / c)
            i1, j1 = round((x1 - o) / c), round((y1 - o) / c)
            if i1 < n:  # east edge: the column i1, rows j0..j1-1
                self._runs(index, True, x1, [region_of[j * n + i1] for j in range(j0, j1)], y0)
            if j1 < n:  # north edge: the row j1, columns i0..i1-1
                self._runs(index, False, y1, region_of[j1 * n + i0:j1 * n + i1], x0)

    def _runs(self, low: int, vertical: bool, line: float, neighbours: list[int], start: float) -> None:
        c = self.settings.cell_m
        k = 0
        while k < len(neighbours):
            high = neighbours[k]
            end = k
            while end + 1 < len(neighbours) and neighbours[end + 1] == high:
                end += 1
            if high >= 0:
                self.region_portals[low].append(len(self.portals))
                self.region_portals[high].append(len(self.portals))
                self.portals.append(Portal(low, high, vertical, line, start + k * c, start + (end + 1) * c))
            k = end + 1

    def _nearest_regions(self, region_of: list[int]) -> list[int]:
        """Each cell's region; a blocked cell takes the region of a nearest free cell (breadth first, four
        neighbours), so a body pushed into an obstacle's margin still has a way."""
        n = self.n
        out = list(region_of)
        frontier = [k for k in range(n * n) if out[k] >= 0]
        while frontier:
            grown = []
            for k in frontier:
                i, j = k % n, k // n
                for m, ok in ((k - 1, i > 0), (k + 1, i < n - 1), (k - n, j > 0), (k + n, j < n - 1)):
                    if ok and out[m] < 0:
                        out[m] = out[k]
                        grown.append(m)
            frontier = grown
        return out

    def _neighbours(self, portal: int, region: int) -> list[tuple[int, float]]:
        """The other portals of ``region`` with their midpoints' distances from ``portal``'s."""
        mx, my = self._mids[portal]
        return [(q, math.hypot(self._mids[q][0] - mx, self._mids[q][1] - my))
                for q in self.region_portals[region] if q != portal]

    # ------------------------------------------------------------ queries

    def region_at(self, x: float, y: float) -> int:
        """The region of the cell under (x, y) (of a nearest free cell if it is blocked); -1 in a town with
        no free cell."""
        n, inv = self.n, self._inv
        i, j = int((x - self.origin) * inv), int((y - self.origin) * inv)
        i = 0 if i < 0 else n - 1 if i >= n else i
        j = 0 if j < 0 else n - 1 if j >= n else j
        return self.cell_region[j * n + i]

    def set_goal(self, x: float, y: float) -> None:
        """Make (x, y) the goal (the player); the flow field follows when he enters another region."""
        self.goal = (x, y)
        region = self.region_at(x, y)
        if region != self.goal_region:
            self.goal_region = region
            field = self._fields.get(region)
            if field is None:
                field = self._fields[region] = self._flow_field(region)
            self._exits, self._lengths, self._entries = field

    def waypoint(self, x: float, y: float) -> tuple[float, float, bool]:
        """Where a zombie at (x, y) walks straight to next: ``(x, y, final)``; ``final`` when it is the goal
        itself (the zombie is in the goal's region, or has no way there)."""
        n, inv, origin = self.n, self._inv, self.origin
        i, j = int((x - origin) * inv), int((y - origin) * inv)  # truncation: only negatives, clamped to 0, differ
        i = 0 if i < 0 else n - 1 if i >= n else i
        j = 0 if j < 0 else n - 1 if j >= n else j
        region = self.cell_region[j * n + i]
        exit_ = self._exits[region] if region >= 0 else UNREACHABLE
        if exit_ < 0:
            return self._lost(x, y) if exit_ == UNREACHABLE and self._has_finer else (self.goal[0], self.goal[1], True)
        vertical, line, lo, hi, margin, low, high = self._steer[exit_]
        if region == low:
            side, beyond_region = 1.0, high
        else:
            side, beyond_region = -1.0, low
        after = self._exits[beyond_region]  # the way on, past the portal
        ax, ay = self._mids[after] if after >= 0 else self.goal
        if vertical:
            p_across, p_along, a_across, a_along = x, y, ax, ay
        else:
            p_across, p_along, a_across, a_along = y, x, ay, ax
        depth = (line - p_across) * side  # how far the zombie is before the portal's line
        beyond = (a_across - line) * side  # and the way on past it
        along = p_along + (a_along - p_along) * depth / (depth + beyond) if depth > 0.0 and beyond > 0.0 else a_along
        along = lo + margin if along < lo + margin else hi - margin if along > hi - margin else along
        half = self._half
        # where a straight walk to half a cell past the portal (at ``along``) crosses the portal's line
        crossing = p_along + (along - p_along) * depth / (depth + half) if depth > 0.0 else p_along
        across = line + side * half if lo < crossing < hi else line - side * half  # else first to before it
        return (across, along, False) if vertical else (along, across, False)

    def _lost(self, x: float, y: float) -> tuple[float, float, bool]:
        """The waypoint of a zombie whose region has no way to the goal: the finer navigator's."""
        finer = self._finer
        if finer is None:
            s = self.settings
            finer = self._finer = Navigator(self.town, NavSettings(s.agent_radius_m, s.cell_m / 2.0, s.region_max_m),
                                            finer=False)
        finer.set_goal(*self.goal)
        return finer.waypoint(x, y)

    def path_length(self, x: float, y: float) -> float:
        """The length (m) of a zombie's way from (x, y) to the goal, as the flow field sees it (through the
        portals' midpoints: an overestimate); ``math.inf`` when there is no way."""
        region = self.region_at(x, y)
        if region < 0:
            return math.inf
        exit_ = self._exits[region]
        if exit_ == GOAL:
            return math.hypot(x - self.goal[0], y - self.goal[1])
        if exit_ == UNREACHABLE:
            return math.inf
        mx, my = self.portals[exit_].mid
        ex, ey = self.portals[self._entries[exit_]].mid  # where the way enters the goal's region
        gx, gy = self.centres[self.goal_region]
        return (math.hypot(x - mx, y - my) + self._lengths[exit_] - math.hypot(ex - gx, ey - gy)
                + math.hypot(ex - self.goal[0], ey - self.goal[1]))

    # ------------------------------------------------------------ the flow field

    def _flow_field(self, goal: int) -> tuple[list[int], list[float], list[int]]:
        """Dijkstra over the portals from the goal's region: each region's exit, each portal's length and
        the portal by which its way enters the goal's region.

        A portal's length is its way to the goal region's centre; its ``via``
        is the region the way goes on through, and a region may leave only by
        a portal whose way goes on beyond it (never back through itself).
        """
        portals, region_portals, links = self.portals, self.region_portals, self._links
        mids = self._mids
        length = [math.inf] * len(portals)
        via = [-1] * len(portals)
        entry = [-1] * len(portals)
        heap: list[tuple[float, int]] = []
        exits = [UNREACHABLE] * len(self.regions)
        if goal < 0:
            return exits, length, entry
        gx, gy = self.centres[goal]
        for p in region_portals[goal]:
            length[p] = math.hypot(mids[p][0] - gx, mids[p][1] - gy)
            via[p] = goal
            entry[p] = p
            heap.append((length[p], p))
        heapq.heapify(heap)
        pop, push = heapq.heappop, heapq.heappush
        while heap:
            d, p = pop(heap)
            if d > length[p]:
                continue
            portal = portals[p]
            region = portal.high if via[p] == portal.low else portal.low  # the side the way comes from
            for q, w in links[p][region == portal.high]:
                nd = d + w
                if nd < length[q]:
                    length[q] = nd
                    via[q] = region
                    entry[q] = entry[p]
                    push(heap, (nd, q))
        for region, (cx, cy) in enumerate(self.centres):
            best = math.inf
            for q in region_portals[region]:
                if via[q] != region and length[q] < math.inf:
                    way = length[q] + math.hypot(mids[q][0] - cx, mids[q][1] - cy)
                    if way < best:
                        best, exits[region] = way, q
        exits[goal] = GOAL
        return exits, length, entry
