"""The HUD over the play view: score, wave, health, the ball's charge, input and link health, FPS."""

from __future__ import annotations

import pygame

from .palette import ACCENT, DIM_TEXT, OUTLINE, TEXT, Colour, lerp
from .sprites import TextCache


def draw_bar(surface, rect: pygame.Rect, fraction: float, colour: Colour, back: Colour = (20, 22, 40)) -> None:
    """A bar filled to ``fraction`` (0..1) of ``rect``, outlined, a highlight along its top."""
    pygame.draw.rect(surface, OUTLINE, rect.inflate(4, 4))
    pygame.draw.rect(surface, back, rect)
    fill = rect.copy()
    fill.width = int(rect.width * max(0.0, min(1.0, fraction)))
    if fill.width:
        pygame.draw.rect(surface, colour, fill)
        hi = fill.copy()
        hi.height = max(1, rect.height // 3)
        pygame.draw.rect(surface, lerp(colour, (255, 255, 255), 0.35), hi)


class Hud:
    """Draws the HUD (a part of :class:`~game.ui.render.Renderer`, with its text)."""

    text: TextCache

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
        draw_bar(surface, bar, frac, lerp((230, 60, 50), (90, 230, 110), max(0.0, min(1.0, frac))))
        t.blit(surface, f"{max(0, int(round(health)))}", small, TEXT, (bar.right + 10, bar.centery), "midleft")
        t.blit(surface, f"WAVE {int(hud.get('wave', 0))}", big, ACCENT, (w // 2, 14), "midtop")
        if "fps" in hud:
            t.blit(surface, f"{float(hud['fps']):.0f} FPS", small, DIM_TEXT, (w - 16, 12), "topright")
        # the ball: state and charge, bottom centre
        state = str(hud.get("ball", hud.get("ball_state", "")))
        charge = float(hud.get("charge", 0.0))
        cbar = pygame.Rect(w // 2 - w // 8, h - 22 - max(10, h // 50), w // 4, max(10, h // 50))
        draw_bar(surface, cbar, charge, lerp((60, 140, 255), (255, 240, 160), charge))
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

