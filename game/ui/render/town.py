"""The town seen from the camera: the lines of its streets on the ground, its obstacles as lit boxes.

What never changes for a town (every face's corners, colours, the street
lines) is worked out once per :class:`~game.world.town.Town` object
(:class:`TownModel`). Each frame :class:`TownView` keeps the obstacles in
view (a sphere about each against the view's four sides), puts their
corners into the frame's one projection, leaves out those wholly behind a
nearer wall (:func:`hidden_boxes`), and plans each as one paint item:
its faces that look toward the camera, filled and outlined in the neon
style, fogged with distance (a lamp post: a pole and a glowing light).
While the camera stands still the last frame's plan is used again.

Paint order (painter's algorithm): the boxes far to near by the distance
from the eye to the nearest point of their footprint; every actor before
the first box that covers it (see :meth:`TownView.cover_slots`). A box
between the camera and the player fades (:mod:`.occlusion`). Limits: one
distance per box orders two boxes wrongly only where a long box passes
close beside a short one (their faces may overlap a little at the ends);
an actor is placed by a few points of its body (feet, hips, head), so a
hand reaching round a corner may be painted over by it, or over it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pygame
import pygame.gfxdraw

from .actors import paint_calls
from .camera import Batch, Camera, Frame, clip_pixels
from .occlusion import covers, ease, occluders
from .palette import CENTRE_LINE, HAZE, KERB, KERB_DIM, KIND_COLOURS, TOWN_EDGE, TOWN_EDGE_DIM, Colour, lerp
from .sprites import SpriteCache
from .world import fog

POLE_M = 0.12  # a lamp post's pole, drawn
NEAR_POLE_M = 2.5  # lamp posts nearer the eye than this are not drawn
THIN_M = 0.16  # faces narrower than this are not drawn (a fence is its two sides)
RUIN_TOP_POINTS = 5  # points along a ruin's broken wall top
FLOOR_M = 3.0  # a building's floors: a lit line across its sides every this many metres
FOG_LEVELS = 16
SHADES = {"top": 1.45, "x": 1.0, "y": 0.78, "inner": 0.55}  # a face's light by the way it faces
KERB_M = 0.25  # a kerb: a bright line on the open ground's edge, a dim one this far in


# ------------------------------------------------------------------ the street lines (pure geometry)


def _outside(a0: float, a1: float, cuts: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The pieces of the interval a0..a1 outside every interval of ``cuts``."""
    pieces, pos = [], a0
    for c0, c1 in sorted(cuts):
        if c0 > pos:
            pieces.append((pos, min(c0, a1)))
        pos = max(pos, c1)
        if pos >= a1:
            break
    if pos < a1:
        pieces.append((pos, a1))
    return [(p0, p1) for p0, p1 in pieces if p1 - p0 > 1e-6]


def open_outline(streets, half_size_m: float, eps: float = 1e-6) -> list[tuple[str, tuple, tuple[int, int]]]:
    """The outline of the open ground (streets, alleys and squares together): (kind, (x0, y0, x1, y1),
    the way into the open ground (dx, dy)) pieces.

    Each side of each rectangle, less where it lies inside or on the edge of
    another open rectangle (a crossing, an alley's mouth: open ground on both
    sides is no kerb) or on the town's edge. The kind is that of the
    rectangle the side bounds.
    """
    out = []
    for k, s in enumerate(streets):
        for along_x, c, a0, a1, inward in ((True, s.y0, s.x0, s.x1, (0, 1)), (True, s.y1, s.x0, s.x1, (0, -1)),
                                           (False, s.x0, s.y0, s.y1, (1, 0)), (False, s.x1, s.y0, s.y1, (-1, 0))):
            if abs(c) >= half_size_m - eps:
                continue
            cuts = []
            for j, o in enumerate(streets):
                c0, c1, b0, b1 = (o.y0, o.y1, o.x0, o.x1) if along_x else (o.x0, o.x1, o.y0, o.y1)
                if j != k and c0 - eps <= c <= c1 + eps:
                    cuts.append((b0, b1))
            for p0, p1 in _outside(a0, a1, cuts):
                out.append((s.kind, (p0, c, p1, c) if along_x else (c, p0, c, p1), inward))
    return out


def centre_dashes(streets, dash_m: float = 2.0, gap_m: float = 2.0) -> list[tuple[float, float, float, float]]:
    """Dashes down the middle of each street (not alleys or squares), none inside a crossing."""
    out = []
    for k, s in enumerate(streets):
        if s.kind != "street":
            continue
        along_x = s.along_x
        c = (s.y0 + s.y1) / 2.0 if along_x else (s.x0 + s.x1) / 2.0
        a0, a1 = (s.x0, s.x1) if along_x else (s.y0, s.y1)
        cuts = [((o.x0, o.x1) if along_x else (o.y0, o.y1)) for j, o in enumerate(streets)
                if j != k and ((o.y0 < c < o.y1) if along_x else (o.x0 < c < o.x1))]
        for p0, p1 in _outside(a0, a1, cuts):
            pos = p0 + gap_m / 2.0
            while pos + dash_m <= p1 - gap_m / 2.0 + 1e-9:
                out.append((pos, c, pos + dash_m, c) if along_x else (c, pos, c, pos + dash_m))
                pos += dash_m + gap_m
    return out


def ground_lines(town) -> tuple[np.ndarray, np.ndarray, list[Colour]]:
    """The town's lines on the ground: kerbs (street and square edges, alleys dimmer), street centre
    dashes, and the town's edge; their start and end points (N, 3) and colours."""
    h = town.half_size_m
    segs: list[tuple[float, float, float, float]] = []
    colours: list[Colour] = []
    for kind, (x0, y0, x1, y1), inward in open_outline(town.streets, h):
        segs += [(x0, y0, x1, y1), (x0 + inward[0] * KERB_M, y0 + inward[1] * KERB_M,
                                    x1 + inward[0] * KERB_M, y1 + inward[1] * KERB_M)]
        colours += [KERB[kind], KERB_DIM[kind]]
    for seg in centre_dashes(town.streets):
        segs.append(seg)
        colours.append(CENTRE_LINE)
    for inset, colour in ((0.06, TOWN_EDGE_DIM), (-0.06, TOWN_EDGE_DIM), (0.0, TOWN_EDGE)):  # a soft glow
        e = h + inset
        segs += [(-e, -e, e, -e), (e, -e, e, e), (e, e, -e, e), (-e, e, -e, -e)]
        colours += [colour] * 4
    s = np.asarray(segs, dtype=float).reshape(-1, 4)
    zeros = np.zeros((len(s), 1))
    return np.hstack([s[:, :2], zeros]), np.hstack([s[:, 2:], zeros]), colours


# ------------------------------------------------------------------ the boxes


def behind_walls(screen: np.ndarray, nearest: np.ndarray, rects: np.ndarray, far: np.ndarray) -> np.ndarray:
    """(N, W) bools: whether each thing's screen box (x0, y0, x1, y1, N of them) lies inside each wall's
    rectangle (W of them) with the wall's farthest corner nearer than the thing's ``nearest`` depth."""
    inside = ((rects[None, :, 0] <= screen[:, None, 0]) & (rects[None, :, 1] <= screen[:, None, 1])
              & (rects[None, :, 2] >= screen[:, None, 2]) & (rects[None, :, 3] >= screen[:, None, 3]))
    return inside & (far[None, :] < nearest[:, None])


def hidden_boxes(screen: np.ndarray, nearest: np.ndarray, rects: np.ndarray, far: np.ndarray, owner: np.ndarray,
                 opaque: np.ndarray) -> np.ndarray:
    """Which boxes need no painting: those whose screen box (x0, y0, x1, y1) lies inside the rectangle of
    a wall of another, opaque box whose farthest corner is nearer than their nearest one."""
    if not len(rects):
        return np.zeros(len(screen), dtype=bool)
    other = owner[None, :] != np.arange(len(screen))[:, None]
    return (behind_walls(screen, nearest, rects, far) & other & opaque[owner][None, :]).any(axis=1)



@dataclass
class Face:
    """One face of a drawn box: its corners (indices into its obstacle's points), which way it faces,
    its shade, and lines drawn across it (a building's floors: pairs of point indices)."""

    corners: tuple[int, ...]
    axis: int  # 0: x, 1: y, 2: z (the top)
    side: float  # +1: it faces +axis, -1: -axis
    plane: float  # its coordinate on that axis
    shade: str  # "top", "x" or "y"
    hollow: bool = False  # a ruin's wall: its inner side is drawn too, where it faces away
    lines: tuple[tuple[int, int], ...] = ()


def _box(points: list, faces: list, x0: float, y0: float, x1: float, y1: float, z0: float, z1: float,
         floors: tuple[float, ...] = ()) -> None:
    """Append a box's eight corners and its faces (four sides and the top), with a line across each side
    at each of the ``floors`` heights."""
    b = len(points)
    points += [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0),
               (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
    rings = []
    for z in floors:
        rings.append(len(points))
        points += [(x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)]

    def across(i: int, j: int) -> tuple[tuple[int, int], ...]:
        return tuple((r + i, r + j) for r in rings)

    wide_x, wide_y = x1 - x0 >= THIN_M, y1 - y0 >= THIN_M  # a fence's ends and top are too thin to draw
    faces += [f for f, wide in ((Face((b, b + 1, b + 5, b + 4), 1, -1.0, y0, "y", lines=across(0, 1)), wide_x),
                                (Face((b + 2, b + 3, b + 7, b + 6), 1, 1.0, y1, "y", lines=across(2, 3)), wide_x),
                                (Face((b + 3, b, b + 4, b + 7), 0, -1.0, x0, "x", lines=across(3, 0)), wide_y),
                                (Face((b + 1, b + 2, b + 6, b + 5), 0, 1.0, x1, "x", lines=across(1, 2)), wide_y),
                                (Face((b + 4, b + 5, b + 6, b + 7), 2, 1.0, z1, "top"), wide_x and wide_y)) if wide]


def _ruin(points: list, faces: list, o, rng: np.random.Generator) -> None:
    """A roofless shell whose walls end in a broken, jagged top."""
    corners = [(o.x0, o.y0), (o.x1, o.y0), (o.x1, o.y1), (o.x0, o.y1)]
    sides = ((1, -1.0, o.y0, "y"), (0, 1.0, o.x1, "x"), (1, 1.0, o.y1, "y"), (0, -1.0, o.x0, "x"))
    for k, (axis, side, plane, shade) in enumerate(sides):
        (ax, ay), (bx, by) = corners[k], corners[(k + 1) % 4]
        t = np.linspace(1.0, 0.0, RUIN_TOP_POINTS)  # from b back to a
        tops = o.height * (1.0 - rng.uniform(0.0, 0.55, RUIN_TOP_POINTS))
        tops[0], tops[-1] = o.height * rng.uniform(0.6, 1.0), o.height * rng.uniform(0.6, 1.0)
        b = len(points)
        points += [(ax, ay, 0.0), (bx, by, 0.0)]
        points += [(ax + (bx - ax) * u, ay + (by - ay) * u, z) for u, z in zip(t.tolist(), tops.tolist())]
        faces.append(Face(tuple(range(b, b + 2 + RUIN_TOP_POINTS)), axis, side, plane, shade, True))


def _parts(o, k: int) -> tuple[list, list]:
    """An obstacle's points and faces by its kind (a car: a body and a cabin; a ruin: broken walls; a
    building: lit floors)."""
    points: list = []
    faces: list = []
    if o.kind == "car":
        body = 0.6 * o.height
        long_x = o.x1 - o.x0 >= o.y1 - o.y0
        _box(points, faces, o.x0, o.y0, o.x1, o.y1, 0.15, body)
        along, across = 0.22, 0.06  # the cabin's inset at the ends and at the sides
        ix, iy = (along * (o.x1 - o.x0), across * (o.y1 - o.y0)) if long_x else (across * (o.x1 - o.x0),
                                                                                 along * (o.y1 - o.y0))
        _box(points, faces, o.x0 + ix, o.y0 + iy, o.x1 - ix, o.y1 - iy, body, o.height)
    elif o.kind == "ruin":
        _ruin(points, faces, o, np.random.default_rng(k))
    elif o.kind == "lamp_post":  # a pole (a line from its foot to its top), thinner than the post's footprint
        cx, cy = (o.x0 + o.x1) / 2.0, (o.y0 + o.y1) / 2.0
        points += [(cx, cy, 0.0), (cx, cy, o.height)]
    else:
        floors = tuple(np.arange(FLOOR_M, o.height - 0.5, FLOOR_M).tolist()) if o.kind == "building" else ()
        _box(points, faces, o.x0, o.y0, o.x1, o.y1, 0.0, o.height, floors)
    return points, faces


SHADE_NAMES = ("top", "x", "y", "inner")


def colour_table() -> np.ndarray:
    """Fill and edge colours by kind (in KIND_COLOURS' order), shade (SHADE_NAMES), fog level (0 clear ..
    FOG_LEVELS - 1 deep in the haze): an int array (kinds, shades, levels, 2, 3)."""
    table = np.zeros((len(KIND_COLOURS), len(SHADE_NAMES), FOG_LEVELS, 2, 3), dtype=int)
    for i, (fill, edge) in enumerate(KIND_COLOURS.values()):
        for j, shade in enumerate(SHADE_NAMES):
            lit = np.minimum(255, (np.asarray(fill) * SHADES[shade]).astype(int)).tolist()
            line = (np.asarray(edge) * (0.6 if shade == "inner" else 1.0)).astype(int).tolist()
            for level in range(FOG_LEVELS):
                a = 0.85 * level / (FOG_LEVELS - 1)
                table[i, j, level] = lerp(lit, HAZE, a), lerp(line, HAZE, a)
    return table


class TownModel:
    """What never changes for one town: every obstacle's points and faces as flat arrays, its bounds, the
    street lines. Face corners are padded to the most any face has by repeating the last (a polygon
    with a point twice is the same polygon)."""

    def __init__(self, town) -> None:
        self.town = town
        obstacles = town.obstacles
        n = len(obstacles)
        kinds = list(KIND_COLOURS)
        self.kind = np.array([kinds.index(o.kind) for o in obstacles], dtype=int)
        self.lamp = self.kind == kinds.index("lamp_post")
        self.lo = np.array([(o.x0, o.y0, 0.0) for o in obstacles], dtype=float).reshape(n, 3)
        self.hi = np.array([(o.x1, o.y1, o.height) for o in obstacles], dtype=float).reshape(n, 3)
        self.centre = (self.lo + self.hi) / 2.0
        self.radius = np.linalg.norm(self.hi - self.lo, axis=1) / 2.0
        self.light = np.column_stack([self.centre[:, :2], self.hi[:, 2] + 0.15])  # a lamp's light
        points: list = []
        faces: list[Face] = []
        point_starts, face_starts, face_owner = [0], [0], []
        for k, o in enumerate(obstacles):
            pts, fcs = _parts(o, k)
            points += pts
            faces += fcs
            face_owner += [k] * len(fcs)
            point_starts.append(len(points))
            face_starts.append(len(faces))
        self.points = np.asarray(points, dtype=float).reshape(-1, 3)
        self.point_starts = np.asarray(point_starts)
        self.face_starts = np.asarray(face_starts)
        width = max((len(f.corners) for f in faces), default=1)
        self.corners = np.array([list(f.corners) + [f.corners[-1]] * (width - len(f.corners)) for f in faces],
                                dtype=int).reshape(-1, width)  # from the obstacle's first point
        self.axis = np.array([f.axis for f in faces], dtype=int)
        self.side = np.array([f.side for f in faces], dtype=float)
        self.plane = np.array([f.plane for f in faces], dtype=float)
        self.hollow = np.array([f.hollow for f in faces], dtype=bool)
        self.shade = np.array([SHADE_NAMES.index(f.shade) for f in faces], dtype=int)
        lines = [(i, a, b) for i, f in enumerate(faces) for a, b in f.lines]
        self.line_face = np.array([i for i, _, _ in lines], dtype=int)
        self.line_ends = np.array([(a, b) for _, a, b in lines], dtype=int).reshape(-1, 2)
        self.line_owner = np.asarray(face_owner, dtype=int)[self.line_face] if lines else np.zeros(0, dtype=int)
        self.colours = colour_table()
        self.ground = ground_lines(town)


def _ranges(starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """The indices starts[0]..ends[0]-1, starts[1]..ends[1]-1, ... in one array."""
    counts = ends - starts
    total = int(counts.sum())
    if not total:
        return np.zeros(0, dtype=int)
    first = np.cumsum(counts) - counts
    return np.repeat(starts - first, counts) + np.arange(total)


@dataclass
class BoxPoints:
    """The obstacles in view this frame (far to near) and where their points sit in the frame's batch."""

    keep: np.ndarray  # obstacle indices, far to near
    points: slice  # their points, obstacle after obstacle
    offsets: np.ndarray  # each kept obstacle's first point, from points.start
    lights: slice  # the lights of the kept lamp posts
    lamps: np.ndarray  # which kept obstacles (their places in keep) are lamp posts
    distance: np.ndarray  # each kept obstacle's distance (m) from the eye, ground plan
    fresh: bool = True  # False: the camera has not moved since; the points are not in this frame's batch


@dataclass
class LampLights:
    """The lights at the lamp posts' tops: additive glow blits, and each one's world point, pixel and depth."""

    glows: list = field(default_factory=list)
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    xy: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    depth: np.ndarray = field(default_factory=lambda: np.zeros(0))
    owner: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))  # each light's lamp: its place in keep


@dataclass
class TownPlan:
    """A frame's boxes: paint items far to near, their bounds, their screen boxes and nearest depths."""

    items: list = field(default_factory=list)  # (paint, payload) per kept obstacle, far to near
    lights: LampLights = field(default_factory=LampLights)  # those of the boxes painted
    lo: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    hi: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    screen: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))  # x0, y0, x1, y1 pixels
    nearest: np.ndarray = field(default_factory=lambda: np.zeros(0))  # the least depth of any corner
    opaque: bool = True  # no box is fading: each is painted whole
    walls: tuple = (np.zeros((0, 4)), np.zeros(0), np.zeros(0, dtype=int))  # the painted opaque walls (_walls)


class TownView:
    """Draws one town's obstacles (see the module's docstring); fades those in front of the player."""

    COLORKEY = (255, 0, 255)

    def __init__(self, camera: Camera, sprites: SpriteCache) -> None:
        self.camera = camera
        self.sprites = sprites
        self.model: TownModel | None = None
        self.alpha = np.zeros(0)  # each obstacle's opacity (0..1), eased
        self._scratch: pygame.Surface | None = None
        self._view_key: tuple | None = None  # the camera and town the view below was worked out for
        self._view: BoxPoints | None = None
        self._drawn: tuple = ()  # that view's paint calls, lamp lights, screen boxes, nearest depths and walls
        self._planned: tuple = (None, TownPlan())  # the last plan, and the opacities it was made with

    def model_of(self, town) -> TownModel | None:
        """The town's model, built at the first frame that shows it (and again for a new town)."""
        if town is None:
            self.model = None
        elif self.model is None or self.model.town is not town:
            self.model = TownModel(town)
            self.alpha = np.ones(len(town.obstacles))
        return self.model

    def gather(self, batch: Batch, town) -> BoxPoints | None:
        """The obstacles in view (a sphere about each against the view's four sides), far to near: their
        points into the frame's batch. While the camera stands still the last frame's view and paint calls
        are used again (nothing goes into the batch)."""
        m = self.model_of(town)
        if m is None or not len(m.lo):
            return None
        cam = self.camera
        key = (id(m), *cam.pose())
        if key == self._view_key and self._view is not None:
            self._view.fresh = False
            return self._view
        self._view_key = key
        c = cam.to_camera(m.centre)
        r = m.radius
        f, half_w, half_h = cam.f, cam.cx, cam.cy
        side, vert = math.hypot(f, half_w), math.hypot(f, half_h)
        seen = ((c[:, 2] > cam.near - r) & (f * c[:, 0] - half_w * c[:, 2] < r * side)
                & (-f * c[:, 0] - half_w * c[:, 2] < r * side) & (f * c[:, 1] - half_h * c[:, 2] < r * vert)
                & (-f * c[:, 1] - half_h * c[:, 2] < r * vert))
        keep = np.flatnonzero(seen)
        ex, ey = cam.eye[0], cam.eye[1]
        dx = np.maximum(np.maximum(m.lo[keep, 0] - ex, ex - m.hi[keep, 0]), 0.0)
        dy = np.maximum(np.maximum(m.lo[keep, 1] - ey, ey - m.hi[keep, 1]), 0.0)
        distance = np.hypot(dx, dy)
        order = np.argsort(-distance, kind="stable")
        keep, distance = keep[order], distance[order]
        counts = m.point_starts[keep + 1] - m.point_starts[keep]
        points = batch.add(m.points[_ranges(m.point_starts[keep], m.point_starts[keep + 1])])
        lamps = np.flatnonzero(m.lamp[keep])
        self._view = BoxPoints(keep, points, np.cumsum(counts) - counts, batch.add(m.light[keep[lamps]]), lamps,
                               distance)
        return self._view

    def plan(self, frame: Frame, g: BoxPoints | None, targets: np.ndarray, dt: float) -> TownPlan:
        """The kept obstacles as paint items, far to near; those between the eye and any of ``targets``
        (the player's points) fade out over :data:`~.occlusion.FADE_S`, the others back in."""
        m = self.model
        if m is None or g is None:
            return TownPlan()
        keep, n = g.keep, len(g.keep)
        cam = self.camera
        faded = np.zeros(len(m.lo), dtype=bool)
        if len(targets) and n:  # only the boxes whose footprint meets the ground plan of the sight lines
            ends = np.vstack([targets[:, :2], cam.eye[None, :2]])
            (x0, y0), (x1, y1) = ends.min(axis=0), ends.max(axis=0)
            near = keep[(m.lo[keep, 0] < x1) & (m.hi[keep, 0] > x0) & (m.lo[keep, 1] < y1) & (m.hi[keep, 1] > y0)]
            if len(near):
                faded[near] = occluders(cam.eye, targets, m.lo[near], m.hi[near])
        self.alpha = ease(self.alpha, faded, dt)
        if not n:
            return TownPlan()
        alpha = self.alpha[keep]
        if not g.fresh and np.array_equal(alpha, self._planned[0]):  # nothing changed since the last frame
            return self._planned[1]
        if not g.fresh:
            calls, lights, screen, nearest, walls = self._drawn
        else:
            calls, lights, screen, nearest, walls = self._drawn = self._draw(m, frame, g)
        opaque = alpha >= 0.999
        hidden = hidden_boxes(screen, nearest, *walls, opaque).tolist()
        items = [(paint_calls, []) if out else (paint_calls, c) if a >= 0.999 else (self._paint_faded, (c, a))
                 for c, a, out in zip(calls, alpha.tolist(), hidden)]
        shown = ~np.asarray(hidden, dtype=bool)[lights.owner]
        lit = LampLights([glow for glow, k in zip(lights.glows, shown.tolist()) if k], lights.points[shown],
                         lights.xy[shown], lights.depth[shown], lights.owner[shown])
        solid = (opaque & ~np.asarray(hidden, dtype=bool))[walls[2]]
        plan = TownPlan(items, lit, m.lo[keep], m.hi[keep], screen, nearest, bool(opaque.all()),
                        tuple(w[solid] for w in walls))
        self._planned = (alpha, plan)
        return plan

    def _draw(self, m: TownModel, frame: Frame, g: BoxPoints) -> tuple:
        """The kept obstacles' paint calls, their lamps' lights, their screen boxes, the depths of their nearest
        corners, and the walls that may hide others (:meth:`_walls`)."""
        cam = self.camera
        level = np.minimum(FOG_LEVELS - 1, (fog(g.distance + 1.0) * ((FOG_LEVELS - 0.01) / 0.85)).astype(int))
        depth = frame.cam[g.points, 2]
        xy = frame.xy[g.points]
        nearest = np.minimum.reduceat(depth, g.offsets)
        clipped = nearest <= cam.near + 1e-3  # a corner behind the near plane: faces are cut (slow path)
        screen = np.column_stack([np.minimum.reduceat(xy[:, 0], g.offsets), np.minimum.reduceat(xy[:, 1], g.offsets),
                                  np.maximum.reduceat(xy[:, 0], g.offsets), np.maximum.reduceat(xy[:, 1], g.offsets)])
        screen[clipped] = (-np.inf, -np.inf, np.inf, np.inf)
        calls, walls = self._face_calls(m, frame, g, level, clipped)
        return calls, self._lamp_calls(m, calls, frame, g, level, clipped), screen, nearest, walls

    def _face_calls(self, m: TownModel, frame: Frame, g: BoxPoints, level: np.ndarray,
                    clipped: np.ndarray) -> tuple[list[list], tuple]:
        """Each kept obstacle's paint calls: its faces toward the eye (a ruin's far walls first, from
        inside), filled then outlined, then the lines across them (a building's floors); and its walls
        that may hide others (:meth:`_walls`)."""
        eye = self.camera.eye
        keep, n = g.keep, len(g.keep)
        faces = _ranges(m.face_starts[keep], m.face_starts[keep + 1])
        rank = np.repeat(np.arange(n), m.face_starts[keep + 1] - m.face_starts[keep])
        toward = (eye[m.axis[faces]] - m.plane[faces]) * m.side[faces] > 0.0
        drawn = toward | m.hollow[faces]
        order = np.lexsort((toward, rank))  # by obstacle, a ruin's inner walls first
        order = order[drawn[order]]
        faces, rank, toward = faces[order], rank[order], toward[order]
        corners = m.corners[faces] + g.offsets[rank][:, None]  # into the kept points
        shade = np.where(toward, m.shade[faces], SHADE_NAMES.index("inner"))
        colours = m.colours[m.kind[keep][rank], shade, level[rank]].tolist()
        block = frame.ixy[g.points]
        polygons = block[corners].tolist()
        fast = ~clipped[rank]
        if not fast.all():
            cam_block = frame.cam[g.points]
            for k in np.flatnonzero(~fast).tolist():
                polygons[k] = self._clipped(cam_block[corners[k]], self.camera.near + 1e-3)
        polygon, outline = pygame.draw.polygon, pygame.gfxdraw.polygon  # 1-px outlines: ten times faster
        calls: list[list] = [[] for _ in range(n)]
        for r, (fill, edge), pts in zip(rank.tolist(), colours, polygons):
            if len(pts) >= 3:
                calls[r] += [(polygon, (fill, pts)), (outline, (pts, edge))]
        self._line_calls(m, calls, block, g, faces[fast], level)
        side = fast & toward & (m.axis[faces] != 2) & ~m.hollow[faces]
        return calls, self._walls(frame, g, corners[side], rank[side])

    @staticmethod
    def _walls(frame: Frame, g: BoxPoints, corners: np.ndarray, rank: np.ndarray) -> tuple:
        """The side faces that may hide other boxes: for each, a rectangle of screen inside it, the depth of
        its farthest corner, and its box (its place in keep).

        A side's corners are (bottom a, bottom b, top b, top a) and the camera
        never rolls, so its left and right edges are the a and b edges in some
        order and its top and bottom edges run across: the rectangle from the
        inner ends of each pair of edges lies inside the face.
        """
        xy = frame.xy[g.points][corners[:, :4]]  # (K, 4, 2)
        depth = frame.cam[g.points, 2][corners[:, :4]]
        a_x, b_x = xy[:, [0, 3], 0], xy[:, [1, 2], 0]  # the a edge's and the b edge's x
        a_left = a_x.mean(axis=1) < b_x.mean(axis=1)
        left, right = np.where(a_left[:, None], a_x, b_x), np.where(a_left[:, None], b_x, a_x)
        rects = np.column_stack([left.max(axis=1), xy[:, 2:, 1].max(axis=1), right.min(axis=1),
                                 xy[:, :2, 1].min(axis=1)])
        return rects, depth.max(axis=1), rank

    def _lamp_calls(self, m: TownModel, calls: list[list], frame: Frame, g: BoxPoints, level: np.ndarray,
                    clipped: np.ndarray) -> LampLights:
        """Each lamp post in view: its pole among its calls; returned, their lights (an additive glow at each
        top); none within ``NEAR_POLE_M`` of the eye (a pole beside the camera would cut the view in two)."""
        cam = self.camera
        line = pygame.draw.line
        glows, lit = [], []
        for i, j in zip(g.lamps.tolist(), range(g.lights.start, g.lights.stop)):
            if clipped[i] or g.distance[i] < NEAR_POLE_M:
                continue
            foot = g.points.start + int(g.offsets[i])
            width = max(1, int(cam.f * POLE_M / frame.depth[foot]))
            fill, edge = m.colours[m.kind[g.keep[i]], SHADE_NAMES.index("x"), level[i]]
            pole = ((fill + edge) // 2).tolist()
            calls[i].append((line, (pole, frame.ixy[foot].tolist(), frame.ixy[foot + 1].tolist(), width)))
            if frame.visible[j]:
                x, y = frame.xy[j]
                glows.append(self.sprites.glow_blit(x, y, cam.f * 0.55 / frame.depth[j], "spark",
                                                    2 if level[i] < 8 else 1))
                lit.append((i, j))
        owner, at = (np.array(v, dtype=int) for v in zip(*lit)) if lit else (np.zeros(0, dtype=int),) * 2
        return LampLights(glows, m.light[g.keep[owner]], frame.xy[at], frame.depth[at], owner)

    def _line_calls(self, m: TownModel, calls: list[list], block: np.ndarray, g: BoxPoints, faces: np.ndarray,
                    level: np.ndarray) -> None:
        """The lines across the drawn faces (a building's floors), half-way from the edge colour to the fill."""
        shown = np.zeros(len(m.axis), dtype=bool)
        shown[faces] = True
        pick = np.flatnonzero(shown[m.line_face])
        if not len(pick):
            return
        rank_of = np.full(len(m.lo), -1)
        rank_of[g.keep] = np.arange(len(g.keep))
        rank = rank_of[m.line_owner[pick]]
        ends = (m.line_ends[pick] + g.offsets[rank][:, None])
        a, b = block[ends[:, 0]].tolist(), block[ends[:, 1]].tolist()
        fill_edge = m.colours[m.kind[g.keep][rank], SHADE_NAMES.index("x"), level[rank]]
        colour = ((fill_edge[:, 0] * 0.55 + fill_edge[:, 1] * 0.45).astype(int)).tolist()
        line = pygame.gfxdraw.line  # 1 px: several times faster than pygame.draw.line
        for r, c, (x1, y1), (x2, y2) in zip(rank.tolist(), colour, a, b):
            calls[r].append((line, (x1, y1, x2, y2, c)))

    def cover_slots(self, plan: TownPlan, eye: np.ndarray, points: np.ndarray, xy: np.ndarray,
                    depth: np.ndarray) -> np.ndarray:
        """For each point (world ``points``, with its pixel ``xy`` and camera ``depth``), the first box in
        paint order that covers it from the eye, or the number of boxes if none does: a thing at that point
        is painted just before that box. Only the boxes whose screen box holds the pixel and whose nearest
        corner is nearer than the point are tested (:func:`~.occlusion.covers`)."""
        n = len(plan.items)
        slots = np.full(len(points), n, dtype=int)
        if not n or not len(points):
            return slots
        s = plan.screen
        maybe = ((xy[:, None, 0] >= s[None, :, 0]) & (xy[:, None, 0] <= s[None, :, 2])
                 & (xy[:, None, 1] >= s[None, :, 1]) & (xy[:, None, 1] <= s[None, :, 3])
                 & (depth[:, None] > plan.nearest[None, :]))
        p, b = np.nonzero(maybe)
        hit = covers(eye, points[p], plan.lo[b], plan.hi[b])
        np.minimum.at(slots, p[hit], b[hit])
        return slots

    def _clipped(self, cam_pts: np.ndarray, near: float) -> list:
        """A face (camera space) cut by the near plane (Sutherland and Hodgman), projected to pixels."""
        out = []
        n = len(cam_pts)
        for i in range(n):
            a, b = cam_pts[i], cam_pts[(i + 1) % n]
            a_in, b_in = a[2] > near, b[2] > near
            if a_in:
                out.append(a)
            if a_in != b_in:
                t = (near - a[2]) / (b[2] - a[2])
                out.append(a + (b - a) * t)
        if len(out) < 3:
            return []
        xy = self.camera.project_camera(np.array(out))[0]
        return clip_pixels(xy).astype(int).tolist()

    def _paint_faded(self, surface: pygame.Surface, payload: tuple) -> list[pygame.Rect]:
        """Paint a box's calls onto a scratch surface, then onto the frame at the box's opacity; returns the
        rectangle painted."""
        calls, alpha = payload
        pts = [p for fn, args in calls if fn is pygame.draw.polygon for p in args[1]]
        pts += [p for fn, args in calls if fn is pygame.draw.line for p in args[1:3]]  # a lamp's pole
        if not pts:
            return []
        xs, ys = [p[0] for p in pts], [p[1] for p in pts]
        rect = pygame.Rect(min(xs) - 2, min(ys) - 2, max(xs) - min(xs) + 5, max(ys) - min(ys) + 5)
        rect = rect.clip(surface.get_rect())
        if not rect.width or not rect.height:
            return []
        scratch = self._scratch
        if scratch is None or scratch.get_size() != surface.get_size():
            scratch = self._scratch = pygame.Surface(surface.get_size())
            scratch.set_colorkey(self.COLORKEY)
        scratch.fill(self.COLORKEY, rect)
        paint_calls(scratch, calls)
        scratch.set_alpha(int(255 * alpha))
        return [surface.blit(scratch, rect.topleft, rect)]
