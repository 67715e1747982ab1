"""The renderer the app draws with: the parts of :mod:`game.ui.render`, composed.

A world frame (:meth:`Renderer.draw_world`) gathers every point of the world
(:mod:`.world`), the town's boxes (:mod:`.town`), the actors (:mod:`.actors`)
and the effects (:mod:`.effects`) into one batch, projects it once
(:mod:`.camera`), plans every paint call, then paints: ground, shadows, then
boxes, actors and light far to near, each thing before the first box that
covers it (:meth:`Renderer._order`); while the camera stands still, the
ground and the boxes come from the still picture (:mod:`.still`). The 2D
pictures (the HUD, the minimap, plots, screens and the Board setup's) come
from the parts it inherits.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable

import numpy as np
import pygame

from .actors import ActorPlan, Actors, paint_blits, paint_calls
from .board import BoardPictures
from .camera import Batch, Camera, CameraRig, Frame, depth_order
from .effects import Effects, Vignette
from .hud import Hud
from .minimap import Minimap
from .plots import Plots
from .screens import Screens
from .sprites import SpriteCache, TextCache
from .still import StillView, paint_items
from .town import TownPlan, TownView, behind_walls
from .world import Scenery, setting


@dataclass
class _Plan:
    """Everything a frame paints, worked out before the first pixel is touched.

    The full-screen background blit evicts the interpreter's working set from
    the caches; numpy calls after it cost about twice as much (measured), so
    all of them run first and painting is pygame calls over ready lists.
    """

    grid: list = field(default_factory=list)  # [x1, y1, x2, y2] per line
    lines: list = field(default_factory=list)  # the town's lines on the ground: (x1, y1, x2, y2, colour)
    shadows: list = field(default_factory=list)  # MULT blit tuples
    boxes: list = field(default_factory=list)  # the town's boxes, (paint function, payload), far to near
    buckets: list = field(default_factory=lambda: [[]])  # what goes before each box, and after the last
    still: tuple | None = None  # the camera's pose and the town, when no box fades (:mod:`.still`)
    hurt: float = 0.0  # 0..1, the red vignette


@dataclass
class _Backdrop:
    """An arena's town and player without its actors (what :meth:`Renderer.draw_backdrop` draws)."""

    player: object
    town: object
    settings: object
    zombies: tuple = ()
    balls: tuple = ()
    held: None = None


class Renderer(Hud, Plots, Screens, BoardPictures):
    """Draws the world, its effects, the HUD, the minimap, plots and the app's screens.

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
        self.town = TownView(self.camera, self.sprites)
        self.minimap = Minimap()
        self.actors = Actors(self.camera, self.sprites, rng)
        self.effects = Effects(self.camera, self.sprites, rng, max_particles)
        self.vignette = Vignette()
        self.still = StillView()

    def react(self, events: Iterable) -> None:
        """Spawn effects for arena events (:meth:`Effects.react`)."""
        self.effects.react(events)

    def draw_minimap(self, surface: pygame.Surface, arena) -> None:
        """The town from above in the HUD's corner, with the zombies and the player (:mod:`.minimap`)."""
        self.minimap.draw(surface, arena)

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
        self._paint(surface, self._plan(arena, avatar, effects_dt))

    def draw_backdrop(self, surface: pygame.Surface, arena=None) -> None:
        """The sky and the ground, and the arena's town if given (none of its actors, no avatar): behind a
        screen full of panels."""
        self._fit(surface)
        if getattr(arena, "town", None) is None:
            self.scenery.backdrop(surface)
            return
        self.effects.particles.clear()  # what was flying when play stopped does not hang in the air
        self.effects.flashes.clear()
        self.draw_world(surface, _Backdrop(arena.player, arena.town, getattr(arena, "settings", None)), None, 0.0)

    def _fit(self, surface: pygame.Surface) -> None:
        """Take the surface's size (the window is resizable)."""
        w, h = surface.get_size()
        if (w, h) != (self.camera.width, self.camera.height):
            self.camera.set_viewport(w, h)

    def _plan(self, arena, avatar, dt: float) -> _Plan:
        """All of the frame's numpy work: gather every point, project once, build the paint lists."""
        settings = getattr(arena, "settings", None)
        town = getattr(arena, "town", None)
        model = self.town.model_of(town)
        batch = Batch()
        ground = self.scenery.gather(batch, model.ground if model is not None else None)
        boxes = self.town.gather(batch, town)
        actors = self.actors.gather(batch, arena, avatar, settings)
        particles, flashes = self.effects.gather(batch)
        points = batch.array()
        frame = self.camera.frame(points)  # the ONE projection
        hurt = float(getattr(arena.player, "hurt", 0.0)) / setting(settings, ("hurt_flash_s",), 0.3)
        plan = _Plan(hurt=min(1.0, hurt))
        plan.grid, plan.lines = self.scenery.plan_ground(frame, ground)
        plan.shadows = self.scenery.plan_shadows(frame, *self.actors.shadow_spots(actors))
        town_plan = self.town.plan(frame, boxes, points[self.actors.body_points(actors)], dt)
        plan.boxes = town_plan.items
        plan.buckets = self._order(town_plan, self.actors.plan(frame, actors, settings),
                                   self.effects.plan(frame, particles, flashes), points, frame)
        plan.still = (self.camera.pose(), id(model)) if town_plan.opaque else None
        return plan

    def _order(self, boxes: TownPlan, actors: ActorPlan, light: tuple, points: np.ndarray, frame: Frame
               ) -> list[list]:
        """Boxes, actors and light in one paint order (painter's algorithm, :mod:`.town`'s docstring): what
        goes before each box (its bucket), and after the last.

        The boxes come far to near. Each actor goes just before the first box
        that covers one of its probe points, or after every box, and the
        actors keep their own order far to near (an actor never goes after a
        nearer one); an actor wholly behind a wall painted after it is left
        out (:meth:`_walled_in`). Each glow and flash ring of the effects, and
        each lamp post's light (additive: their order does not matter), goes
        just before the first box that covers its point.
        """
        n = len(boxes.items)
        circles, glows, at = light
        lamps = boxes.lights
        glows = glows + lamps.glows
        idx = np.concatenate([actors.probes, np.asarray(at, dtype=int)])
        slots = self.town.cover_slots(boxes, self.camera.eye, np.concatenate([points[idx], lamps.points]),
                                      np.concatenate([frame.xy[idx], lamps.xy]),
                                      np.concatenate([frame.depth[idx], lamps.depth]))
        buckets: list[list] = [[] for _ in range(n + 1)]
        if actors.items:
            first = np.full(len(actors.items), n)
            np.minimum.at(first, actors.owner, slots[:len(actors.probes)])
            far_to_near = depth_order(actors.depth)
            mine = np.minimum.accumulate(first[far_to_near][::-1])[::-1]
            slot_of = np.empty(len(actors.items), dtype=int)
            slot_of[far_to_near] = mine
            out = self._walled_in(boxes, actors.extents, slot_of)
            for k, slot in zip(far_to_near.tolist(), mine.tolist()):
                if not out[k]:
                    buckets[slot].append(actors.items[k])
        lit = slots[len(idx) - len(at):].tolist()  # the effects' points (rings, then glows), then the lamps'
        for paint, light_items, at_slots in ((paint_calls, circles, lit), (paint_blits, glows, lit[len(circles):])):
            by_slot: dict[int, list] = {}
            for item, slot in zip(light_items, at_slots):
                by_slot.setdefault(slot, []).append(item)
            for slot, payload in by_slot.items():
                buckets[slot].append((paint, payload))
        return buckets

    @staticmethod
    def _walled_in(boxes: TownPlan, extents: np.ndarray, slot_of: np.ndarray) -> list[bool]:
        """Which actors need no painting: those with an extent (screen box and nearest depth, NaN if unknown)
        inside a wall's rectangle (2 px in from it: the fill's rounding), wholly behind the wall, whose box is
        painted after them (its slot not before theirs): the wall paints over every pixel of theirs."""
        out = [False] * len(extents)
        rects, far, owner = boxes.walls
        with_extent = np.flatnonzero(~np.isnan(extents[:, 4]))
        if not len(rects) or not len(with_extent):
            return out
        extent = extents[with_extent]
        behind = behind_walls(extent[:, :4], extent[:, 4], rects + (2.0, 2.0, -2.0, -2.0), far)
        hidden = (behind & (owner[None, :] >= slot_of[with_extent][:, None])).any(axis=1)
        for k, h in zip(with_extent.tolist(), hidden.tolist()):
            out[k] = h
        return out

    def _paint(self, surface: pygame.Surface, plan: _Plan) -> None:
        """Paint a planned frame: ground, shadows, then boxes, actors and light far to near (from the still
        picture if the camera has not moved, :mod:`.still`)."""
        def ground(target: pygame.Surface) -> None:
            self.scenery.paint_ground(target, plan.grid, plan.lines)

        if not self.still.paint(surface, plan.still, ground, plan.shadows, plan.boxes, plan.buckets):
            ground(surface)
            self.scenery.paint_shadows(surface, plan.shadows)
            for items, box in zip(plan.buckets, plan.boxes):
                paint_items(surface, items + [box])
            paint_items(surface, plan.buckets[-1])
        if plan.hurt > 0:
            self.vignette.draw(surface, plan.hurt)
