"""The abandoned town: its data and its seeded generator (Zhu & Shi, sec. 5, Fig. 6). Pure logic, no pygame.

The paper's game: "an avatar of the player arrives in an abandoned town with
zombies surrounded" (sec. 5); Fig. 6 shows the avatar in a street between
houses. Here the town is a square area (``half_size_m`` either side of the
origin; metres, x east, y north, z up, as :mod:`game.arena_model`) of open
ground (:class:`Street`: streets, alleys and squares) and blocks. The blocks
are cut into lots along their long side; a lot holds a building, a ruin
behind a standing wall, or an empty plot behind a fence, with a pavement
between the block's edge and what stands on it, and now and then an alley
between two lots. The streets hold wrecked cars and lamp posts against their
edges. Every obstacle (:class:`Obstacle`) is an axis-aligned box: a
footprint on the ground and a height.

Promises (the tests check each against an independent sampling):
  every obstacle lies inside the area; none comes within ``start_radius_m``
  of :attr:`Town.start`, where the player starts; every cross-section of a
  street or an alley keeps a clear gap of at least ``min_passage_m``
  (2.5 m) across; every spawn point (the street ends at the town's edge and
  the open alleys) is clear and connected to the start.

Layouts (:data:`LAYOUTS`), chosen by the seed unless named:
  ``grid``        three streets east-west crossed by two north-south: a
                  grid of blocks; the start is on the middle street.
  ``crossroads``  two wide main streets crossing at a central square, one
                  narrower street each way on a side the seed picks; large
                  blocks get a back alley.
  ``ring``        a market square inside a ring road, four streets from the
                  ring to the edges.

The same seed gives the same town. The generator draws from its own random
stream, ``np.random.default_rng(SeedSequence(seed, spawn_key=(TOWN_STREAM,)))``,
so building the town never changes the draws of the arena's
``default_rng(seed)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Callable

import numpy as np
from mypy_extensions import mypyc_attr

from .spatial import ObstacleGrid

Rect = tuple[float, float, float, float]  # x0, y0, x1, y1 (m), x0 < x1, y0 < y1
Point = tuple[float, float]
TOWN_STREAM = 0x746F776E  # the spawn key of the town's random stream ("town")
OPEN_KINDS = ("street", "alley", "square")


@dataclass(frozen=True)
class KindSpec:
    """What one kind of obstacle is like: its size ranges (m) and whether it hides a zombie behind it."""

    width_m: tuple[float, float]  # the footprint's short side
    length_m: tuple[float, float]  # its long side
    height_m: tuple[float, float]
    hides: bool  # blocks sight; a lamp post is too thin to hide a zombie (0.7 m wide)


KINDS: dict[str, KindSpec] = {
    "building": KindSpec(width_m=(3.0, 12.0), length_m=(3.0, 14.0), height_m=(5.0, 11.0), hides=True),
    "ruin": KindSpec(width_m=(2.0, 12.0), length_m=(2.0, 14.0), height_m=(1.2, 4.0), hides=True),
    "wall": KindSpec(width_m=(0.3, 0.5), length_m=(1.5, 5.0), height_m=(1.0, 2.6), hides=True),
    "car": KindSpec(width_m=(1.7, 2.0), length_m=(3.8, 4.8), height_m=(1.3, 1.5), hides=True),
    "fence": KindSpec(width_m=(0.1, 0.15), length_m=(1.0, 14.0), height_m=(1.0, 1.4), hides=True),
    "lamp_post": KindSpec(width_m=(0.2, 0.3), length_m=(0.2, 0.3), height_m=(4.0, 5.5), hides=False),
}


@dataclass(frozen=True)
class Obstacle:
    """A box standing on the ground: footprint ``x0 < x1``, ``y0 < y1`` (m) and ``height`` (m)."""

    kind: str  # one of KINDS
    x0: float
    y0: float
    x1: float
    y1: float
    height: float

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {', '.join(KINDS)}, not {self.kind!r}")
        numbers = (self.x0, self.y0, self.x1, self.y1, self.height)
        if not (all(math.isfinite(v) for v in numbers) and self.x0 < self.x1 and self.y0 < self.y1
                and self.height > 0.0):
            raise ValueError(f"an obstacle needs finite x0 < x1, y0 < y1 and a height > 0, not {numbers}")

    @property
    def hides(self) -> bool:
        """Whether it blocks sight (its kind's :attr:`KindSpec.hides`)."""
        return KINDS[self.kind].hides


@dataclass(frozen=True)
class Street:
    """Open ground, for drawing and the minimap: a street, an alley or a square (an axis-aligned rectangle, m)."""

    kind: str  # one of OPEN_KINDS
    x0: float
    y0: float
    x1: float
    y1: float

    @property
    def along_x(self) -> bool:
        """Whether it runs east-west (its long side along x)."""
        return self.x1 - self.x0 >= self.y1 - self.y0

    @property
    def width(self) -> float:
        """Its short side (m): the width of a street or an alley."""
        return min(self.x1 - self.x0, self.y1 - self.y0)


@mypyc_attr(native_class=False)  # a plain class even when compiled: __post_init__ sets the frozen grid
@dataclass(frozen=True)
class Town:
    """A town: its obstacles, open ground, start square and spawn points (see the module's docstring).

    A hand-built town (tests, tutorials) needs only ``half_size_m`` and ``obstacles``.
    """

    half_size_m: float  # the town's area: -half_size_m..half_size_m on x and on y
    obstacles: tuple[Obstacle, ...]
    layout: str = "custom"
    seed: int = 0
    start: Point = (0.0, 0.0)  # the start square's centre, where the player starts
    start_radius_m: float = 0.0  # kept clear of obstacles
    spawn_points: tuple[Point, ...] = ()  # where zombies come in: street ends at the edge, alleys
    streets: tuple[Street, ...] = ()
    min_passage_m: float = 2.5  # the clear gap every street and alley keeps across
    grid: ObstacleGrid = field(init=False, repr=False, compare=False)  # the spatial hash of ``obstacles``

    def __post_init__(self) -> None:
        # Built here, not as a cached_property: the compiled build turns one into a plain property,
        # which would build the grid again at every use.
        object.__setattr__(self, "grid", ObstacleGrid(self.obstacles, self.half_size_m))


@dataclass(frozen=True)
class TownSettings:
    """Every tunable of the town generator, with its default (metres; a pair is a uniform range).

    Area:
      ``half_size_m`` 24: the town is a 48 m square about the origin.
      ``start_radius_m`` 4: no obstacle within this of the start (the origin).
    Open ground:
      ``street_width_m`` (5, 7): a street's width (the main streets of
      ``crossroads``: ``main_street_m`` 8).
      ``square_half_m`` (6, 8): half the side of the central square
      (``crossroads``, ``ring``).
      ``alley_width_m`` (2.6, 3.4): an alley between two lots, or behind a
      deep block's two rows.
      ``deep_block_m`` 18: a block deeper than this is split into two rows by a back alley.
    Blocks:
      ``lot_length_m`` (5, 10): a lot's frontage (the last lot of a block
      takes what is left, up to ``lot_length_m[1] + lot_min_m``); ``lot_min_m`` 4.
      ``alley_chance`` 0.4: after a lot, an alley (if the block has room).
      ``setback_m`` (0.8, 1.5): the pavement between a block's edge and its buildings.
      ``building_chance`` 0.55, ``ruin_chance`` 0.3: what a lot holds; the
      rest are empty plots behind a fence, with ``plot_car_chance`` 0.3 of a wreck in it.
    Streets:
      ``car_per_m`` 0.06: tries at a wrecked car per metre of street (some
      fail: no room); ``lamp_spacing_m`` 12: lamp posts along a street,
      either side in turn.
      ``min_passage_m`` 2.5: the clear gap kept across every street and alley;
      obstacles less than ``passage_margin_m`` 1.5 apart along a street
      count as side by side for it.
      ``gap_m`` 0.3: the least gap between two things placed in a street.
    Spawn points:
      ``spawn_inset_m`` 1: a street's spawn point is this far in from the
      town's edge; ``spawn_clear_m`` 2: nothing is placed this near a spawn point.
    """

    half_size_m: float = 24.0
    start_radius_m: float = 4.0
    street_width_m: tuple[float, float] = (5.0, 7.0)
    main_street_m: float = 8.0
    square_half_m: tuple[float, float] = (6.0, 8.0)
    alley_width_m: tuple[float, float] = (2.6, 3.4)
    deep_block_m: float = 18.0
    lot_length_m: tuple[float, float] = (5.0, 10.0)
    lot_min_m: float = 4.0
    alley_chance: float = 0.4
    setback_m: tuple[float, float] = (0.8, 1.5)
    building_chance: float = 0.55
    ruin_chance: float = 0.3
    plot_car_chance: float = 0.3
    car_per_m: float = 0.06
    lamp_spacing_m: float = 12.0
    min_passage_m: float = 2.5
    passage_margin_m: float = 1.5
    gap_m: float = 0.3
    spawn_inset_m: float = 1.0
    spawn_clear_m: float = 2.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            pair = value if isinstance(value, tuple) else (value,)
            if not (len(pair) in (1, 2) and all(_number(v) and v >= 0.0 for v in pair)):
                raise ValueError(f"{f.name} must be a finite number (or a pair) of 0 or more, not {value!r}")
            if len(pair) == 2 and pair[0] > pair[1]:
                raise ValueError(f"{f.name} must be a range (low, high) with low <= high, not {value!r}")
        checks = (
            (self.half_size_m >= 15.0, f"half_size_m must be at least 15 m, not {self.half_size_m!r}"),
            (min(self.street_width_m[0], self.main_street_m, self.alley_width_m[0]) >= self.min_passage_m > 0.0,
             f"streets, main streets and alleys must be at least min_passage_m ({self.min_passage_m}) wide "
             "and min_passage_m more than 0"),
            (self.start_radius_m < self.square_half_m[0],
             f"start_radius_m ({self.start_radius_m}) must be below square_half_m's low end "
             f"({self.square_half_m[0]})"),
            (self.building_chance + self.ruin_chance <= 1.0,
             "building_chance + ruin_chance must be at most 1"),
            (max(self.alley_chance, self.plot_car_chance) <= 1.0,
             "alley_chance and plot_car_chance must be at most 1"),
            (self.lot_length_m[0] > 0.0 and self.lot_min_m > 0.0 and self.lamp_spacing_m > 0.0,
             "lot_length_m, lot_min_m and lamp_spacing_m must be more than 0"),
            (self.deep_block_m > 2 * self.lot_min_m,
             f"deep_block_m must be more than twice lot_min_m ({self.lot_min_m})"),
        )
        for ok, message in checks:
            if not ok:
                raise ValueError(message)


def _number(v: object) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


# ---------------------------------------------------------------- rectangles

def overlaps(a: Rect, b: Rect) -> bool:
    """Whether two rectangles share some area (touching edges do not)."""
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def subtract(a: Rect, hole: Rect) -> list[Rect]:
    """``a`` without ``hole``: up to four rectangles (a full-width slab below and above the hole, and
    the pieces left and right of it in between)."""
    if not overlaps(a, hole):
        return [a]
    x0, y0, x1, y1 = a
    hy0, hy1 = max(y0, hole[1]), min(y1, hole[3])
    pieces = [(x0, y0, x1, hy0), (x0, hy1, x1, y1), (x0, hy0, max(x0, hole[0]), hy1), (min(x1, hole[2]), hy0, x1, hy1)]
    return [p for p in pieces if p[0] < p[2] and p[1] < p[3]]


def box_distance(rect: Rect, x: float, y: float) -> float:
    """The distance (m) from a point to a rectangle (0 inside)."""
    dx = max(rect[0] - x, 0.0, x - rect[2])
    dy = max(rect[1] - y, 0.0, y - rect[3])
    return math.hypot(dx, dy)


def _rect(o: Obstacle | Street) -> Rect:
    return (o.x0, o.y0, o.x1, o.y1)


# ---------------------------------------------------------------- layouts

def _street(along_x: bool, centre: float, width: float, a0: float, a1: float, kind: str = "street") -> Street:
    """A street (or alley) running along x (or y) from a0 to a1, centred across on ``centre``."""
    c0, c1 = centre - width / 2.0, centre + width / 2.0
    return Street(kind, a0, c0, a1, c1) if along_x else Street(kind, c0, a0, c1, a1)


def _square(half: float) -> Street:
    return Street("square", -half, -half, half, half)


def _grid(rng: np.random.Generator, s: TownSettings) -> list[Street]:
    """Three streets east-west (the start on the middle one) and two north-south, edge to edge."""
    h = s.half_size_m
    spacing = float(rng.uniform(0.5, 0.62)) * h
    out = [_street(True, centre, float(rng.uniform(*s.street_width_m)), -h, h)
           for centre in (-spacing + float(rng.uniform(-1.0, 1.0)), 0.0, spacing + float(rng.uniform(-1.0, 1.0)))]
    offset = float(rng.uniform(0.3, 0.45)) * h
    out += [_street(False, centre, float(rng.uniform(*s.street_width_m)), -h, h) for centre in (-offset, offset)]
    return out


def _crossroads(rng: np.random.Generator, s: TownSettings) -> list[Street]:
    """Two main streets crossing at a central square, and one narrower street each way."""
    h = s.half_size_m
    out = [_square(float(rng.uniform(*s.square_half_m)))]
    for along_x in (True, False):
        out.append(_street(along_x, 0.0, s.main_street_m, -h, h))
        side = 1.0 if rng.random() < 0.5 else -1.0
        out.append(_street(along_x, side * float(rng.uniform(0.5, 0.65)) * h,
                           float(rng.uniform(*s.street_width_m)), -h, h))
    return out


def _ring(rng: np.random.Generator, s: TownSettings) -> list[Street]:
    """A market square inside a ring road; a street from the middle of each side of the ring to the edge."""
    h = s.half_size_m
    q = float(rng.uniform(*s.square_half_m))
    w = float(rng.uniform(*s.street_width_m))
    r = q + w  # the ring's outer half side
    out = [_square(q),
           Street("street", -r, q, r, r), Street("street", -r, -r, r, -q),  # north and south: full length
           Street("street", q, -q, r, q), Street("street", -r, -q, -q, q)]  # east and west: between them
    for along_x, sign in ((False, 1.0), (True, 1.0), (False, -1.0), (True, -1.0)):
        centre = float(rng.uniform(-0.3, 0.3)) * q
        a0, a1 = (r, h) if sign > 0 else (-h, -r)
        out.append(_street(along_x, centre, float(rng.uniform(*s.street_width_m)), a0, a1))
    return out


LAYOUTS: dict[str, Callable[[np.random.Generator, TownSettings], list[Street]]] = {
    "grid": _grid, "crossroads": _crossroads, "ring": _ring}


# ---------------------------------------------------------------- the generator

def make_town(seed: int, layout: str | None = None, settings: TownSettings | None = None) -> Town:
    """The town of ``seed``: ``layout`` (one of :data:`LAYOUTS`) or the one the seed picks.

    The layout is drawn first either way, so ``make_town(seed)`` equals
    ``make_town(seed, make_town(seed).layout)``.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a whole number of 0 or more, not {seed!r}")
    if layout is not None and layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {', '.join(LAYOUTS)}, not {layout!r}")
    s = settings if settings is not None else TownSettings()
    if not isinstance(s, TownSettings):
        raise ValueError(f"settings must be TownSettings, not {type(s).__name__}")
    rng = np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(TOWN_STREAM,)))
    names = list(LAYOUTS)
    drawn = names[int(rng.integers(len(names)))]
    name = layout if layout is not None else drawn
    builder = _Builder(rng, s, LAYOUTS[name](rng, s))
    builder.build()
    return Town(half_size_m=s.half_size_m, obstacles=tuple(builder.obstacles), layout=name, seed=int(seed),
                start=(0.0, 0.0), start_radius_m=s.start_radius_m, spawn_points=tuple(builder.spawns),
                streets=tuple(builder.open), min_passage_m=s.min_passage_m)


class _Builder:
    """Places the obstacles and spawn points of one town on the open ground its layout made."""

    def __init__(self, rng: np.random.Generator, settings: TownSettings, open_ground: list[Street]) -> None:
        self.rng, self.s = rng, settings
        self.open = list(open_ground)
        self.obstacles: list[Obstacle] = []
        self.spawns: list[Point] = []
        self.mouths: list[Rect] = []  # alley mouths: kept clear so the alleys stay open

    def build(self) -> None:
        """Spawn points at the street ends, then the blocks, then the streets' cars and lamp posts."""
        h = self.s.half_size_m
        for street in [st for st in self.open if st.kind == "street"]:
            self._edge_spawns(street)
        blocks: list[Rect] = [(-h, -h, h, h)]
        for area in list(self.open):
            blocks = [piece for block in blocks for piece in subtract(block, _rect(area))]
        for block in blocks:
            for part in self._rows(block):
                self._fill(part)
        for area in list(self.open):
            if area.kind == "street":
                self._furnish(area)
            elif area.kind == "square":
                self._square_lamps(area)

    # ------------------------------------------------------------ spawn points

    def _edge_spawns(self, street: Street) -> None:
        """A spawn point where the street meets the town's edge, ``spawn_inset_m`` in, on its middle line."""
        h, inset = self.s.half_size_m, self.s.spawn_inset_m
        mid_x, mid_y = (street.x0 + street.x1) / 2.0, (street.y0 + street.y1) / 2.0
        if street.along_x:
            ends = [(-h + inset, mid_y)] * (street.x0 <= -h) + [(h - inset, mid_y)] * (street.x1 >= h)
        else:
            ends = [(mid_x, -h + inset)] * (street.y0 <= -h) + [(mid_x, h - inset)] * (street.y1 >= h)
        self.spawns.extend(ends)

    # ------------------------------------------------------------ blocks

    def _rows(self, block: Rect) -> list[Rect]:
        """A block, or the two rows of a deep one with a back alley between them."""
        x0, y0, x1, y1 = block
        along_x = x1 - x0 >= y1 - y0
        c0, c1 = (y0, y1) if along_x else (x0, x1)
        if c1 - c0 <= self.s.deep_block_m:
            return [block]
        width = float(self.rng.uniform(*self.s.alley_width_m))
        mid = (c0 + c1) / 2.0 + float(self.rng.uniform(-1.0, 1.0))
        a0, a1 = (x0, x1) if along_x else (y0, y1)
        self._alley(_street(along_x, mid, width, a0, a1, "alley"))
        lo, hi = mid - width / 2.0, mid + width / 2.0
        return [(x0, c0, x1, lo), (x0, hi, x1, c1)] if along_x else [(c0, y0, lo, y1), (hi, y0, c1, y1)]

    def _fill(self, block: Rect) -> None:
        """Cut a block into lots along its long side (an alley now and then) and build on each."""
        s, rng = self.s, self.rng
        x0, y0, x1, y1 = block
        along_x = x1 - x0 >= y1 - y0
        a0, a1 = (x0, x1) if along_x else (y0, y1)
        c0, c1 = (y0, y1) if along_x else (x0, x1)
        if c1 - c0 < 2.0:
            return  # a sliver of open ground
        pos = a0
        while a1 - pos > 1e-9:
            length = float(rng.uniform(*s.lot_length_m))
            if a1 - pos - length < s.lot_min_m:
                length = a1 - pos  # the last lot takes the rest
            self._lot(along_x, (pos, pos + length), (c0, c1), first=pos == a0, last=pos + length >= a1 - 1e-9)
            pos += length
            width = float(rng.uniform(*s.alley_width_m))
            if a1 - pos > width + s.lot_min_m and rng.random() < s.alley_chance:
                self._alley(_street(not along_x, pos + width / 2.0, width, c0, c1, "alley"))
                pos += width

    def _alley(self, alley: Street) -> None:
        """Keep an alley open; list it, with a spawn point in its middle, if an end opens on a street or square."""
        mouths = []
        depth = 2.5  # the mouth: this much of the street in front of the alley stays clear
        if alley.along_x:
            mouths = [(alley.x0 - depth, alley.y0, alley.x0, alley.y1),
                      (alley.x1, alley.y0, alley.x1 + depth, alley.y1)]
        else:
            mouths = [(alley.x0, alley.y0 - depth, alley.x1, alley.y0),
                      (alley.x0, alley.y1, alley.x1, alley.y1 + depth)]
        opening = [m for m in mouths if any(a.kind != "alley" and overlaps(m, _rect(a)) for a in self.open)]
        self.mouths.extend(opening)
        if opening:
            self.open.append(alley)
            self.spawns.append(((alley.x0 + alley.x1) / 2.0, (alley.y0 + alley.y1) / 2.0))

    def _lot(self, along_x: bool, span: tuple[float, float], cross: tuple[float, float], first: bool,
             last: bool) -> None:
        """A building, a ruin behind a standing wall, or an empty plot behind a fence."""
        s, rng = self.s, self.rng
        setback = float(rng.uniform(*s.setback_m))
        a0 = span[0] + (setback if first else 0.0)
        a1 = span[1] - (setback if last else 0.0)
        c0, c1 = cross[0] + setback, cross[1] - setback
        sign = 1.0 if rng.random() < 0.5 else -1.0  # the lot's front: its low (+1) or high (-1) cross side
        front = c0 if sign > 0 else c1
        room = c1 - c0

        def box(kind: str, d0: float, d1: float, b0: float, b1: float, height: float) -> None:
            """Place a box ``d0..d1`` in from the front and ``b0..b1`` along, if it is clear of the start."""
            lo, hi = sorted((front + sign * d0, front + sign * d1))
            rect = (b0, lo, b1, hi) if along_x else (lo, b0, hi, b1)
            if box_distance(rect, 0.0, 0.0) > s.start_radius_m:
                self.obstacles.append(Obstacle(kind, *rect, height))

        choice = rng.random()
        if choice < s.building_chance:
            spec = KINDS["building"]
            depth = min(room, float(rng.uniform(0.6, 1.0)) * spec.width_m[1])
            if depth >= spec.width_m[0] and a1 - a0 >= spec.length_m[0]:
                box("building", 0.0, depth, a0, a1, float(rng.uniform(*spec.height_m)))
            return
        if choice < s.building_chance + s.ruin_chance:
            wall, ruin = KINDS["wall"], KINDS["ruin"]
            thick = float(rng.uniform(*wall.width_m))
            length = min(float(rng.uniform(*wall.length_m)), a1 - a0 - 0.6)
            if length >= wall.length_m[0]:
                b0 = a0 + 0.3 + float(rng.uniform(0.0, a1 - a0 - 0.6 - length))
                box("wall", 0.0, thick, b0, b0 + length, float(rng.uniform(*wall.height_m)))
            inset = float(rng.uniform(0.3, 1.2))
            depth = min(room - thick - 0.5 - inset, float(rng.uniform(0.5, 1.0)) * ruin.width_m[1])
            if depth >= ruin.width_m[0] and a1 - a0 - 2 * inset >= ruin.length_m[0]:
                box("ruin", thick + 0.5 + inset, thick + 0.5 + inset + depth, a0 + inset, a1 - inset,
                    float(rng.uniform(*ruin.height_m)))
            return
        fence = KINDS["fence"]
        thick, height = float(rng.uniform(*fence.width_m)), float(rng.uniform(*fence.height_m))
        b0, b1 = a0 + 0.2, a1 - 0.2
        gate = float(rng.uniform(b0 + 1.0, max(b0 + 1.0, b1 - 2.2)))  # a 1.2 m gate, a metre or more from the ends
        for p0, p1 in ((b0, gate), (gate + 1.2, b1)):
            if p1 - p0 >= fence.length_m[0]:
                box("fence", 0.0, thick, p0, p1, height)
        car = KINDS["car"]
        width, length = float(rng.uniform(*car.width_m)), float(rng.uniform(*car.length_m))
        if rng.random() < s.plot_car_chance and room - thick - 1.0 >= width and b1 - b0 - 1.0 >= length:
            d0 = thick + 0.5 + float(rng.uniform(0.0, room - thick - 1.0 - width))
            p0 = b0 + 0.5 + float(rng.uniform(0.0, b1 - b0 - 1.0 - length))
            box("car", d0, d0 + width, p0, p0 + length, float(rng.uniform(*car.height_m)))

    # ------------------------------------------------------------ streets

    def _furnish(self, street: Street) -> None:
        """Lamp posts along the street, either side in turn, and wrecked cars against its edges."""
        s, rng = self.s, self.rng
        a0, a1 = (street.x0, street.x1) if street.along_x else (street.y0, street.y1)
        lamp = KINDS["lamp_post"]
        side = 1.0 if rng.random() < 0.5 else -1.0
        pos = a0 + float(rng.uniform(0.3, 1.0)) * s.lamp_spacing_m
        while pos < a1 - 1.0:
            size = float(rng.uniform(*lamp.width_m))
            self._against_edge(street, "lamp_post", side, 0.3, size, pos, size, float(rng.uniform(*lamp.height_m)))
            side = -side
            pos += s.lamp_spacing_m * float(rng.uniform(0.8, 1.2))
        car = KINDS["car"]
        for _ in range(int(round((a1 - a0) * s.car_per_m))):
            width, length = float(rng.uniform(*car.width_m)), float(rng.uniform(*car.length_m))
            side = 1.0 if rng.random() < 0.5 else -1.0
            self._against_edge(street, "car", side, float(rng.uniform(0.2, 0.6)), width,
                               float(rng.uniform(a0, a1 - length)), length, float(rng.uniform(*car.height_m)))

    def _square_lamps(self, square: Street) -> None:
        """A lamp post in each corner of a square."""
        size, height = KINDS["lamp_post"].width_m[1], KINDS["lamp_post"].height_m[0]
        for x, y in ((square.x0 + 0.8, square.y0 + 0.8), (square.x1 - 0.8 - size, square.y0 + 0.8),
                     (square.x0 + 0.8, square.y1 - 0.8 - size), (square.x1 - 0.8 - size, square.y1 - 0.8 - size)):
            self._place(Obstacle("lamp_post", x, y, x + size, y + size, height), square)

    def _against_edge(self, street: Street, kind: str, side: float, offset: float, width: float, at: float,
                      length: float, height: float) -> None:
        """Place a ``width`` x ``length`` box ``offset`` in from the street's low (side -1) or high (+1)
        edge, from ``at`` along it."""
        lo_edge, hi_edge = (street.y0, street.y1) if street.along_x else (street.x0, street.x1)
        c0 = hi_edge - offset - width if side > 0 else lo_edge + offset
        if street.along_x:
            rect = (at, c0, at + length, c0 + width)
        else:
            rect = (c0, at, c0 + width, at + length)
        self._place(Obstacle(kind, *rect, height), street)

    def _place(self, obstacle: Obstacle, home: Street) -> None:
        """Add a street object if it fits: inside its street or square, clear of the start, the spawn
        points, the alley mouths, other open ground and other obstacles, and leaving the passage."""
        s = self.s
        rect = _rect(obstacle)
        grown = (rect[0] - s.gap_m, rect[1] - s.gap_m, rect[2] + s.gap_m, rect[3] + s.gap_m)
        home_rect = _rect(home)
        fits = (home_rect[0] <= rect[0] and rect[2] <= home_rect[2] and home_rect[1] <= rect[1]
                and rect[3] <= home_rect[3]
                and box_distance(rect, 0.0, 0.0) > s.start_radius_m
                and all(box_distance(rect, x, y) > s.spawn_clear_m for x, y in self.spawns)
                and not any(overlaps(rect, m) for m in self.mouths)
                and not any(a is not home and overlaps(rect, _rect(a)) for a in self.open)
                and not any(overlaps(grown, _rect(o)) for o in self.obstacles)
                and (home.kind == "square" or self._leaves_passage(home, rect)))
        if fits:
            self.obstacles.append(obstacle)

    def _leaves_passage(self, street: Street, rect: Rect) -> bool:
        """Whether, with ``rect`` added, the street keeps ``min_passage_m`` clear across wherever
        obstacles stand within ``passage_margin_m`` of it along the street (taken as side by side)."""
        m = self.s.passage_margin_m
        if street.along_x:
            window = (rect[0] - m, street.y0, rect[2] + m, street.y1)
            lo, hi, first = street.y0, street.y1, 1
        else:
            window = (street.x0, rect[1] - m, street.x1, rect[3] + m)
            lo, hi, first = street.x0, street.x1, 0
        spans = [(rect[first], rect[first + 2])]
        spans += [(r[first], r[first + 2]) for r in map(_rect, self.obstacles) if overlaps(r, window)]
        return largest_gap(lo, hi, spans) >= self.s.min_passage_m


def largest_gap(lo: float, hi: float, spans: list[tuple[float, float]]) -> float:
    """The longest stretch of ``lo..hi`` that none of the intervals ``spans`` covers."""
    best, pos = 0.0, lo
    for s0, s1 in sorted(spans):
        if s0 > pos:
            best = max(best, min(s0, hi) - pos)
        pos = max(pos, s1)
        if pos >= hi:
            break
    return max(best, hi - pos)
