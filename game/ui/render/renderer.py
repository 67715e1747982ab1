"""The renderer the app draws with: the parts of :mod:`game.ui.render`, composed.

A world frame (:meth:`Renderer.draw_world`) gathers every point of the world
(:mod:`.world`), the actors (:mod:`.actors`) and the effects (:mod:`.effects`)
into one batch, projects it once (:mod:`.camera`), plans every paint call, then
paints: ground, shadows, actors far to near, light on top. The 2D pictures (the
HUD, plots, screens and the Board setup's) come from the parts it inherits.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable

import numpy as np
import pygame

from .actors import Actors
from .board import BoardPictures
from .camera import Batch, Camera, CameraRig
from .effects import Effects, Vignette
from .hud import Hud
from .plots import Plots
from .screens import Screens
from .sprites import SpriteCache, TextCache
from .world import Scenery, setting


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


class Renderer(Hud, Plots, Screens, BoardPictures):
    """Draws the world, its effects, the HUD, plots and the app's screens.

    ``react(events)`` turns arena events into effects; ``draw_world`` advances
    the effects by ``effects_dt`` and draws one frame.
    """

    def __init__(self, screen_size: tuple[int, int] = (1280, 720), seed: int = 0,
                 rig: CameraRig | None = None, max_particles: int = Effects.MAX_PARTICLES) -> None:
        rng = np.random.default_rng(seed)  # the effects' randomness, one stream for the frames to repeat
        self.camera = Camera(rig, tuple(screen_size))
        self.sprites = SpriteCache.shared()
        self.sprites.warm_up()  # no frame should stall building a sprite
        self.text = TextCache()
        self.globes: dict[tuple, tuple] = {}
        self.scenery = Scenery(self.camera, self.sprites)
        self.actors = Actors(self.camera, self.sprites, rng)
        self.effects = Effects(self.camera, self.sprites, rng, max_particles)
        self.vignette = Vignette()

    def react(self, events: Iterable) -> None:
        """Spawn effects for arena events (:meth:`Effects.react`)."""
        self.effects.react(events)

    def update_effects(self, dt: float, arena=None) -> None:
        """Advance the effects by ``dt`` (:meth:`Effects.update`)."""
        self.effects.update(dt, arena)

    def prepare(self, size: tuple[int, int]) -> None:
        """Build what a frame at this size may need, so that no frame in play stalls building it."""
        self.vignette.prepare(size)

    def draw_world(self, surface: pygame.Surface, arena, avatar, effects_dt: float) -> None:
        """One frame of the arena seen from behind the player (effects advance by ``effects_dt``)."""
        self._fit(surface)
        player = arena.player
        self.camera.follow(player.x, player.y, player.yaw, effects_dt)
        self.effects.update(effects_dt, arena)
        self.actors.update_stride(avatar, effects_dt)
        self.scenery.prepare(surface)
        self._paint(surface, self._plan(arena, avatar))

    def draw_backdrop(self, surface: pygame.Surface) -> None:
        """The sky and the ground alone, no arena and no avatar: behind a screen full of panels."""
        self._fit(surface)
        self.scenery.backdrop(surface)

    def _fit(self, surface: pygame.Surface) -> None:
        """Take the surface's size (the window is resizable)."""
        w, h = surface.get_size()
        if (w, h) != (self.camera.width, self.camera.height):
            self.camera.set_viewport(w, h)

    def _plan(self, arena, avatar) -> _Plan:
        """All of the frame's numpy work: gather every point, project once, build the paint lists."""
        settings = getattr(arena, "settings", None)
        batch = Batch()
        ground = self.scenery.gather(batch, settings)
        actors = self.actors.gather(batch, arena, avatar, settings)
        particles, flashes = self.effects.gather(batch)
        frame = self.camera.frame(batch.array())  # the ONE projection
        hurt = float(getattr(arena.player, "hurt", 0.0)) / setting(settings, ("hurt_flash_s",), 0.3)
        plan = _Plan(hurt=min(1.0, hurt))
        plan.grid, plan.ring = self.scenery.plan_ground(frame, ground)
        plan.shadows = self.scenery.plan_shadows(frame, *self.actors.shadow_spots(actors))
        plan.items = self.actors.plan(frame, actors, settings)
        plan.circles, plan.glows = self.effects.plan(frame, particles, flashes)
        return plan

    def _paint(self, surface: pygame.Surface, plan: _Plan) -> None:
        """Paint a planned frame: ground, shadows, things far to near, light on top."""
        self.scenery.paint(surface, plan.grid, plan.ring, plan.shadows)
        for paint, payload in plan.items:
            paint(surface, payload)
        for colour, centre, radius, width in plan.circles:
            pygame.draw.circle(surface, colour, centre, radius, width)
        surface.blits(plan.glows, doreturn=False)
        if plan.hurt > 0:
            self.vignette.draw(surface, plan.hurt)
