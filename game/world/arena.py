"""The arena: zombies, energy balls, hits, waves and score (Zhu & Shi, sec. 5). Pure logic, no pygame.

Zhu & Shi's game: "an avatar of the player arrives in an abandoned town with
zombies surrounded"; the arm throws energy balls, and "the zombie will be
blown to the sky if it is hit by the flying ball". Here the player also walks
(WASD, :class:`~game.world.arena_model.Controls`) while the tracked arm aims, as
the IMU and infrared hand-tracking paper joins an external position source with
IMU orientation (its OptiTrack marker position plus the 3-Space sensor
orientation, sec. 2).

Frames and units as :mod:`game.world.arena_model`: metres, seconds, radians; x east,
y north, z up; the player's yaw 0 faces +y and a positive yaw (or turn)
turns left, counter-clockwise seen from above; a zombie's heading is measured
from +x.

Clock. :meth:`Arena.step` advances exactly one fixed step
(:attr:`ArenaSettings.dt_s`, 1/120 s); :meth:`Arena.advance` takes the real
frame time and runs as many fixed steps as it has accumulated, so the game
plays the same at any frame rate. A frame time above
:attr:`ArenaSettings.max_catch_up_s` (after a pause, a dragged window) is cut
to it: the world slows down rather than jumping.

Balls fly straight: no gravity by default (``ball_gravity`` 0). The paper's
ball is "shot out to the direction he targeted" (sec. 5), and a player aims
with the whole arm, so a ball that drops would land short of what the arm
points at; a small ``ball_gravity`` can be set for an arc.

Hits are swept: in one step a ball's centre moves along the segment p0p1;
a walking zombie's body is a vertical capsule (the axis from ``z + r`` to
``z + height - r``, radius ``r``). The ball touches the body when the
distance between the segment p0p1 and the axis segment is below
``ball radius + r`` (:func:`segment_distance`), so no ball is fast enough to
pass through a zombie between two steps. Of several zombies touched in one
step, the one whose closest approach comes first along p0p1 (the smallest
parameter ``s``) takes the ball. A miss (flight time over, out of the arena,
or into the ground) stops the ball where it is, with a "miss" event at that
moment (the fizzle's sound and flash belong there); it then fades out over
``ball_fade_s`` and is removed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from enum import Enum
from operator import attrgetter

import numpy as np
from mypy_extensions import mypyc_attr

from .arena_model import (Ball, BallState, ArenaEvent, Controls, HeldBall, Player, Vec3, Zombie,
                          ZombieState)
from .collision import inside, push_out, sweep_sphere
from .navigation import NavSettings, Navigator
from .sight import open_yaw
from .town import Town, make_town

TAU = 2.0 * math.pi
HELD_STATES = ("idle", "loading", "spinning", "fired")
STOP_FRACTION = 0.9  # a zombie stops walking at this fraction of the contact distance (it stays in reach)
BALL_EXIT_MARGIN_M = 1.0  # a ball this far beyond the town's edge has left it (zombies come in at the edge)
NAV_EVERY = 4  # a zombie asks the navigator for its waypoint every this many steps (30 Hz), by turns
WAIST_M = 0.9  # the height at which a zombie's straight way to the player is tested against obstacles
STRAIGHT_M2 = 8.0 ** 2  # within 8 m a zombie walks straight at the player when nothing is in the way
# (farther, the navigator's waypoints: their bends cost little over a long way, a sweep a lot)
INSIDE_TOLERANCE_M = 1e-6  # a body closer than its radius minus this to an obstacle stands inside it
_TINY = 1e-24  # squared length (m^2) below which a segment is a point
_PARALLEL = 1e-12  # sin^2 of the angle below which two segments count as parallel

_INTS = ("wave_base_count", "wave_count_per_wave", "max_walking", "tough_health_max", "ball_damage")
_NON_NEGATIVE = ("zombie_speed_growth", "tough_chance_per_wave", "knockback_m", "first_wave_delay_s",
                 "wave_pause_s", "spawn_clearance_m", "ball_gravity", "ball_radius_per_charge_m",
                 "ball_speed_per_charge_m_s", "blown_push_m_s", "spin_min", "score_per_hit",
                 "score_wave_bonus", "held_spin_rate", "held_spin_rate_spinning", "hurt_interval_s",
                 "hurt_flash_s", "contact_damage_per_s", "zombie_speed_min", "zombie_stride_m")
_POSITIVE = ("player_radius_m", "dt_s", "max_catch_up_s", "player_speed_m_s", "player_turn_rate",
             "player_max_health", "zombie_radius_m", "zombie_height_m", "zombie_speed_cap",
             "zombie_turn_rate", "contact_distance_m", "knockback_s", "spawn_interval_s",
             "spawn_interval_min_s", "ball_radius_m", "ball_speed_m_s", "ball_max_flight_s", "ball_fade_s",
             "gravity", "blown_up_min_m_s", "flying_max_s", "flying_max_height_m")


class _PerStep:
    """Constants of the fixed step derived from :class:`ArenaSettings`, so that
    :meth:`Arena.step` does not work them out again 120 times a second. Each is
    the very expression the step used, so the floats are the same."""

    __slots__ = ("player_step", "stop", "phase_per_m", "max_turn", "knock_decay", "fall", "gap", "gap2",
                 "reach2", "ball_fall", "fade_step")

    def __init__(self, s: ArenaSettings) -> None:
        dt = s.dt_s
        self.player_step = s.player_speed_m_s * dt  # metres walked per step at full input
        self.stop = STOP_FRACTION * s.contact_distance_m  # a zombie walks no closer than this
        self.phase_per_m = TAU / s.zombie_stride_m if s.zombie_stride_m > 0 else 0.0
        self.max_turn = s.zombie_turn_rate * dt  # a zombie's largest turn per step
        self.knock_decay = math.exp(-dt / s.knockback_s)  # a knock-back slide's speed left after a step
        self.fall = s.gravity * dt  # a flying zombie's vertical speed lost per step
        self.gap = 2.0 * s.zombie_radius_m  # two walking zombies closer than this are pushed apart
        self.gap2 = self.gap * self.gap
        self.reach2 = s.contact_distance_m ** 2
        self.ball_fall = s.ball_gravity * dt
        self.fade_step = dt / s.ball_fade_s  # a missed ball's fade per step


@mypyc_attr(native_class=False)  # a plain class even when compiled (README, "The compiled build")
@dataclass(frozen=True)
class ArenaSettings:
    """Every tunable of the arena, with its default.

    World and clock:
      The town (:mod:`game.world.town`, one per match from its seed): the
      player and the zombies walk its streets, zombies come in at its edges
      and alleys, walls stop bodies and balls.
      ``dt_s`` 1/120: the fixed logic step.
      ``max_catch_up_s`` 0.25: the most real time one :meth:`Arena.advance` catches up.
    Player:
      ``player_speed_m_s`` 3 (walking), ``player_turn_rate`` 2.5 rad/s,
      ``player_max_health`` 100; ``player_radius_m`` 0.35: the body, against walls.
      ``contact_distance_m`` 0.9: a walking zombie whose centre is this close
      (horizontally) to the player's touches him (body 0.35 + zombie 0.35 +
      reach 0.2) and does ``contact_damage_per_s`` 15 of health a second.
      ``hurt_interval_s`` 0.5: "hurt" events come at most this often;
      ``hurt_flash_s`` 0.3: how long :attr:`Player.hurt` flashes after one.
    Zombies:
      ``zombie_radius_m`` 0.35, ``zombie_height_m`` 1.8: the body capsule.
      ``zombie_speed_min`` 0.5, ``zombie_speed_max`` 1.2 m/s: wave 1's walking
      speeds (uniform); both grow by ``zombie_speed_growth`` 0.1 m/s a wave,
      up to ``zombie_speed_cap`` 2.4 (below the player's 3, who can always walk away).
      ``zombie_turn_rate`` 4 rad/s: how fast a zombie's heading follows its way.
      ``zombie_stride_m`` 1.2: the distance walked per gait cycle (the
      animation phase advances 2 pi per stride; 0 freezes it).
      Health: 1, or with a chance of ``tough_chance_per_wave`` 0.1 per wave
      after the first (at most ``tough_chance_max`` 0.6) a tough zombie with
      2 to ``tough_health_max`` 3 (uniform).
      ``knockback_m`` 0.5: how far a hit that does not kill pushes a zombie
      back along the ball's way, sliding with the time constant ``knockback_s`` 0.12.
    Waves (wave n brings ``wave_base_count + wave_count_per_wave * n`` zombies: 4 + 3n):
      ``first_wave_delay_s`` 2: from the start to wave 1.
      ``spawn_interval_s`` 1.2: between two zombies of wave 1, times
      ``spawn_interval_decay`` 0.9 per wave, at least ``spawn_interval_min_s`` 0.4.
      Zombies spawn at the town's spawn points (street ends at its edge, alleys)
      drawn at random, at least ``spawn_clearance_m`` 4 from the player (a few
      tries, else the farthest).
      ``max_walking`` 60: no spawn while this many walk (the rest wait their turn).
      ``wave_pause_s`` 4: when every zombie of a wave has spawned and none
      walks any more, the next wave starts after this pause.
    Balls:
      radius ``ball_radius_m`` 0.22 + ``ball_radius_per_charge_m`` 0.1 * charge;
      speed ``ball_speed_m_s`` 10 + ``ball_speed_per_charge_m_s`` 20 * charge;
      ``ball_gravity`` 0 m/s^2 (straight flight, see the module's docstring);
      ``ball_max_flight_s`` 2.5: a ball flying longer has missed;
      ``ball_fade_s`` 0.6: a missed ball fades out over this;
      ``ball_damage`` 1: health a hit takes.
    Blown up (a killed zombie, "blown to the sky", Zhu & Shi, sec. 5):
      launch velocity: straight up at ``blown_up_min_m_s`` 10 to
      ``blown_up_max_m_s`` 16 (uniform), plus the ball's direction times
      ``blown_push_m_s`` 3 * (1 + charge); spin ``spin_min`` 4 to ``spin_max``
      12 rad/s either way; ballistic under ``gravity`` 9.81.
      Removed after ``flying_max_s`` 4, above ``flying_max_height_m`` 40, or
      when it falls back below the ground.
    Score: a hit scores ``score_per_hit`` 100 * (1 + charge) * (1 +
    ``score_wave_bonus`` 0.25 * (wave - 1)), rounded.
    Held ball (drawing only): spins at ``held_spin_rate`` 3 rad/s, or
    ``held_spin_rate_spinning`` 20 * (1 + charge) while the gesture spins it.
    """

    dt_s: float = 1.0 / 120.0
    max_catch_up_s: float = 0.25
    player_speed_m_s: float = 3.0
    player_turn_rate: float = 2.5
    player_max_health: float = 100.0
    player_radius_m: float = 0.35
    contact_distance_m: float = 0.9
    contact_damage_per_s: float = 15.0
    hurt_interval_s: float = 0.5
    hurt_flash_s: float = 0.3
    zombie_radius_m: float = 0.35
    zombie_height_m: float = 1.8
    zombie_speed_min: float = 0.5
    zombie_speed_max: float = 1.2
    zombie_speed_growth: float = 0.1
    zombie_speed_cap: float = 2.4
    zombie_turn_rate: float = 4.0
    zombie_stride_m: float = 1.2
    tough_chance_per_wave: float = 0.1
    tough_chance_max: float = 0.6
    tough_health_max: int = 3
    knockback_m: float = 0.5
    knockback_s: float = 0.12
    first_wave_delay_s: float = 2.0
    wave_base_count: int = 4
    wave_count_per_wave: int = 3
    spawn_interval_s: float = 1.2
    spawn_interval_decay: float = 0.9
    spawn_interval_min_s: float = 0.4
    spawn_clearance_m: float = 4.0
    max_walking: int = 60
    wave_pause_s: float = 4.0
    ball_radius_m: float = 0.22
    ball_radius_per_charge_m: float = 0.10
    ball_speed_m_s: float = 10.0
    ball_speed_per_charge_m_s: float = 20.0
    ball_gravity: float = 0.0
    ball_max_flight_s: float = 2.5
    ball_fade_s: float = 0.6
    ball_damage: int = 1
    gravity: float = 9.81
    blown_up_min_m_s: float = 10.0
    blown_up_max_m_s: float = 16.0
    blown_push_m_s: float = 3.0
    spin_min: float = 4.0
    spin_max: float = 12.0
    flying_max_s: float = 4.0
    flying_max_height_m: float = 40.0
    score_per_hit: float = 100.0
    score_wave_bonus: float = 0.25
    held_spin_rate: float = 3.0
    held_spin_rate_spinning: float = 20.0
    _per_step: _PerStep = field(init=False, repr=False, compare=False)  # what every fixed step uses

    def __post_init__(self) -> None:
        for f in fields(self):
            if not f.init:
                continue
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"{f.name} must be a finite number, not {value!r}")
        for name in _INTS:
            if not isinstance(getattr(self, name), int):
                raise ValueError(f"{name} must be a whole number, not {getattr(self, name)!r}")
        for name in _NON_NEGATIVE + _INTS:
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be 0 or more, not {getattr(self, name)!r}")
        for name in _POSITIVE:
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be more than 0, not {getattr(self, name)!r}")
        checks = (
            (self.dt_s <= 0.1, f"dt_s must be at most 0.1 s, not {self.dt_s!r}"),
            (self.max_catch_up_s >= self.dt_s,
             f"max_catch_up_s ({self.max_catch_up_s}) must be at least one step, dt_s ({self.dt_s})"),
            (self.zombie_height_m >= 2 * self.zombie_radius_m,
             f"zombie_height_m ({self.zombie_height_m}) must be at least twice zombie_radius_m "
             f"({self.zombie_radius_m}): the body is a capsule"),
            (self.zombie_speed_min <= self.zombie_speed_max,
             f"zombie_speed_min ({self.zombie_speed_min}) must not be above zombie_speed_max "
             f"({self.zombie_speed_max})"),
            (self.tough_chance_max <= 1.0, f"tough_chance_max must be at most 1, not {self.tough_chance_max!r}"),
            (self.tough_health_max >= 1, f"tough_health_max must be 1 or more, not {self.tough_health_max!r}"),
            (self.ball_damage >= 1, f"ball_damage must be 1 or more, not {self.ball_damage!r}"),
            (self.max_walking >= 1, f"max_walking must be 1 or more, not {self.max_walking!r}"),
            (self.wave_base_count + self.wave_count_per_wave >= 1,
             "wave_base_count + wave_count_per_wave must be 1 or more: wave 1 needs a zombie"),
            (0.0 < self.spawn_interval_decay <= 1.0,
             f"spawn_interval_decay must be in (0, 1], not {self.spawn_interval_decay!r}"),
            (self.blown_up_min_m_s <= self.blown_up_max_m_s,
             f"blown_up_min_m_s ({self.blown_up_min_m_s}) must not be above blown_up_max_m_s "
             f"({self.blown_up_max_m_s})"),
            (self.spin_min <= self.spin_max,
             f"spin_min ({self.spin_min}) must not be above spin_max ({self.spin_max})"),
        )
        for ok, message in checks:
            if not ok:
                raise ValueError(message)
        # Worked out here, not as a cached_property: the compiled build turns one into a plain
        # property, which would work them out again at every use.
        object.__setattr__(self, "_per_step", _PerStep(self))

    # ------------------------------------------------------------ derived

    def ball_radius(self, charge: float) -> float:
        """A ball's radius (m) for its charge 0..1."""
        return self.ball_radius_m + self.ball_radius_per_charge_m * charge

    def ball_speed(self, charge: float) -> float:
        """A launched ball's speed (m/s) for its charge 0..1."""
        return self.ball_speed_m_s + self.ball_speed_per_charge_m_s * charge

    def wave_size(self, wave: int) -> int:
        """How many zombies wave ``wave`` (1, 2, ...) brings."""
        return self.wave_base_count + self.wave_count_per_wave * wave

    def speed_range(self, wave: int) -> tuple[float, float]:
        """The walking speeds (m/s) of a wave's zombies: (slowest, fastest)."""
        grow = self.zombie_speed_growth * (wave - 1)
        return (min(self.zombie_speed_cap, self.zombie_speed_min + grow),
                min(self.zombie_speed_cap, self.zombie_speed_max + grow))

    def tough_chance(self, wave: int) -> float:
        """The chance that one of the wave's zombies is tough (2 to ``tough_health_max`` health)."""
        return min(self.tough_chance_max, self.tough_chance_per_wave * (wave - 1))

    def spawn_interval(self, wave: int) -> float:
        """Seconds between two spawns in wave ``wave``."""
        return max(self.spawn_interval_min_s, self.spawn_interval_s * self.spawn_interval_decay ** (wave - 1))

    def hit_score(self, charge: float, wave: int) -> int:
        """Points for one hit with a ball of ``charge`` in wave ``wave``."""
        multiplier = 1.0 + self.score_wave_bonus * max(0, wave - 1)
        return int(round(self.score_per_hit * (1.0 + charge) * multiplier))


# ---------------------------------------------------------------- geometry

def segment_distance(p0: Vec3, p1: Vec3, q0: Vec3, q1: Vec3) -> tuple[float, float, float]:
    """The closest points of segments p0p1 and q0q1: ``(distance, s, t)``.

    The points are ``p0 + s (p1 - p0)`` and ``q0 + t (q1 - q0)``, s and t in
    [0, 1]. Minimises the convex quadratic |r + s d1 - t d2|^2: s at the
    unconstrained optimum clamped to [0, 1], t for that s, and when t has to
    be clamped, s again for the clamped t (Ericson, Real-Time Collision
    Detection, sec. 5.1.9). A segment shorter than 1e-12 m is a point.
    Parallel segments (sin^2 of the angle below 1e-12) have a whole range of
    closest pairs; this starts from s = 0, which gives the earliest s of the
    range whenever p0 lies beside q0q1 or when the range begins at an end of q0q1.
    Plain floats: this runs per ball and zombie every step.
    """
    d1x, d1y, d1z = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
    d2x, d2y, d2z = q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]
    rx, ry, rz = p0[0] - q0[0], p0[1] - q0[1], p0[2] - q0[2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    if a <= _TINY:
        s = 0.0
        t = 0.0 if e <= _TINY else _clamp01(f / e)
    else:
        c = d1x * rx + d1y * ry + d1z * rz
        if e <= _TINY:
            s, t = _clamp01(-c / a), 0.0
        else:
            b = d1x * d2x + d1y * d2y + d1z * d2z
            denom = a * e - b * b
            s = _clamp01((b * f - c * e) / denom) if denom > _PARALLEL * a * e else 0.0
            tn = b * s + f
            if tn < 0.0:
                s, t = _clamp01(-c / a), 0.0
            elif tn > e:
                s, t = _clamp01((b - c) / a), 1.0
            else:
                t = tn / e
    dx = rx + d1x * s - d2x * t
    dy = ry + d1y * s - d2y * t
    dz = rz + d1z * s - d2z * t
    return math.sqrt(dx * dx + dy * dy + dz * dz), s, t


def _clamp01(x: float) -> float:
    return 0.0 if x < 0.0 else 1.0 if x > 1.0 else x


def _finite_vec(v) -> Vec3 | None:
    """``v`` as a tuple of three finite floats, or None."""
    try:
        x, y, z = (float(c) for c in v)
    except (TypeError, ValueError):
        return None
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        return None
    return (x, y, z)


def _input(value: float) -> float:
    """A control axis clamped to -1..1; NaN (or junk) is 0."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        return 0.0
    if math.isnan(value):
        return 0.0
    return -1.0 if value < -1.0 else 1.0 if value > 1.0 else value


_by_x = attrgetter("x")


def _charge(value: float) -> float:
    """A charge clamped to 0..1; NaN (or junk) is 0."""
    return max(0.0, _input(value))


def _wrap(angle: float) -> float:
    """An angle in [-pi, pi)."""
    return (angle + math.pi) % TAU - math.pi


# ---------------------------------------------------------------- the world

class Arena:
    """The world: the player, zombies, balls in flight and the ball in hand; waves and score.

    ``step(controls)`` advances one fixed step and returns its events;
    ``advance(real_dt, controls)`` runs the steps a frame's time adds up to.
    ``launch`` and ``hold`` come from the gesture machine (the app works out
    where the hand is); their events ("launch") come out of the next
    ``step``/``advance``. All randomness comes from ``rng``, seeded by
    ``seed``: the same seed and inputs give the same game.

    State the renderer reads: ``town`` (and its ``navigator``), ``player``,
    ``zombies``, ``balls``, ``held``, ``score``, ``wave``, ``time``,
    ``game_over``; tallies for reports: ``shots`` (balls launched), ``hits``
    (balls that struck a zombie), ``kills`` (zombies blown into the sky),
    ``wall_hits`` (balls stopped by an obstacle), ``obstacle_violations``
    (steps in which the player or a walking zombie stood inside an obstacle:
    walls push bodies out, so it stays 0); :attr:`alive_zombies`,
    :attr:`wave_progress`, :attr:`next_wave_in`, :attr:`interpolation`. A
    walking zombie's ``velocity`` is its knock-back slide (zero when none); a
    flying one's, its flight. A zombie marked GONE is removed at the next step.

    Events (:class:`~game.world.arena_model.ArenaEvent`), position and value:
      "launch"    the ball's origin; its charge.
      "hit"       the ball's centre at its closest approach to the body; the points scored.
      "miss"      where the ball stopped (it fades there); its charge.
      "wall"      where the ball struck an obstacle (it fades there); its charge.
      "hurt"      the player, 1 m up; his health left (at most one every ``hurt_interval_s``).
      "spawn"     the zombie on the ground; its id.
      "wave"      the origin; the wave's number (wave 1 too, ``first_wave_delay_s`` after the start).
      "game_over" the player; the final score.
    """

    def __init__(self, settings: ArenaSettings | None = None, seed: int = 0, town: Town | None = None) -> None:
        """``town``: the same town for every match (tests, tutorials); None: each match's own, from its
        seed (:func:`~game.world.town.make_town`)."""
        self.settings = settings if settings is not None else ArenaSettings()
        self.seed = seed
        self._fixed_town = town
        self.reset()

    # ------------------------------------------------------------ state

    def reset(self, seed: int | None = None) -> None:
        """Start over: full health, no zombies or balls, wave 1 after ``first_wave_delay_s``."""
        if seed is not None:
            self.seed = seed
        s = self.settings
        self.rng = np.random.default_rng(self.seed)
        town = self._fixed_town if self._fixed_town is not None else make_town(self.seed)
        if not town.spawn_points:
            raise ValueError("the town has no spawn points: zombies could not come in")
        if getattr(self, "town", None) is not town:
            self.town = town
            self.navigator = Navigator(town, NavSettings(agent_radius_m=s.zombie_radius_m))
        self.player = Player(x=town.start[0], y=town.start[1], yaw=open_yaw(town, town.start),
                             health=float(s.player_max_health))
        self.zombies: list[Zombie] = []
        self.balls: list[Ball] = []
        self.held = HeldBall()
        self.score = 0
        self.shots = self.hits = self.kills = self.wall_hits = self.obstacle_violations = 0
        self.wave = 0
        self.ticks = 0
        self.time = 0.0
        self.game_over = False
        self._accumulator = 0.0
        self._pending: list[ArenaEvent] = []
        self._next_id = 1
        self._to_spawn = 0  # zombies of the current wave still to come
        self._spawn_timer = 0.0
        self._between_waves = True
        self._pause_left = s.first_wave_delay_s
        self._next_hurt = 0.0  # arena time from which the next "hurt" event may come
        self._walking = 0

    @property
    def alive_zombies(self) -> list[Zombie]:
        """The zombies still walking (a threat); flying ones are done for."""
        return [z for z in self.zombies if z.state is ZombieState.WALKING]

    @property
    def wave_progress(self) -> float:
        """How much of the current wave is defeated, 0..1 (1 between waves, 0 before the first)."""
        if self.wave == 0:
            return 0.0
        if self._between_waves:
            return 1.0
        total = self.settings.wave_size(self.wave)
        return max(0.0, min(1.0, (total - self._to_spawn - self._walking) / total))

    @property
    def next_wave_in(self) -> float:
        """Seconds until the next wave starts; 0 while a wave is on."""
        return max(0.0, self._pause_left) if self._between_waves else 0.0

    @property
    def interpolation(self) -> float:
        """How far real time is into the next step, 0..1 (for drawing between steps)."""
        return max(0.0, min(1.0, self._accumulator / self.settings.dt_s))

    # ------------------------------------------------------------ inputs

    def launch(self, origin: Vec3, direction: Vec3, charge: float) -> Ball | None:
        """Throw a ball from ``origin`` along ``direction`` (normalised here) with ``charge`` 0..1.

        A NaN or zero direction (or a NaN origin) throws nothing: returns
        None. A NaN charge is 0, and the charge is clamped to 0..1. No ball
        after the game is over.
        """
        start, d = _finite_vec(origin), _finite_vec(direction)
        if self.game_over or start is None or d is None:
            return None
        norm = math.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
        if not norm > 1e-9:
            return None
        charge = _charge(charge)
        speed = self.settings.ball_speed(charge) / norm
        ball = Ball(position=start, velocity=(d[0] * speed, d[1] * speed, d[2] * speed), charge=charge)
        ball.trail.append(start)
        self.balls.append(ball)
        self.shots += 1
        self._pending.append(ArenaEvent("launch", start, charge))
        return ball

    def hold(self, position: Vec3, state: str, charge: float) -> None:
        """Place the ball in hand: where the app put it for the gesture ``state`` (idle, loading,
        spinning, fired), with the spin's ``charge``. A NaN position keeps the last one."""
        state = state.value if isinstance(state, Enum) else state
        if state not in HELD_STATES:
            raise ValueError(f"state must be one of {', '.join(HELD_STATES)}, not {state!r}")
        finite = _finite_vec(position)
        if finite is not None:
            self.held.position = finite
        self.held.state = state
        self.held.charge = _charge(charge)
        self.held.visible = state != "fired"  # "fired": the ball has gone, the arm is empty

    def add_zombie(self, x: float, y: float, speed: float | None = None, health: int = 1) -> Zombie:
        """Put a walking zombie at (x, y), facing the player (tests, tutorials; waves use :meth:`_spawn`).

        ``speed`` defaults to the slowest of the current wave's.
        """
        s = self.settings
        if speed is None:
            speed = s.speed_range(max(1, self.wave))[0]
        heading = math.atan2(self.player.y - y, self.player.x - x)
        zombie = Zombie(id=self._next_id, x=float(x), y=float(y), speed=float(speed), health=int(health),
                        phase=0.0, heading=heading)
        self._next_id += 1
        self.zombies.append(zombie)
        self._walking += 1
        return zombie

    # ------------------------------------------------------------ clock

    def advance(self, real_dt: float, controls: Controls = Controls()) -> list[ArenaEvent]:
        """Run the fixed steps that ``real_dt`` seconds of real time add up to (at most
        ``max_catch_up_s`` of them); the rest carries over to the next call."""
        dt = self.settings.dt_s
        try:
            real_dt = float(real_dt)
        except (TypeError, ValueError):
            real_dt = 0.0
        if not real_dt > 0.0:  # NaN, negative
            real_dt = 0.0
        self._accumulator += min(real_dt, self.settings.max_catch_up_s)
        events, self._pending = self._pending, []
        # The tolerance makes N frames of 1/60 s give exactly 2N steps, though the float sum is a hair short.
        while self._accumulator >= dt * (1.0 - 1e-9):
            self._accumulator -= dt
            events += self.step(controls)
        return events

    def step(self, controls: Controls = Controls()) -> list[ArenaEvent]:
        """Advance the world by exactly one fixed step; return what happened."""
        events, self._pending = self._pending, []
        if self.game_over:
            return events
        s = self.settings
        dt = s.dt_s
        self.ticks += 1
        self.time = self.ticks * dt
        self._move_player(controls, dt)
        self._update_wave(events, dt)
        walking, hemmed = self._move_zombies(dt)
        if self._inside_obstacle(hemmed):
            self.obstacle_violations += 1
        self._move_balls(events, dt, walking)
        self._contact(events, dt, walking)
        if not self.game_over and not self._between_waves and self._to_spawn == 0 and self._walking == 0:
            self._between_waves = True
            self._pause_left = s.wave_pause_s
        held = self.held
        rate = s.held_spin_rate_spinning * (1.0 + held.charge) if held.state == "spinning" else s.held_spin_rate
        held.spin = (held.spin + rate * dt) % TAU
        return events

    # ------------------------------------------------------------ player

    def _move_player(self, controls: Controls, dt: float) -> None:
        s, p = self.settings, self.player
        forward, strafe, turn = _input(controls.forward), _input(controls.strafe), _input(controls.turn)
        p.yaw = _wrap(p.yaw + turn * s.player_turn_rate * dt)
        if forward or strafe:
            length = math.hypot(forward, strafe)
            if length > 1.0:  # diagonals no faster than straight
                forward, strafe = forward / length, strafe / length
            c, si = math.cos(p.yaw), math.sin(p.yaw)
            # yaw 0 faces +y; forward = (-sin, cos), right = (cos, sin)
            step = s._per_step.player_step
            x = p.x + step * (-si * forward + c * strafe)
            y = p.y + step * (c * forward + si * strafe)
            p.x, p.y = push_out(self.town, x, y, s.player_radius_m, (p.x, p.y))  # slides along walls
        if p.hurt > 0.0:
            p.hurt = max(0.0, p.hurt - dt)

    # ------------------------------------------------------------ waves

    def _update_wave(self, events: list[ArenaEvent], dt: float) -> None:
        s = self.settings
        if self._between_waves:
            self._pause_left -= dt
            if self._pause_left <= 1e-12:
                self._between_waves = False
                self._pause_left = 0.0
                self.wave += 1
                self._to_spawn = s.wave_size(self.wave)
                self._spawn_timer = 0.0
                events.append(ArenaEvent("wave", (0.0, 0.0, 0.0), float(self.wave)))
            return
        if self._to_spawn > 0:
            self._spawn_timer -= dt
            if self._spawn_timer <= 1e-12 and self._walking < s.max_walking:
                zombie = self._spawn()
                self._to_spawn -= 1
                self._spawn_timer = s.spawn_interval(self.wave)
                events.append(ArenaEvent("spawn", (zombie.x, zombie.y, 0.0), float(zombie.id)))

    def _spawn(self) -> Zombie:
        """A zombie of the current wave at one of the town's spawn points, clear of the player."""
        s, rng, p = self.settings, self.rng, self.player
        points = self.town.spawn_points
        best = (-1.0, 0.0, 0.0)  # (gap, x, y): any spot beats it
        for _ in range(8):
            x, y = points[int(rng.integers(len(points)))]
            gap = math.hypot(x - p.x, y - p.y)
            if gap > best[0]:
                best = (gap, x, y)
            if gap >= s.spawn_clearance_m:
                break
        _, x, y = best
        lo, hi = s.speed_range(self.wave)
        speed = float(rng.uniform(lo, hi))
        health = 1
        if float(rng.random()) < s.tough_chance(self.wave) and s.tough_health_max >= 2:
            health = int(rng.integers(2, s.tough_health_max + 1))
        zombie = self.add_zombie(x, y, speed=speed, health=health)
        zombie.phase = float(rng.uniform(0.0, TAU))
        return zombie

    # ------------------------------------------------------------ zombies

    def _move_zombies(self, dt: float) -> tuple[list[Zombie], list[Zombie]]:
        """Walk, turn and separate the walking zombies, fly the flying ones; return the walking ones,
        and those of them that stand near an obstacle (:meth:`_separate`).

        A zombie marked GONE at an earlier step is dropped from :attr:`zombies`
        here; one that lands now is marked GONE and dropped at the next step.
        The loop runs for every zombie 120 times a second: constants are locals.
        """
        s, per, p = self.settings, self.settings._per_step, self.player
        px, py = p.x, p.y
        nav, town, radius = self.navigator, self.town, s.zombie_radius_m
        nav.set_goal(px, py)
        turn_of = self.ticks % NAV_EVERY  # the zombies whose id has this remainder ask for a new waypoint
        stop, phase_per_m, max_turn, decay, fall = per.stop, per.phase_per_m, per.max_turn, per.knock_decay, per.fall
        max_age, max_height = s.flying_max_s, s.flying_max_height_m
        atan2, sqrt, pi, tau = math.atan2, math.sqrt, math.pi, TAU
        walking_state, flying_state = ZombieState.WALKING, ZombieState.FLYING
        zombies = self.zombies
        walking, landed, stale = [], [], False
        for z in zombies:
            state = z.state
            if state is walking_state:
                z.age += dt
                z.start = (z.x, z.y)
                kvx, kvy, _ = z.velocity
                if kvx or kvy:  # sliding from a knock-back
                    z.x += kvx * dt
                    z.y += kvy * dt
                    kvx, kvy = kvx * decay, kvy * decay
                    z.velocity = (kvx, kvy, 0.0) if kvx * kvx + kvy * kvy > 1e-6 else (0.0, 0.0, 0.0)
                x, y = z.x, z.y
                way = z.waypoint
                if way is None or z.id % NAV_EVERY == turn_of:  # near him, straight at him if the way is clear
                    near = (px - x) ** 2 + (py - y) ** 2 < STRAIGHT_M2
                    clear = near and sweep_sphere(town, (x, y, WAIST_M), (px, py, WAIST_M), radius) is None
                    way = z.waypoint = (px, py, True) if clear else nav.waypoint(x, y)
                final = way[2]
                dx, dy = (px - x, py - y) if final else (way[0] - x, way[1] - y)
                d = sqrt(dx * dx + dy * dy)
                halt = stop if final else 0.0  # only the player himself is kept at arm's length
                if d > halt:
                    walk = z.speed * dt
                    if final and walk > d - halt:
                        walk = d - halt
                    z.x = x + dx / d * walk
                    z.y = y + dy / d * walk
                    phase = z.phase + walk * phase_per_m
                    z.phase = phase - tau if phase >= tau else phase
                if d > 1e-9:  # turn toward its way, at most max_turn; angles stay in [-pi, pi)
                    heading = z.heading
                    turn = atan2(dy, dx) - heading
                    if turn >= pi:
                        turn -= tau
                    elif turn < -pi:
                        turn += tau
                    if turn > max_turn:
                        turn = max_turn
                    elif turn < -max_turn:
                        turn = -max_turn
                    if turn:
                        heading += turn
                        z.heading = heading - tau if heading >= pi else heading + tau if heading < -pi else heading
                walking.append(z)
            elif state is flying_state:
                z.age += dt
                vx, vy, vz = z.velocity
                vz -= fall  # semi-implicit Euler
                z.velocity = (vx, vy, vz)
                z.x += vx * dt
                z.y += vy * dt
                height = z.z = z.z + vz * dt
                z.spin = (z.spin + z.spin_rate * dt) % tau
                if z.age >= max_age or height > max_height or (height < 0.0 and vz < 0.0):
                    landed.append(z)
            else:  # GONE since an earlier step
                stale = True
        if stale:
            self.zombies = [z for z in zombies if z.state is not ZombieState.GONE]
        for z in landed:
            z.state = ZombieState.GONE
            z.age = 0.0
        self._walking = len(walking)
        return walking, self._separate(sorted(walking, key=_by_x))

    def _separate(self, walking: list[Zombie]) -> list[Zombie]:
        """Push apart walking zombies closer than two radii (half the overlap each), then out of the
        town's obstacles (they slide along walls); return those that may stand near an obstacle:
        the others stand in a cell of the town's grid with none (:meth:`_inside_obstacle` skips them).

        ``walking`` is sorted by x. A sweep along x pairs each zombie with the
        following ones less than two radii further in x (none when the next one
        is that far), and applies the pushes in that order.
        """
        s, per = self.settings, self.settings._per_step
        gap, gap2 = per.gap, per.gap2
        sqrt = math.sqrt
        xs = [z.x for z in walking]  # plain lists: much faster than attributes in the pair loop
        ys = [z.y for z in walking]
        n = len(walking)
        for i in range(n - 1):
            xi = xs[i]
            if xs[i + 1] - xi >= gap:
                continue
            yi = ys[i]
            for j in range(i + 1, n):
                dx = xs[j] - xi
                if dx >= gap:
                    break
                dy = ys[j] - yi
                d2 = dx * dx + dy * dy
                if d2 >= gap2:
                    continue
                if d2 < 1e-18:  # on top of each other: a direction of their own, deterministic
                    angle = (walking[i].id * 2.399963 + walking[j].id) % TAU
                    ux, uy = 0.5 * gap * math.cos(angle), 0.5 * gap * math.sin(angle)
                else:
                    d = sqrt(d2)
                    k = 0.5 * (gap - d) / d
                    ux, uy = dx * k, dy * k
                xi -= ux
                yi -= uy
                xs[j] += ux
                ys[j] += uy
            xs[i], ys[i] = xi, yi
        town, radius = self.town, s.zombie_radius_m
        near, h = town.grid.near, town.half_size_m - radius
        hemmed = []
        for z, x, y in zip(walking, xs, ys):
            if near(x, y):  # an obstacle close by (its cell's list): out of it, along its face
                x, y = push_out(town, x, y, radius, z.start)
                hemmed.append(z)
            else:  # open ground: only the town's edge holds it
                cx = -h if x < -h else h if x > h else x
                cy = -h if y < -h else h if y > h else y
                if cx != x or cy != y:  # held at the edge: maybe in another cell
                    hemmed.append(z)
                x, y = cx, cy
            z.x, z.y = x, y
        return hemmed

    def _inside_obstacle(self, hemmed: list[Zombie]) -> bool:
        """Whether the player or a zombie of ``hemmed`` (the walking ones that may stand near an
        obstacle: :meth:`_separate`) stands inside an obstacle (deeper than ``INSIDE_TOLERANCE_M``)."""
        s, town, p = self.settings, self.town, self.player
        if inside(town, p.x, p.y, s.player_radius_m, INSIDE_TOLERANCE_M):
            return True
        r, near = s.zombie_radius_m, town.grid.near
        for z in hemmed:
            x, y = z.x, z.y
            if near(x, y) and inside(town, x, y, r, INSIDE_TOLERANCE_M):
                return True
        return False

    # ------------------------------------------------------------ balls

    def _move_balls(self, events: list[ArenaEvent], dt: float, walking: list[Zombie]) -> None:
        """Fly the balls, which hit the zombies of ``walking`` (this step's, still walking); fade
        the missed ones."""
        s, per, town = self.settings, self.settings._per_step, self.town
        edge = town.half_size_m + BALL_EXIT_MARGIN_M
        kept = []
        for ball in self.balls:
            if ball.state is BallState.FADING:
                ball.age += dt
                ball.fade -= per.fade_step
                ball.trail.append(ball.position)  # the trail shrinks into the ball
                if ball.fade > 0.0:
                    kept.append(ball)
                continue
            vx, vy, vz = ball.velocity
            if s.ball_gravity:
                vz -= per.ball_fall
                ball.velocity = (vx, vy, vz)
            x0, y0, z0 = ball.position
            x1, y1, z1 = x0 + vx * dt, y0 + vy * dt, z0 + vz * dt
            limit = 1.0  # how much of the step the ball flies before it meets the ground
            if z1 < 0.0:
                limit = z0 / (z0 - z1) if z0 > 0.0 else 0.0
            radius = s.ball_radius(ball.charge)
            wall = sweep_sphere(town, (x0, y0, z0), (x1, y1, z1), radius)
            if wall is not None and wall[0] < limit:  # the wall comes first: no hit through it
                limit = wall[0]
            hit = self._first_hit((x0, y0, z0), (x1, y1, z1), radius, limit, walking)
            if hit is not None:
                zombie, t = hit
                contact = (x0 + (x1 - x0) * t, y0 + (y1 - y0) * t, z0 + (z1 - z0) * t)
                events.append(ArenaEvent("hit", contact, float(self._hit(zombie, ball))))
                continue  # the ball is spent
            struck = wall is not None and limit == wall[0]
            if limit < 1.0:
                x1, y1, z1 = x0 + (x1 - x0) * limit, y0 + (y1 - y0) * limit, (z0 + (z1 - z0) * limit) if struck else 0.0
            ball.position = (x1, y1, z1)
            ball.age += dt
            ball.trail.append(ball.position)
            if limit < 1.0 or ball.age >= s.ball_max_flight_s or abs(x1) > edge or abs(y1) > edge:
                ball.state = BallState.FADING
                ball.velocity = (0.0, 0.0, 0.0)
                if struck:
                    self.wall_hits += 1
                events.append(ArenaEvent("wall" if struck else "miss", ball.position, ball.charge))
            kept.append(ball)
        self.balls = kept

    def _first_hit(self, p0: Vec3, p1: Vec3, ball_radius: float, limit: float,
                   walking: list[Zombie]) -> tuple[Zombie, float] | None:
        """The zombie of ``walking`` (in the order of :attr:`zombies`) still walking that the ball's
        path p0p1 touches first (at most ``limit`` along it), with the parameter of its closest
        approach; None if none."""
        s = self.settings
        r = s.zombie_radius_m
        reach = ball_radius + r
        top = s.zombie_height_m - r
        x0, y0, z0 = p0
        x1, y1, z1 = p1
        lox, hix = (x0 - reach, x1 + reach) if x0 <= x1 else (x1 - reach, x0 + reach)
        loy, hiy = (y0 - reach, y1 + reach) if y0 <= y1 else (y1 - reach, y0 + reach)
        loz, hiz = (z0 - reach, z1 + reach) if z0 <= z1 else (z1 - reach, z0 + reach)
        best, best_t = None, math.inf
        walking_state = ZombieState.WALKING
        for z in walking:
            # broad phase: the path's box, grown by the reach, against the axis segment's box
            zx = z.x
            if zx < lox or zx > hix:
                continue
            zy, zz = z.y, z.z
            if zy < loy or zy > hiy or zz + top < loz or zz + r > hiz or z.state is not walking_state:
                continue
            d, t, _ = segment_distance(p0, p1, (zx, zy, zz + r), (zx, zy, zz + top))
            if d < reach and t <= limit and t < best_t:
                best, best_t = z, t
        return None if best is None else (best, best_t)

    def _hit(self, zombie: Zombie, ball: Ball) -> int:
        """A ball hits ``zombie``: damage, and either blown into the sky or knocked back. Returns the points."""
        s, rng = self.settings, self.rng
        points = s.hit_score(ball.charge, self.wave)
        self.hits += 1
        self.score += points
        vx, vy, vz = ball.velocity
        speed = math.sqrt(vx * vx + vy * vy + vz * vz)
        ux, uy, uz = (vx / speed, vy / speed, vz / speed) if speed > 0.0 else (0.0, 0.0, 0.0)
        zombie.health -= s.ball_damage
        if zombie.health <= 0:
            zombie.health = 0
            push = s.blown_push_m_s * (1.0 + ball.charge)
            up = float(rng.uniform(s.blown_up_min_m_s, s.blown_up_max_m_s))
            zombie.state = ZombieState.FLYING
            self.kills += 1
            zombie.age = 0.0
            zombie.velocity = (ux * push, uy * push, up + uz * push)
            zombie.spin_rate = float(rng.uniform(s.spin_min, s.spin_max)) * (1.0 if rng.random() < 0.5 else -1.0)
            self._walking -= 1
        else:
            horizontal = math.hypot(ux, uy)
            if horizontal > 1e-9:  # a ball straight down pushes nowhere
                k = s.knockback_m / s.knockback_s / horizontal
                zombie.velocity = (ux * k, uy * k, 0.0)
        return points

    # ------------------------------------------------------------ contact

    def _contact(self, events: list[ArenaEvent], dt: float, walking: list[Zombie]) -> None:
        """The zombies of ``walking`` (this step's) still walking and within reach of the player
        hurt him; at no health the game is over."""
        s, p = self.settings, self.player
        px, py, reach2 = p.x, p.y, s._per_step.reach2
        touching = 0
        for z in walking:
            dx, dy = z.x - px, z.y - py
            if dx * dx + dy * dy <= reach2 and z.state is ZombieState.WALKING:
                touching += 1
        if not touching:
            return
        p.health -= touching * s.contact_damage_per_s * dt
        if self.time >= self._next_hurt - 1e-12:
            self._next_hurt = self.time + s.hurt_interval_s
            p.hurt = s.hurt_flash_s
            events.append(ArenaEvent("hurt", (p.x, p.y, 1.0), max(0.0, p.health)))
        if p.health <= 0.0:
            p.health = 0.0
            self.game_over = True
            events.append(ArenaEvent("game_over", (p.x, p.y, 0.0), float(self.score)))
