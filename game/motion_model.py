"""A simulated player wearing the board: human-like arm motion and what the player meant.

The output is a :class:`tracker.sim.Motion` for :func:`tracker.sim.arm_chain`
(the upper arm as the root, the elbow as its one hinge) plus the ground truth
of the player's intentions (:class:`Session`): when each launch was made, where
it was aimed, when the player was idle, and when the wearing calibration's two
poses were held. The eval harness and the headless match feed the motion to
the sensor simulator and score the tracker and the gesture machine against it.

Frames. The body frame B is x right, y forward, z up (:mod:`game.avatar`); the
simulated world is the body frame at heading 0 (z up, no walking turns). The
root quaternion ``motion.root(t)`` is q_WL, the orientation in the world of
the simulator's upper-arm *link* frame L, which is the sensor frame of an
ideally worn board: its y axis is the elbow hinge, its -x points forward when
the arm hangs, its -z runs down the arm (``arm_chain``: at identity the arm
hangs along -z; a positive flex swings the forearm toward -x). The bone frame
of the avatar (x the hinge, y forward) is L turned by the ideal mounting
q_LB = ``game.avatar.Wearing().mount`` (a quarter turn about z), so

    q_WL(t) = Rz(-azimuth) Rx(elevation) Rz(twist) exp(sway + tremor) conj(q_LB)

a raise by ``elevation`` in the sagittal plane (about the shoulder's
left-right axis, the bone's x), turned by ``azimuth`` about the vertical
toward the target (positive to the right, like a compass), with a small
humeral ``twist`` about the arm's long axis (plus some tremor), and idle
sways and tremor as a rotation vector in the bone frame. The arm points along
``direction(azimuth, elevation)`` = (sin el sin az, sin el cos az, -cos el):
elevation is the angle from hanging (90 = level), the body-frame direction a
launch records. A mounting error is not part of the motion: the harness puts
it on the sensor as ``SensorSpec.mount`` = q_LS = :meth:`PlayerProfile.mount`
= Rz(mount_roll) Ry(mount_pitch) (roll about the arm's long axis, link z,
then pitch about the hinge, link y), so the board measures q_WS = q_WL q_LS.

Movements. Every change of posture follows the minimum-jerk profile
s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5 (Flash and Hogan 1985, the
point-to-point move of least squared jerk), between keyframes on each channel (azimuth,
elevation, twist, sway about x and y, elbow flex); oscillations (the walking
pendulum, scratching, physiological tremor at 8-12 Hz) are sines under
minimum-jerk envelopes. Position, velocity and acceleration are continuous
everywhere, so the simulator's fourth-order differences (0.5 ms) give sane
rates and specific forces (the jerk jumps at keyframes, which tracker.sim
tolerates). All durations are divided by ``PlayerProfile.speed``; every
random draw comes from ``numpy.random.default_rng`` seeded by the session's
seed, one child seed per segment, so a segment's draws do not depend on what
came before it.
"""

from __future__ import annotations

import copy
import json
import math
import os
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tracker import quat as Q
from tracker.flex import FlexSensor
from tracker.sim import Chain, Motion, SensorErrors, arm_chain, mpu9250

from .avatar import Wearing

Array = NDArray[np.float64]
Interval = tuple[float, float]

LAUNCH_THRESHOLD_DEG = 25.0  # a launch happens when the straightening elbow crosses this
IDEAL_MOUNT = np.asarray(Wearing().mount)  # q_LB: the bone frame in the ideally worn sensor's
_X, _Z = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)
_CHANNELS = ("az", "el", "tw", "sx", "sy", "flex")  # degrees


# ------------------------------------------------------------------ profile

# name: (low, high, what it is) - the sane range of each profile value
_RANGES: dict[str, tuple[float, float, str]] = {
    "upper_arm_m": (0.15, 0.50, "an upper-arm length in metres"),
    "forearm_m": (0.15, 0.50, "a forearm length in metres"),
    "mount_roll_deg": (-180.0, 180.0, "a roll of the board about the arm in degrees"),
    "mount_pitch_deg": (-45.0, 45.0, "a tilt of the board across the arm in degrees"),
    "flex_straight_ohm": (1e3, 1e6, "a flex-sensor resistance in ohms"),
    "flex_bent_ohm": (1e3, 1e6, "a flex-sensor resistance in ohms"),
    "gyro_bias_dps": (0.0, 30.0, "a gyroscope offset bound in degrees per second"),
    "noise_scale": (0.0, 20.0, "a factor on the data-sheet noise"),
    "tremor_deg": (0.0, 5.0, "a tremor amplitude in degrees"),
    "speed": (0.25, 4.0, "a movement speed factor"),
}


@dataclass(frozen=True)
class PlayerProfile:
    """One simulated player and how the board sits on them: the single definition.

    The motion model uses the arm lengths, ``tremor_deg`` and ``speed``; the
    harness builds the simulator from the rest, e.g. with :meth:`chain`,
    :meth:`flex_sensor` and :meth:`sensor_errors`. Values are checked on
    construction (ValueError naming the key).
    """

    upper_arm_m: float = 0.30
    forearm_m: float = 0.27
    mount_roll_deg: float = 0.0  # board turned about the arm's long axis (link z)
    mount_pitch_deg: float = 0.0  # board tilted across it, about the hinge (link y)
    flex_straight_ohm: float = 12000.0
    flex_bent_ohm: float = 50000.0
    gyro_bias_dps: float = 1.0  # each gyro axis draws a constant offset within +-this
    noise_scale: float = 1.0  # times the MPU-9250 data-sheet noise densities
    tremor_deg: float = 0.005  # peak tremor per swing axis, two 8-12 Hz sines of half this each
    # (physiological tremor: at 10 Hz this moves the elbow 26 um and shakes it by 0.1 m/s^2)
    speed: float = 1.0  # > 1: faster movements (every duration divided by it)

    def __post_init__(self) -> None:
        for name, (low, high, what) in _RANGES.items():
            value = getattr(self, name)
            ok = isinstance(value, (int, float)) and not isinstance(value, bool)
            if not (ok and math.isfinite(value) and low <= value <= high):
                raise ValueError(f"player profile: {name} must be {what} between {low:g} "
                                 f"and {high:g}, not {value!r}")
            object.__setattr__(self, name, float(value))
        if self.flex_bent_ohm <= self.flex_straight_ohm:
            raise ValueError(f"player profile: flex_bent_ohm ({self.flex_bent_ohm:g}) must exceed "
                             f"flex_straight_ohm ({self.flex_straight_ohm:g})")

    @classmethod
    def from_json(cls, data: object) -> PlayerProfile:
        """A profile from a JSON object; missing keys take the defaults."""
        if not isinstance(data, dict):
            raise ValueError(f"player profile: expected a JSON object, not {type(data).__name__}")
        known = [f.name for f in fields(cls)]
        unknown = sorted(str(k) for k in data if k not in known)
        if unknown:
            raise ValueError(f"player profile: unknown key {unknown[0]!r} "
                             f"(known: {', '.join(known)})")
        return cls(**data)

    @classmethod
    def load(cls, path: str | os.PathLike) -> PlayerProfile:
        """Read a profile file; ValueError naming the file if it is broken."""
        try:
            with open(path, encoding="utf-8") as f:
                data = json.load(f)
        except (UnicodeDecodeError, json.JSONDecodeError) as e:
            raise ValueError(f"{path}: not a player profile (bad JSON: {e})") from None
        try:
            return cls.from_json(data)
        except ValueError as e:
            raise ValueError(f"{path}: {e}") from None

    def to_json(self) -> dict:
        return asdict(self)

    def mount(self) -> Array:
        """q_LS: the board in the upper-arm link frame, Rz(roll) Ry(pitch) (module docstring)."""
        roll = Q.from_axis_angle(_Z, math.radians(self.mount_roll_deg))
        pitch = Q.from_axis_angle((0.0, 1.0, 0.0), math.radians(self.mount_pitch_deg))
        return Q.multiply(roll, pitch)

    def chain(self) -> Chain:
        """:func:`tracker.sim.arm_chain` for this arm, the IMU at the elbow end, worn by :meth:`mount`."""
        base = arm_chain(self.upper_arm_m, self.forearm_m, sensor_m=self.upper_arm_m)
        mount = tuple(float(v) for v in self.mount())
        return replace(base, sensors=(replace(base.sensors[0], mount=mount),))

    def flex_sensor(self) -> FlexSensor:
        return FlexSensor(straight_ohm=self.flex_straight_ohm, bent_ohm=self.flex_bent_ohm)

    def sensor_errors(self) -> SensorErrors:
        """MPU-9250 errors (:func:`tracker.sim.mpu9250`): noise scaled, the gyro offset bounded here."""
        base = mpu9250()
        gyr = replace(base.gyr, noise_density=base.gyr.noise_density * self.noise_scale,
                      offset_max=math.radians(self.gyro_bias_dps))
        acc = replace(base.acc, noise_density=base.acc.noise_density * self.noise_scale)
        return replace(base, gyr=gyr, acc=acc)


# ------------------------------------------------------------------ building blocks


def minimum_jerk(tau: ArrayLike) -> Array:
    """s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5 on [0, 1], clamped outside (Flash and Hogan 1985)."""
    s = np.clip(np.asarray(tau, dtype=float), 0.0, 1.0)
    return s**3 * (10.0 - 15.0 * s + 6.0 * s**2)


def minimum_jerk_velocity(tau: ArrayLike) -> Array:
    """ds/dtau = 30 tau^2 (1 - tau)^2; its peak, at tau = 1/2, is 1.875 times the mean (1)."""
    s = np.asarray(tau, dtype=float)
    return np.where((s >= 0) & (s <= 1), 30.0 * s**2 * (1.0 - s) ** 2, 0.0)


def _minimum_jerk_inverse(fraction: float) -> float:
    """tau in [0, 1] where s(tau) = fraction (s is increasing), by bisection."""
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if minimum_jerk(mid) < fraction else (lo, mid)
    return 0.5 * (lo + hi)


def direction(azimuth_deg: ArrayLike, elevation_deg: ArrayLike) -> Array:
    """The body-frame unit vector of the arm raised by ``elevation`` and turned right by ``azimuth``."""
    az, el = np.radians(azimuth_deg), np.radians(elevation_deg)
    return np.stack([np.sin(el) * np.sin(az), np.sin(el) * np.cos(az), -np.cos(el)], axis=-1)


def _angle_deg(a: Array, b: Array) -> float:
    return math.degrees(math.acos(float(np.clip(np.dot(a, b), -1.0, 1.0))))


@dataclass
class _Track:
    """One channel's keyframes: minimum-jerk moves between them, held before and after."""

    t: list[float]
    v: list[float]

    def move(self, t0: float, t1: float, value: float) -> None:
        if t0 < self.t[-1] - 1e-9 or t1 <= t0:
            raise ValueError(f"a move over {t0:.3f}-{t1:.3f} s overlaps the previous one")
        if t0 > self.t[-1]:
            self.t.append(t0)
            self.v.append(self.v[-1])
        self.t.append(t1)
        self.v.append(float(value))

    def __call__(self, t: Array) -> Array:
        knots, values = np.asarray(self.t), np.asarray(self.v)
        if len(knots) == 1:
            return np.full(t.shape, values[0])
        i = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, len(knots) - 2)
        tau = (t - knots[i]) / (knots[i + 1] - knots[i])
        return values[i] + (values[i + 1] - values[i]) * minimum_jerk(tau)


@dataclass(frozen=True)
class _Wave:
    """amplitude sin(2 pi freq (t - t0) + phase) on one channel, faded in and out over ``ramp``."""

    channel: str
    t0: float
    t1: float
    amplitude: float
    freq_hz: float
    phase: float = 0.0
    ramp: float = math.inf  # inf: no envelope (the whole session)

    def __call__(self, t: Array) -> Array:
        wave = self.amplitude * np.sin(2 * np.pi * self.freq_hz * (t - self.t0) + self.phase)
        if math.isinf(self.ramp):
            return wave
        envelope = minimum_jerk((t - self.t0) / self.ramp) * minimum_jerk((self.t1 - t) / self.ramp)
        return wave * envelope


# ------------------------------------------------------------------ the result


@dataclass(frozen=True)
class TrueLaunch:
    """A launch as the player made it (seconds, body frame)."""

    t_straight_start: float  # the elbow starts straightening
    t_straight: float  # the elbow angle crosses below LAUNCH_THRESHOLD_DEG
    direction_body: tuple[float, float, float]  # unit, where the arm pointed (x right, y forward, z up)
    charge_time: float  # from the start of the elbow flex to the start of the straightening


@dataclass(frozen=True)
class Segment:
    kind: str  # "calibration", "gesture" or "idle"
    t0: float
    t1: float


@dataclass(frozen=True)
class Session:
    """A scripted session: the motion for the simulator and the truth of what was meant."""

    motion: Motion
    duration_s: float
    launches: list[TrueLaunch]
    idle_intervals: list[Interval]
    calibration: tuple[Interval, Interval] | None  # (arm down, arm forward) still intervals
    segments: list[Segment] = field(default_factory=list)

    def pointing(self, t: ArrayLike) -> Array:
        """The upper arm's unit direction (shoulder to elbow) in the body frame, (N, 3)."""
        return Q.rotate(self.motion.root(np.atleast_1d(np.asarray(t, dtype=float))), (0.0, 0.0, -1.0))

    def elevation_deg(self, t: ArrayLike) -> Array:
        """The upper arm's angle from hanging straight down, degrees."""
        return np.degrees(np.arccos(np.clip(-self.pointing(t)[:, 2], -1.0, 1.0)))

    def flex_deg(self, t: ArrayLike) -> Array:
        """The true elbow angle, degrees (0 straight)."""
        return np.degrees(self.motion.joints(np.atleast_1d(np.asarray(t, dtype=float)))[:, 0])

    def truth_json(self) -> dict:
        """The ground truth (everything but the motion) as a JSON object."""
        return {"duration_s": self.duration_s,
                "launches": [asdict(x) for x in self.launches],
                "idle_intervals": [list(i) for i in self.idle_intervals],
                "calibration": None if self.calibration is None else [list(i) for i in self.calibration],
                "segments": [asdict(s) for s in self.segments]}


# ------------------------------------------------------------------ the script


class Script:
    """Builds a session segment by segment; :meth:`build` gives the :class:`Session`.

    Each segment starts and ends with the arm hanging still, the elbow at the
    player's relaxed angle, so segments chain in any order.
    """

    def __init__(self, profile: PlayerProfile = PlayerProfile(), seed: int = 0,
                 threshold_deg: float = LAUNCH_THRESHOLD_DEG) -> None:
        self.profile, self.threshold_deg = profile, threshold_deg
        self._seeds = np.random.SeedSequence(seed)
        rng = self.rng()
        self.rest_flex = float(rng.uniform(2.0, 8.0))  # relaxed elbow when hanging
        self.now = 0.0
        self._tracks = {c: _Track([0.0], [self.rest_flex if c == "flex" else 0.0]) for c in _CHANNELS}
        self._waves: list[_Wave] = []
        if profile.tremor_deg > 0:  # two components per swing axis, half as much twist
            for channel, amp in (("sx", 1.0), ("sy", 1.0), ("tw", 0.5)):
                for _ in range(2):
                    self._waves.append(_Wave(channel, 0.0, math.inf, amp * profile.tremor_deg / 2,
                                             rng.uniform(8.0, 12.0), rng.uniform(0, 2 * np.pi)))
        self.launches: list[TrueLaunch] = []
        self.idle_intervals: list[Interval] = []
        self.segments: list[Segment] = []
        self.calibration_intervals: tuple[Interval, Interval] | None = None

    # -------------------------------------------------------- helpers

    def rng(self) -> np.random.Generator:
        """A fresh generator from the next child of the session's seed."""
        return np.random.default_rng(self._seeds.spawn(1)[0])

    def _dur(self, rng: np.random.Generator, lo: float, hi: float) -> float:
        return float(rng.uniform(lo, hi)) / self.profile.speed

    def _move(self, t0: float, duration: float, **targets: float) -> float:
        for channel, value in targets.items():
            self._tracks[channel].move(t0, t0 + duration, value)
        return t0 + duration

    def _wave(self, channel: str, t0: float, t1: float, amplitude: float, freq_hz: float,
              ramp: float, phase: float = 0.0) -> None:
        self._waves.append(_Wave(channel, t0, t1, amplitude, freq_hz * self.profile.speed, phase, ramp))

    def _reach_time(self, rng: np.random.Generator, angle_deg: float) -> float:
        """A point-to-point arm move lasts longer the farther it goes (about 0.7 s for 90 deg)."""
        return (0.40 + 0.0035 * angle_deg) * float(rng.uniform(0.85, 1.15)) / self.profile.speed

    def _finish(self, kind: str, t0: float, t1: float) -> None:
        self.segments.append(Segment(kind, t0, t1))
        self.now = t1

    # -------------------------------------------------------- segments

    def calibration(self) -> tuple[Interval, Interval]:
        """The wearing calibration: hang still, raise the straight arm forward to level, hold, lower.

        The holds are as long as the game asks for (the player's speed does
        not shorten them); only the movements between them scale with speed.
        """
        rng, t0 = self.rng(), self.now
        down = (t0, t0 + float(rng.uniform(2.4, 2.7)))
        t = self._move(down[1], self._dur(rng, 0.9, 1.3), el=90.0)
        forward = (t, t + float(rng.uniform(1.9, 2.2)))
        t = self._move(forward[1], self._dur(rng, 0.9, 1.3), el=0.0)
        self._finish("calibration", t0, t + self._dur(rng, 0.4, 0.6))
        self.calibration_intervals = (down, forward)
        return down, forward

    def gesture(self, targets: Sequence[tuple[float, float]] | None = None) -> list[TrueLaunch]:
        """Raise the arm at a target, flex (load), hold (spin), straighten (launch), lower.

        ``targets``: (azimuth, elevation) in degrees, one per launch; by default
        a random target (azimuth within +-60 deg, elevation 70-110 deg) and
        0-2 reloads at nearby targets.
        """
        rng, t_start = self.rng(), self.now
        extra = int(rng.choice(3, p=[0.6, 0.3, 0.1]))
        az, el = float(rng.uniform(-60, 60)), float(rng.uniform(70, 110))
        drawn = [(az, el)]
        for _ in range(extra):
            az = float(np.clip(az + rng.uniform(-25, 25), -60, 60))
            el = float(np.clip(el + rng.uniform(-10, 10), 70, 110))
            drawn.append((az, el))
        aims = [(float(a), float(e)) for a, e in targets] if targets is not None else drawn
        if not aims or not all(math.isfinite(a) and math.isfinite(e) for a, e in aims):
            raise ValueError("gesture targets must be finite (azimuth, elevation) pairs")
        twist = float(rng.uniform(-10, 10))
        t = self.now + self._dur(rng, 0.2, 0.4)  # reaction time
        pointing = np.array([0.0, 0.0, -1.0])
        launches = []
        for k, (az, el) in enumerate(aims):
            if k:
                t += self._dur(rng, 0.15, 0.4)  # follow-through before retargeting
            aim = direction(az, el)
            t = self._move(t, self._reach_time(rng, _angle_deg(pointing, aim)), az=az, el=el, tw=twist)
            pointing = aim
            t += self._dur(rng, 0.3, 0.8) if k == 0 else self._dur(rng, 0.1, 0.3)
            t_flex = t
            bent, straight = float(rng.uniform(90, 120)), float(rng.uniform(0, 6))
            t = self._move(t, self._dur(rng, 0.25, 0.5), flex=bent)  # loading
            t += self._dur(rng, 0.3, 1.0)  # spinning
            t_go, duration = t, self._dur(rng, 0.12, 0.25)
            t = self._move(t, duration, flex=straight)  # the launch
            fraction = (bent - self.threshold_deg) / (bent - straight)
            t_cross = t_go + duration * _minimum_jerk_inverse(fraction)
            launches.append(TrueLaunch(t_go, t_cross, tuple(float(v) for v in aim), t_go - t_flex))
        t += self._dur(rng, 0.2, 0.5)
        t = self._move(t, self._reach_time(rng, _angle_deg(pointing, np.array([0.0, 0.0, -1.0]))),
                       az=0.0, el=0.0, tw=0.0, flex=self.rest_flex)
        self._finish("gesture", t_start, t + self._dur(rng, 0.2, 0.5))
        self.launches += launches
        return launches

    def idle(self, duration_s: float) -> Interval:
        """``duration_s`` (not scaled by speed) of fidgeting, walking, elbow bends and scratches.

        The arm stays down: elevation below 35 deg whenever the elbow bends past
        25 deg (no launch is meant), sways below 25 deg, bends up to 60 deg.
        """
        if not (math.isfinite(duration_s) and duration_s >= 0):
            raise ValueError(f"an idle stretch needs a length in seconds >= 0, not {duration_s!r}")
        rng, t0 = self.rng(), self.now
        t1 = t0 + duration_s
        activities: dict[str, Callable[[np.random.Generator, float, float], float | None]] = {
            "fidget": self._fidget, "walk": self._walk, "bend": self._bend, "scratch": self._scratch}
        names, weights = list(activities), np.array([0.35, 0.3, 0.2, 0.15])
        t = t0
        while True:
            t += self._dur(rng, 0.3, 1.5)  # still, tremor only
            if t >= t1:
                break
            end = activities[names[rng.choice(len(names), p=weights)]](rng, t, t1)
            if end is None:
                break
            t = end
        self._finish("idle", t0, t1)
        self.idle_intervals.append((t0, t1))
        return t0, t1

    def _fidget(self, rng: np.random.Generator, t: float, t1: float) -> float | None:
        """One to three small sways of the hanging arm (< 20 deg a side), then back."""
        steps = []
        for _ in range(int(rng.integers(1, 4))):
            size, angle = rng.uniform(4, 20), rng.uniform(0, 2 * np.pi)
            steps.append((self._dur(rng, 0.5, 1.0), self._dur(rng, 0.2, 0.8),
                          size * math.cos(angle), min(size * math.sin(angle), 8.0)))
        back = self._dur(rng, 0.5, 1.0)
        if t + sum(d + h for d, h, _, _ in steps) + back > t1:
            return None
        for move, hold, sx, sy in steps:
            t = self._move(t, move, sx=sx, sy=sy) + hold
        return self._move(t, back, sx=0.0, sy=0.0)

    def _walk(self, rng: np.random.Generator, t: float, t1: float) -> float | None:
        """The arm swings like a pendulum while walking (+-15-25 deg, ~0.9 Hz), elbow a little bent."""
        ramp = 0.6 / self.profile.speed
        end = min(t + self._dur(rng, 2.5, 6.0), t1)
        if end - t < 4 * ramp:
            return None
        freq, amplitude = rng.uniform(0.8, 1.0), rng.uniform(15, 25)
        self._wave("sx", t, end, amplitude, freq, ramp)
        self._wave("flex", t, end, rng.uniform(3, 6), freq, ramp, phase=-0.5)
        self._move(t, ramp, flex=rng.uniform(10, 30))
        return self._move(end - ramp, ramp, flex=self.rest_flex)

    def _bend(self, rng: np.random.Generator, t: float, t1: float) -> float | None:
        """The elbow bends to 30-60 deg with the arm down (at most 15 deg forward), and back."""
        up, hold, down = self._dur(rng, 0.4, 0.8), self._dur(rng, 0.3, 1.0), self._dur(rng, 0.4, 0.8)
        if t + up + hold + down > t1:
            return None
        t = self._move(t, up, flex=rng.uniform(30, 60), sx=rng.uniform(0, 15)) + hold
        return self._move(t, down, flex=self.rest_flex, sx=0.0)

    def _scratch(self, rng: np.random.Generator, t: float, t1: float) -> float | None:
        """A brief scratch at the belly: arm a little forward and across, elbow ~50 deg, rubbing."""
        there, rub, back = self._dur(rng, 0.4, 0.7), self._dur(rng, 0.6, 1.5), self._dur(rng, 0.4, 0.7)
        if t + there + rub + back > t1:
            return None
        t = self._move(t, there, sx=rng.uniform(10, 25), sy=rng.uniform(0, 15), flex=rng.uniform(45, 52))
        self._wave("flex", t, t + rub, rng.uniform(3, 6), rng.uniform(3, 5), 0.15 / self.profile.speed)
        return self._move(t + rub, back, sx=0.0, sy=0.0, flex=self.rest_flex)

    # -------------------------------------------------------- the result

    def channels(self, t: ArrayLike) -> dict[str, Array]:
        """Every channel (degrees) at times ``t``: keyframes plus oscillations."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = {c: track(t) for c, track in self._tracks.items()}
        for wave in self._waves:
            if math.isinf(wave.t1):
                out[wave.channel] = out[wave.channel] + wave(t)
            else:  # zero outside its span: evaluate only there
                inside = (t > wave.t0) & (t < wave.t1)
                out[wave.channel][inside] += wave(t[inside])
        return out

    def root(self, t: ArrayLike) -> Array:
        """q_WL(t), the upper-arm link (= ideally worn sensor) in the world (module docstring)."""
        c = {k: np.radians(v) for k, v in self.channels(t).items()}
        q = Q.multiply(Q.from_axis_angle(_Z, -c["az"]), Q.from_axis_angle(_X, c["el"]))
        q = Q.multiply(q, Q.from_axis_angle(_Z, c["tw"]))
        q = Q.multiply(q, Q.from_rotvec(np.stack([c["sx"], c["sy"], np.zeros_like(c["sx"])], axis=-1)))
        return Q.multiply(q, Q.conjugate(IDEAL_MOUNT))

    def joints(self, t: ArrayLike) -> Array:
        """The elbow angle in radians, (N, 1)."""
        return np.radians(self.channels(t)["flex"])[:, None]

    def build(self) -> Session:
        """The session so far; later segments added to this script do not change it."""
        frozen = copy.deepcopy(self)
        return Session(Motion(frozen.root, frozen.joints), self.now, list(self.launches),
                       list(self.idle_intervals), self.calibration_intervals, list(self.segments))


def session(profile: PlayerProfile = PlayerProfile(), seed: int = 0, gestures: int = 5,
            idle_s: float | tuple[float, float] = (4.0, 10.0), calibration: bool = True) -> Session:
    """Calibration, then idle and gesture in turn (``gestures`` of them), ending idle.

    ``idle_s``: each idle stretch's length, or a (low, high) range to draw it
    from; 0 leaves the idle stretches out.
    """
    if isinstance(idle_s, (int, float)):
        low, high = float(idle_s), float(idle_s)
    else:
        low, high = (float(v) for v in idle_s)
    if not (0 <= low <= high < math.inf):
        raise ValueError(f"idle_s must be seconds >= 0 or a (low, high) range, not {idle_s!r}")
    if gestures < 0:
        raise ValueError(f"gestures must be >= 0, not {gestures}")
    script = Script(profile, seed)
    lengths = script.rng().uniform(low, high, gestures + 1)
    if calibration:
        script.calibration()
    for k in range(gestures + 1):
        if lengths[k] > 0:
            script.idle(float(lengths[k]))
        if k < gestures:
            script.gesture()
    return script.build()
