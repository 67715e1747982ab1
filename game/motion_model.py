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

import bisect
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
from tracker.fusion.qmath import as_quat, as_vec
from tracker.sim import Chain, Motion, SensorErrors, arm_chain, mpu9250

from .avatar import Wearing

Array = NDArray[np.float64]
Interval = tuple[float, float]

LAUNCH_THRESHOLD_DEG = 25.0  # a launch happens when the straightening elbow crosses this
IDEAL_MOUNT = np.asarray(Wearing().mount)  # q_LB: the bone frame in the ideally worn sensor's
_Z = (0.0, 0.0, 1.0)
_CHANNELS = ("az", "el", "tw", "sx", "sy", "flex")  # degrees


# ------------------------------------------------------------------ profile

# name: (low, high, what it is) - the sane range of each profile value
SPEED_RANGE = (0.25, 4.0)  # a player's movement speed factor, slowest to fastest

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
    "speed": (*SPEED_RANGE, "a movement speed factor"),
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
        return replace(base, sensors=(replace(base.sensors[0], mount=as_quat(self.mount())),))

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
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


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


def _aim(a: Array, b: Array, c: Array) -> Array:
    """Rz(a) Rx(b) Rz(c), the three Hamilton products (Sola 2017, sec. 1.2.2) written out:
    (cos(b/2) cos((a+c)/2), sin(b/2) cos((a-c)/2), sin(b/2) sin((a-c)/2), cos(b/2) sin((a+c)/2))."""
    half = 0.5 * np.array([b, a + c, a - c])
    (cb, cp, cm), (sb, sp, sm) = np.cos(half), np.sin(half)
    return np.stack([cb * cp, sb * cm, sb * sm, cb * sp], axis=-1)


def _angle_deg(a: Array, b: Array) -> float:
    return math.degrees(math.acos(float(np.clip(np.dot(a, b), -1.0, 1.0))))


@dataclass(frozen=True)
class _Segments:
    """Every channel's moves end to end, so that all channels are evaluated at once.

    A channel with n keyframes has n + 1 segments: a hold of the first value
    before them, the n - 1 moves, and a hold of the last value after them, so
    segment ``searchsorted(knots, t, "right")`` of the channel covers t.
    """

    knots: tuple[Array, ...]  # each channel's keyframe times
    first: Array  # (C, 1) each channel's first segment in ``table``
    table: Array  # (4, segments): start time, duration, start value and change of each

    @classmethod
    def of(cls, knots: list[list[float]], values: list[list[float]]) -> _Segments:
        """The segments of channels with these keyframe times and values."""
        columns = [cls._channel(np.array(k), np.array(v)) for k, v in zip(knots, values)]
        sizes = np.array([c.shape[1] for c in columns])
        return cls(tuple(np.array(k) for k in knots), (np.cumsum(sizes) - sizes)[:, None],
                   np.concatenate(columns, axis=1))

    @staticmethod
    def _channel(k: Array, v: Array) -> Array:
        """One channel's segments (class docstring) as the columns of a (4, n + 1) table."""
        return np.array([np.concatenate([k[:1], k]),
                         np.concatenate([[1.0], np.diff(k), [1.0]]),
                         np.concatenate([v[:1], v[:-1], v[-1:]]),
                         np.concatenate([[0.0], np.diff(v), [0.0]])])

    def __call__(self, t: Array) -> Array:
        """Every channel at times ``t`` (M,), as (C, M)."""
        i = np.array([np.searchsorted(k, t, side="right") for k in self.knots]) + self.first
        start, duration, value, change = (row.take(i) for row in self.table)
        return value + change * minimum_jerk((t - start) / duration)


class _Keyframes:
    """Every channel's keyframes: minimum-jerk moves between them, held before and after."""

    def __init__(self, start: dict[str, float]) -> None:
        self._t = {c: [0.0] for c in start}
        self._v = {c: [float(v)] for c, v in start.items()}
        self._segments: _Segments | None = None

    def move(self, channel: str, t0: float, t1: float, value: float) -> None:
        knots, values = self._t[channel], self._v[channel]
        if t0 < knots[-1] - 1e-9 or t1 <= t0:
            raise ValueError(f"a move over {t0:.3f}-{t1:.3f} s overlaps the previous one")
        if t0 > knots[-1]:
            knots.append(t0)
            values.append(values[-1])
        knots.append(t1)
        values.append(float(value))
        self._segments = None

    def forget_before(self, t: float) -> None:
        """Drop the keyframes no time from ``t`` on needs (each channel keeps its last one before ``t``)."""
        for knots, values in zip(self._t.values(), self._v.values()):
            i = bisect.bisect_right(knots, t) - 1
            if i > 0:
                del knots[:i], values[:i]
                self._segments = None

    def __call__(self, t: Array) -> Array:
        """Every channel at times ``t`` (M,), as (C, M)."""
        if self._segments is None:
            self._segments = _Segments.of(list(self._t.values()), list(self._v.values()))
        return self._segments(t)


def _sine(amplitude: Array | float, freq_hz: Array | float, phase: Array | float, t: Array) -> Array:
    """amplitude sin(2 pi freq t + phase)."""
    return amplitude * np.sin(2 * np.pi * freq_hz * t + phase)


@dataclass(frozen=True)
class _Tremor:
    """Steady oscillations amplitude sin(2 pi freq t + phase), each on one channel (a row)."""

    rows: tuple[int, ...]
    amplitude: Array
    freq_hz: Array
    phase: Array

    def add_to(self, channels: Array, t: Array) -> None:
        """Add every oscillation at times ``t`` (M,) to its row of ``channels`` (C, M)."""
        waves = _sine(self.amplitude[:, None], self.freq_hz[:, None], self.phase[:, None], t)
        for row, wave in zip(self.rows, waves):
            channels[row] = channels[row] + wave


@dataclass(frozen=True)
class _Wave:
    """amplitude sin(2 pi freq (t - t0) + phase) on one channel, faded in and out over ``ramp``."""

    channel: str
    t0: float
    t1: float
    amplitude: float
    freq_hz: float
    phase: float
    ramp: float

    def __call__(self, t: Array) -> Array:
        wave = _sine(self.amplitude, self.freq_hz, self.phase, t - self.t0)
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
        self._keyframes = _Keyframes({c: self.rest_flex if c == "flex" else 0.0 for c in _CHANNELS})
        self._tremor = self._draw_tremor(rng)
        self._waves: list[_Wave] = []
        self.launches: list[TrueLaunch] = []
        self.idle_intervals: list[Interval] = []
        self.segments: list[Segment] = []
        self.calibration_intervals: tuple[Interval, Interval] | None = None
        self._edited_from = math.inf  # the earliest time a move or wave added since take_edits()

    # -------------------------------------------------------- helpers

    def take_edits(self) -> float:
        """The earliest time from which segments added since the last call change the motion
        (inf: none were). Who computes the motion ahead (the headless match) redoes it from there."""
        edited, self._edited_from = self._edited_from, math.inf
        return edited

    def _draw_tremor(self, rng: np.random.Generator) -> _Tremor:
        """Two 8-12 Hz components per swing axis, half as much twist (none at tremor 0)."""
        rows, amplitude, freq, phase = [], [], [], []
        if self.profile.tremor_deg > 0:
            for channel, amp in (("sx", 1.0), ("sy", 1.0), ("tw", 0.5)):
                for _ in range(2):
                    rows.append(_CHANNELS.index(channel))
                    amplitude.append(amp * self.profile.tremor_deg / 2)
                    freq.append(rng.uniform(8.0, 12.0))
                    phase.append(rng.uniform(0, 2 * np.pi))
        return _Tremor(tuple(rows), np.array(amplitude), np.array(freq), np.array(phase))

    def rng(self) -> np.random.Generator:
        """A fresh generator from the next child of the session's seed."""
        return np.random.default_rng(self._seeds.spawn(1)[0])

    def _dur(self, rng: np.random.Generator, lo: float, hi: float) -> float:
        return float(rng.uniform(lo, hi)) / self.profile.speed

    def _move(self, t0: float, duration: float, **targets: float) -> float:
        self._edited_from = min(self._edited_from, t0)
        for channel, value in targets.items():
            self._keyframes.move(channel, t0, t0 + duration, value)
        return t0 + duration

    def _wave(self, channel: str, t0: float, t1: float, amplitude: float, freq_hz: float,
              ramp: float, phase: float = 0.0) -> None:
        self._edited_from = min(self._edited_from, t0)
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

    def wait_until(self, t: float) -> None:
        """Start the next segment no earlier than ``t`` (the arm holds still until then)."""
        self.now = max(self.now, float(t))

    def reach(self, azimuth_deg: float, elevation_deg: float, kind: str = "reach") -> float:
        """Move the straight arm to point at (azimuth, elevation) from now, one minimum-jerk
        reach (elbow relaxed, no twist); returns when it arrives. (0, 0) lowers it."""
        rng, t0 = self.rng(), self.now
        start = self.pointing_at(t0)
        aim = direction(azimuth_deg, elevation_deg)
        t = self._move(t0, self._reach_time(rng, _angle_deg(start, aim)), az=azimuth_deg,
                       el=elevation_deg, tw=0.0, flex=self.rest_flex)
        self._finish(kind, t0, t)
        return t

    def pointing_at(self, t: float) -> Array:
        """The body-frame unit direction of the upper arm at ``t``, without sway and tremor."""
        c = self.channels([t])
        return direction(float(c["az"][0]), float(c["el"][0]))

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
            launches.append(TrueLaunch(t_go, t_cross, as_vec(aim), t_go - t_flex))
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

    def _degrees(self, t: Array) -> Array:
        """Every channel at times ``t`` (M,), as (channels, M) in degrees."""
        out = self._keyframes(t)
        self._tremor.add_to(out, t)
        lo, hi = (t.min(), t.max()) if len(t) else (math.inf, -math.inf)
        for wave in self._waves:  # zero outside its span: evaluate only there
            if wave.t0 < hi and wave.t1 > lo:
                inside = (t > wave.t0) & (t < wave.t1)
                out[_CHANNELS.index(wave.channel), inside] += wave(t[inside])
        return out

    def channels(self, t: ArrayLike) -> dict[str, Array]:
        """Every channel (degrees) at times ``t``: keyframes plus oscillations."""
        return dict(zip(_CHANNELS, self._degrees(np.atleast_1d(np.asarray(t, dtype=float)))))

    def _radians(self, t: ArrayLike) -> Array:
        """Every channel at times ``t``, as (channels, N) in radians."""
        return np.radians(self._degrees(np.atleast_1d(np.asarray(t, dtype=float))))

    @staticmethod
    def _root(c: Array) -> Array:
        """q_WL from the channels (radians, in the order of ``_CHANNELS``) (module docstring)."""
        az, el, tw, sx, sy = c[:5]
        sway = Q.from_rotvec(np.stack([sx, sy, np.zeros_like(sx)], axis=-1))
        return Q.multiply(Q.multiply(_aim(-az, el, tw), sway), Q.conjugate(IDEAL_MOUNT))

    def root(self, t: ArrayLike) -> Array:
        """q_WL(t), the upper-arm link (= ideally worn sensor) in the world (module docstring)."""
        return self._root(self._radians(t))

    @staticmethod
    def _elbow(c: Array) -> Array:
        """The elbow angle (N, 1) from the channels in radians."""
        return c[_CHANNELS.index("flex")][:, None]

    def joints(self, t: ArrayLike) -> Array:
        """The elbow angle in radians, (N, 1)."""
        return self._elbow(self._radians(t))

    def pose(self, t: ArrayLike) -> tuple[Array, Array]:
        """:meth:`root` and :meth:`joints` together, from one evaluation of the channels."""
        c = self._radians(t)
        return self._root(c), self._elbow(c)

    def forget_before(self, t: float) -> None:
        """Let go of the motion before ``t`` (keyframes, ended oscillations): a script that is
        extended for an hour stays small and fast. The motion from ``t`` on is unchanged."""
        self._keyframes.forget_before(t)
        self._waves = [w for w in self._waves if w.t1 > t]

    @property
    def motion(self) -> Motion:
        """The script as a live :class:`tracker.sim.Motion`: segments added later change it."""
        return Motion(self.root, self.joints, self.pose)

    def build(self) -> Session:
        """The session so far; later segments added to this script do not change it."""
        frozen = copy.deepcopy(self)
        return Session(frozen.motion, self.now, list(self.launches),
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
