"""All pygame drawing: the third-person camera, the world, effects, the HUD, plots and screens.

The renderer only reads the arena's data (:mod:`game.world.arena_model`) and the
posed :class:`game.body.avatar.Avatar`; the arena itself is duck-typed (``player``,
``zombies``, ``balls``, ``held``, ``settings``), so this module never imports
the game logic.

Screen axes are this module's business: the camera looks along its own +z
(depth), x to the right, y up; pixels run x right, y down. World frame: x east,
y north, z up, metres (ARCHITECTURE.md).

Speed (the render budget is 3 ms a frame at 1280x720): every point of the
frame (grid, ring, zombie joints, shadows, balls, trails, particles, the
avatar) goes through ONE camera transform and projection per frame; the sky,
ground, haze, glows and shadows are pre-rendered and cached; the per-item work
is a handful of ``pygame.draw`` calls or one batched ``Surface.blits``.
"""

from __future__ import annotations

import bisect
import functools
import math
from dataclasses import dataclass, field
from typing import Iterable, Sequence

import numpy as np
import pygame
import pygame.gfxdraw

Colour = tuple[int, int, int]

# ------------------------------------------------------------------ palette

SKY_TOP: Colour = (6, 8, 28)
SKY_HORIZON: Colour = (118, 58, 112)
HILLS: Colour = (38, 24, 58)
GROUND_HORIZON: Colour = (66, 42, 84)
GROUND_NEAR: Colour = (14, 16, 32)
HAZE: Colour = GROUND_HORIZON  # what distant things fade into
GRID: Colour = (70, 140, 178)  # brighter than the ground in every channel (see Renderer._build_ground)
RING: Colour = (255, 70, 160)
_RING_DIM: Colour = (170, 60, 130)
SHADOW_DARKNESS = (0.45, 0.65, 0.85)  # multiply factors: dark, medium, faint

OUTLINE: Colour = (8, 10, 22)
AVATAR_BODY: Colour = (70, 130, 240)
AVATAR_LEGS: Colour = (44, 78, 160)
AVATAR_FREE_ARM: Colour = (58, 108, 206)
AVATAR_HEAD: Colour = (236, 196, 160)
AVATAR_HAIR: Colour = (92, 60, 40)
AVATAR_ARM: Colour = (255, 160, 50)  # the tracked arm

ZOMBIE_LEGS: Colour = (58, 92, 52)
ZOMBIE_BODY: Colour = (88, 140, 66)
ZOMBIE_ARMS: Colour = (112, 172, 82)
ZOMBIE_HEAD: Colour = (146, 196, 104)
ZOMBIE_EYES: Colour = (255, 70, 40)
FLYING_TINT: Colour = (170, 255, 220)  # zombies charged by a hit glow a little


GLOW_COLOURS: dict[str, Colour] = {
    "energy": (90, 190, 255),
    "spark": (255, 214, 130),
    "goo": (110, 255, 100),
    "ember": (255, 100, 50),
    "white": (230, 240, 255),
}
PALETTES = tuple(GLOW_COLOURS)  # particle palette index -> glow colour name
_PALETTE_INDEX = {name: i for i, name in enumerate(PALETTES)}
AXIS_COLOURS: tuple[Colour, ...] = ((255, 96, 96), (96, 232, 112), (96, 156, 255), (255, 206, 80))
TEXT: Colour = (236, 238, 246)
DIM_TEXT: Colour = (170, 176, 196)
ACCENT: Colour = (110, 210, 255)

GLOW_SIZES = np.array([2, 3, 4, 5, 6, 8, 10, 13, 16, 20, 25, 32, 40, 50, 64, 80, 100, 128])  # radii, px
_GLOW_SIZE_LIST = GLOW_SIZES.tolist()
GLOW_LEVELS = (0.3, 0.55, 0.8, 1.0)  # brightness steps of each glow sprite
ADD = pygame.BLEND_RGB_ADD
MULT = pygame.BLEND_RGB_MULT
SUB = pygame.BLEND_RGB_SUB


def _zombie_colour_table() -> list:
    """Zombie part colours (legs, body, arms, head, outline) at 16 fog levels: walking, then flying."""
    base = np.array([ZOMBIE_LEGS, ZOMBIE_BODY, ZOMBIE_ARMS, ZOMBIE_HEAD, OUTLINE], dtype=float)
    table = []
    for tint in (0.0, 0.55):  # flying zombies glow a little
        cols = base * (1 - tint) + np.asarray(FLYING_TINT, float) * tint
        for level in range(16):
            fog = 0.85 * level / 15
            table.append((cols * (1 - fog) + np.asarray(HAZE, float) * fog).astype(int).tolist())
    return table


_ZOMBIE_COLOURS = _zombie_colour_table()


def _lerp(a: Sequence[float], b: Sequence[float], t: float) -> Colour:
    return (int(a[0] + (b[0] - a[0]) * t), int(a[1] + (b[1] - a[1]) * t), int(a[2] + (b[2] - a[2]) * t))


def _clip_pixels(xy: np.ndarray) -> np.ndarray:
    """Pixel coordinates kept within +-30000 (pygame and SDL_gfx take 16-bit coordinates)."""
    return np.minimum(np.maximum(xy, -30000.0), 30000.0)


def _setting(settings: object, names: Iterable[str], default: float) -> float:
    """A number from the arena's settings under the first name that exists (the arena is duck-typed)."""
    for name in names:
        value = getattr(settings, name, None)
        if isinstance(value, (int, float)):
            return float(value)
    return default


# ------------------------------------------------------------------ camera


def clip_near(a: np.ndarray, b: np.ndarray, near: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Clip camera-space segments a->b (N, 3) against the plane depth = ``near``.

    Returns the clipped end points and ``keep`` (N,): False where both ends lie
    behind the plane. An end behind the plane moves along the segment onto it.
    """
    za, zb = a[:, 2], b[:, 2]
    keep = (za > near) | (zb > near)
    denom = zb - za
    t = (near - za) / np.where(np.abs(denom) < 1e-12, 1e-12, denom)
    cut = a + (b - a) * t[:, None]
    a_out = np.where(((za < near) & keep)[:, None], cut, a)
    b_out = np.where(((zb < near) & keep)[:, None], cut, b)
    return a_out, b_out, keep


def depth_order(depths: np.ndarray) -> np.ndarray:
    """Indices that draw far things first (painter's algorithm); stable for equal depths."""
    return np.argsort(-np.asarray(depths, dtype=float), kind="stable")


@dataclass(frozen=True)
class CameraRig:
    """Where the third-person camera sits relative to the player (metres, seconds, degrees)."""

    back: float = 4.5  # behind the player
    up: float = 2.6  # above the ground
    ahead: float = 6.0  # it looks at a point this far ahead ...
    look_height: float = 1.3  # ... at chest height
    fov_y_deg: float = 60.0  # vertical field of view
    near: float = 0.2  # near plane depth
    follow_s: float = 0.12  # time constant of the position smoothing
    turn_s: float = 0.18  # time constant of the yaw smoothing


class Camera:
    """A pinhole camera without roll, following the player from behind and above.

    ``rot`` holds the camera's right, up and forward axes as rows (world
    frame), so camera coordinates are ``rot @ (p - eye)``; a point at depth
    ``z`` with camera offsets ``(x, y)`` lands at pixel
    ``(cx + f x / z, cy - f y / z)`` with ``f = (h / 2) / tan(fov_y / 2)``.
    """

    def __init__(self, rig: CameraRig | None = None, viewport: tuple[int, int] = (1280, 720)) -> None:
        self.rig = rig or CameraRig()
        self.near = self.rig.near
        self.width = self.height = 0
        self.f = self.cx = self.cy = 0.0
        self.set_viewport(*viewport)
        self.eye, self.rot = np.zeros(3), np.eye(3)
        self._place(0.0, 0.0, 0.0)
        self.state: tuple[float, float, float] | None = None  # smoothed (x, y, yaw); the first follow() snaps

    def set_viewport(self, width: int, height: int) -> None:
        """Take the surface's size (called each frame: the window is resizable)."""
        self.width, self.height = int(width), int(height)
        self.cx, self.cy = 0.5 * self.width, 0.5 * self.height
        self.f = 0.5 * self.height / math.tan(math.radians(self.rig.fov_y_deg) / 2)

    def look_at(self, eye: Sequence[float], target: Sequence[float]) -> None:
        """Place the camera at ``eye`` looking at ``target``, world z up (no roll)."""
        ex, ey, ez = (float(v) for v in eye)
        fx, fy, fz = float(target[0]) - ex, float(target[1]) - ey, float(target[2]) - ez
        n = math.sqrt(fx * fx + fy * fy + fz * fz)
        fx, fy, fz = fx / n, fy / n, fz / n
        h = math.hypot(fx, fy)
        rx, ry = (fy / h, -fx / h) if h > 1e-9 else (1.0, 0.0)  # forward x world up
        up = (ry * fz, -rx * fz, rx * fy - ry * fx)  # right x forward
        self.eye = np.array([ex, ey, ez])
        self.rot = np.array([[rx, ry, 0.0], up, [fx, fy, fz]])

    def snap(self, x: float, y: float, yaw: float) -> None:
        """Jump straight to the pose behind a player at (x, y) facing ``yaw``."""
        self.state = (float(x), float(y), float(yaw))
        self._place(*self.state)

    def follow(self, x: float, y: float, yaw: float, dt: float) -> None:
        """Move smoothly toward the pose behind the player (exponential smoothing, yaw wrapped)."""
        if self.state is None:
            self.snap(x, y, yaw)
            return
        sx, sy, syaw = self.state
        a = 1.0 - math.exp(-max(dt, 0.0) / self.rig.follow_s)
        b = 1.0 - math.exp(-max(dt, 0.0) / self.rig.turn_s)
        turn = (yaw - syaw + math.pi) % (2 * math.pi) - math.pi
        self.state = (sx + (x - sx) * a, sy + (y - sy) * a, syaw + turn * b)
        self._place(*self.state)

    @property
    def yaw(self) -> float:
        return self.state[2] if self.state else 0.0

    def _place(self, x: float, y: float, yaw: float) -> None:
        fx, fy = -math.sin(yaw), math.cos(yaw)  # yaw 0 faces +y, positive turns left
        r = self.rig
        self.look_at((x - fx * r.back, y - fy * r.back, r.up), (x + fx * r.ahead, y + fy * r.ahead, r.look_height))

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """World points (N, 3) -> camera coordinates (N, 3): right, up, depth."""
        return (np.asarray(points, dtype=float).reshape(-1, 3) - self.eye) @ self.rot.T

    def project_camera(self, cam: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Camera coordinates -> (pixels (N, 2), depth (N,), visible (N,): in front of the near plane)."""
        z = cam[:, 2]
        visible = z > self.near
        inv = self.f / np.where(visible, z, self.near)
        xy = np.empty((len(cam), 2))
        xy[:, 0] = self.cx + cam[:, 0] * inv
        xy[:, 1] = self.cy - cam[:, 1] * inv
        return xy, z, visible

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World points (N, 3) -> (screen xy (N, 2), depth (N,), visible mask (N,))."""
        return self.project_camera(self.to_camera(points))

    def project_segments(self, a: np.ndarray, b: np.ndarray, near: float | None = None
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World segments a->b (N, 3) clipped against the near plane, then projected: (xy_a, xy_b, keep)."""
        ca, cb, keep = clip_near(self.to_camera(a), self.to_camera(b), self.near if near is None else near)
        return self.project_camera(ca)[0], self.project_camera(cb)[0], keep

    def horizon_y(self) -> float:
        """The screen row of the horizon (the camera never rolls, so it is one row)."""
        f = self.rot[2]
        flat = np.array([f[0], f[1], 0.0])
        n = np.linalg.norm(flat)
        if n < 1e-9:
            return -1e9 if f[2] < 0 else 1e9
        c = self.rot @ (flat / n)
        return self.cy - self.f * c[1] / c[2]

    def ground_depth(self, rows: np.ndarray) -> np.ndarray:
        """Depth of the ground plane seen through each screen row (inf at and above the horizon)."""
        dz = self.rot[2, 2] - (np.asarray(rows, dtype=float) - self.cy) / self.f * self.rot[1, 2]
        with np.errstate(divide="ignore"):
            return np.where(dz < -1e-9, -self.eye[2] / np.minimum(dz, -1e-9), np.inf)


def grid_segments(cx: float, cy: float, step: float, extent: float) -> tuple[np.ndarray, np.ndarray]:
    """Ground lines every ``step`` m on a disc of radius ``extent`` m around (cx, cy) (a grid point).

    Returns the lines' start and end points (N, 3); the rim of the disc lies
    in the haze, so the ground seems to run to the horizon.
    """
    k = np.arange(-extent + step, extent - step / 2, step)
    half = np.sqrt(extent * extent - k * k)
    zeros = np.zeros(len(k))
    a = np.concatenate([np.stack([cx + k, cy - half, zeros], 1), np.stack([cx - half, cy + k, zeros], 1)])
    b = np.concatenate([np.stack([cx + k, cy + half, zeros], 1), np.stack([cx + half, cy + k, zeros], 1)])
    return a, b


# ------------------------------------------------------------------ particles


def _rows(values, n: int):
    """One (3,) vector as is (it broadcasts), or the last ``n`` rows of an (m, 3) array."""
    if isinstance(values, np.ndarray) and values.ndim == 2:
        return values[-n:]
    return values


class Particles:
    """A capped particle system: one numpy array, a row a particle.

    Columns: position (3), velocity (3), life left, life at birth, size (m),
    gravity factor, palette index (into PALETTES).
    """

    DRAG = 1.6  # 1/s, velocity decay
    COLUMNS = 11

    def __init__(self, cap: int = 400, rng: np.random.Generator | None = None) -> None:
        self.cap = int(cap)
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.clear()

    def clear(self) -> None:
        self.data = np.zeros((0, self.COLUMNS))

    @property
    def count(self) -> int:
        return len(self.data)

    pos = property(lambda self: self.data[:, 0:3])
    vel = property(lambda self: self.data[:, 3:6])
    life = property(lambda self: self.data[:, 6])
    life0 = property(lambda self: self.data[:, 7])
    size = property(lambda self: self.data[:, 8])
    palette = property(lambda self: self.data[:, 10].astype(np.int64))

    def emit(self, position: Sequence[float], n: int, speed: float, palette: str = "energy",
             life: tuple[float, float] = (0.4, 0.9), size: float = 0.06, gravity: float = 1.0,
             base_velocity: Sequence[float] = (0.0, 0.0, 0.0), spread: float = 0.0) -> None:
        """Add ``n`` particles at ``position`` (+- ``spread`` m) flying out at up to ``speed`` m/s.

        ``position`` and ``base_velocity`` are one (3,) vector or one row (n, 3)
        per particle. Beyond the cap the oldest particles make room (a burst always shows).
        """
        asked = int(n)
        n = min(asked, self.cap)
        if n <= 0:
            return
        rng = self.rng
        r = rng.random((n, 6))  # speed, life and size factors, spread
        d = rng.standard_normal((n, 3))
        d *= (speed * (0.3 + 0.7 * r[:, 0]) / np.sqrt((d * d).sum(axis=1) + 1e-18))[:, None]
        block = np.empty((n, self.COLUMNS))
        block[:, 0:3] = _rows(position, n)
        if spread:
            block[:, 0:3] += spread * (2.0 * r[:, 3:6] - 1.0)
        block[:, 3:6] = d
        block[:, 3:6] += _rows(base_velocity, n)
        block[:, 6] = life[0] + (life[1] - life[0]) * r[:, 1]
        block[:, 7] = block[:, 6]
        block[:, 8] = size * (0.7 + 0.6 * r[:, 2])
        block[:, 9] = gravity
        block[:, 10] = _PALETTE_INDEX[palette]
        data = np.concatenate((self.data, block))
        self.data = data[-self.cap:] if len(data) > self.cap else data

    def update(self, dt: float) -> None:
        """Move, slow down, fall, age; drop the dead ones."""
        d = self.data
        if dt <= 0 or not len(d):
            return
        d[:, 5] -= 9.81 * dt * d[:, 9]
        d[:, 3:6] *= math.exp(-self.DRAG * dt)
        d[:, 0:3] += d[:, 3:6] * dt
        d[:, 6] -= dt
        below = d[:, 2] < 0  # bounce off the ground, losing most of the energy
        if below.any():
            d[below, 2] = 0.0
            d[below, 5] *= -0.3
        alive = d[:, 6] > 0
        if not alive.all():
            self.data = d[alive]


@dataclass
class Flash:
    """The expanding ring of a hit."""

    position: tuple[float, float, float]
    age: float = 0.0
    duration: float = 0.35
    radius: float = 1.3  # metres at the end


# ------------------------------------------------------------------ caches


_SHARED_SPRITES = None


class SpriteCache:
    """Pre-rendered glow, shadow and panel surfaces (built on first use, kept)."""

    def __init__(self) -> None:
        self._glow: dict[tuple[int, str, int], pygame.Surface] = {}
        self._by_code: dict[int, pygame.Surface] = {}
        self._shadow: dict[tuple[int, int, int], pygame.Surface] = {}
        self._panel: dict[tuple[int, int, int], pygame.Surface] = {}
        self._warm = False

    @classmethod
    def shared(cls) -> "SpriteCache":
        """One cache for every renderer of the process (the sprites never change)."""
        global _SHARED_SPRITES
        if _SHARED_SPRITES is None:
            _SHARED_SPRITES = cls()
        return _SHARED_SPRITES

    @staticmethod
    def size_index(radius_px: np.ndarray | float) -> np.ndarray:
        """The cached glow size just at or above each radius."""
        return np.minimum(np.searchsorted(GLOW_SIZES, radius_px), len(GLOW_SIZES) - 1)

    @staticmethod
    def glow_codes(size_index: np.ndarray, palette: np.ndarray, level: np.ndarray) -> np.ndarray:
        """One int per glow sprite: (palette index * 100 + size index) * 10 + level."""
        return (np.asarray(palette, np.int64) * 100 + size_index) * 10 + level

    def glows(self, codes: list[int]) -> dict[int, pygame.Surface]:
        """The glow sprites by code, with every one of ``codes`` present."""
        by_code = self._by_code
        for code in set(codes).difference(by_code):
            by_code[code] = self.glow(code // 10 % 100, PALETTES[code // 1000], code % 10)
        return by_code

    def glow(self, size_index: int, colour: str, level: int) -> pygame.Surface:
        """A radial glow (hot white core, coloured halo) on black, for additive blits."""
        key = (int(size_index), colour, int(level))
        s = self._glow.get(key)
        if s is None:
            halo, core = _glow_profile(key[0])
            rgb = np.multiply.outer(halo, np.asarray(GLOW_COLOURS[colour], dtype=float))
            rgb += (229.5 * core)[..., None]
            rgb *= GLOW_LEVELS[key[2]]
            s = self._glow[key] = _surface_from_array(np.minimum(rgb, 255).astype(np.uint8))
        return s

    def warm_up(self) -> None:
        """Build the glow sprites a frame is likely to need, so that no frame stalls making one.

        Every palette up to 40 px radius (particles, trails); the big sizes in
        the ball, flash and hand colours. About 90 ms, once a cache.
        """
        if self._warm:
            return
        self._warm = True
        big = ("energy", "white", "spark")
        for si, r in enumerate(_GLOW_SIZE_LIST):
            for colour in (PALETTES if r <= 40 else big):
                for level in range(len(GLOW_LEVELS)):
                    self.glow(si, colour, level)

    def shadow(self, width: int, height: int, level: int) -> pygame.Surface:
        """A soft dark ellipse on white, for multiply blits (sizes rounded down to even)."""
        key = (width, height, level)
        s = self._shadow.get(key)
        if s is None:
            if len(self._shadow) > 4000:
                self._shadow.clear()
            s = self._shadow[key] = self._make_shadow(max(2, int(width) & ~1), max(2, int(height) & ~1), int(level))
        return s

    @staticmethod
    def _make_shadow(w: int, h: int, level: int) -> pygame.Surface:
        s = pygame.Surface((w, h))
        s.fill((255, 255, 255))
        dark = SHADOW_DARKNESS[level]
        for i, k in enumerate((0.35, 0.7, 1.0)):  # soft edge: three nested ellipses
            v = int(255 * (1.0 - (1.0 - dark) * k))
            inset_w, inset_h = int(w * 0.16 * i), int(h * 0.16 * i)
            pygame.draw.ellipse(s, (v, v, v), (inset_w, inset_h, max(1, w - 2 * inset_w), max(1, h - 2 * inset_h)))
        return s

    def panel(self, width: int, height: int, alpha: int = 175) -> pygame.Surface:
        """A translucent dark panel with a thin light border."""
        key = (max(1, int(width)), max(1, int(height)), int(alpha))
        s = self._panel.get(key)
        if s is None:
            s = pygame.Surface(key[:2], pygame.SRCALPHA)
            s.fill((10, 12, 30, alpha))
            pygame.draw.rect(s, (120, 150, 220, min(255, alpha + 40)), s.get_rect(), 1)
            if len(self._panel) > 64:
                self._panel.clear()
            self._panel[key] = s
        return s


@functools.lru_cache(maxsize=None)
def _glow_profile(size_index: int) -> tuple[np.ndarray, np.ndarray]:
    """A glow's radial halo (1 - r/R)^2 and hot core, (2R+1) pixels square."""
    r = _GLOW_SIZE_LIST[size_index]
    u = np.hypot(*np.meshgrid(np.arange(-r, r + 1), np.arange(-r, r + 1), indexing="ij")) / max(r, 1)
    return np.maximum(1.0 - u, 0.0) ** 2, np.maximum(1.0 - u / 0.3, 0.0)


def _surface_from_array(rgb: np.ndarray) -> pygame.Surface:
    """A plain RGB surface from an array indexed [x, y, channel]."""
    s = pygame.Surface(rgb.shape[:2])
    pygame.surfarray.blit_array(s, rgb)
    return s


class TextCache:
    """Fonts by size and rendered strings (with a drop shadow) by (text, size, colour)."""

    LIMIT = 600

    def __init__(self) -> None:
        self._fonts: dict[int, pygame.font.Font] = {}
        self._text: dict[tuple, pygame.Surface] = {}

    def font(self, size: int) -> pygame.font.Font:
        f = self._fonts.get(size)
        if f is None:
            if not pygame.font.get_init():
                pygame.font.init()
            try:
                f = pygame.font.Font(None, size)
            except (pygame.error, OSError):  # no default font: any system font will do
                f = pygame.font.SysFont(None, size)
            self._fonts[size] = f
        return f

    def render(self, text: str, size: int, colour: Sequence[int] = TEXT, shadow: bool = True) -> pygame.Surface:
        key = (text, int(size), tuple(colour), shadow)
        s = self._text.get(key)
        if s is None:
            font = self.font(int(size))
            fg = font.render(text, True, colour)
            if shadow:
                d = max(1, size // 16)
                s = pygame.Surface((fg.get_width() + d, fg.get_height() + d), pygame.SRCALPHA)
                s.blit(font.render(text, True, (0, 0, 0)), (d, d))
                s.blit(fg, (0, 0))
            else:
                s = fg
            if len(self._text) > self.LIMIT:
                self._text.clear()
            self._text[key] = s
        return s

    def render_on_black(self, text: str, size: int, colour: Sequence[int]) -> pygame.Surface:
        """Text on an opaque black background, for additive blits (a glow)."""
        key = (text, int(size), tuple(colour), "on black")
        s = self._text.get(key)
        if s is None:
            s = self._text[key] = self.font(int(size)).render(text, True, colour, (0, 0, 0))
        return s

    def blit(self, surface: pygame.Surface, text: str, size: int, colour: Sequence[int], pos: Sequence[int],
             anchor: str = "topleft", shadow: bool = True) -> pygame.Rect:
        s = self.render(text, size, colour, shadow)
        rect = s.get_rect(**{anchor: (int(pos[0]), int(pos[1]))})
        surface.blit(s, rect)
        return rect


# ------------------------------------------------------------------ zombies (vectorised pose)

(Z_HIP, Z_NECK, Z_HEAD, Z_SHL, Z_SHR, Z_HANDL, Z_HANDR, Z_KNEEL, Z_KNEER, Z_FOOTL, Z_FOOTR,
 Z_EYEL, Z_EYER) = range(13)
Z_JOINTS = 13
Z_LEGS = [Z_FOOTL, Z_KNEEL, Z_HIP, Z_KNEER, Z_FOOTR]
Z_ARMS = [Z_HANDL, Z_SHL, Z_SHR, Z_HANDR]


def _zombie_pose_basis() -> tuple[np.ndarray, np.ndarray]:
    """The zombie's local poses as a template plus a linear basis (x right, y forward, z up, 1.8 m tall).

    A pose is ``template + coefficients @ basis`` with the coefficients
    [sin(phase), max(cos, 0), max(-cos, 0)] for a walker (stride, left and
    right foot lift with a body bob) and [1, sin(f), sin(1.3 f + 1)] for a
    flier (the flying template, then its flailing): one matrix product for all zombies.
    """
    walk = np.array([[0, 0, 0.95], [0, 0.12, 1.50], [0, 0.18, 1.66], [-0.2, 0.10, 1.45], [0.2, 0.10, 1.45],
                     [-0.17, 0.70, 1.38], [0.17, 0.70, 1.38], [-0.11, 0.06, 0.50], [0.11, 0.06, 0.50],
                     [-0.13, 0.0, 0.0], [0.13, 0.0, 0.0], [-0.05, 0.30, 1.70], [0.05, 0.30, 1.70]])
    fly = np.array([[0, 0, 0.95], [0, 0, 1.50], [0, 0.03, 1.68], [-0.2, 0, 1.45], [0.2, 0, 1.45],
                    [-0.55, 0, 1.75], [0.55, 0, 1.75], [-0.2, 0, 0.50], [0.2, 0, 0.50],
                    [-0.28, 0, 0.08], [0.28, 0, 0.08], [-0.05, 0.13, 1.70], [0.05, 0.13, 1.70]])
    basis = np.zeros((6, Z_JOINTS, 3))
    stride, lift_l, lift_r, to_fly, flail, kick = basis
    for j, (k_stride, k_flail, k_kick) in {Z_FOOTL: (0.28, 0, 0.35), Z_FOOTR: (-0.28, 0, -0.35),
                                           Z_KNEEL: (0.14, 0.25, 0), Z_KNEER: (-0.14, -0.25, 0)}.items():
        stride[j, 1], flail[j, 1], kick[j, 1] = k_stride, k_flail, k_kick
    stride[Z_HANDL, 2], stride[Z_HANDR, 2] = 0.07, -0.07
    lift_l[:, 2], lift_r[:, 2] = 0.03, 0.03  # the bob
    lift_l[Z_FOOTL, 2] += 0.10
    lift_r[Z_FOOTR, 2] += 0.10
    to_fly[:] = fly - walk
    flail[Z_HANDL, 2], flail[Z_HANDR, 2] = 0.25, -0.25
    kick[Z_HANDL, 1], kick[Z_HANDR, 1] = 0.2, -0.2
    return walk.reshape(-1), basis.reshape(6, -1)


_Z_TEMPLATE, _Z_BASIS = _zombie_pose_basis()


def zombie_joints(x, y, z, phase, heading, spin, flying, age, height: float = 1.8) -> np.ndarray:
    """World joint positions (N, 13, 3) of N zombies, all at once.

    Walking: the classic shamble, arms reaching forward, legs and arms swinging
    with ``phase``. Flying: flailing limbs, the whole body tumbling by ``spin``
    about its own right-left axis through the hips.
    """
    x, y, z, phase, heading, spin, age = (np.asarray(v, dtype=float) for v in (x, y, z, phase, heading, spin, age))
    fl = np.asarray(flying, dtype=float)
    wk = 1.0 - fl
    c = np.cos(phase)
    f = phase + 9.0 * age
    coef = np.column_stack([np.sin(phase) * wk, np.maximum(c, 0) * wk, np.maximum(-c, 0) * wk,
                            fl, np.sin(f) * fl, np.sin(1.3 * f + 1.0) * fl])
    local = (_Z_TEMPLATE + coef @ _Z_BASIS).reshape(-1, Z_JOINTS, 3)
    lx, ly, lz = local[:, :, 0], local[:, :, 1], local[:, :, 2] - 0.95
    a = (spin * fl)[:, None]  # tumble about the local x axis through the hips (0 for walkers)
    ca, sa = np.cos(a), np.sin(a)
    ly, lz = ly * ca - lz * sa, ly * sa + lz * ca
    k = height / 1.8
    sh, ch = np.sin(heading)[:, None] * k, np.cos(heading)[:, None] * k  # forward (ch, sh), right (sh, -ch)
    out = np.empty_like(local)
    out[:, :, 0] = x[:, None] + lx * sh + ly * ch
    out[:, :, 1] = y[:, None] - lx * ch + ly * sh
    out[:, :, 2] = z[:, None] + (lz + 0.95) * k
    return out


# ------------------------------------------------------------------ avatar parts

def avatar_parts(avatar, stride_phase: float = 0.0, stride_amp: float = 0.0
                 ) -> list[tuple[str, list[tuple[float, float, float]], float, Colour]]:
    """The avatar as capsule chains: (name, joints, width in metres, colour).

    The skeleton has no legs (the tracker does not see them): they are drawn
    from the hips to the ground, striding while the player walks.
    """
    wp = avatar.world_pos
    side = avatar.body.side
    other = "left" if side == "right" else "right"
    yaw = avatar.body_yaw
    rx, ry = math.cos(yaw), math.sin(yaw)  # body right
    fx, fy = -ry, rx  # body forward
    hips = wp["hips"]
    k = hips[2]  # the hips stand 1.0 m high at the reference height (game.body.avatar)
    legs = []
    for sign, swing in ((-1.0, 1.0), (1.0, -1.0)):
        step = 0.3 * stride_amp * swing * math.sin(stride_phase)
        lift = 0.08 * stride_amp * max(0.0, swing * math.cos(stride_phase))
        hip = (hips[0] + sign * 0.1 * rx, hips[1] + sign * 0.1 * ry, hips[2] - 0.04 * k)
        foot = (hips[0] + sign * 0.12 * rx + step * fx, hips[1] + sign * 0.12 * ry + step * fy, lift)
        knee = (0.5 * (hip[0] + foot[0]) + 0.06 * fx, 0.5 * (hip[1] + foot[1]) + 0.06 * fy, 0.5 * hip[2] + lift)
        legs.append([hip, knee, foot])

    def arm(s: str) -> list:
        return [wp[f"{s}_upper_arm"], wp[f"{s}_forearm"], wp[f"{s}_hand"], avatar.end_of(f"{s}_hand")]

    head = wp["head"]
    centre = (head[0], head[1], head[2] + 0.09 * k)
    return [
        ("leg_l", legs[0], 0.14, AVATAR_LEGS),
        ("leg_r", legs[1], 0.14, AVATAR_LEGS),
        ("torso", [hips, wp["chest"], wp["neck"]], 0.27, AVATAR_BODY),
        ("shoulders", [wp["left_upper_arm"], wp["right_upper_arm"]], 0.14, AVATAR_BODY),
        ("arm_free", arm(other), 0.095, AVATAR_FREE_ARM),
        ("arm_tracked", arm(side), 0.105, AVATAR_ARM),
        # the head: its centre, and a point on the face (to tell the face from the back of the head)
        ("head", [centre, (centre[0] + 0.12 * fx, centre[1] + 0.12 * fy, centre[2])], 0.23, AVATAR_HEAD),
    ]


# ------------------------------------------------------------------ renderer


class _Batch:
    """Collects point sets for the frame's single projection; hands back slices."""

    def __init__(self) -> None:
        self.parts: list[np.ndarray] = []
        self.n = 0

    def add(self, points) -> slice:
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        sl = slice(self.n, self.n + len(points))
        self.parts.append(points)
        self.n += len(points)
        return sl

    def array(self) -> np.ndarray:
        return np.concatenate(self.parts) if self.parts else np.zeros((0, 3))


@dataclass
class _Frame:
    """The frame's single projection: camera coordinates, pixels, depth, visibility, int pixels."""

    cam: np.ndarray
    xy: np.ndarray
    depth: np.ndarray
    visible: np.ndarray
    ixy: np.ndarray  # int32 pixels, clipped to +-30000 (safe for pygame)


@dataclass
class _Plan:
    """Everything a frame paints, worked out before the first pixel is touched.

    The full-screen background blit evicts the interpreter's working set from
    the caches; numpy calls after it cost about twice as much (measured), so
    all of them run first and painting is pygame calls over ready lists.
    """

    grid: list = field(default_factory=list)  # [x1, y1, x2, y2] per line
    ring: list = field(default_factory=list)  # (colour, polyline)
    shadows: list = field(default_factory=list)  # MULT blit tuples
    items: list = field(default_factory=list)  # (paint function, payload), far to near
    circles: list = field(default_factory=list)  # flash rings: (colour, centre, radius, width)
    glows: list = field(default_factory=list)  # ADD blit tuples painted last (particles, flashes)
    hurt: float = 0.0  # 0..1, the red vignette


@dataclass
class _Gathered:
    """Where each kind of point sits in the frame's projection batch."""

    batch: "_Batch"
    ground: slice
    za: np.ndarray  # zombies in view: x, y, z, phase, heading, spin, age, flying (one row each)
    s_zj: slice  # their joints, Z_JOINTS each
    s_zg: slice  # their ground points
    balls: list
    s_balls: slice
    s_bg: slice  # the balls' ground points
    s_trails: slice  # all trails, ball after ball
    trail_lengths: list
    held: object
    s_held: slice
    parts: list  # avatar_parts()
    s_parts: list
    s_av: slice  # the avatar's ground point
    s_particles: slice
    s_flash: slice


def _runs(keep: list[bool], a: list, b: list) -> list[list]:
    """Polylines through the kept segments a[i]->b[i] of a closed loop (no run wraps across the seam)."""
    n = len(keep)
    start = keep.index(False) if not all(keep) else 0
    runs, run = [], []
    for j in range(n):
        i = (start + j) % n
        if keep[i]:
            if not run:
                run.append(a[i])
            run.append(b[i])
        elif run:
            runs.append(run)
            run = []
    if run:
        runs.append(run)
    return runs


def _paint_blits(surface: pygame.Surface, blits: list) -> None:
    surface.blits(blits, doreturn=False)


def _paint_calls(surface: pygame.Surface, calls: list) -> None:
    """Paint a list of (function, arguments) with the surface as first argument."""
    for fn, args in calls:
        fn(surface, *args)


def _paint_zombie(surface: pygame.Surface, record: tuple) -> None:
    """One zombie from its record (see :meth:`Renderer._zombie_records`)."""
    legs, arms, (hip, neck, head, eye_l, eye_r), limb, torso, head_r, colours, eyes = record
    legs_c, body_c, arms_c, head_c, out_c = colours
    lines, line, circle = pygame.draw.lines, pygame.draw.line, pygame.draw.circle
    if limb >= 7:  # near: a dark outline under each part, round joints
        lines(surface, out_c, False, legs, limb + 3)
        line(surface, out_c, hip, neck, torso + 3)
        lines(surface, out_c, False, arms, limb + 3)
        circle(surface, out_c, head, head_r + 2)
    lines(surface, legs_c, False, legs, limb)
    line(surface, body_c, hip, neck, torso)
    lines(surface, arms_c, False, arms, limb)
    if limb >= 9:
        r = limb // 2
        circle(surface, legs_c, legs[1], r)
        circle(surface, legs_c, legs[3], r)
        circle(surface, arms_c, arms[0], r)
        circle(surface, arms_c, arms[3], r)
    circle(surface, head_c, head, head_r)
    if eyes and head_r >= 5:
        r = max(1, head_r // 4)
        circle(surface, ZOMBIE_EYES, eye_l, r)
        circle(surface, ZOMBIE_EYES, eye_r, r)


class Renderer:
    """Draws the world, its effects, the HUD, plots and the app's screens.

    ``react(events)`` turns arena events into effects; ``draw_world`` advances
    the effects by ``effects_dt`` and draws one frame.
    """

    GRID_STEP = 2.0
    GRID_EXTENT = 56.0  # the grid's disc; its rim lies in the haze
    GRID_NEAR = 0.8  # ground lines are clipped here: nearer ground is below the screen
    FOG_NEAR, FOG_FAR = 12.0, 55.0
    RING_SEGMENTS = 96
    TOO_CLOSE = 2.0  # zombies nearer the camera than this (m) are not drawn: they would fill the view
    MAX_PARTICLES = 400
    TRAIL_SPARKS_PER_S = 40.0  # per flying ball
    EMIT_PERIOD_S = 1 / 30  # trail and charge sparks are emitted this often

    def __init__(self, screen_size: tuple[int, int] = (1280, 720), seed: int = 0,
                 rig: CameraRig | None = None, max_particles: int = MAX_PARTICLES) -> None:
        self.rng = np.random.default_rng(seed)
        self.camera = Camera(rig, tuple(screen_size))
        self.particles = Particles(max_particles, self.rng)
        self.flashes: list[Flash] = []
        self.sprites = SpriteCache.shared()
        self.sprites.warm_up()  # no frame should stall building a sprite
        self.text = TextCache()
        self._emit_dt = 0.0
        self._bg_key: tuple | None = None
        self._sky: pygame.Surface | None = None
        self._ground: pygame.Surface | None = None
        self._haze: pygame.Surface | None = None
        self._sky_period = 1
        self._horizon = 0
        self._ground_key: tuple | None = None
        self._ground_pts = np.zeros((0, 3))
        self._ground_plan_key: tuple | None = None
        self._ground_plan: tuple[list, list] = ([], [])
        self._vignette: dict[tuple[int, int, int], pygame.Surface] = {}
        self._stride = [0.0, 0.0, None]  # phase, amplitude, last position
        self._globes: dict[tuple, tuple] = {}  # (radius, turn, directions) -> (globe_cells(), covered, surface)

    # ---------------------------------------------------------- effects

    def react(self, events: Iterable) -> None:
        """Spawn effects for arena events: bursts and a flash ring for hits, sparks for the rest."""
        p = self.particles
        for e in events:
            kind, pos = getattr(e, "kind", None), tuple(getattr(e, "position", (0.0, 0.0, 0.0)))
            if kind == "hit":
                p.emit(pos, 34, 7.0, "energy", (0.4, 1.0), 0.08, 0.4)
                p.emit(pos, 20, 5.0, "goo", (0.5, 1.1), 0.07, 1.0)
                p.emit(pos, 10, 9.0, "white", (0.15, 0.35), 0.05, 0.0)
                self.flashes.append(Flash(pos))
            elif kind == "launch":
                p.emit(pos, 14, 2.5, "spark", (0.2, 0.45), 0.04, 0.2)
            elif kind == "miss":
                p.emit(pos, 18, 1.5, "energy", (0.3, 0.7), 0.05, -0.1)
            elif kind == "spawn":
                p.emit(pos, 14, 1.2, "goo", (0.4, 0.8), 0.06, -0.05, spread=0.3)
            elif kind == "hurt":
                p.emit(pos, 10, 2.0, "ember", (0.2, 0.5), 0.05, 0.8)
        if len(self.flashes) > 16:
            del self.flashes[:-16]

    def update_effects(self, dt: float, arena=None) -> None:
        """Advance particles and flashes by ``dt``; trails and crackle emit from the arena's balls."""
        self.particles.update(dt)
        for fl in self.flashes:
            fl.age += dt
        self.flashes = [fl for fl in self.flashes if fl.age < fl.duration]
        if arena is None or dt <= 0:
            return
        self._emit_dt += dt
        if self._emit_dt < self.EMIT_PERIOD_S:  # sparks come in batches: fewer, larger emissions
            return
        dt, self._emit_dt = self._emit_dt, 0.0
        rng = self.rng
        flying = [b for b in getattr(arena, "balls", ()) if b.state == "flying"]
        if flying:  # trail sparks, all balls in one emission
            counts = rng.poisson(self.TRAIL_SPARKS_PER_S * dt, len(flying))
            if counts.sum():
                pos = np.repeat(np.array([b.position for b in flying], dtype=float), counts, axis=0)
                vel = np.repeat(np.array([b.velocity for b in flying], dtype=float), counts, axis=0)
                self.particles.emit(pos, len(pos), 1.2, "energy", (0.25, 0.5), 0.045, 0.0, -0.08 * vel, 0.08)
        held = getattr(arena, "held", None)
        if held is not None and held.visible and held.state in ("loading", "spinning"):
            n = rng.poisson((30.0 + 120.0 * held.charge) * dt)
            if n:
                self.particles.emit(held.position, n, 1.0 + 2.0 * held.charge, "spark" if held.state == "spinning"
                                    else "energy", (0.12, 0.3), 0.03, -0.2, spread=0.05 + 0.1 * held.charge)

    # ---------------------------------------------------------- background

    def _ensure_background(self, surface: pygame.Surface) -> None:
        """(Re)build the sky panorama, the ground gradient and the haze strips when the view changes."""
        w, h = surface.get_size()
        horizon = int(round(min(max(self.camera.horizon_y(), -1.0), h + 1.0)))
        key = (w, h, horizon, round(self.camera.f, 3), round(float(self.camera.eye[2]), 3))
        if key == self._bg_key:
            return
        self._bg_key, self._horizon = key, horizon
        hz = max(0, min(h, horizon))
        self._sky_period = max(1, int(round(2 * math.pi * self.camera.f)))
        self._sky = self._build_sky(w, h, hz, self._sky_period) if hz > 0 else None
        self._ground, self._haze = self._build_ground(w, h, hz) if h > hz else (None, None)

    @staticmethod
    def _build_sky(w: int, h: int, hz: int, period: int) -> pygame.Surface:
        """A panorama one full turn wide (plus a screen for the wrap): gradient, hills, stars."""
        rng = np.random.default_rng(7)
        t = (np.arange(hz) / max(hz - 1, 1)) ** 1.6
        column = np.asarray(SKY_TOP, float) + (np.asarray(SKY_HORIZON, float) - SKY_TOP) * t[:, None]
        sky = np.broadcast_to(column, (period + w, hz, 3)).copy()
        xs = np.arange(period) * (2 * math.pi / period)
        hills = (np.sin(3 * xs + 1.0) * 7 + np.sin(7 * xs + 2.0) * 5 + np.sin(13 * xs) * 3
                 + np.sin(29 * xs + 0.5) * 1.5 + 18) * (h / 720)
        rows = np.arange(hz)[None, :]
        mask = rows >= (hz - hills)[:, None]
        haze = np.clip((rows - (hz - hills[:, None])) / np.maximum(hills[:, None], 1), 0, 1)
        hill_rgb = np.asarray(HILLS, float) + (np.asarray(SKY_HORIZON, float) * 0.6 - HILLS) * haze[..., None] * 0.5
        sky[:period][mask] = hill_rgb[mask]
        n_stars = int(period * hz / 2500)
        sx, sy = rng.integers(0, period, n_stars), (rng.random(n_stars) ** 1.8 * hz * 0.75).astype(int)
        bright = rng.uniform(90, 255, n_stars)[:, None] * (1 - sy / max(hz, 1))[:, None] ** 0.5
        sky[sx, sy] = np.maximum(sky[sx, sy], bright * np.array([0.9, 0.92, 1.0]))
        sky[period:] = sky[:w]
        return _surface_from_array(sky.astype(np.uint8))

    def _build_ground(self, w: int, h: int, hz: int) -> tuple[pygame.Surface, pygame.Surface | None]:
        """The ground gradient, and the haze that fades the grid into it with distance.

        The haze is one subtractive strip: a row at fog amount ``a`` takes
        ``k = a (GRID - ground)`` off every pixel, turning a grid pixel into
        ``lerp(GRID, ground, a)``; the ground under the strip is pre-rendered
        ``k`` brighter, so it comes out unchanged (GRID is brighter than the
        ground in every channel).
        """
        gh = h - hz
        t = (np.arange(gh) / max(gh - 1, 1)) ** 0.35
        column = np.asarray(GROUND_HORIZON, float) + (np.asarray(GROUND_NEAR, float) - GROUND_HORIZON) * t[:, None]
        a = self.fog(self.camera.ground_depth(np.arange(hz, h) + 0.5)) / 0.85
        band = int(np.count_nonzero(a > 0.01))
        k = np.maximum(a[:band, None] * (np.asarray(GRID, float) - column[:band]), 0.0)
        lifted = column.copy()
        lifted[:band] += k
        ground = _surface_from_array(np.broadcast_to(lifted, (w, gh, 3)).round().astype(np.uint8))
        if not band:
            return ground, None
        return ground, _surface_from_array(np.broadcast_to(k, (w, band, 3)).round().astype(np.uint8))

    def _draw_background(self, surface: pygame.Surface) -> None:
        hz = max(0, min(surface.get_height(), self._horizon))
        if self._sky is not None:
            offset = int((-self.camera.yaw * self.camera.f) % self._sky_period)
            surface.blit(self._sky, (0, 0), pygame.Rect(offset, 0, surface.get_width(), hz))
        if self._ground is not None:
            surface.blit(self._ground, (0, hz))

    def fog(self, depth: np.ndarray) -> np.ndarray:
        """How much of the haze colour replaces a thing's own at each depth (0..0.85)."""
        a = (np.asarray(depth, dtype=float) - self.FOG_NEAR) / (self.FOG_FAR - self.FOG_NEAR)
        return 0.85 * np.minimum(np.maximum(a, 0.0), 1.0) ** 0.8

    # ---------------------------------------------------------- world

    def draw_world(self, surface: pygame.Surface, arena, avatar, effects_dt: float) -> None:
        """One frame of the arena seen from behind the player (effects advance by ``effects_dt``)."""
        w, h = surface.get_size()
        cam = self.camera
        if (w, h) != (cam.width, cam.height):
            cam.set_viewport(w, h)
        player = arena.player
        cam.follow(player.x, player.y, player.yaw, effects_dt)
        self.update_effects(effects_dt, arena)
        self._update_stride(avatar, effects_dt)
        self._ensure_background(surface)
        self._paint(surface, self._plan(arena, avatar))

    def draw_backdrop(self, surface: pygame.Surface) -> None:
        """The sky and the ground alone, no arena and no avatar: behind a screen full of panels."""
        w, h = surface.get_size()
        if (w, h) != (self.camera.width, self.camera.height):
            self.camera.set_viewport(w, h)
        self._ensure_background(surface)
        self._draw_background(surface)
        if self._haze is not None:  # the ground lifted toward the grid's colour, less the grid: the haze off
            surface.blit(self._haze, (0, max(0, min(h, self._horizon))), special_flags=SUB)

    def _plan(self, arena, avatar) -> _Plan:
        """All of the frame's numpy work: gather every point, project once, build the paint lists."""
        settings = getattr(arena, "settings", None)
        g = self._gather(arena, avatar, settings)
        frame = self._project(g.batch)  # the ONE projection
        plan = _Plan(hurt=min(1.0, float(getattr(arena.player, "hurt", 0.0))
                              / _setting(settings, ("hurt_flash_s",), 0.3)))
        cam = self.camera
        key = (cam.width, cam.height, cam.f, *cam.eye.tolist(), *cam.rot[2].tolist(), self._ground_key)
        if key != self._ground_plan_key:  # the ground only changes when the camera moves
            self._ground_plan_key, self._ground_plan = key, self._plan_ground(frame.cam[g.ground])
        plan.grid, plan.ring = self._ground_plan
        # shadows: zombies (smaller and fainter when flying), balls, the avatar
        n_av = g.s_av.stop - g.s_av.start
        plan.shadows = self._plan_shadows(
            frame, np.r_[g.s_zg, g.s_bg, g.s_av],
            np.concatenate([np.full(len(g.za), 0.75), [0.5 + 0.3 * b.charge for b in g.balls], np.full(n_av, 0.9)]),
            np.concatenate([g.za[:, 2], [b.position[2] for b in g.balls], np.zeros(n_av)]))
        plan.items = self._plan_items(frame, g, settings)
        plan.circles, plan.glows = self._plan_flashes(frame, g.s_flash)
        plan.glows += self._plan_particles(frame, g.s_particles)
        return plan

    def _gather(self, arena, avatar, settings) -> "_Gathered":
        """Every point of the frame into one batch: ground, zombie joints, balls and trails, avatar, effects."""
        cam = self.camera
        batch = _Batch()
        ground = batch.add(self._ground_points(cam.state[:2], _setting(
            settings, ("arena_radius_m", "arena_radius", "radius"), 18.0)))
        za = np.array([(z.x, z.y, z.z, z.phase, z.heading, z.spin, z.age, z.state == "flying")
                       for z in arena.zombies if z.state != "gone"], dtype=float).reshape(-1, 8)
        if len(za):  # skip zombies behind the camera or far out to the side before posing them
            c = cam.to_camera(np.column_stack([za[:, 0], za[:, 1], za[:, 2] + 0.9]))
            za = za[(c[:, 2] > self.TOO_CLOSE - 1.0) & (np.abs(c[:, 0]) < c[:, 2] * (cam.cx / cam.f) + 1.5)]
        s_zj = batch.add(zombie_joints(za[:, 0], za[:, 1], za[:, 2], za[:, 3], za[:, 4], za[:, 5], za[:, 7] > 0,
                                       za[:, 6], _setting(settings, ("zombie_height_m", "zombie_height"), 1.8)))
        s_zg = batch.add(np.column_stack([za[:, 0], za[:, 1], np.zeros(len(za))]))
        balls = list(getattr(arena, "balls", ()))
        s_balls = batch.add([b.position for b in balls])
        s_bg = batch.add([(b.position[0], b.position[1], 0.0) for b in balls])
        trail_points = [p for b in balls for p in b.trail]
        s_trails = batch.add(trail_points)
        held = getattr(arena, "held", None)
        parts = avatar_parts(avatar, self._stride[0], self._stride[1]) if avatar is not None else []
        return _Gathered(
            batch, ground, za, s_zj, s_zg, balls, s_balls, s_bg, s_trails, [len(b.trail) for b in balls],
            held, batch.add([held.position] if held is not None else []), parts,
            [batch.add(pts) for _, pts, _, _ in parts],
            batch.add([(avatar.position[0], avatar.position[1], 0.0)] if avatar is not None else []),
            batch.add(self.particles.pos), batch.add([fl.position for fl in self.flashes]))

    def _plan_items(self, frame: _Frame, g: "_Gathered", settings) -> list:
        """Zombies, balls, the held ball and the avatar as (paint, payload), far to near."""
        items: list[tuple[float, object, object]] = []
        if len(g.za):
            zdepth, records = self._zombie_records(frame, g.s_zj, len(g.za), g.za[:, 7] > 0)
            items += [(d, _paint_zombie, rec) for d, rec in zip(zdepth.tolist(), records)]
        if g.balls:
            r0, r1 = _setting(settings, ("ball_radius_m",), 0.22), _setting(settings, ("ball_radius_per_charge_m",), 0.1)
            radii = [r0 + r1 * float(b.charge) for b in g.balls]
            fades = [float(b.fade) if b.state == "fading" else 1.0 for b in g.balls]
            trails = self._plan_trails(frame, g.s_trails, g.trail_lengths, radii, fades)
            for i, blits in enumerate(trails):
                j = g.s_balls.start + i
                if frame.visible[j]:
                    items.append((float(frame.depth[j]), _paint_blits, blits + self._plan_ball(frame, j, radii[i],
                                                                                                 fades[i])))
        held, j = g.held, g.s_held.start
        if held is not None and held.visible and (held.state in ("loading", "spinning") or held.charge > 0) \
                and frame.visible[j]:
            items.append((float(frame.depth[j]), _paint_calls, self._plan_held(frame, held, j)))
        if g.parts and frame.visible[g.s_parts[2].start + 1]:  # the chest
            items.append((float(frame.depth[g.s_parts[2].start + 1]), _paint_calls,
                          self._plan_avatar(frame, g.parts, g.s_parts)))
        order = depth_order(np.array([it[0] for it in items])).tolist() if items else []
        return [items[k][1:] for k in order]

    def _paint(self, surface: pygame.Surface, plan: _Plan) -> None:
        """Paint a planned frame: ground, shadows, things far to near, light on top."""
        self._draw_background(surface)
        line = pygame.gfxdraw.line  # 1-px lines: several times faster than pygame.draw.line
        for x1, y1, x2, y2 in plan.grid:
            line(surface, x1, y1, x2, y2, GRID)
        for colour, pts in plan.ring:
            pygame.draw.lines(surface, colour, False, pts)
        if self._haze is not None:
            surface.blit(self._haze, (0, max(0, min(surface.get_height(), self._horizon))), special_flags=SUB)
        surface.blits(plan.shadows, doreturn=False)
        for paint, payload in plan.items:
            paint(surface, payload)
        for colour, centre, radius, width in plan.circles:
            pygame.draw.circle(surface, colour, centre, radius, width)
        surface.blits(plan.glows, doreturn=False)
        if plan.hurt > 0:
            self._draw_vignette(surface, plan.hurt)

    def _project(self, batch: _Batch) -> _Frame:
        cam = self.camera
        camp = cam.to_camera(batch.array())
        xy, depth, visible = cam.project_camera(camp)
        return _Frame(camp, xy, depth, visible, _clip_pixels(xy).astype(np.int32))

    def _update_stride(self, avatar, dt: float) -> None:
        """The legs stride while the avatar moves (the skeleton has none: the tracker does not see them)."""
        if avatar is None:
            return
        phase, amp, last = self._stride
        pos = tuple(avatar.position)
        moved = math.dist(pos, last) if last is not None else 0.0
        if dt > 0:
            phase += moved / 0.55 * math.pi
            amp += (min(1.0, moved / dt / 2.0) - amp) * (1 - math.exp(-dt / 0.12))
        self._stride = [phase, amp, pos]

    # ---------------------------------------------------------- ground

    def _ground_points(self, cam_xy: Sequence[float], radius: float) -> np.ndarray:
        """Grid line starts, grid line ends, then the arena ring's closed polyline (cached per grid cell)."""
        step = self.GRID_STEP
        key = (round(cam_xy[0] / step), round(cam_xy[1] / step), radius)
        if key != self._ground_key:
            a, b = grid_segments(key[0] * step, key[1] * step, step, self.GRID_EXTENT)
            ang = np.linspace(0, 2 * math.pi, self.RING_SEGMENTS + 1)
            ring = np.stack([radius * np.cos(ang), radius * np.sin(ang), np.zeros_like(ang)], 1)
            self._ground_key, self._ground_pts = key, np.concatenate([a, b, ring])
        return self._ground_pts

    def _plan_ground(self, camp: np.ndarray) -> tuple[list, list]:
        """Clip grid and ring (camera space) in one go: grid lines, and the ring as glowing polylines."""
        n = (len(camp) - self.RING_SEGMENTS - 1) // 2
        grid, ring = camp[:2 * n], camp[2 * n:]
        pa, pb, keep = self._screen_segments(np.concatenate([grid[:n], ring[:-1]]),
                                             np.concatenate([grid[n:], ring[1:]]),
                                             max(self.GRID_NEAR, self.camera.near))
        g = keep[:n]
        lines = np.hstack([pa[:n][g], pb[:n][g]]).astype(np.int32).tolist()
        runs = _runs(keep[n:].tolist(), pa[n:].astype(np.int32).tolist(), pb[n:].astype(np.int32).tolist())
        polylines = []
        for run in runs:
            for dy, colour in ((-1, _RING_DIM), (1, _RING_DIM), (0, RING)):  # three 1-px lines: a soft glow
                polylines.append((colour, [[x, y + dy] for x, y in run]))
        return lines, polylines

    def _screen_segments(self, ca: np.ndarray, cb: np.ndarray, near: float):
        """Clip camera-space segments, project them, drop those entirely off one side of the screen."""
        cam = self.camera
        ca, cb, keep = clip_near(ca, cb, near)
        xy = _clip_pixels(cam.project_camera(np.concatenate([ca, cb]))[0]).reshape(2, len(ca), 2)
        lo, hi = np.minimum(xy[0], xy[1]), np.maximum(xy[0], xy[1])
        keep &= (hi[:, 0] >= 0) & (hi[:, 1] >= 0) & (lo[:, 0] <= cam.width) & (lo[:, 1] <= cam.height)
        return xy[0], xy[1], keep

    def _plan_shadows(self, frame: _Frame, idx: np.ndarray, width_m: np.ndarray, height_m: np.ndarray) -> list:
        """Soft dark ellipses (multiply blits) at ground points; smaller and fainter under things in the air."""
        cam = self.camera
        d = frame.depth[idx]
        ok = frame.visible[idx] & (d > 1.0)
        idx, d, width_m, height_m = idx[ok], d[ok], width_m[ok], height_m[ok]
        shrink = 1.0 / (1.0 + np.maximum(height_m, 0) / 3.0)
        wpx = np.minimum(np.maximum(cam.f * width_m * shrink / d, 2), 400)
        hpx = np.maximum(2, wpx * np.minimum(np.maximum(cam.eye[2] / d, 0.12), 1.0))  # ground foreshortening
        x, y = frame.xy[idx, 0], frame.xy[idx, 1]
        on = (x + wpx > 0) & (x - wpx < cam.width) & (y + hpx > 0) & (y - hpx < cam.height)
        wq, hq = wpx[on].astype(int) & ~1, hpx[on].astype(int) & ~1
        level = np.minimum(2, (height_m[on] / 2.5).astype(int))
        shadow = self.sprites.shadow
        return [(shadow(wi, hi, lv), (xi, yi), None, MULT) for wi, hi, lv, xi, yi in zip(
            wq.tolist(), hq.tolist(), level.tolist(), (x[on] - wq // 2).astype(int).tolist(),
            (y[on] - hq // 2).astype(int).tolist())]

    # ---------------------------------------------------------- zombies

    def _zombie_records(self, frame: _Frame, sl: slice, n: int, flying: np.ndarray) -> tuple[np.ndarray, list]:
        """The zombies worth drawing (in front, not too close, on screen): their depths and paint records.

        A record is (leg polyline, arm polyline, [hip, neck, head, eyes] pixels,
        limb width, torso width, head radius, colours, eyes shown).
        """
        cam = self.camera
        d = frame.depth[sl].reshape(n, Z_JOINTS)
        xy = frame.xy[sl].reshape(n, Z_JOINTS, 2)
        lo, hi = xy.min(axis=1), xy.max(axis=1)
        ok = np.flatnonzero((d > cam.near + 0.3).all(axis=1) & (d[:, Z_HIP] > self.TOO_CLOSE)
                            & (hi[:, 0] > -20) & (lo[:, 0] < cam.width + 20)
                            & (hi[:, 1] > -20) & (lo[:, 1] < cam.height + 20))
        if not len(ok):
            return np.zeros(0), []
        d, flying = d[ok], flying[ok]
        hip = d[:, Z_HIP]
        ppm = cam.f / hip
        fog_level = (self.fog(hip) * (15.99 / 0.85)).astype(int) + 16 * flying
        pts = frame.ixy[sl].reshape(n, Z_JOINTS, 2)[ok]
        records = list(zip(pts[:, Z_LEGS].tolist(), pts[:, Z_ARMS].tolist(),
                           pts[:, [Z_HIP, Z_NECK, Z_HEAD, Z_EYEL, Z_EYER]].tolist(),
                           np.maximum(1, ppm * 0.11).astype(int).tolist(),
                           np.maximum(1, ppm * 0.22).astype(int).tolist(),
                           np.maximum(2, ppm * 0.13).astype(int).tolist(),
                           [_ZOMBIE_COLOURS[i] for i in fog_level.tolist()],
                           (d[:, Z_EYEL] < d[:, Z_HEAD]).tolist()))  # eyes nearer than the head: facing us
        return hip, records

    # ---------------------------------------------------------- balls and glows

    def _glow(self, x: float, y: float, radius_px: float, colour: str, level: int) -> tuple:
        """One additive glow blit centred at (x, y)."""
        si = min(bisect.bisect_left(_GLOW_SIZE_LIST, radius_px), len(_GLOW_SIZE_LIST) - 1)
        r = int(GLOW_SIZES[si])
        return (self.sprites.glow(si, colour, level), (int(x) - r, int(y) - r), None, ADD)

    def _glow_blits(self, xy: np.ndarray, radius_px: np.ndarray, palette: np.ndarray, level: np.ndarray) -> list:
        """Many additive glow blits at once (centres, radii, palette indices, levels)."""
        if not len(xy):
            return []
        si = SpriteCache.size_index(radius_px)
        tl = (xy - GLOW_SIZES[si][:, None]).astype(int)
        codes = SpriteCache.glow_codes(si, palette, level).tolist()
        glow = self.sprites.glows(codes)
        return [(glow[k], (px, py), None, ADD) for k, px, py in zip(codes, tl[:, 0].tolist(), tl[:, 1].tolist())]

    def _plan_trails(self, frame: _Frame, sl: slice, lengths: list, radii: list, fades: list) -> list:
        """Every ball's trail as glow blits, all at once: every other point, tapering, oldest faintest."""
        cam = self.camera
        n = sl.stop - sl.start
        if not n:
            return [[] for _ in lengths]
        owner = np.repeat(np.arange(len(lengths)), lengths)
        starts = np.cumsum(lengths) - np.asarray(lengths)
        age = np.arange(n) - starts[owner]  # 0 = oldest
        k = (age + 1) / np.asarray(lengths, dtype=float)[owner]  # 1 = newest
        pick = ((np.asarray(lengths)[owner] - 1 - age) % 2 == 0) & frame.visible[sl]
        depth = frame.depth[sl][pick]
        k, owner = k[pick], owner[pick]
        rad = cam.f * np.asarray(radii)[owner] * (0.3 + 0.8 * k) / depth
        level = np.minimum(3, (k * 3.2 * np.asarray(fades)[owner]).astype(int))
        blits = self._glow_blits(frame.xy[sl][pick], rad, np.zeros(len(k), np.int64), level)
        ends = np.searchsorted(owner, np.arange(len(lengths) + 1)).tolist()
        return [blits[a:b] for a, b in zip(ends[:-1], ends[1:])]

    def _plan_ball(self, frame: _Frame, j: int, radius_m: float, fade: float) -> list:
        """A flying ball's halo and hot core (if on screen)."""
        cam = self.camera
        x, y = frame.xy[j]
        rpx = cam.f * radius_m / frame.depth[j]
        if not (-4 * rpx < x < cam.width + 4 * rpx and -4 * rpx < y < cam.height + 4 * rpx):
            return []
        level = max(0, min(3, int(fade * 3.99)))
        return [self._glow(x, y, 2.2 * rpx, "energy", level), self._glow(x, y, 1.1 * rpx, "white", level)]

    def _plan_held(self, frame: _Frame, held, j: int) -> list:
        """The ball at the hand: bigger and brighter with charge; crackling bolts while it loads or spins."""
        cam = self.camera
        x, y = frame.xy[j]
        charge = min(max(float(held.charge), 0.0), 1.0)
        rpx = cam.f * (0.06 + 0.16 * charge) / frame.depth[j]
        level = min(3, 1 + int(charge * 3))
        blit = pygame.Surface.blit
        calls = [(blit, self._glow(x, y, 2.4 * rpx, "energy", level)), (blit, self._glow(x, y, rpx, "white", level))]
        if held.state in ("loading", "spinning") and rpx >= 2:
            n_bolts = 2 + int(4 * charge)  # jagged bolts turning with the ball's spin, more as the charge grows
            angle = (held.spin + np.arange(n_bolts) * (2 * math.pi / n_bolts))[:, None] \
                + self.rng.normal(0, 0.35, (n_bolts, 3))
            reach = rpx * (0.8 + np.cumsum(self.rng.uniform(0.4, 0.9, (n_bolts, 3)), axis=1))
            bolts = np.empty((n_bolts, 4, 2))
            bolts[:, 0] = x, y
            bolts[:, 1:, 0] = x + reach * np.cos(angle)
            bolts[:, 1:, 1] = y + reach * np.sin(angle)
            colour = (170, 230, 255) if held.state == "loading" else (255, 240, 190)
            calls += [(pygame.draw.lines, (colour, False, pts)) for pts in bolts.astype(int).tolist()]
        return calls

    # ---------------------------------------------------------- avatar

    def _plan_avatar(self, frame: _Frame, parts, slices) -> list:
        """Capsules, parts far to near: a dark outline pass, then the colour pass, joints as circles."""
        cam = self.camera
        line, circle = pygame.draw.line, pygame.draw.circle
        all_depth = frame.depth[slices[0].start:slices[-1].stop].tolist()
        base = slices[0].start
        depth = [sum(all_depth[s.start - base:s.stop - base]) / (s.stop - s.start) for s in slices]
        calls: list = []
        for k in depth_order(np.array(depth)).tolist():
            name, _, width_m, colour = parts[k]
            s = slices[k]
            if not frame.visible[s].all():
                continue
            pts = frame.ixy[s].tolist()
            wpx = max(2, int(cam.f * width_m / depth[k]))
            if name == "head":  # seen from behind (the usual view): hair
                back = frame.depth[s.start + 1] > frame.depth[s.start]
                calls += [(circle, (OUTLINE, pts[0], wpx // 2 + 2)),
                          (circle, (AVATAR_HAIR if back else colour, pts[0], wpx // 2))]
                continue
            for col, ww in ((OUTLINE, wpx + 4), (colour, wpx)):
                calls += [(line, (col, a, b, ww)) for a, b in zip(pts[:-1], pts[1:])]
                calls += [(circle, (col, p, ww // 2)) for p in pts]
            if name == "arm_tracked":  # the tracked arm glows a little at the hand
                calls.append((pygame.Surface.blit, self._glow(pts[-1][0], pts[-1][1], wpx * 1.6, "spark", 0)))
        return calls

    # ---------------------------------------------------------- effects

    def _plan_flashes(self, frame: _Frame, sl: slice) -> tuple[list, list]:
        """Hit flashes: an expanding ring fading into the haze, a bright glow at first."""
        cam = self.camera
        circles, glows = [], []
        for k, fl in enumerate(self.flashes):
            j = sl.start + k
            if not frame.visible[j]:
                continue
            u = fl.age / fl.duration
            x, y = frame.xy[j]
            r = cam.f * fl.radius * (0.2 + 0.8 * math.sqrt(u)) / frame.depth[j]
            if 1 <= r <= 4000:
                colour = _lerp(_lerp((255, 255, 255), (60, 160, 255), u), HAZE, u * u)
                circles.append((colour, (int(x), int(y)), int(r), max(1, int(5 * (1 - u)) + 1)))
                if u < 0.5:
                    glows.append(self._glow(x, y, r * 1.2, "white", int(3 * (1 - 2 * u))))
        return circles, glows

    def _plan_particles(self, frame: _Frame, sl: slice) -> list:
        p = self.particles
        if not p.count:
            return []
        cam = self.camera
        x, y = frame.xy[sl, 0], frame.xy[sl, 1]
        rad = np.minimum(np.maximum(cam.f * p.size / np.maximum(frame.depth[sl], cam.near), 1), 40)
        on = frame.visible[sl] & (x > -rad) & (x < cam.width + rad) & (y > -rad) & (y < cam.height + rad)
        return self._glow_blits(frame.xy[sl][on], rad[on], p.palette[on],
                                np.minimum(3, (p.life[on] / p.life0[on] * 4).astype(int)))

    def _vignette_for(self, w: int, h: int, level: int) -> pygame.Surface:
        """The red edge glow for a screen size at one of four strengths (built for all four at once)."""
        v = self._vignette.get((w, h, level))
        if v is None:
            if len(self._vignette) > 8:
                self._vignette.clear()
            band = max(1, int(0.22 * min(w, h)))
            xs = np.minimum(np.arange(w), w - 1 - np.arange(w)) / band
            ys = np.minimum(np.arange(h), h - 1 - np.arange(h)) / band
            edge = (np.clip(1 - np.minimum(xs[:, None], ys[None, :]), 0, 1) ** 2)[..., None]
            for k in range(1, 5):
                rgb = edge * np.array([200.0, 10.0, 20.0]) * (k / 4)
                self._vignette[(w, h, k)] = _surface_from_array(rgb.astype(np.uint8))
            v = self._vignette[(w, h, level)]
        return v

    def prepare(self, size: tuple[int, int]) -> None:
        """Build what a frame at this size may need, so that no frame in play stalls building it."""
        self._vignette_for(size[0], size[1], 4)

    def _draw_vignette(self, surface: pygame.Surface, strength: float) -> None:
        """A red glow creeping in from the edges, drawn only in the edge bands (the centre is untouched)."""
        w, h = surface.get_size()
        level = max(1, min(4, int(math.ceil(strength * 4))))
        v = self._vignette_for(w, h, level)
        band = max(1, int(0.22 * min(w, h)))
        for rect in ((0, 0, w, band), (0, h - band, w, band), (0, band, band, h - 2 * band),
                     (w - band, band, band, h - 2 * band)):
            surface.blit(v, rect[:2], pygame.Rect(rect), special_flags=ADD)

    # ---------------------------------------------------------- HUD

    def _bar(self, surface, rect: pygame.Rect, fraction: float, colour: Colour, back: Colour = (20, 22, 40)) -> None:
        pygame.draw.rect(surface, OUTLINE, rect.inflate(4, 4))
        pygame.draw.rect(surface, back, rect)
        fill = rect.copy()
        fill.width = int(rect.width * max(0.0, min(1.0, fraction)))
        if fill.width:
            pygame.draw.rect(surface, colour, fill)
            hi = fill.copy()
            hi.height = max(1, rect.height // 3)
            pygame.draw.rect(surface, _lerp(colour, (255, 255, 255), 0.35), hi)

    def draw_hud(self, surface: pygame.Surface, hud: dict) -> None:
        """Score, wave, health, the ball's state and charge, input and link health, FPS.

        Keys (all optional): score, wave, health, health_max, ball (or
        ball_state), charge 0..1, input (a ready-made line) or source +
        rate_hz + loss_pct, calibrated, magnetometer (a line, shown in the
        warning colour, when the tracker's filter has switched it off), fps,
        notice.
        """
        w, h = surface.get_size()
        t = self.text
        big, mid, small = max(18, h // 18), max(16, h // 26), max(14, h // 34)
        t.blit(surface, f"SCORE {int(hud.get('score', 0))}", big, TEXT, (20, 14))
        health = float(hud.get("health", 0.0))
        hmax = float(hud.get("health_max", 100.0)) or 100.0
        frac = health / hmax
        bar = pygame.Rect(22, 16 + big, max(120, w // 5), max(10, h // 50))
        self._bar(surface, bar, frac, _lerp((230, 60, 50), (90, 230, 110), max(0.0, min(1.0, frac))))
        t.blit(surface, f"{max(0, int(round(health)))}", small, TEXT, (bar.right + 10, bar.centery), "midleft")
        t.blit(surface, f"WAVE {int(hud.get('wave', 0))}", big, ACCENT, (w // 2, 14), "midtop")
        if "fps" in hud:
            t.blit(surface, f"{float(hud['fps']):.0f} FPS", small, DIM_TEXT, (w - 16, 12), "topright")
        # the ball: state and charge, bottom centre
        state = str(hud.get("ball", hud.get("ball_state", "")))
        charge = float(hud.get("charge", 0.0))
        cbar = pygame.Rect(w // 2 - w // 8, h - 22 - max(10, h // 50), w // 4, max(10, h // 50))
        self._bar(surface, cbar, charge, _lerp((60, 140, 255), (255, 240, 160), charge))
        if state:
            t.blit(surface, f"ball: {state}   {int(round(100 * charge))}%", mid, TEXT, (w // 2, cbar.top - 6),
                   "midbottom")
        # input source and link health, bottom left
        lines = []
        if "input" in hud:
            lines.append(str(hud["input"]))
        elif "source" in hud:
            parts = [str(hud["source"])]
            if hud.get("rate_hz") is not None:
                parts.append(f"{float(hud['rate_hz']):.0f} Hz")
            if hud.get("loss_pct") is not None:
                parts.append(f"loss {float(hud['loss_pct']):.1f}%")
            lines.append(", ".join(parts))
        if "calibrated" in hud:
            lines.append("calibrated: " + ("yes" if hud["calibrated"] else "no"))
        warnings = [str(hud["magnetometer"])] if hud.get("magnetometer") else []
        y = h - 14
        for line in reversed(lines + warnings):
            colour = (255, 150, 120) if line.endswith(": no") or line in warnings else DIM_TEXT
            y = t.blit(surface, line, small, colour, (16, y), "bottomleft").top - 2
        notice = hud.get("notice")
        if notice:
            t.blit(surface, str(notice), mid, (250, 210, 80), (w // 2, 22 + big), "midtop")

    def draw_plots(self, surface: pygame.Surface, series: dict, rect) -> None:
        """Live sensor plots, one strip per series (columns are axes), autoscaled, labelled.

        ``series`` maps a label ("gyroscope (rad/s)", "accelerometer (m/s2)",
        "flex (ADC)", ...) to an array (N,) or (N, k); a "t" entry (N,), when
        given, only labels the time span.
        """
        rect = pygame.Rect(rect)
        surface.blit(self.sprites.panel(rect.width, rect.height, 190), rect)
        keys = [k for k in series if k != "t"]
        if not keys:
            return
        small = max(13, rect.height // 18)
        t = series.get("t")
        if t is not None and len(t) > 1:
            self.text.blit(surface, f"last {float(t[-1] - t[0]):.1f} s", small, DIM_TEXT,
                           (rect.right - 6, rect.bottom - 4), "bottomright")
        strip_h = (rect.height - 8) / len(keys)
        for n, key in enumerate(keys):
            top = rect.top + 4 + n * strip_h
            area = pygame.Rect(rect.left + 44, int(top + small + 2), rect.width - 52, int(strip_h - small - 8))
            self.text.blit(surface, str(key), small, TEXT, (rect.left + 6, int(top)))
            self._plot(surface, np.asarray(series[key], dtype=float), area, small)

    def _plot(self, surface: pygame.Surface, data: np.ndarray, area: pygame.Rect, small: int) -> None:
        pygame.draw.rect(surface, (60, 70, 110), area, 1)
        if data.ndim == 1:
            data = data[:, None]
        if data.size == 0 or area.width < 4 or area.height < 4:
            return
        step = max(1, int(math.ceil(len(data) / area.width)))
        d = data[::-1][::step][::-1]  # keep the newest sample
        finite = np.isfinite(d)
        if not finite.any():
            return
        lo, hi = float(np.min(d[finite])), float(np.max(d[finite]))
        pad = max(1e-6, 0.08 * (hi - lo), 1e-3 * max(abs(lo), abs(hi)))
        lo, hi = lo - pad, hi + pad
        ys_of = lambda v: area.bottom - 1 - (v - lo) / (hi - lo) * (area.height - 2)  # noqa: E731
        if lo < 0 < hi:
            y0 = int(ys_of(0.0))
            pygame.draw.line(surface, (70, 80, 120), (area.left, y0), (area.right - 1, y0))
        self.text.blit(surface, f"{hi:.3g}", small - 2, DIM_TEXT, (area.left - 4, area.top), "topright")
        self.text.blit(surface, f"{lo:.3g}", small - 2, DIM_TEXT, (area.left - 4, area.bottom), "bottomright")
        m = len(d)
        xs = area.left + 1 + np.arange(m) * ((area.width - 3) / max(m - 1, 1))
        single = d.shape[1] == 1
        for c in range(d.shape[1]):
            colour = AXIS_COLOURS[3] if single else AXIS_COLOURS[c % 3]
            col = np.where(np.isfinite(d[:, c]), d[:, c], lo)
            pts = np.column_stack([xs, ys_of(col)]).astype(int).tolist()
            if len(pts) >= 2:
                pygame.draw.lines(surface, colour, False, pts, 1)
            if not single:
                self.text.blit(surface, "xyz"[c % 3], small - 2, colour, (area.right - 36 + 12 * c, area.top - small - 1))

    # ---------------------------------------------------------- screens

    def draw_title(self, surface: pygame.Surface, title: str, subtitle: str = "") -> None:
        """A big glowing title in the upper third, a subtitle under it."""
        w, h = surface.get_size()
        size = max(32, h // 7)
        y = h // 6
        glow = self.text.render_on_black(title, size, (40, 110, 200))
        for dx, dy in ((-3, 0), (3, 0), (0, -3), (0, 3)):
            surface.blit(glow, glow.get_rect(midtop=(w // 2 + dx, y + dy)), special_flags=ADD)
        rect = self.text.blit(surface, title, size, (235, 245, 255), (w // 2, y), "midtop")
        if subtitle:
            self.text.blit(surface, subtitle, max(18, h // 28), DIM_TEXT, (w // 2, rect.bottom + 8), "midtop")

    def draw_menu(self, surface: pygame.Surface, items: list[str], selected: int, y0: int) -> None:
        """A centred vertical menu from ``y0``; the selected item on a bright bar with arrows."""
        w, h = surface.get_size()
        size = max(22, h // 20)
        gap = int(size * 1.35)
        width = max([self.text.font(size).size(f">  {item}  <")[0] for item in items] + [200]) + 80
        back = pygame.Rect(w // 2 - width // 2, int(y0 - gap * 0.6), width, int(gap * (len(items) + 0.2)))
        surface.blit(self.sprites.panel(back.width, back.height, 110), back)
        for i, item in enumerate(items):
            y = int(y0 + i * gap)
            if i == selected:
                bar = pygame.Rect(0, 0, width - 16, gap - 6)
                bar.center = (w // 2, y)
                surface.blit(self.sprites.panel(bar.width, bar.height, 150), bar)
                self.text.blit(surface, f">  {item}  <", size, (255, 230, 120), (w // 2, y), "center")
            else:
                self.text.blit(surface, item, size, DIM_TEXT, (w // 2, y), "center")

    def draw_panel(self, surface: pygame.Surface, lines: list[str], rect) -> None:
        """A translucent panel with lines of text (those that fit)."""
        rect = pygame.Rect(rect)
        surface.blit(self.sprites.panel(rect.width, rect.height), rect)
        size = max(16, min(28, surface.get_height() // 28))
        y = rect.top + 8
        for line in lines:
            if y + size * 0.7 > rect.bottom:
                break
            if line:
                self.text.blit(surface, str(line), size, TEXT, (rect.left + 12, y))
            y += int(size * 0.95)

    def draw_banner(self, surface: pygame.Surface, text: str, colour: Sequence[int] = TEXT) -> None:
        """Big centred text on a dark band."""
        w, h = surface.get_size()
        size = max(28, h // 9)
        if self.text.font(size).size(text)[0] > w * 0.92:  # long text: smaller
            size = max(18, int(size * w * 0.92 / self.text.font(size).size(text)[0]))
        band = pygame.Rect(0, h // 2 - int(size * 0.75), w, int(size * 1.5))
        surface.blit(self.sprites.panel(w, band.height, 140), band)
        self.text.blit(surface, text, size, tuple(colour), band.center, "center")

    def draw_countdown(self, surface: pygame.Surface, seconds_left: float, instruction: str) -> None:
        """A big number counting down, the second's progress as an arc, the instruction below."""
        w, h = surface.get_size()
        left = max(0.0, float(seconds_left))
        size = max(40, h // 4)
        centre = (w // 2, h // 2 - h // 12)
        radius = size // 2 + 10
        frac = left - math.floor(left) if left > 0 else 0.0
        pygame.draw.circle(surface, (30, 40, 80), centre, radius, 4)
        if frac > 0:
            box = pygame.Rect(0, 0, 2 * radius, 2 * radius)
            box.center = centre
            pygame.draw.arc(surface, ACCENT, box, math.pi / 2, math.pi / 2 + 2 * math.pi * frac, 6)
        self.text.blit(surface, str(int(math.ceil(left))), size, (255, 240, 170), centre, "center")
        self.text.blit(surface, instruction, max(20, h // 22), TEXT, (w // 2, centre[1] + radius + 16), "midtop")

    def draw_arm_view(self, surface: pygame.Surface, avatar, rect) -> None:
        """The tracked arm as stick figures, side view (forward right) and front view, in the body frame."""
        rect = pygame.Rect(rect)
        surface.blit(self.sprites.panel(rect.width, rect.height), rect)
        side = avatar.body.side
        wp = avatar.world_pos
        names = [f"{side}_upper_arm", f"{side}_forearm", f"{side}_hand"]
        pts = np.array([wp[n] for n in names] + [avatar.end_of(f"{side}_hand"), wp["chest"], wp["hips"], wp["neck"]])
        yaw = avatar.body_yaw
        rel = pts - pts[0]
        c, s = math.cos(yaw), math.sin(yaw)
        body = np.column_stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1], rel[:, 2]])  # x right, y fwd
        small = max(14, rect.height // 14)
        half = rect.width // 2
        reach = 0.75
        for k, (label, ax) in enumerate((("side", 1), ("front", 0))):
            view = pygame.Rect(rect.left + k * half + 6, rect.top + small + 6, half - 12, rect.height - small - 12)
            self.text.blit(surface, label, small, DIM_TEXT, (view.centerx, rect.top + 4), "midtop")
            pygame.draw.rect(surface, (50, 60, 100), view, 1)
            scale = min(view.width, view.height) / (2 * reach)
            ox, oy = view.centerx, view.centery
            horiz = body[:, ax] * (1 if ax == 1 else (1 if side == "right" else -1))
            p2 = [(int(ox + hx * scale), int(oy - vz * scale)) for hx, vz in zip(horiz.tolist(), body[:, 2].tolist())]
            pygame.draw.line(surface, (70, 90, 150), p2[6], p2[5], 3)  # the torso, for reference
            pygame.draw.lines(surface, AVATAR_ARM, False, p2[:4], 4)
            for j, colour in zip(range(4), ((255, 255, 255), (255, 210, 120), (255, 180, 80), (255, 140, 60))):
                pygame.draw.circle(surface, colour, p2[j], 5 if j < 3 else 3)

    # ---------------------------------------------------------- board setup (the maker's calibrations)

    def draw_board(self, surface: pygame.Surface, rect, up: Sequence[float] | np.ndarray | None, title: str,
                   highlight: str | None = None, captured: Sequence[str] = (), turn: float = 0.0) -> None:
        """The sensor board as a box with its axes, turned so that the sensor-frame vector ``up`` points up.

        ``highlight``: the face drawn glowing (the face to put up next); ``captured``:
        faces drawn ticked; ``turn``: the view's slow swing about the vertical (rad),
        so the box reads as solid. Faces are named as :data:`BOARD_FACES` ("+x" = the
        sensor's x axis up). ``up`` None (no reading yet) draws the board flat.
        """
        rect = pygame.Rect(rect)
        surface.blit(self.sprites.panel(rect.width, rect.height), rect)
        small = max(14, rect.height // 16)
        self.text.blit(surface, title, small, TEXT, (rect.centerx, rect.top + 6), "midtop")
        box = rect.inflate(-rect.width // 6, -rect.height // 4).move(0, small // 2)
        scale = 0.5 * min(box.width, box.height) / (max(BOARD_HALF) + 1.1)  # the arrows' tips fit
        view = board_view(np.array(up if up is not None else (0.0, 0.0, 1.0), dtype=float), turn)
        centre = np.array(box.center, dtype=float)
        toward = [float((view @ face_normal("+" + a))[2]) >= 0.0 for a in "xyz"]
        for axis in range(3):  # axes pointing away first: the box hides what is behind it
            if not toward[axis]:
                self._draw_axis(surface, view, centre, scale, axis, small)
        for face in visible_faces(view):
            corners = [_to_screen(view @ c, centre, scale) for c in face_corners(face)]
            light = 0.55 + 0.45 * max(0.0, float((view @ face_normal(face)) @ LIGHT_DIR))
            base = FACE_HIGHLIGHT if face == highlight else FACE_DONE if face in captured else FACE_COLOUR
            pygame.draw.polygon(surface, tuple(int(c * light) for c in base), corners)
            pygame.draw.polygon(surface, OUTLINE, corners, 2)
            if face == "+z":  # the IMU chip sits on the top face
                self._draw_chip(surface, view, centre, scale)
            if face == highlight and face[0] == "-":  # a + face has its axis' label at the arrow's tip
                mid = _to_screen(view @ (face_normal(face) * np.array(BOARD_HALF)), centre, scale)
                self.text.blit(surface, face, small + 4, OUTLINE, mid, "center", shadow=False)
        for axis in range(3):
            if toward[axis]:
                self._draw_axis(surface, view, centre, scale, axis, small)
        arrow_x, top = rect.left + 24, box.top + small
        self.text.blit(surface, "up", small, DIM_TEXT, (arrow_x, box.top), "midtop")
        pygame.draw.line(surface, DIM_TEXT, (arrow_x, top + 30), (arrow_x, top + 4), 2)
        pygame.draw.polygon(surface, DIM_TEXT, [(arrow_x, top), (arrow_x - 6, top + 8), (arrow_x + 6, top + 8)])

    def _draw_axis(self, surface: pygame.Surface, view: np.ndarray, centre: np.ndarray, scale: float,
                   axis: int, small: int) -> None:
        """A sensor axis as an arrow out of its + face, labelled "+x", "+y" or "+z" at the tip."""
        start, tip = np.zeros(3), np.zeros(3)
        start[axis], tip[axis] = BOARD_HALF[axis], BOARD_HALF[axis] + 0.9
        a, b = _to_screen(view @ start, centre, scale), _to_screen(view @ tip, centre, scale)
        colour = AXIS_COLOURS[axis]
        pygame.draw.line(surface, colour, a, b, 3)
        pygame.draw.circle(surface, colour, b, 5)
        dx, dy = b[0] - a[0], b[1] - a[1]
        length = math.hypot(dx, dy) or 1.0
        at = (round(b[0] + 16 * dx / length), round(b[1] + 16 * dy / length))
        self.text.blit(surface, "+" + "xyz"[axis], small, colour, at, "center")

    def _draw_chip(self, surface: pygame.Surface, view: np.ndarray, centre: np.ndarray, scale: float) -> None:
        """The IMU chip: a small dark square on the board's +z face, a dot at its pin 1."""
        hz = BOARD_HALF[2]
        chip = [np.array((x, y, hz)) for x, y in ((-0.9, -0.3), (-0.3, -0.3), (-0.3, 0.3), (-0.9, 0.3))]
        pygame.draw.polygon(surface, (24, 26, 34), [_to_screen(view @ c, centre, scale) for c in chip])
        pygame.draw.circle(surface, (220, 220, 220), _to_screen(view @ np.array((-0.8, 0.2, hz)), centre, scale), 2)

    def draw_face_chips(self, surface: pygame.Surface, rect, asked: str | None, captured: Sequence[str],
                        up: str | None, pulse: float = 0.0) -> None:
        """The six faces in the order they are asked: captured ticked green, the asked one
        glowing, the one up now outlined."""
        rect = pygame.Rect(rect)
        size = max(14, rect.height // 2)
        width = rect.width // len(BOARD_FACES)
        for i, face in enumerate(BOARD_FACES):
            chip = pygame.Rect(rect.left + i * width + 4, rect.top, width - 8, rect.height)
            glow = 0.75 + 0.25 * math.sin(pulse * 6.0)
            colour = FACE_DONE if face in captured else \
                tuple(int(c * glow) for c in FACE_HIGHLIGHT) if face == asked else (40, 46, 80)
            pygame.draw.rect(surface, colour, chip, border_radius=6)
            if face == up:
                pygame.draw.rect(surface, TEXT, chip.inflate(4, 4), 3, border_radius=8)
            ink = OUTLINE if face in captured or face == asked else DIM_TEXT
            self.text.blit(surface, face, size, ink, chip.center, "center", shadow=False)
            if face in captured:
                x, y = chip.right - 14, chip.top + 6
                pygame.draw.lines(surface, OUTLINE, False, [(x - 6, y + 5), (x - 2, y + 9), (x + 6, y)], 3)

    def draw_direction_sphere(self, surface: pygame.Surface, rect, directions: np.ndarray,
                              covered: Sequence[bool]) -> None:
        """The sphere of directions as two globes (its front and its back half), each bin lit once covered.

        ``directions``: the bins' unit vectors (n, 3), sensor frame; ``covered``: one
        flag per bin. Each pixel of a globe shows the bin whose direction is nearest
        (the cells of the bins' centres), shaded by the light.
        """
        rect = pygame.Rect(rect)
        surface.blit(self.sprites.panel(rect.width, rect.height), rect)
        small = max(14, rect.height // 16)
        radius = max(8, min(rect.width // 4 - 12, rect.height // 2 - small - 16))
        for k, label in enumerate(("front", "back")):
            centre = (rect.left + rect.width * (1 + 2 * k) // 4, rect.centery + small // 2)
            globe = self._globe(radius, k * math.pi, np.asarray(directions, float), tuple(bool(c) for c in covered))
            surface.blit(globe, globe.get_rect(center=centre))
            pygame.draw.circle(surface, OUTLINE, centre, radius + 1, 2)
            self.text.blit(surface, label, small, DIM_TEXT, (centre[0], rect.top + 6), "midtop")

    def _globe(self, radius: int, turn: float, directions: np.ndarray, covered: tuple[bool, ...]) -> pygame.Surface:
        """A globe turned by ``turn`` about the vertical (:func:`globe_cells`, :func:`globe_image`) as a
        surface; its geometry is computed once, its picture again only when ``covered`` changes."""
        key = (radius, turn, directions.tobytes())
        cells, shown, globe = self._globes.get(key, (None, None, None))
        if cells is None:
            cells = globe_cells(radius, view_rotation(turn, GLOBE_TILT), directions)
            if len(self._globes) >= GLOBE_CACHE:  # a new size or new bins: the old ones go
                self._globes.clear()
        if globe is None or shown != covered:
            colours = np.array([COVER_ON if c else COVER_OFF for c in covered], dtype=float).reshape(-1, 3)
            image = globe_image(radius, cells, colours)
            globe = pygame.surfarray.make_surface(np.ascontiguousarray(image.transpose(1, 0, 2)))
            globe.set_colorkey((0, 0, 0))
        self._globes[key] = (cells, covered, globe)
        return globe

    def draw_meter(self, surface: pygame.Surface, rect, label: str, fraction: float, colour: Colour) -> None:
        """A labelled bar: the label above, the bar filled to ``fraction``."""
        rect = pygame.Rect(rect)
        size = max(14, rect.height // 2)
        self.text.blit(surface, label, size, TEXT, rect.topleft)
        self._bar(surface, pygame.Rect(rect.left, rect.top + size + 4, rect.width, max(8, rect.height // 3)),
                  fraction, colour)

    def draw_setup_header(self, surface: pygame.Surface, title: str, steps: Sequence[str], current: int) -> None:
        """A band across the top: the title on the left, the numbered steps on the right, the current one lit."""
        w, h = surface.get_size()
        size = max(20, h // 26)
        band = pygame.Rect(0, 0, w, int(size * 2.2))
        surface.blit(self.sprites.panel(w, band.height, 160), band)
        self.text.blit(surface, title, size + 6, (235, 245, 255), (20, band.centery), "midleft")
        x = w - 20
        for i in reversed(range(len(steps))):
            lit = i == current
            rect = self.text.blit(surface, f"{i + 1} {steps[i]}", size, (255, 230, 120) if lit else DIM_TEXT,
                                  (x, band.centery), "midright")
            if lit:
                pygame.draw.line(surface, (255, 230, 120), (rect.left, rect.bottom + 2), (rect.right, rect.bottom + 2), 2)
            x = rect.left - 30

    def draw_setup_text(self, surface: pygame.Surface, rect, message: str, lines: Sequence[str], keys: str,
                        warn: bool = False) -> None:
        """The maker's panel: the procedure's line (big; warm when something is wrong), the figures, the keys."""
        rect = pygame.Rect(rect)
        surface.blit(self.sprites.panel(rect.width, rect.height), rect)
        h = surface.get_height()
        big, small = max(18, h // 28), max(15, h // 36)
        size = big
        while size > small and self.text.font(size).size(message)[0] > rect.width - 28:
            size -= 1  # a long line: smaller, so it stays one line
        colour = (255, 170, 110) if warn else (255, 240, 170)
        y = self.text.blit(surface, message, size, colour, (rect.left + 14, rect.top + 10)).bottom + 8
        for line in lines:
            if y + small > rect.bottom - small - 12:
                break
            y = self.text.blit(surface, line, small, TEXT, (rect.left + 14, y)).bottom + 3
        self.text.blit(surface, keys, small, DIM_TEXT, (rect.left + 14, rect.bottom - 8), "bottomleft")


# ------------------------------------------------------------------ board setup geometry

BOARD_FACES = ("+z", "-z", "+x", "-x", "+y", "-y")  # as tracker.accel_procedure.FACES asks them
BOARD_HALF = (1.6, 1.0, 0.22)  # the board's half-extent along its x, y, z (a flat board, x the long side)
FACE_COLOUR: Colour = (44, 72, 150)  # the board's solder mask
FACE_HIGHLIGHT: Colour = (255, 214, 90)
FACE_DONE: Colour = (110, 220, 130)
COVER_ON: Colour = (90, 230, 200)
COVER_OFF: Colour = (38, 44, 88)
LIGHT_DIR = np.array((-0.35, 0.55, 0.76)) / np.linalg.norm((-0.35, 0.55, 0.76))  # screen frame: x right, y up, z out
VIEW_PITCH = math.radians(28.0)  # the board is seen from above the horizon by this much
GLOBE_TILT = math.radians(20.0)
GLOBE_CACHE = 8  # globes kept (two a frame; more only after a resize)


def face_normal(face: str) -> np.ndarray:
    """The outward unit normal of a face ("+x", "-z", ...), sensor frame."""
    n = np.zeros(3)
    n["xyz".index(face[1])] = 1.0 if face[0] == "+" else -1.0
    return n


def face_corners(face: str) -> list[np.ndarray]:
    """A face's four corners (sensor frame, the board's size), in order around it."""
    axis = "xyz".index(face[1])
    u, v = [a for a in range(3) if a != axis]
    half = np.array(BOARD_HALF)
    corners = []
    for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        c = face_normal(face) * half
        c[u], c[v] = su * half[u], sv * half[v]
        corners.append(c)
    return corners


def rotation_to_up(up: np.ndarray) -> np.ndarray:
    """The rotation R (3 x 3) that turns the sensor-frame vector ``up`` onto the world's +z.

    Rodrigues' formula for the shortest turn; for ``up`` along -z (the board upside
    down), half a turn about x. A zero vector leaves the board as it is.
    """
    n = float(np.linalg.norm(up))
    if n == 0.0 or not np.isfinite(n):
        return np.eye(3)
    a = up / n
    z = np.array((0.0, 0.0, 1.0))
    axis = np.cross(a, z)
    s, c = float(np.linalg.norm(axis)), float(a @ z)
    if s < 1e-9:
        return np.eye(3) if c > 0 else np.diag((1.0, -1.0, -1.0))
    k = axis / s
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + s * kx + (1.0 - c) * (kx @ kx)


def view_rotation(turn: float, pitch: float) -> np.ndarray:
    """World (z up) to screen (x right, y up, z toward the viewer): a turn about the vertical,
    then the viewer raised by ``pitch`` above the horizon."""
    ct, st = math.cos(turn), math.sin(turn)
    yaw = np.array([[ct, -st, 0.0], [st, ct, 0.0], [0.0, 0.0, 1.0]])
    cp, sp = math.cos(pitch), math.sin(pitch)
    # world x -> screen x; world z (up) -> screen y tipped toward the viewer; world -y -> out of the screen
    look = np.array([[1.0, 0.0, 0.0], [0.0, sp, cp], [0.0, -cp, sp]])
    return look @ yaw


def board_view(up: np.ndarray, turn: float) -> np.ndarray:
    """Sensor frame to screen frame for the board with ``up`` up, seen from :data:`VIEW_PITCH` above."""
    return view_rotation(turn - 0.6, VIEW_PITCH) @ rotation_to_up(up)


def visible_faces(view: np.ndarray) -> list[str]:
    """The faces that face the viewer (screen z > 0) under ``view``: a convex box needs no sorting."""
    return [f for f in BOARD_FACES if float((view @ face_normal(f))[2]) > 1e-6]


def _to_screen(p: np.ndarray, centre: np.ndarray, scale: float) -> tuple[int, int]:
    """A screen-frame point (x right, y up) to pixels (orthographic)."""
    return int(round(centre[0] + scale * p[0])), int(round(centre[1] - scale * p[1]))


def globe_image(radius: int, cells: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
                colours: np.ndarray) -> np.ndarray:
    """An image (2r+1, 2r+1, 3) of a globe (:func:`globe_cells`): each pixel the colour of its nearest
    direction (``colours``, one row per direction), shaded, the cells' borders dark, black outside
    the disc (the colour key)."""
    inside, best, border, shade = cells
    rgb = colours[best] * shade[:, None]
    rgb[border] *= 0.45
    image = np.zeros((2 * radius + 1, 2 * radius + 1, 3), dtype=np.uint8)
    image[inside] = np.clip(rgb, 1, 255).astype(np.uint8)  # 1: never the colour key inside the disc
    return image


def globe_cells(radius: int, view: np.ndarray, directions: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A globe's geometry: the unit sphere of radius ``radius`` px under ``view``; which pixels lie
    on the disc, each one's nearest of ``directions`` (n, 3) (an index), whether it lies on a border
    between two cells, and its shading by :data:`LIGHT_DIR`."""
    y, x = np.mgrid[radius:-radius - 1:-1, -radius:radius + 1] / radius  # rows top to bottom: y up
    r2 = x * x + y * y
    inside = r2 < 1.0
    screen = np.stack([x[inside], y[inside], np.sqrt(1.0 - r2[inside])], axis=1)
    dots = (screen @ view) @ np.asarray(directions).T  # view^T turns screen points back to the sensor frame
    rows = np.arange(len(dots))
    best = np.argmax(dots, axis=1)
    nearest = dots[rows, best]
    dots[rows, best] = -np.inf
    border = nearest - np.max(dots, axis=1) < 0.018
    shade = 0.35 + 0.65 * np.clip(screen @ LIGHT_DIR, 0.0, 1.0)
    return inside, best, border, shade
