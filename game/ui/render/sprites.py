"""Pre-rendered pictures the renderer blits: glows, shadows, panels, and text by (string, size, colour)."""

from __future__ import annotations

import bisect
import functools
from typing import Sequence

import numpy as np
import pygame

from .palette import ADD, GLOW_COLOURS, PALETTES, SHADOW_DARKNESS, TEXT

GLOW_SIZES = np.array([2, 3, 4, 5, 6, 8, 10, 13, 16, 20, 25, 32, 40, 50, 64, 80, 100, 128])  # radii, px
_GLOW_SIZE_LIST = GLOW_SIZES.tolist()
GLOW_LEVELS = (0.3, 0.55, 0.8, 1.0)  # brightness steps of each glow sprite

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
            s = self._glow[key] = surface_from_array(np.minimum(rgb, 255).astype(np.uint8))
        return s

    def glow_blit(self, x: float, y: float, radius_px: float, colour: str, level: int) -> tuple:
        """One additive glow blit centred at (x, y)."""
        si = min(bisect.bisect_left(_GLOW_SIZE_LIST, radius_px), len(_GLOW_SIZE_LIST) - 1)
        r = int(GLOW_SIZES[si])
        return (self.glow(si, colour, level), (int(x) - r, int(y) - r), None, ADD)

    def glow_blits(self, xy: np.ndarray, radius_px: np.ndarray, palette: np.ndarray, level: np.ndarray) -> list:
        """Many additive glow blits at once (centres, radii, palette indices, levels)."""
        if not len(xy):
            return []
        si = SpriteCache.size_index(radius_px)
        tl = (xy - GLOW_SIZES[si][:, None]).astype(int)
        codes = SpriteCache.glow_codes(si, palette, level).tolist()
        glow = self.glows(codes)
        return [(glow[k], (px, py), None, ADD) for k, px, py in zip(codes, tl[:, 0].tolist(), tl[:, 1].tolist())]

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


def surface_from_array(rgb: np.ndarray) -> pygame.Surface:
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
