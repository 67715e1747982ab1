"""The menus' pictures: titles, menus, panels, banners, the countdown and the arm's stick figures."""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
import pygame

from .palette import ACCENT, ADD, AVATAR_ARM, DIM_TEXT, TEXT
from .sprites import SpriteCache, TextCache


class Screens:
    """Draws the screens' parts (a part of :class:`~game.ui.render.Renderer`, with its text and sprites)."""

    text: TextCache
    sprites: SpriteCache

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

    def panel_lines(self, lines: Sequence[str], width: int, surface_height: int) -> list[str]:
        """``lines`` broken at spaces to fit ``width`` pixels of a panel on a surface this high (a
        word longer than the width stays whole)."""
        font = self.text.font(_panel_text_size(surface_height))
        out: list[str] = []
        for line in lines:
            words, row = str(line).split(" "), ""
            for word in words:
                wider = f"{row} {word}" if row else word
                if row and font.size(wider)[0] > width:
                    out.append(row)
                    wider = word
                row = wider
            out.append(row)
        return out

    def draw_panel(self, surface: pygame.Surface, lines: list[str], rect) -> None:
        """A translucent panel with lines of text, wrapped to its width (those that fit)."""
        rect = pygame.Rect(rect)
        self._panel(surface, self.panel_lines(lines, rect.width - 24, surface.get_height()), rect)

    def draw_footer(self, surface: pygame.Surface, lines: list[str]) -> None:
        """A panel along the bottom edge, as tall as its lines wrapped to the width."""
        w, h = surface.get_size()
        wrapped = self.panel_lines(lines, w - 64, h)
        height = 20 + 30 * len(wrapped)
        self._panel(surface, wrapped, pygame.Rect(20, h - height - 20, w - 40, height))

    def _panel(self, surface: pygame.Surface, lines: list[str], rect: pygame.Rect) -> None:
        """The panel and its lines as they are (those that fit)."""
        surface.blit(self.sprites.panel(rect.width, rect.height), rect)
        size = _panel_text_size(surface.get_height())
        y = rect.top + 8
        for line in lines:
            if y + size * 0.7 > rect.bottom:
                break
            if line:
                self.text.blit(surface, line, size, TEXT, (rect.left + 12, y))
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
        # x right, y forward
        body = np.column_stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1], rel[:, 2]])
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


def _panel_text_size(surface_height: int) -> int:
    """The panels' text size on a surface this high."""
    return max(16, min(28, surface_height // 28))
