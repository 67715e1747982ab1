"""Effects: particles, the expanding ring of a hit, trail and charge sparks, the red vignette of a hurt player."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np
import pygame

from .camera import Batch, Camera, Frame
from .palette import ADD, HAZE, PALETTE_INDEX, lerp
from .sprites import SpriteCache, surface_from_array


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
        block[:, 10] = PALETTE_INDEX[palette]
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


class Effects:
    """The particles and hit flashes: spawned by arena events, moved each frame, planned as glows and rings."""

    MAX_PARTICLES = 400
    TRAIL_SPARKS_PER_S = 40.0  # per flying ball
    EMIT_PERIOD_S = 1 / 30  # trail and charge sparks are emitted this often

    def __init__(self, camera: Camera, sprites: SpriteCache, rng: np.random.Generator,
                 max_particles: int = MAX_PARTICLES) -> None:
        self.camera = camera
        self.sprites = sprites
        self.rng = rng
        self.particles = Particles(max_particles, rng)
        self.flashes: list[Flash] = []
        self._emit_dt = 0.0

    def react(self, events: Iterable) -> None:
        """Spawn effects for arena events: bursts and a flash ring for hits and for a ball on a wall, sparks
        for the rest."""
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
            elif kind == "wall":  # the ball bursts on a wall: sparks thrown back, a flash
                p.emit(pos, 26, 5.0, "spark", (0.3, 0.7), 0.06, 0.8)
                p.emit(pos, 16, 3.0, "energy", (0.3, 0.8), 0.07, 0.3)
                self.flashes.append(Flash(pos, duration=0.25, radius=0.8))
            elif kind == "spawn":
                p.emit(pos, 14, 1.2, "goo", (0.4, 0.8), 0.06, -0.05, spread=0.3)
            elif kind == "hurt":
                p.emit(pos, 10, 2.0, "ember", (0.2, 0.5), 0.05, 0.8)
        if len(self.flashes) > 16:
            del self.flashes[:-16]

    def update(self, dt: float, arena=None) -> None:
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

    def gather(self, batch: Batch) -> tuple[slice, slice]:
        """The particles' and the flashes' positions into the frame's batch."""
        return batch.add(self.particles.pos), batch.add([fl.position for fl in self.flashes])

    def plan(self, frame: Frame, particles: slice, flashes: slice) -> tuple[list, list, np.ndarray]:
        """The flashes' rings (draw calls), and the glows of flashes and particles (additive blits), each
        ring and glow with the batch index of its point (rings first): what covers it (:mod:`.occlusion`)."""
        circles, glows, idx = self._plan_flashes(frame, flashes)
        blits, at = self._plan_particles(frame, particles)
        return circles, glows + blits, np.concatenate([np.asarray(idx, dtype=int), at])

    def _plan_flashes(self, frame: Frame, sl: slice) -> tuple[list, list, list]:
        """Hit flashes: an expanding ring fading into the haze, a bright glow at first."""
        cam = self.camera
        circles, glows, rings_at, glows_at = [], [], [], []
        for k, fl in enumerate(self.flashes):
            j = sl.start + k
            if not frame.visible[j]:
                continue
            u = fl.age / fl.duration
            x, y = frame.xy[j]
            r = cam.f * fl.radius * (0.2 + 0.8 * math.sqrt(u)) / frame.depth[j]
            if 1 <= r <= 4000:
                colour = lerp(lerp((255, 255, 255), (60, 160, 255), u), HAZE, u * u)
                circles.append((pygame.draw.circle, (colour, (int(x), int(y)), int(r), max(1, int(5 * (1 - u)) + 1))))
                rings_at.append(j)
                if u < 0.5:
                    glows.append(self.sprites.glow_blit(x, y, r * 1.2, "white", int(3 * (1 - 2 * u))))
                    glows_at.append(j)
        return circles, glows, rings_at + glows_at

    def _plan_particles(self, frame: Frame, sl: slice) -> tuple[list, np.ndarray]:
        """The particles on screen as glow blits, and their batch indices."""
        p = self.particles
        if not p.count:
            return [], np.zeros(0, dtype=int)
        cam = self.camera
        x, y = frame.xy[sl, 0], frame.xy[sl, 1]
        rad = np.minimum(np.maximum(cam.f * p.size / np.maximum(frame.depth[sl], cam.near), 1), 40)
        on = frame.visible[sl] & (x > -rad) & (x < cam.width + rad) & (y > -rad) & (y < cam.height + rad)
        return (self.sprites.glow_blits(frame.xy[sl][on], rad[on], p.palette[on],
                                        np.minimum(3, (p.life[on] / p.life0[on] * 4).astype(int))),
                sl.start + np.flatnonzero(on))


class Vignette:
    """The red glow creeping in from the screen's edges while the player is hurt."""

    def __init__(self) -> None:
        self._edges: dict[tuple[int, int, int], pygame.Surface] = {}

    def edges(self, w: int, h: int, level: int) -> pygame.Surface:
        """The red edge glow for a screen size at one of four strengths (built for all four at once)."""
        v = self._edges.get((w, h, level))
        if v is None:
            if len(self._edges) > 8:
                self._edges.clear()
            band = max(1, int(0.22 * min(w, h)))
            xs = np.minimum(np.arange(w), w - 1 - np.arange(w)) / band
            ys = np.minimum(np.arange(h), h - 1 - np.arange(h)) / band
            edge = (np.clip(1 - np.minimum(xs[:, None], ys[None, :]), 0, 1) ** 2)[..., None]
            for k in range(1, 5):
                rgb = edge * np.array([200.0, 10.0, 20.0]) * (k / 4)
                self._edges[(w, h, k)] = surface_from_array(rgb.astype(np.uint8))
            v = self._edges[(w, h, level)]
        return v

    def prepare(self, size: tuple[int, int]) -> None:
        """Build the edge glows for this screen size now, so that no frame in play stalls building them."""
        self.edges(size[0], size[1], 4)

    def draw(self, surface: pygame.Surface, strength: float) -> None:
        """A red glow creeping in from the edges, drawn only in the edge bands (the centre is untouched)."""
        w, h = surface.get_size()
        level = max(1, min(4, int(math.ceil(strength * 4))))
        v = self.edges(w, h, level)
        band = max(1, int(0.22 * min(w, h)))
        for rect in ((0, 0, w, band), (0, h - band, w, band), (0, band, band, h - 2 * band),
                     (w - band, band, band, h - 2 * band)):
            surface.blit(v, rect[:2], pygame.Rect(rect), special_flags=ADD)
