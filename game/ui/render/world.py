"""The world around the actors: sky, ground and haze, the ground grid, the town's lines on the ground, shadows.

The sky, ground and haze are pre-rendered and cached; the grid and the
town's street lines (:func:`game.ui.render.town.ground_lines`) are clipped
and projected once per camera move. The town's boxes are :mod:`.town`'s.
"""

from __future__ import annotations

import math
from typing import Iterable, Sequence

import numpy as np
import pygame
import pygame.gfxdraw

from .camera import Batch, Camera, Frame
from .palette import GRID, GROUND_HORIZON, GROUND_NEAR, HILLS, MULT, SKY_HORIZON, SKY_TOP, SUB
from .sprites import SpriteCache, surface_from_array

FOG_NEAR, FOG_FAR = 12.0, 55.0


def fog(depth: np.ndarray) -> np.ndarray:
    """How much of the haze colour replaces a thing's own at each depth (0..0.85)."""
    a = (np.asarray(depth, dtype=float) - FOG_NEAR) / (FOG_FAR - FOG_NEAR)
    return 0.85 * np.minimum(np.maximum(a, 0.0), 1.0) ** 0.8


def setting(settings: object, names: Iterable[str], default: float) -> float:
    """A number from the arena's settings under the first name that exists (the arena is duck-typed)."""
    for name in names:
        value = getattr(settings, name, None)
        if isinstance(value, (int, float)):
            return float(value)
    return default


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


class Scenery:
    """Draws the sky, the ground with its grid and the town's lines fading into the haze, and shadows."""

    GRID_STEP = 2.0
    GRID_EXTENT = 56.0  # the grid's disc; its rim lies in the haze
    GRID_NEAR = 0.8  # ground lines are clipped here: nearer ground is below the screen

    def __init__(self, camera: Camera, sprites: SpriteCache) -> None:
        self.camera = camera
        self.sprites = sprites
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
        self._town_colours: list = []

    def gather(self, batch: Batch, lines: tuple[np.ndarray, np.ndarray, list] | None) -> slice:
        """The ground's points (the grid's, then the town's ``lines``: starts, ends, colours) into the frame's batch."""
        return batch.add(self._ground_points(self.camera.state[:2], lines))

    def plan_ground(self, frame: Frame, ground: slice) -> tuple[list, list]:
        """Grid lines and the town's coloured lines on screen (worked out again only when the camera moves)."""
        cam = self.camera
        key = (cam.width, cam.height, cam.f, *cam.eye.tolist(), *cam.rot[2].tolist(), self._ground_key)
        if key != self._ground_plan_key:
            self._ground_plan_key, self._ground_plan = key, self._plan_ground(frame.cam[ground])
        return self._ground_plan

    def paint_ground(self, surface: pygame.Surface, grid: list, lines: list) -> None:
        """The background, the grid and the town's lines fading into the haze."""
        self._draw_background(surface)
        line = pygame.gfxdraw.line  # 1-px lines: several times faster than pygame.draw.line
        for x1, y1, x2, y2 in grid:
            line(surface, x1, y1, x2, y2, GRID)
        for x1, y1, x2, y2, colour in lines:
            line(surface, x1, y1, x2, y2, colour)
        self._draw_haze(surface)

    @staticmethod
    def paint_shadows(surface: pygame.Surface, shadows: list) -> list[pygame.Rect]:
        """The shadows on the ground (:meth:`plan_shadows`); returns the rectangles painted."""
        return surface.blits(shadows)

    def backdrop(self, surface: pygame.Surface) -> None:
        """The sky and the ground alone: behind a screen full of panels."""
        self.prepare(surface)
        self._draw_background(surface)
        self._draw_haze(surface)  # the ground lifted toward the grid's colour, less the grid: the haze off

    def prepare(self, surface: pygame.Surface) -> None:
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
        return surface_from_array(sky.astype(np.uint8))

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
        a = fog(self.camera.ground_depth(np.arange(hz, h) + 0.5)) / 0.85
        band = int(np.count_nonzero(a > 0.01))
        k = np.maximum(a[:band, None] * (np.asarray(GRID, float) - column[:band]), 0.0)
        lifted = column.copy()
        lifted[:band] += k
        ground = surface_from_array(np.broadcast_to(lifted, (w, gh, 3)).round().astype(np.uint8))
        if not band:
            return ground, None
        return ground, surface_from_array(np.broadcast_to(k, (w, band, 3)).round().astype(np.uint8))

    def _draw_background(self, surface: pygame.Surface) -> None:
        hz = max(0, min(surface.get_height(), self._horizon))
        if self._sky is not None:
            offset = int((-self.camera.yaw * self.camera.f) % self._sky_period)
            surface.blit(self._sky, (0, 0), pygame.Rect(offset, 0, surface.get_width(), hz))
        if self._ground is not None:
            surface.blit(self._ground, (0, hz))

    def _draw_haze(self, surface: pygame.Surface) -> None:
        """Fade what is drawn on the ground (the grid, the town's lines) into the haze with distance
        (:meth:`_build_ground`)."""
        if self._haze is not None:
            surface.blit(self._haze, (0, max(0, min(surface.get_height(), self._horizon))), special_flags=SUB)

    def _ground_points(self, cam_xy: Sequence[float], lines) -> np.ndarray:
        """Grid line starts, grid line ends, then the town's line starts and ends (cached per grid cell and town)."""
        step = self.GRID_STEP
        key = (round(cam_xy[0] / step), round(cam_xy[1] / step), id(lines))
        if key != self._ground_key:
            a, b = grid_segments(key[0] * step, key[1] * step, step, self.GRID_EXTENT)
            starts, ends, colours = lines if lines is not None else (np.zeros((0, 3)), np.zeros((0, 3)), [])
            self._ground_key, self._town_colours = key, colours
            self._ground_pts = np.concatenate([a, starts, b, ends])
        return self._ground_pts

    def _plan_ground(self, camp: np.ndarray) -> tuple[list, list]:
        """Clip the grid's and the town's lines (camera space) in one go: the grid's, and the town's with colours."""
        n = len(camp) // 2
        pa, pb, keep = self.camera.screen_segments(camp[:n], camp[n:], max(self.GRID_NEAR, self.camera.near))
        lines = np.hstack([pa, pb]).astype(np.int32)
        g = n - len(self._town_colours)  # the grid's lines come first
        grid = lines[:g][keep[:g]].tolist()
        town = [(*seg, colour) for seg, k, colour in zip(lines[g:].tolist(), keep[g:].tolist(), self._town_colours)
                if k]
        return grid, town

    def plan_shadows(self, frame: Frame, idx: np.ndarray, width_m: np.ndarray, height_m: np.ndarray) -> list:
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
