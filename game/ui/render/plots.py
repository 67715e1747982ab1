"""Live sensor plots: one autoscaled, labelled strip per series."""

from __future__ import annotations

import math

import numpy as np
import pygame

from .palette import AXIS_COLOURS, DIM_TEXT, TEXT
from .sprites import SpriteCache, TextCache


class Plots:
    """Draws the sensor plots (a part of :class:`~game.ui.render.Renderer`, with its text and sprites)."""

    text: TextCache
    sprites: SpriteCache

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
                self.text.blit(surface, "xyz"[c % 3], small - 2, colour,
                               (area.right - 36 + 12 * c, area.top - small - 1))
