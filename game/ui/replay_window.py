"""A replay in the game's window: the recorded game at its pace, with pause, seek and speed.

Keys (shown on screen): Space pauses and resumes; Right seeks 5 s ahead and
Left 5 s back; Up and Down double and halve the speed (1/4x to 8x); Home
starts again; Esc ends. The window's own events drive only this viewer: the
game hears the recorded ones. Seeking back plays the recording again from
its start without drawing up to the moment sought (a replay is the game run
again, so there is no earlier state to jump to), which takes a moment in a
long session.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import pygame

from ..replay.replay import ReplayReport, replay
from .render.palette import TEXT

SEEK_S = 5.0
SPEEDS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0)
KEYS = "Space pause  Left/Right 5 s  Up/Down speed  Home restart  Esc quit"
BAR_PX = 20  # the replay's bar, along the bottom under the HUD's ball


@dataclass
class ReplayWindow:
    """Watches one replay: paces it, takes the window's keys, draws the replay's bar."""

    path: Path
    start_s: float = 0.0  # from where to show it
    speed: float = 1.0
    paused: bool = False
    restart_at: float | None = None  # the moment a seek back (or Home) asks to start again from
    quit: bool = False
    _wall: float = 0.0  # when the last frame was shown
    _shown_t: float = 0.0

    def drawing(self, t: float) -> bool:
        return t >= self.start_s

    def after(self, app, t: float) -> bool:
        if t < self.start_s:  # seeking ahead: the game runs on, undrawn
            return True
        picture = pygame.display.get_surface().copy()
        self._show(app, picture, t)
        wait = (t - self._shown_t) / self.speed - (time.monotonic() - self._wall)
        if 0 < wait < 0.5:
            time.sleep(wait)
        self._wall, self._shown_t = time.monotonic(), t
        self._keys()
        while self.paused and not self._leaving() and self.start_s <= t:
            time.sleep(1 / 60)
            self._keys()
            self._show(app, picture, t)
        return not self._leaving()

    def _leaving(self) -> bool:
        return self.quit or self.restart_at is not None

    def _keys(self) -> None:
        for event in pygame.event.get():
            if event.type == pygame.QUIT:
                self.quit = True
            elif event.type == pygame.KEYDOWN:
                self._key(event.key)

    def _key(self, key: int) -> None:
        if key == pygame.K_ESCAPE:
            self.quit = True
        elif key == pygame.K_SPACE:
            self.paused = not self.paused
        elif key == pygame.K_RIGHT:
            self.start_s = self._shown_t + SEEK_S
        elif key in (pygame.K_LEFT, pygame.K_HOME):
            self.restart_at = 0.0 if key == pygame.K_HOME else max(0.0, self._shown_t - SEEK_S)
        elif key in (pygame.K_UP, pygame.K_DOWN):
            k = SPEEDS.index(self.speed) + (1 if key == pygame.K_UP else -1)
            self.speed = SPEEDS[max(0, min(len(SPEEDS) - 1, k))]

    def _show(self, app, picture: pygame.Surface, t: float) -> None:
        """The game's ``picture`` with the replay's bar over it, on the screen."""
        surface = pygame.display.get_surface()
        surface.blit(picture, (0, 0))
        text = app.game.renderer.text
        w, h = surface.get_size()
        bar = pygame.Surface((w, BAR_PX), pygame.SRCALPHA)
        bar.fill((0, 0, 0, 170))
        surface.blit(bar, (0, h - BAR_PX))
        state = "paused" if self.paused else f"x{self.speed:g}"
        text.blit(surface, f"REPLAY {int(t // 60)}:{t % 60:04.1f} {state}   {KEYS}", 16, TEXT, (8, h - BAR_PX + 4))
        pygame.display.flip()


def watch(path: str | Path, start_s: float = 0.0, speed: float = 1.0) -> ReplayReport:
    """Replay ``path`` in a window from ``start_s`` at ``speed``; the report of the last pass."""
    window = ReplayWindow(Path(path), start_s=start_s, speed=speed)
    while True:
        report = replay(path, window)
        if window.restart_at is None:
            return report
        window.start_s, window.restart_at, window.paused = window.restart_at, None, False
        window._shown_t = window.start_s
