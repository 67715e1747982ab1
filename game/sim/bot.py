"""A simulated player for headless matches: it sees the arena, picks targets, moves its arm like a person.

The bot plays through the same screens as a person. It presses Enter at the
menu, and in the guided calibration it hangs its arm still, then raises it
forward when the screen asks. Then it plays. Every game frame,
:meth:`Bot.act` looks at what a player sees and answers with keys to press
and the walking input. Its arm moves only through the motion it writes into a
:class:`~game.sim.motion_model.Script`: minimum-jerk reaches, the load, spin and
launch of each throw, tremor, idle fidgeting. The headless match feeds that
motion to the sensor simulator. The game then learns what the arm did only
from the board's decoded samples, as with a person.

How it plays:
  Sight. It sees only the zombies in its line of sight (from its eyes to a
  zombie's chest, over low walls and cars, never through a building or a
  wall: :func:`~game.world.sight.sees`), each looked at again every
  ``LOOK_S`` (a glance, not a frame-by-frame scan), and throws only at those.
  Threat. Each seen zombie's threat is its time to contact: the length of
  its way round the obstacles left to its reach, over its speed. The most
  threatening one is the target.
  Facing. Outside +-45 deg of the body's facing, the bot first turns toward
  the target (the keyboard's turn keys). It never turns while the arm is up,
  which would swing the aim.
  Throwing. After its reaction time, it raises the arm at the target, flexes
  the elbow, spins and snaps it straight (:meth:`Script.gesture`). Aims are
  azimuth and elevation from the shoulder to the target's chest. Better
  players lead a walking zombie to where it will be at the launch. Each
  angle gets Gaussian noise. With reloads, one raise throws at the next
  targets too.
  Walking. When a zombie (seen or not: it hears them) would reach it within
  ``FLEE_S`` (2.5 s), it walks away until it is a third further clear. Of
  ``FLEE_WAYS`` headings it takes the one that best combines going away from
  the near zombies, open ground ahead (walls within ``FLEE_LOOK_M``) and the
  way round the obstacles back to the start square (``HOME_PULL``), so it
  does not run into a dead end. Cornered (no heading clear for
  ``CORNERED_M`` but those into the zombies, or fleeing moved it less than
  ``STUCK_M`` in ``STUCK_S``:
  bodies in the way), it stands and throws for ``FIGHT_S``. With zombies about
  but none in sight (nor a ball's way to one), it walks back to the start
  square, the open ground with the longest views, along the way round the
  obstacles. It does not walk during a throw (which would swing the aim
  off), unless a zombie is about to strike.
  Fatigue. Per minute played, its movements slow by ``fatigue_per_min`` and
  its aim noise grows by the same fraction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from ..world.arena import Arena
from ..world.arena_model import Controls, Player, Zombie
from ..world.collision import sweep_sphere
from ..world.navigation import NavSettings, Navigator
from ..world.sight import sees
from ..world.town import Town
from .motion_model import SPEED_RANGE, PlayerProfile, Script, TrueLaunch

CHEST_M = 1.2  # the height the bot aims at on a zombie (1.8 m tall)
SHOULDER_M = 1.4  # about where its balls leave from
CLOSE_M = 4.0  # a zombie this close is judged by its straight distance
FACING_DEG = 45.0  # a target further off the body's facing is turned toward first
NEAR_M = 6.0  # zombies within this push the fleeing bot away
LOOK_S = 0.25  # how often the bot looks again whether a zombie is in sight
FLEE_WAYS = 16  # the headings the fleeing bot weighs, evenly round from straight away
FLEE_LOOK_M = 4.0  # how far along each it looks for walls
HOME_PULL = 0.5  # the weight of the way home against going straight away and open ground
TOWARD_COS = -0.5  # headings more than 120 deg off straight away lead into the zombies: never taken
CORNERED_M = 1.0  # with no other heading this clear of walls the bot is cornered
STUCK_M = 0.3  # or when fleeing moved it less than this in STUCK_S (bodies in the way)
STUCK_S = 1.0
FIGHT_S = 2.0  # a cornered bot stands and throws for this long before trying to flee again
WAIST_M = 0.9  # the height at which its way ahead is tested against obstacles
THROW_S = 2.7  # the typical time from the decision to a launch at speed 1 (reach, load, spin)
RELOAD_S = 1.3  # and from one launch to the next of the same raise
IDLE_S = (1.0, 2.5)  # fidgeting between waves, seconds
FLEE_S = 2.5  # the bot walks away when a zombie would reach it within this time
FLEE_UNTIL = 1.3  # and walks on until the nearest zombie is this many times FLEE_S away
STRIKE_S = 0.6  # a zombie this close to contact makes the bot walk even mid-throw
FORGET_S = 1.0  # the motion script keeps this much past (the simulator never looks further back)


@dataclass(frozen=True)
class Skill:
    """How well the bot plays: one difficulty level."""

    reaction_s: float  # from seeing a change to starting to move (visual choice reaction time)
    aim_noise_deg: float  # standard deviation of the aim, in azimuth and in elevation
    speed: float  # movement speed factor (times the profile's)
    fatigue_per_min: float  # per minute played: movements slow and aim noise grows by this fraction
    leads_targets: bool  # aims where a walking zombie will be at the launch
    reloads: int  # extra launches at further targets per raise of the arm


DIFFICULTIES: dict[str, Skill] = {
    "easy": Skill(reaction_s=0.55, aim_noise_deg=2.5, speed=0.8, fatigue_per_min=0.05,
                  leads_targets=False, reloads=0),
    "normal": Skill(reaction_s=0.40, aim_noise_deg=1.2, speed=1.0, fatigue_per_min=0.03,
                    leads_targets=True, reloads=1),
    "hard": Skill(reaction_s=0.28, aim_noise_deg=0.5, speed=1.3, fatigue_per_min=0.02,
                  leads_targets=True, reloads=2),
}


@dataclass(frozen=True)
class Action:
    """What the bot does this frame: keys pressed (by name: "return", "r") and the walking input."""

    keys: tuple[str, ...] = ()
    controls: Controls = Controls()


@dataclass(frozen=True)
class Screen:
    """What the bot sees of the app: which screen, and the calibration's step."""

    name: str  # "menu", "calibration", "play", "game_over", or another screen's name
    step: str = ""  # the calibration's: "down", "forward", "done", "failed"


class Bot:
    """A simulated player; its arm motion is :attr:`script`, its intended launches :attr:`launches`."""

    def __init__(self, skill: Skill, profile: PlayerProfile = PlayerProfile(), seed: int = 0) -> None:
        self.skill = skill
        self.profile = replace(profile, speed=_speed(profile.speed * skill.speed))
        self.script = Script(self.profile, seed)
        self.rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1,)))
        self.play_started: float | None = None
        self._step_seen = ""  # the calibration step the bot last reacted to
        self._lowered_at: float | None = None  # when the arm is back down after calibrating
        self.fleeing = False
        self._seen: dict[int, tuple[float, bool]] = {}  # zombie id: (when looked at, in sight)
        self._home: Navigator | None = None  # the way back to the town's start square
        self._flee_mark: tuple[float, float, float] | None = None  # (t, x, y) where the last flight was checked
        self._fight_until = -math.inf  # cornered: it throws instead of fleeing until then

    @property
    def launches(self) -> list[TrueLaunch]:
        return self.script.launches

    # ------------------------------------------------------------ the loop

    def act(self, t: float, screen: Screen, arena: Arena, shoulder: Sequence[float]) -> Action:
        """This frame's keys and walking at simulated time ``t``; arm moves start a reaction time later."""
        start = t + self.skill.reaction_s
        if screen.name == "menu":
            return Action(keys=("return",))
        if screen.name == "calibration":
            return self._calibrate(t, start, screen.step)
        if screen.name != "play":
            return Action()
        if self.play_started is None:
            self.play_started = t
        return self._play(t, start, arena, shoulder)

    def _calibrate(self, t: float, start: float, step: str) -> Action:
        """Arm down and still; forward when asked; down again and Enter when done (R after a failure)."""
        if step != self._step_seen:
            self._step_seen = step
            if step == "forward":
                self.script.wait_until(start)
                self.script.reach(0.0, 90.0, kind="calibration")
            elif step in ("done", "failed"):
                self.script.wait_until(start)
                self._lowered_at = self.script.reach(0.0, 0.0, kind="calibration")
        if step in ("done", "failed") and self._lowered_at is not None and t >= self._lowered_at:
            self._lowered_at = None
            return Action(keys=("return",) if step == "done" else ("r",))
        return Action()

    def _play(self, t: float, start: float, arena: Arena, shoulder: Sequence[float]) -> Action:
        player = arena.player
        walking = arena.alive_zombies
        busy = t < self.script.now  # the arm is on what was planned
        soonest = min((self._time_to_contact(z, arena) for z in walking), default=math.inf)
        # Walk away from a close zombie until well clear (hysteresis); mid-throw only when it is
        # about to strike, since walking swings a throw's aim off its target.
        self.fleeing = soonest < (FLEE_UNTIL * FLEE_S if self.fleeing else FLEE_S)
        if self.fleeing and (not busy or soonest < STRIKE_S) and t >= self._fight_until:
            way = self._flee(arena)
            if way is not None and not self._stuck(t, player):
                return Action(controls=way)
            self._fight_until = t + FIGHT_S  # cornered: it stands and throws
        self._flee_mark = None  # not walking away this frame: the next flight is judged afresh
        if busy:
            return Action()
        minutes = (t - (self.play_started or t)) / 60.0
        self._tire(minutes)
        self.script.forget_before(t - FORGET_S)
        visible = self._in_sight(t, walking, arena)
        if not visible and walking and not self._home_reached(arena):
            return Action(controls=self._go_home(arena))  # back to the open square, where it sees them
        if not visible:
            self.script.wait_until(start)
            self.script.idle(float(self.rng.uniform(*IDLE_S)))
            return Action()
        threats = sorted(visible, key=lambda z: self._time_to_contact(z, arena))
        ahead = (start - t) + THROW_S / self.script.profile.speed
        aims = []
        for k, zombie in enumerate(threats[:1 + self.skill.reloads]):
            az, el = self._aim(zombie, arena, shoulder, ahead + k * RELOAD_S / self.script.profile.speed)
            if abs(az) > FACING_DEG:
                break
            noise = self.skill.aim_noise_deg * (1.0 + self.skill.fatigue_per_min * minutes)
            aims.append((az + float(self.rng.normal(0.0, noise)), el + float(self.rng.normal(0.0, noise))))
        if not aims:  # turn toward the threat first (a positive turn is to the left)
            azimuth, _ = self._aim(threats[0], arena, shoulder, 0.0)
            return Action(controls=Controls(turn=-math.copysign(1.0, azimuth)))
        self.script.wait_until(start)
        self.script.gesture(aims)
        return Action()

    # ------------------------------------------------------------ judgement

    def _tire(self, minutes: float) -> None:
        """Movements slow with minutes played (fatigue)."""
        speed = self.profile.speed / (1.0 + self.skill.fatigue_per_min * minutes)
        self.script.profile = replace(self.profile, speed=_speed(speed))

    def _in_sight(self, t: float, walking: list[Zombie], arena: Arena) -> list[Zombie]:
        """The walking zombies the bot sees and could hit (nothing in a ball's way from its shoulder
        to the chest: a lamp post hides nothing but stops a ball), each looked at again every ``LOOK_S``."""
        p, seen, out = arena.player, self._seen, []
        town, radius = arena.town, arena.settings.ball_radius(1.0)
        for z in walking:
            looked = seen.get(z.id)
            if looked is None or t - looked[0] >= LOOK_S:
                clear = sees(town, (p.x, p.y), (z.x, z.y)) and sweep_sphere(
                    town, (p.x, p.y, SHOULDER_M), (z.x, z.y, CHEST_M), radius) is None
                looked = seen[z.id] = (t, clear)
            if looked[1]:
                out.append(z)
        if len(seen) > 4 * len(walking) + 16:  # forget the zombies gone
            ids = {z.id for z in walking}
            self._seen = {k: v for k, v in seen.items() if k in ids}
        return out

    def _home_reached(self, arena: Arena) -> bool:
        p, town = arena.player, arena.town
        return math.hypot(p.x - town.start[0], p.y - town.start[1]) <= max(1.0, town.start_radius_m)

    def _go_home(self, arena: Arena) -> Controls:
        """Walk toward the start square along the way round the obstacles (the open ground with the
        longest views, where zombies come into sight)."""
        hx, hy = self._way_home(arena)
        return _walk_toward(arena.player, hx, hy)

    def _way_home(self, arena: Arena) -> tuple[float, float]:
        """From the player toward the next waypoint of the way round the obstacles to the start square."""
        p, town = arena.player, arena.town
        if self._home is None or self._home.town is not town:
            self._home = Navigator(town, NavSettings(agent_radius_m=arena.settings.player_radius_m))
            self._home.set_goal(*town.start)
        tx, ty, _ = self._home.waypoint(p.x, p.y)
        return tx - p.x, ty - p.y

    def _stuck(self, t: float, player: Player) -> bool:
        """Whether fleeing moved the player less than ``STUCK_M`` over the last ``STUCK_S`` (a mark
        older than twice that is not of this flight: the judgement starts again)."""
        mark = self._flee_mark
        if mark is not None and t - mark[0] < STUCK_S:
            return False
        self._flee_mark = (t, player.x, player.y)
        return mark is not None and t - mark[0] <= 2 * STUCK_S and \
            math.hypot(player.x - mark[1], player.y - mark[2]) < STUCK_M

    @staticmethod
    def _time_to_contact(zombie: Zombie, arena: Arena) -> float:
        """Seconds until ``zombie`` reaches the player along its way round the obstacles (within
        ``CLOSE_M``, or where the navigator knows no way, straight: a zombie that close walks straight)."""
        p = arena.player
        straight = math.hypot(zombie.x - p.x, zombie.y - p.y)
        way = straight if straight < CLOSE_M else arena.navigator.path_length(zombie.x, zombie.y)
        gap = (way if math.isfinite(way) else straight) - arena.settings.contact_distance_m
        return max(0.0, gap) / max(zombie.speed, 1e-6)

    def _aim(self, zombie: Zombie, arena: Arena, shoulder: Sequence[float], ahead_s: float
             ) -> tuple[float, float]:
        """(azimuth, elevation) in degrees from the shoulder to the zombie's chest, ``ahead_s`` from now
        if the bot leads its targets (the zombie walks straight at the player, stopping at reach)."""
        x, y, player = zombie.x, zombie.y, arena.player
        if self.skill.leads_targets and ahead_s > 0:
            dx, dy = player.x - x, player.y - y
            gap = math.hypot(dx, dy)
            walk = min(zombie.speed * ahead_s, max(0.0, gap - arena.settings.contact_distance_m))
            if gap > 1e-9:
                x, y = x + dx / gap * walk, y + dy / gap * walk
        dx, dy, dz = x - shoulder[0], y - shoulder[1], CHEST_M - shoulder[2]
        c, s = math.cos(player.yaw), math.sin(player.yaw)
        right, forward = dx * c + dy * s, -dx * s + dy * c  # yaw 0 faces +y; right = (cos, sin)
        azimuth = math.degrees(math.atan2(right, forward))
        elevation = 90.0 + math.degrees(math.atan2(dz, math.hypot(right, forward)))
        return azimuth, elevation

    def _flee(self, arena: Arena) -> Controls | None:
        """The walking that takes the player away from the near zombies along open ground, round
        the obstacles toward the start square; None when cornered (no heading clear for ``CORNERED_M``
        but those more than 120 deg off straight away, into the zombies).

        Each heading ``u`` scores ``u . away + clear / FLEE_LOOK_M + HOME_PULL u . home``: ``away``
        the unit sum of the near zombies' pushes (each 1 / distance, along the line from it),
        ``clear`` how far the body goes along ``u`` before a wall (at most ``FLEE_LOOK_M``), ``home``
        the unit way to the start square's next waypoint.
        """
        player, town, radius = arena.player, arena.town, arena.settings.player_radius_m
        wx = wy = 0.0
        for z in arena.alive_zombies:
            dx, dy = player.x - z.x, player.y - z.y
            d2 = dx * dx + dy * dy
            if d2 < NEAR_M * NEAR_M:
                wx, wy = wx + dx / max(d2, 0.01), wy + dy / max(d2, 0.01)
        hx, hy = self._way_home(arena)
        away, home = _unit(wx, wy), _unit(hx, hy)
        start = math.atan2(away[1], away[0]) if away != (0.0, 0.0) else math.atan2(home[1], home[0])
        best, best_score = None, -math.inf
        for k in range(FLEE_WAYS):
            a = start + 2.0 * math.pi * k / FLEE_WAYS
            ux, uy = math.cos(a), math.sin(a)
            if ux * away[0] + uy * away[1] < TOWARD_COS:
                continue  # not into the zombies
            clear = _clear_ahead(town, player, ux, uy, radius)
            if clear < CORNERED_M:
                continue
            score = ux * away[0] + uy * away[1] + clear / FLEE_LOOK_M + HOME_PULL * (ux * home[0] + uy * home[1])
            if score > best_score:
                best, best_score = (ux, uy), score
        return None if best is None else _walk_toward(player, *best)


def _unit(x: float, y: float) -> tuple[float, float]:
    """(x, y) scaled to length 1; (0, 0) stays."""
    norm = math.hypot(x, y)
    return (x / norm, y / norm) if norm > 1e-9 else (0.0, 0.0)


def _clear_ahead(town: Town, player: Player, ux: float, uy: float, radius: float) -> float:
    """How far (m, at most ``FLEE_LOOK_M``) the player's body goes along (ux, uy) before an obstacle."""
    ahead = (player.x + ux * FLEE_LOOK_M, player.y + uy * FLEE_LOOK_M, WAIST_M)
    hit = sweep_sphere(town, (player.x, player.y, WAIST_M), ahead, radius)
    return FLEE_LOOK_M if hit is None else hit[0] * FLEE_LOOK_M


def _walk_toward(player: Player, wx: float, wy: float) -> Controls:
    """The walking input that moves the player along (wx, wy) (world frame) without turning him."""
    norm = math.hypot(wx, wy)
    if norm < 1e-9:
        return Controls()
    wx, wy = wx / norm, wy / norm
    c, s = math.cos(player.yaw), math.sin(player.yaw)
    return Controls(forward=-wx * s + wy * c, strafe=wx * c + wy * s)


def _speed(speed: float) -> float:
    """A movement speed factor within what a player profile allows."""
    low, high = SPEED_RANGE
    return min(high, max(low, speed))
