"""The minimap in the HUD's top right corner: the town from above, north up.

Streets, alleys and squares in light tones, the lots between them darker, obstacles as black shapes (a
picture made once per town and size), then each frame the zombies as red
dots, the balls as small blue ones and the player as an arrow pointing the
way he faces. North is up (the town's +y), so the map stays still while the
player turns; the arrow turns instead.
"""

from __future__ import annotations

import math

import numpy as np
import pygame

from .palette import (MAP_BALL, MAP_BORDER, MAP_LOTS, MAP_OBSTACLE, MAP_OPEN, MAP_PLAYER, MAP_ZOMBIE, OUTLINE,
                      Colour)

DOT_KEY = (255, 0, 255)  # no dot is drawn in this colour


def map_rect(size: tuple[int, int]) -> pygame.Rect:
    """Where the minimap sits on a screen of ``size``: a square a quarter of the height high, top right,
    below the frame rate."""
    w, h = size
    side = max(96, h // 4)
    return pygame.Rect(w - 16 - side, 16 + max(14, h // 34), side, side)


def map_xy(rect: pygame.Rect, half_size_m: float, x, y) -> tuple:
    """Where the world point (x, y) falls on the minimap, in fractional pixels (numbers or arrays alike): x
    east to the right, y north up."""
    scale = rect.width / (2.0 * half_size_m)
    return rect.left + (x + half_size_m) * scale, rect.top + (half_size_m - y) * scale


def to_map(rect: pygame.Rect, half_size_m: float, x: float, y: float) -> tuple[int, int]:
    """The minimap pixel of the world point (x, y) (:func:`map_xy`, whole)."""
    mx, my = map_xy(rect, half_size_m, x, y)
    return int(mx), int(my)


class Minimap:
    """Draws the minimap (see the module's docstring)."""

    def __init__(self) -> None:
        self._key: tuple | None = None
        self._picture: pygame.Surface | None = None
        self._dot_cache: dict[tuple, pygame.Surface] = {}

    def draw(self, surface: pygame.Surface, arena) -> None:
        """The town, its zombies and balls and the player, in the corner; nothing when there is no town."""
        town = getattr(arena, "town", None)
        if town is None:
            return
        rect = map_rect(surface.get_size())
        surface.blit(self._background(town, rect.width), rect)
        h = town.half_size_m
        clip = surface.get_clip()
        surface.set_clip(rect)
        dot = max(2, rect.width // 64)
        self._dots(surface, rect, h, [(z.x, z.y) for z in arena.zombies if z.state != "gone"], MAP_ZOMBIE, dot)
        self._dots(surface, rect, h, [b.position[:2] for b in getattr(arena, "balls", ())], MAP_BALL, max(1, dot - 1))
        p = arena.player
        self._arrow(surface, to_map(rect, h, p.x, p.y), p.yaw, max(5, rect.width // 22))
        surface.set_clip(clip)

    def _dots(self, surface: pygame.Surface, rect: pygame.Rect, h: float, xy: list, colour: Colour,
              radius: int) -> None:
        """A dot of ``radius`` pixels at each world point of ``xy``: one blit of a cached dot each, the same
        pixels as a circle drawn there (:func:`to_map`'s pixels, worked out all at once)."""
        if not xy:
            return
        points = np.asarray(xy, dtype=float)
        mx, my = map_xy(rect, h, points[:, 0], points[:, 1])
        x, y = mx.astype(int) - radius, my.astype(int) - radius  # truncated as int() truncates
        dot = self._dot(colour, radius)
        surface.blits([(dot, p) for p in zip(x.tolist(), y.tolist())], doreturn=False)

    def _dot(self, colour: Colour, radius: int) -> pygame.Surface:
        """A circle of ``radius`` pixels round the middle of a 2 ``radius`` square, on a colour key."""
        key = (tuple(colour), radius)
        dot = self._dot_cache.get(key)
        if dot is None:
            dot = pygame.Surface((2 * radius, 2 * radius))
            dot.fill(DOT_KEY)
            dot.set_colorkey(DOT_KEY)
            pygame.draw.circle(dot, colour, (radius, radius), radius)
            self._dot_cache[key] = dot
        return dot

    @staticmethod
    def _arrow(surface: pygame.Surface, centre: tuple[int, int], yaw: float, size: int) -> None:
        """The player: an arrow head pointing the way he faces (yaw 0: north; yaw grows turning left)."""
        fx, fy = -math.sin(yaw), -math.cos(yaw)  # forward on the screen (pixels run down)
        rx, ry = -fy, fx
        cx, cy = centre
        tip = (cx + fx * size, cy + fy * size)
        left = (cx - fx * size * 0.7 + rx * size * 0.7, cy - fy * size * 0.7 + ry * size * 0.7)
        right = (cx - fx * size * 0.7 - rx * size * 0.7, cy - fy * size * 0.7 - ry * size * 0.7)
        notch = (cx - fx * size * 0.3, cy - fy * size * 0.3)
        pts = [tip, left, notch, right]
        pygame.draw.polygon(surface, OUTLINE, pts, 3)
        pygame.draw.polygon(surface, MAP_PLAYER, pts)

    def _background(self, town, side: int) -> pygame.Surface:
        """The town's picture at ``side`` pixels square: open ground, obstacles, a border (kept per town)."""
        key = (id(town), side)
        if key != self._key or self._picture is None:
            picture = pygame.Surface((side, side), pygame.SRCALPHA)
            picture.fill(MAP_LOTS)
            rect = picture.get_rect()
            h = town.half_size_m
            for kind in ("street", "alley", "square"):  # squares over the streets that run into them
                for s in town.streets:
                    if s.kind == kind:
                        self._fill(picture, rect, h, s, MAP_OPEN[kind])
            for o in town.obstacles:
                self._fill(picture, rect, h, o, MAP_OBSTACLE)
            pygame.draw.rect(picture, MAP_BORDER, rect, 1)
            self._key, self._picture = key, picture
        return self._picture

    @staticmethod
    def _fill(picture: pygame.Surface, rect: pygame.Rect, h: float, box, colour: Colour) -> None:
        x0, y0 = to_map(rect, h, box.x0, box.y1)  # the top left corner: west and north
        x1, y1 = to_map(rect, h, box.x1, box.y0)
        pygame.draw.rect(picture, colour, pygame.Rect(x0, y0, max(1, x1 - x0), max(1, y1 - y0)))
