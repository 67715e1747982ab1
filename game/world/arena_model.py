"""The arena's data: what the world logic owns and the renderer draws.

Units: metres, seconds, radians; world frame x east, y north, z up (the same
as the avatar's body frame at yaw 0). :mod:`game.world.arena` changes these;
:mod:`game.ui.render` only reads them.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from enum import Enum

Vec3 = tuple[float, float, float]
TRAIL_LENGTH = 24  # positions kept behind a flying ball, for its trail


class ZombieState(str, Enum):
    WALKING = "walking"  # shambling toward the player
    FLYING = "flying"  # hit: blown into the sky, ballistic with spin
    GONE = "gone"  # out of play; removed at the next step


class BallState(str, Enum):
    FLYING = "flying"  # launched, moving along its direction
    FADING = "fading"  # missed: fading out where it stopped


@dataclass
class Zombie:
    """One zombie: position on the ground (or in the air when flying) and its animation."""

    id: int
    x: float
    y: float
    speed: float  # m/s while walking
    health: int
    phase: float  # animation phase, radians (limbs swing with it)
    state: ZombieState = ZombieState.WALKING
    z: float = 0.0  # height of the feet above the ground
    velocity: Vec3 = (0.0, 0.0, 0.0)  # while flying
    spin: float = 0.0  # rotation while flying, radians
    spin_rate: float = 0.0
    heading: float = 0.0  # the way it faces, radians from +x
    age: float = 0.0  # seconds in the current state
    waypoint: tuple[float, float, bool] | None = None  # where it walks: (x, y, the player himself?)
    start: tuple[float, float] = (0.0, 0.0)  # where this step found it (it stays there if wedged)


@dataclass
class Ball:
    """An energy ball in flight (the ball in the player's hand is :class:`HeldBall`)."""

    position: Vec3
    velocity: Vec3
    charge: float  # 0..1, sets speed, size and glow
    state: BallState = BallState.FLYING
    age: float = 0.0
    fade: float = 1.0  # 1 = fully visible, 0 = gone
    trail: deque = field(default_factory=lambda: deque(maxlen=TRAIL_LENGTH))


@dataclass
class HeldBall:
    """The ball at the player's arm, placed each frame from the gesture state."""

    position: Vec3 = (0.0, 0.0, 1.4)
    state: str = "idle"  # the gesture state: idle, loading, spinning, fired
    charge: float = 0.0
    spin: float = 0.0  # radians, for drawing
    visible: bool = True


@dataclass
class Player:
    """The player's body on the arena floor."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0  # radians, 0 = facing +y (north), positive turns left
    health: float = 100.0
    hurt: float = 0.0  # seconds left of the hurt flash


@dataclass(frozen=True)
class ArenaEvent:
    """Something the renderer and the audio react to once."""

    kind: str  # "launch", "hit", "miss", "hurt", "wave", "spawn", "game_over"
    position: Vec3 = (0.0, 0.0, 0.0)
    value: float = 0.0  # e.g. the charge of a launch, the wave number


@dataclass(frozen=True)
class Controls:
    """The player's movement input for one step (keyboard WASD or a gamepad)."""

    forward: float = 0.0  # -1..1
    strafe: float = 0.0  # -1..1, positive to the right
    turn: float = 0.0  # -1..1, positive to the left
