"""A simulated player wearing the board: human-like arm motion and what the player meant.

The output is a :class:`tracker.sim.Motion` for :func:`tracker.sim.arm_chain`
(the upper arm as the root, the elbow as its one hinge) plus the ground truth
of the player's intentions (:class:`Session`): when each launch was made, where
it was aimed, when the player was idle, and when the wearing calibration's two
poses were held. The eval harness and the headless match feed the motion to
the sensor simulator and score the tracker and the gesture machine against it.

Bone and board. The motion's root (:meth:`Script.root`) is the bone, where
the humerus is: the player's moves, tremor and sway; the forearm and the
elbow's hinge hang on it. The board sits on the bone's soft tissue under a
strap, which turns it (:class:`Script`: rocking, the twist the board does
not follow, slip) by q_m = exp(r), r = (rx, ry, rz) in the link frame
(:meth:`Script.strap`): the motion's time-varying mount
(:class:`tracker.sim.Motion`), q_WS = q_WL,bone q_m(t) q_LS. The board turns
about a point in the soft tissue under it, STRAP_PIVOT_M from the sensor
(STRAP_PIVOT_DEPTH_M toward the bone, the board on the arm's outer side,
link +y for the right arm), so a rocking of A at f Hz adds 2 pi f A to the
board's rate and about (2 pi f)^2 A STRAP_PIVOT_DEPTH_M to its
acceleration, as a board rocking on the soft tissue does (not the upper
arm's length times the angle, as turning the whole arm about the shoulder
would). The
simulator moves the board, so it errs as a real one does; the truth stays
the bone: the launches' directions (where the bone pointed when the elbow
crossed the threshold) and :meth:`Session.pointing` /
:meth:`Session.elevation_deg` come from it.

Frames. The body frame B is x right, y forward, z up (:mod:`game.body.avatar`); the
simulated world is the body frame at heading 0 (z up, no walking turns). The
root quaternion ``motion.root(t)`` is q_WL, the orientation in the world of
the simulator's upper-arm *link* frame L, which is the sensor frame of an
ideally worn board: its y axis is the elbow hinge, its -x points forward when
the arm hangs, its -z runs down the arm (``arm_chain``: at identity the arm
hangs along -z; a positive flex swings the forearm toward -x). The bone frame
of the avatar (x the hinge, y forward) is L turned by the ideal mounting
q_LB = ``game.body.avatar.Wearing().mount`` (a quarter turn about z), so

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
import math
import os
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Callable, Generic, Sequence, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tracker import quat as Q
from tracker.flex import FlexSensor
from tracker.fusion.qmath import as_quat, as_vec
from tracker.sim import (
    TYPICAL_FLEX_CREEP_PCT, TYPICAL_FLEX_HYSTERESIS_PCT, TYPICAL_GYRO_BIAS_DPS, TYPICAL_GYRO_WARMUP_DPS,
    TYPICAL_MAG_DISTURBANCE_UT, TYPICAL_MAG_HARD_IRON_UT, TYPICAL_MAG_SOFT_IRON_PCT, Chain, Motion,
    SensorErrors, Simulator, arm_chain, realistic_errors)
from tracker.userjson import read_json

from ..body.avatar import Wearing

Array = NDArray[np.float64]
Interval = tuple[float, float]

PLAY_POWER_ON = 1  # play is the board's second power-on; the maker's calibrations had others (tracker.maker_sim)
LAUNCH_THRESHOLD_DEG = 25.0  # a launch happens when the straightening elbow crosses this
IDEAL_MOUNT = np.asarray(Wearing().mount)  # q_LB: the bone frame in the ideally worn sensor's
_Z = (0.0, 0.0, 1.0)
_CHANNELS = ("az", "el", "tw", "sx", "sy", "flex")  # degrees
_STRAP = ("rx", "ry", "rz")  # degrees: the board turned relative to the bone, about link x, y, z

# The launch as :meth:`Script.gesture` draws it: bent this far, straightened within this time.
LAUNCH_BENT_DEG = (90.0, 120.0)
LAUNCH_S = (0.12, 0.25)
MINIMUM_JERK_PEAK_ACC = 10.0 / math.sqrt(3.0)  # max s''(tau), at tau = (3 - sqrt 3) / 6
SHARPEST_DEG_S2 = MINIMUM_JERK_PEAK_ACC * LAUNCH_BENT_DEG[1] / LAUNCH_S[0] ** 2  # the snappiest launch
DAMPING_RATIO = 0.3  # soft tissue under a strap (class docstring of Script: 0.2-0.4)
BOARD_RADIUS_M = 0.05  # the board's distance from the humerus' axis (upper-arm radius)
# The board rocks with the skin and the fat it presses on, over the muscle: about a point that
# deep under the sensor (the board's few mm, and the subcutaneous layer: the triceps skinfold, a
# double layer, is about 10-25 mm in adults, Frisancho, Am. J. Clin. Nutr. 34, 1981). Deeper,
# at the humerus' axis (BOARD_RADIUS_M), the typical player's accelerometer at rest would stray
# 1.5-2.2 times the real arm's (game.sim.realism, seeds 0-9); at 2 cm, 1.2-1.5 times.
STRAP_PIVOT_DEPTH_M = 0.02
STRAP_PIVOT_M = (0.0, -STRAP_PIVOT_DEPTH_M, 0.0)  # what the strap turns the board about, from it (link)
RING_DECAYS = 20.0  # a kick's rocking is over after exp(-20) of it is left
TREMOR_SPREAD_HZ = 1.0  # tremor components lie within this of the profile's tremor_hz
TREMOR_COMPONENTS = 4  # sines per channel: beating, the tremor waxes and wanes as a real one
SWAY_HZ = (0.1, 1.0)
# The shoulder is no fixed point (Script, "Shoulder"): where its joint moves with the arm straight
# up (body frame: x right, y forward, z up; metres), and the trunk's bounce while walking.
SHOULDER_RISE_M = (0.0, -0.02, 0.04)
WALK_BOUNCE_M = (0.01, 0.025)  # vertical amplitude, at twice the arm's swing frequency (a step per swing)
WALK_SIDE_M = (0.01, 0.02)  # side to side, at the swing's frequency
# Which strap axis a move of a channel rocks the board about: the hinge (link y) for the
# elbow and for raising the arm in its plane, link x for swings across it (module docstring).
_KICKED = {"flex": 1, "el": 1, "sx": 1, "az": 0, "sy": 0}


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
    "tremor_deg": (0.0, 2.0, "a peak tremor per swing axis in degrees"),
    "speed": (*SPEED_RANGE, "a movement speed factor"),
    "tremor_hz": (3.0, 12.0, "a tremor centre frequency in hertz"),
    "sway_deg": (0.0, 4.0, "a peak postural sway in degrees"),
    "wobble_deg": (0.0, 6.0, "a peak rocking of the board on the soft tissue in degrees"),
    "wobble_hz": (5.0, 25.0, "a natural frequency of that rocking in hertz"),
    "twist_follow": (0.4, 1.0, "a share of the humerus' axial twist the board follows"),
    "slip_deg_per_min": (0.0, 4.0, "a slip of the board's roll about the arm in degrees per minute"),
    "flex_hysteresis_pct": (0.0, 12.0, "a flex-sensor hysteresis in percent of its span"),
    "flex_creep_pct": (0.0, 12.0, "a flex-sensor creep in percent of its span"),
    "gyro_warmup_dps": (0.0, 4.0, "a gyroscope warm-up drift in degrees per second"),
    "mag_hard_iron_ut": (0.0, 200.0, "a hard-iron offset in microtesla"),
    "mag_soft_iron_pct": (0.0, 20.0, "a soft-iron distortion in percent"),
    "mag_disturbance_ut": (0.0, 40.0, "an indoor field disturbance in microtesla"),
}


@dataclass(frozen=True)
class PlayerProfile:
    """One simulated player and how the board sits on them: the single definition.

    The motion model uses the arm lengths, the player's keys (``tremor_*``,
    ``sway_deg``, ``speed``) and the strap's (``wobble_*``, ``twist_follow``,
    ``slip_deg_per_min``); the harness builds the simulator from the rest with
    :meth:`chain`, :meth:`flex_sensor` and :meth:`sensor_errors`. Values are
    checked on construction (one-line ValueError naming the key and its range).
    Every default is the "typical" player and board, tuned so that the typical
    player at rest has the real recording's statistics
    (:func:`game.sim.realism.compare_with_recording`); the board's own figures
    are :mod:`tracker.sim`'s ``TYPICAL_*`` constants, kept there.
    """

    upper_arm_m: float = 0.30
    forearm_m: float = 0.27
    mount_roll_deg: float = 0.0  # board turned about the arm's long axis (link z)
    mount_pitch_deg: float = 0.0  # board tilted across it, about the hinge (link y)
    flex_straight_ohm: float = 12000.0
    flex_bent_ohm: float = 50000.0
    gyro_bias_dps: float = TYPICAL_GYRO_BIAS_DPS  # each gyro axis draws a constant offset within +-this
    noise_scale: float = 1.0  # times the MPU-9250 data-sheet noise densities
    tremor_deg: float = 0.016  # peak tremor per swing axis (TREMOR_COMPONENTS sines sharing it)
    speed: float = 1.0  # > 1: faster movements (every duration divided by it)
    tremor_hz: float = 8.5  # the tremor's centre frequency (components within +-1 Hz)
    sway_deg: float = 0.5  # peak slow postural sway (0.1-1 Hz), always on
    wobble_deg: float = 1.5  # peak rocking of the board on the soft tissue after the sharpest snap
    wobble_hz: float = 9.0  # that rocking's natural frequency
    twist_follow: float = 0.75  # share of the humerus' axial twist the board follows
    slip_deg_per_min: float = 0.5  # drift of the board's roll about the arm during play
    flex_hysteresis_pct: float = TYPICAL_FLEX_HYSTERESIS_PCT
    flex_creep_pct: float = TYPICAL_FLEX_CREEP_PCT
    gyro_warmup_dps: float = TYPICAL_GYRO_WARMUP_DPS
    mag_hard_iron_ut: float = TYPICAL_MAG_HARD_IRON_UT
    mag_soft_iron_pct: float = TYPICAL_MAG_SOFT_IRON_PCT
    mag_disturbance_ut: float = TYPICAL_MAG_DISTURBANCE_UT

    def __post_init__(self) -> None:
        for name, (low, high, what) in _RANGES.items():
            value = getattr(self, name)
            ok = isinstance(value, (int, float)) and not isinstance(value, bool)
            if not (ok and low <= value <= high):  # NaN fails it; a huge int is compared exactly
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
        """Read a profile file; ValueError naming the file if it is broken, OSError if it cannot be read."""
        data = read_json(path)  # JSONInputError (a ValueError) names the file; OSError if unreadable
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

    def simulator(self, motion: Motion, seed: int) -> Simulator:
        """The board this player wears, in ``motion``: its errors drawn from ``seed`` (the board the
        simulated maker calibrated, :func:`game.sim.gesture_eval.maker_calibration`), at the power-on
        of play (:data:`PLAY_POWER_ON`)."""
        return Simulator(self.chain(), motion, self.sensor_errors(), self.flex_sensor(), seed=seed,
                         power_on=PLAY_POWER_ON)

    def sensor_errors(self) -> SensorErrors:
        """The board's errors (:func:`tracker.sim.realistic_errors`) with this profile's figures."""
        return realistic_errors(
            gyro_bias_dps=self.gyro_bias_dps, noise_scale=self.noise_scale,
            gyro_warmup_dps=self.gyro_warmup_dps, mag_hard_iron_ut=self.mag_hard_iron_ut,
            mag_soft_iron_pct=self.mag_soft_iron_pct, mag_disturbance_ut=self.mag_disturbance_ut,
            flex_hysteresis_pct=self.flex_hysteresis_pct, flex_creep_pct=self.flex_creep_pct)


PROFILES_DIR = os.path.join(os.path.dirname(os.path.dirname(__file__)), "profiles")  # game/profiles
CATALOGUE_INDEX = os.path.join(PROFILES_DIR, "README.md")


def catalogue(folder: str | os.PathLike = PROFILES_DIR) -> dict[str, PlayerProfile]:
    """The named players shipped with the game: each ``<name>.json`` of ``folder``, by name."""
    names = sorted(f[:-5] for f in os.listdir(folder) if f.endswith(".json"))
    return {name: PlayerProfile.load(os.path.join(folder, name + ".json")) for name in names}


# The keys a drawn player varies: the harsh world's (issue 12's table) over their whole ranges, the
# board's bias over its range, and speed and noise over the span every draw so far was measured in
# (README, "Players between the catalogue's"): widening it would redraw every player named there.
DRAWN_SPANS: dict[str, tuple[float, float]] = {
    **{key: _RANGES[key][:2] for key in (
        "tremor_deg", "tremor_hz", "sway_deg", "wobble_deg", "wobble_hz", "twist_follow", "slip_deg_per_min",
        "flex_hysteresis_pct", "flex_creep_pct", "gyro_warmup_dps", "mag_hard_iron_ut", "mag_soft_iron_pct",
        "mag_disturbance_ut", "gyro_bias_dps")},
    "speed": (0.5, 3.0), "noise_scale": (0.5, 2.0)}


def drawn_players(count: int, seed: int) -> dict[str, PlayerProfile]:
    """``count`` players drawn uniformly within :data:`DRAWN_SPANS` (the other keys the typical
    player's), named ``drawn-<seed>-<k>``: players between the catalogue's."""
    rng = np.random.default_rng(seed)
    return {f"drawn-{seed}-{k}": PlayerProfile(**{key: round(float(rng.uniform(lo, hi)), 3)
                                                   for key, (lo, hi) in DRAWN_SPANS.items()})
            for k in range(count)}


def catalogue_descriptions(index: str | os.PathLike = CATALOGUE_INDEX) -> dict[str, str]:
    """Each catalogue player's one-line description, from the rows ``| `name` | text |`` of
    the catalogue's index (``profiles/README.md``), by name."""
    rows = {}
    with open(index, encoding="utf-8") as f:
        for line in f:
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if len(cells) == 2 and cells[0].startswith("`") and cells[0].endswith("`"):
                rows[cells[0].strip("`")] = cells[1]
    return dict(sorted(rows.items()))


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

    def __call__(self, t: Array, channel: int | None = None) -> Array:
        """Every channel at times ``t`` (M,), as (C, M); or only ``channel``'s, as (M,)."""
        if channel is None:
            i = np.array([np.searchsorted(k, t, side="right") for k in self.knots]) + self.first
        else:
            i = np.searchsorted(self.knots[channel], t, side="right") + self.first[channel, 0]
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

    def last(self, channel: str) -> float:
        """The channel's latest keyframe value."""
        return self._v[channel][-1]

    def forget_before(self, t: float) -> None:
        """Drop the keyframes no time from ``t`` on needs (each channel keeps its last one before ``t``)."""
        for knots, values in zip(self._t.values(), self._v.values()):
            i = bisect.bisect_right(knots, t) - 1
            if i > 0:
                del knots[:i], values[:i]
                self._segments = None

    def __call__(self, t: Array, channel: int | None = None) -> Array:
        """Every channel at times ``t`` (M,), as (C, M); or only ``channel``'s (its index), as (M,)."""
        if self._segments is None:
            self._segments = _Segments.of(list(self._t.values()), list(self._v.values()))
        return self._segments(t, channel)


def _sine(amplitude: Array | float, freq_hz: Array | float, phase: Array | float, t: Array) -> Array:
    """amplitude sin(2 pi freq t + phase)."""
    return amplitude * np.sin(2 * np.pi * freq_hz * t + phase)


@dataclass(frozen=True)
class _Oscillations:
    """Steady oscillations amplitude sin(2 pi freq t + phase), each on one row of a channel array."""

    rows: tuple[int, ...]
    amplitude: Array
    freq_hz: Array
    phase: Array

    def on_row(self, row: int) -> _Oscillations:
        """Only the oscillations on ``row``, put on row 0."""
        on = np.array(self.rows, dtype=int) == row
        return _Oscillations((0,) * int(np.sum(on)), self.amplitude[on], self.freq_hz[on], self.phase[on])

    def add_to(self, channels: Array, t: Array) -> None:
        """Add every oscillation at times ``t`` (M,) to its row of ``channels`` (C, M)."""
        waves = _sine(self.amplitude[:, None], self.freq_hz[:, None], self.phase[:, None], t)
        for row, wave in zip(self.rows, waves):
            channels[row] = channels[row] + wave


def _draw(rng: np.random.Generator, rows: Sequence[tuple[int, float]], per_row: int,
          freq_hz: tuple[float, float]) -> _Oscillations:
    """``per_row`` sines on each (row, total peak) of ``rows``, each a share of that peak,
    frequencies uniform in ``freq_hz``, phases uniform."""
    n = len(rows) * per_row
    return _Oscillations(tuple(r for r, _ in rows for _ in range(per_row)),
                         np.array([peak / per_row for _, peak in rows for _ in range(per_row)]),
                         rng.uniform(*freq_hz, n), rng.uniform(0.0, 2 * np.pi, n))


def tissue_response(freq_ratio: Array | float) -> tuple[Array, Array]:
    """Gain and phase lag of the board's rocking on the soft tissue driven by the bone's
    acceleration, per unit of the bone's displacement at the board over the board's radius.

    The wobbling mass (Gruber et al. 1998; Wakeling and Nigg 2001, soft-tissue
    vibrations as damped oscillators): phi'' + 2 zeta w phi' + w^2 phi = -x''/rho.
    For x = X sin(W t) with r = W / w the steady response is
    phi = (X / rho) r^2 / sqrt((1 - r^2)^2 + (2 zeta r)^2) sin(W t - lag),
    lag = atan2(2 zeta r, 1 - r^2) (the base-excited oscillator's relative motion).
    """
    r = np.asarray(freq_ratio, dtype=float)
    gain = r * r / np.sqrt((1.0 - r * r) ** 2 + (2.0 * DAMPING_RATIO * r) ** 2)
    return gain, np.arctan2(2.0 * DAMPING_RATIO * r, 1.0 - r * r)


def _step_response(x: Array) -> Array:
    """The unit-step response of the damped oscillator at x = w_d tau (0 before the step):
    1 - exp(-zeta w tau) (cos w_d tau + zeta / sqrt(1 - zeta^2) sin w_d tau)."""
    k = DAMPING_RATIO / math.sqrt(1.0 - DAMPING_RATIO**2)
    return np.where(x > 0, 1.0 - np.exp(-k * x) * (np.cos(x) + k * np.sin(x)), 0.0)


_RING_PEAK = float(np.max(_step_response(np.linspace(0.0, 4 * np.pi, 40001))
                          - _step_response(np.linspace(-np.pi, 3 * np.pi, 40001))))
_RING_K = DAMPING_RATIO / math.sqrt(1.0 - DAMPING_RATIO**2)


def ring(x: ArrayLike) -> Array:
    """The rocking after a kick, at x = w_d tau: the response to a push lasting half a
    damped period, S(x) - S(x - pi), scaled to a peak of 1. Position and rate are
    continuous at the kick (no jump for the simulator's differences); it decays by
    exp(-zeta w tau) and rings at w_d = w sqrt(1 - zeta^2).

    With k = zeta / sqrt(1 - zeta^2) and D(x) = exp(-k x) (cos x + k sin x), S = 1 - D
    after the step, and D(x - pi) = -exp(k pi) D(x): so S(x) - S(x - pi) is 1 - D(x)
    for 0 < x <= pi and -(1 + exp(k pi)) D(x) after, one evaluation of D."""
    x = np.asarray(x, dtype=float)
    d = np.exp(-_RING_K * np.maximum(x, 0.0)) * (np.cos(x) + _RING_K * np.sin(x))
    pushed = np.where(x > np.pi, -(1.0 + math.exp(_RING_K * math.pi)) * d, 1.0 - d)
    return np.where(x > 0, pushed, 0.0) / _RING_PEAK


@dataclass(frozen=True)
class _Ring:
    """The board rocking on the soft tissue after a kick at ``t0`` about a strap axis (a row)."""

    t0: float
    row: int
    amplitude: float  # peak, degrees (signed)
    freq_hz: float  # the tissue's natural frequency

    @property
    def t1(self) -> float:
        """After this the rocking is below exp(-RING_DECAYS) of its peak: taken as over."""
        return self.t0 + RING_DECAYS / (DAMPING_RATIO * 2 * np.pi * self.freq_hz)

    def __call__(self, t: Array) -> Array:
        w_d = 2 * np.pi * self.freq_hz * math.sqrt(1.0 - DAMPING_RATIO**2)
        return self.amplitude * ring(w_d * (t - self.t0))


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


_Span = TypeVar("_Span", _Wave, _Ring)


class _Spans(Generic[_Span]):
    """Time-limited oscillations (each zero outside its t0-t1) in the order added, with their
    start and end times as arrays (built when first needed after a change) to find at once
    the few that are on at given times."""

    def __init__(self) -> None:
        self._spans: list[_Span] = []
        self._bounds: tuple[Array, Array] | None = None

    def __len__(self) -> int:
        return len(self._spans)

    def add(self, *spans: _Span) -> None:
        self._spans += spans
        self._bounds = None

    def forget_before(self, t: float) -> None:
        """Drop those over by ``t``."""
        self._spans = [s for s in self._spans if s.t1 > t]
        self._bounds = None

    def add_to(self, out: Array, t: Array, row: Callable[[_Span], int]) -> None:
        """Add each oscillation to its row of ``out`` (C, M) at the times ``t`` (M,) where it is on."""
        if not self._spans or not len(t):
            return
        if self._bounds is None:
            self._bounds = (np.array([s.t0 for s in self._spans]), np.array([s.t1 for s in self._spans]))
        starts, ends = self._bounds
        for i in np.flatnonzero((starts < t.max()) & (ends > t.min())).tolist():
            span = self._spans[i]
            inside = (t > span.t0) & (t < span.t1)
            out[row(span), inside] += span(t[inside])


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
        """The upper arm's (the bone's) unit direction, shoulder to elbow, in the body frame, (N, 3)."""
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
    player's relaxed angle, so segments chain in any order. Besides the moves,
    always on, each a deterministic function of time drawn from the seed:

    - Tremor (bone): TREMOR_COMPONENTS sines per swing axis (sx, sy) within
      TREMOR_SPREAD_HZ of ``tremor_hz``, together at most ``tremor_deg``, and
      half as much on the twist. Physiological tremor lies at 8-12 Hz,
      essential tremor at 4-12 Hz (Deuschl, Bain and Brin 1998, the Movement
      Disorder Society's consensus statement on tremor, sec. 2 and 5; Elble
      and Koller 1990, "Tremor", ch. 2): ``tremor_hz`` 3-12 Hz, ``tremor_deg``
      0-2 deg. A tremor of A deg at f Hz turns the arm at 2 pi f A deg/s.
    - Postural sway (bone): three sines per swing axis at 0.1-1 Hz (SWAY_HZ),
      their vector at most ``sway_deg`` (0-4 deg) from the aim: the slow
      drift of a held posture, the band of quiet-standing sway (Winter 1995,
      "Human balance and posture control during standing and walking", Gait
      and Posture 3, sec. "Quiet standing") that the shoulder carries.
    - Rocking on the soft tissue (board): the board and the tissue under the
      strap are a wobbling mass, a damped oscillator (Gruber et al. 1998;
      Wakeling and Nigg 2001, J. Biomech. 34: soft-tissue vibrations of
      10-50 Hz damped within a few cycles) of natural frequency ``wobble_hz``
      (5-25 Hz) and damping ratio DAMPING_RATIO = 0.3 (0.2-0.4 for muscle
      under skin-mounted sensors). Every keyframed move of the elbow or the
      arm kicks it twice, at its start (lagging) and at its stop
      (overshooting), :func:`ring`: a peak of ``wobble_deg`` (0-6 deg) times
      the move's peak acceleration over the snappiest launch's
      (SHARPEST_DEG_S2), at most 1, about the hinge (link y) for the elbow
      and raises, about link x for swings across. At rest the tremor drives
      it too: the bone's forward swing (sx) at the board, upper_arm_m times
      the angle, rolls the board about the arm's axis over its radius
      BOARD_RADIUS_M (a 32 cm upper-arm circumference) through
      :func:`tissue_response`, in total at most ``wobble_deg``. This roll is
      what a real upper-arm board shows at rest: its gyroscope strays mostly
      about the arm's axis while the forearm's hardly moves (the recording of
      :mod:`game.sim.realism`).
    - Twist (board): the board follows ``twist_follow`` (0.4-1.0) of the
      humerus' axial twist, its skin sliding over the bone: skin-mounted
      sensors on the upper arm under-read humeral axial rotation most of all
      rotations (Cutti et al. 2008, Med. Biol. Eng. Comput. 46, sec. 4;
      Schmidt et al. 1999, J. Biomech. 32).
    - Slip (board): the board's roll about the arm drifts at
      ``slip_deg_per_min`` (0-4 deg/min), its sign drawn from the seed, from
      the script's start.
    - Shoulder (the chain's root joint, :meth:`shoulder`): the humerus turns
      about a joint that moves. Raising the arm elevates and retracts the
      clavicle (about 11 deg and 20 deg at 120 deg of arm elevation: Ludewig
      et al., "Motion of the shoulder complex during multiplanar humeral
      elevation", J. Bone Joint Surg. Am. 91(2), 2009), which carries the
      joint up and back by a few centimetres over a 15 cm clavicle:
      SHOULDER_RISE_M with the arm straight up, in proportion to
      (1 - cos elevation) / 2 on the way. Walking bounces the trunk by 1-2.5
      cm up and down at the step frequency and 1-2 cm side to side at the
      stride's (the centre of mass's 2.5-5 cm vertical excursion: Gard, Miff
      and Kuo, Human Movement Science 22(6), 2004), the bigger the swing the
      bigger the bounce. Both add accelerations to the board's that no
      rotation about a fixed shoulder explains.
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
        self._twist_tremor = self._tremor.on_row(_CHANNELS.index("tw"))
        self._sway = self._draw_sway(rng)
        self._rest_roll = self._tissue_roll(self._tremor)
        self._slip_sign = float(rng.choice([-1.0, 1.0]))
        self._waves: _Spans[_Wave] = _Spans()
        self._trunk: _Spans[_Wave] = _Spans()  # the shoulder's bounce while walking (channels x, y, z; metres)
        self._rings: _Spans[_Ring] = _Spans()
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

    def _draw_tremor(self, rng: np.random.Generator) -> _Oscillations:
        """TREMOR_COMPONENTS sines per swing axis within TREMOR_SPREAD_HZ of tremor_hz, sharing
        tremor_deg equally, and half as much twist (class docstring)."""
        a, f = self.profile.tremor_deg, self.profile.tremor_hz
        rows = [(_CHANNELS.index("sx"), a), (_CHANNELS.index("sy"), a), (_CHANNELS.index("tw"), a / 2)]
        return _draw(rng, rows, TREMOR_COMPONENTS, (f - TREMOR_SPREAD_HZ, f + TREMOR_SPREAD_HZ))

    def _draw_sway(self, rng: np.random.Generator) -> _Oscillations:
        """Three slow sines per swing axis (SWAY_HZ), together at most sway_deg from the aim."""
        peak = self.profile.sway_deg / math.sqrt(2.0)
        return _draw(rng, [(_CHANNELS.index("sx"), peak), (_CHANNELS.index("sy"), peak)], 3, SWAY_HZ)

    def _tissue_roll(self, tremor: _Oscillations) -> _Oscillations:
        """The board's roll about the arm driven by the tremor's forward swing (class docstring):
        each sx component through :func:`tissue_response`, the lever upper_arm_m / BOARD_RADIUS_M;
        scaled down if together they would exceed wobble_deg."""
        p = self.profile
        sx = np.array(tremor.rows) == _CHANNELS.index("sx")
        gain, lag = tissue_response(tremor.freq_hz[sx] / p.wobble_hz)
        amplitude = tremor.amplitude[sx] * gain * p.upper_arm_m / BOARD_RADIUS_M
        total = float(np.sum(amplitude))
        if total > p.wobble_deg:
            amplitude = amplitude * (p.wobble_deg / total)
        return _Oscillations(tuple([_STRAP.index("rz")] * int(np.sum(sx))), amplitude,
                             tremor.freq_hz[sx], tremor.phase[sx] - lag + np.pi)

    def rng(self) -> np.random.Generator:
        """A fresh generator from the next child of the session's seed."""
        return np.random.default_rng(self._seeds.spawn(1)[0])

    def _dur(self, rng: np.random.Generator, lo: float, hi: float) -> float:
        return float(rng.uniform(lo, hi)) / self.profile.speed

    def _move(self, t0: float, duration: float, **targets: float) -> float:
        self._edited_from = min(self._edited_from, t0)
        for channel, value in targets.items():
            self._kick(channel, t0, duration, value - self._keyframes.last(channel))
            self._keyframes.move(channel, t0, t0 + duration, value)
        return t0 + duration

    def _kick(self, channel: str, t0: float, duration: float, change: float) -> None:
        """The move's start and stop rock the board (class docstring): wobble_deg times the
        move's peak acceleration over SHARPEST_DEG_S2 (at most 1), lagging then overshooting."""
        p = self.profile
        if channel not in _KICKED or change == 0 or p.wobble_deg == 0:
            return
        sharpness = MINIMUM_JERK_PEAK_ACC * abs(change) / duration**2 / SHARPEST_DEG_S2
        amplitude = math.copysign(p.wobble_deg * min(1.0, sharpness), change)
        row = _KICKED[channel]
        self._rings.add(_Ring(t0, row, -amplitude, p.wobble_hz),
                        _Ring(t0 + duration, row, amplitude, p.wobble_hz))

    def _wave(self, channel: str, t0: float, t1: float, amplitude: float, freq_hz: float,
              ramp: float, phase: float = 0.0, spans: _Spans[_Wave] | None = None) -> None:
        """A wave on a channel of the bone (or of ``spans``: the trunk's)."""
        self._edited_from = min(self._edited_from, t0)
        (self._waves if spans is None else spans).add(
            _Wave(channel, t0, t1, amplitude, freq_hz * self.profile.speed, phase, ramp))

    def _reach_time(self, rng: np.random.Generator, angle_deg: float) -> float:
        """A point-to-point arm move lasts longer the farther it goes (about 0.7 s for 90 deg)."""
        return (0.40 + 0.0035 * angle_deg) * float(rng.uniform(0.85, 1.15)) / self.profile.speed

    def _finish(self, kind: str, t0: float, t1: float) -> None:
        self.segments.append(Segment(kind, t0, t1))
        self.now = t1

    # -------------------------------------------------------- segments

    def calibration(self, hold_on_s: float = 0.0) -> tuple[Interval, Interval]:
        """The wearing calibration: hang still, raise the straight arm forward to level, hold, lower.

        The holds are as long as the game asks for (the player's speed does
        not shorten them); only the movements between them scale with speed.
        ``hold_on_s``: how much longer the arm hangs still when the game asks
        for a longer hold (game.body.wearing.HOLD_S["longer"]).
        """
        rng, t0 = self.rng(), self.now
        down = (t0, t0 + float(rng.uniform(2.4, 2.7)) + hold_on_s)
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
            bent, straight = float(rng.uniform(*LAUNCH_BENT_DEG)), float(rng.uniform(0, 6))
            t = self._move(t, self._dur(rng, 0.25, 0.5), flex=bent)  # loading
            t += self._dur(rng, 0.3, 1.0)  # spinning
            t_go, duration = t, self._dur(rng, *LAUNCH_S)
            t = self._move(t, duration, flex=straight)  # the launch
            fraction = (bent - self.threshold_deg) / (bent - straight)
            t_cross = t_go + duration * _minimum_jerk_inverse(fraction)
            launches.append(TrueLaunch(t_go, t_cross, as_vec(self._bone_pointing(t_cross)), t_go - t_flex))
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
            t += self._dur(rng, 0.3, 1.5)  # still: tremor and sway only
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
        stride = (amplitude - 15.0) / 10.0  # the bigger the swing, the bigger the steps
        for channel, freq_k, (low, high) in (("z", 2.0 * freq, WALK_BOUNCE_M), ("x", freq, WALK_SIDE_M)):
            self._wave(channel, t, end, low + stride * (high - low), freq_k, ramp, spans=self._trunk)
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
        """Every channel of the bone at times ``t`` (M,), as (channels, M) in degrees."""
        out = self._keyframes(t)
        self._tremor.add_to(out, t)
        self._sway.add_to(out, t)
        self._waves.add_to(out, t, lambda w: _CHANNELS.index(w.channel))
        return out

    def _twist_degrees(self, t: Array) -> Array:
        """The bone's twist channel alone at times ``t`` (M,), in degrees: :meth:`_degrees`' row
        of it, computed alike (no wave twists the arm)."""
        out = self._keyframes(t, _CHANNELS.index("tw"))[None]
        self._twist_tremor.add_to(out, t)
        return out[0]

    def _strap_degrees(self, twist: Array, t: Array) -> Array:
        """The board turned relative to the bone (link x, y, z; degrees), (3, M), given the
        bone's twist (degrees) at ``t``: rocking after kicks and at rest, the twist the board
        does not follow, and the slip (class docstring)."""
        out = np.zeros((len(_STRAP), len(t)))
        self._rest_roll.add_to(out, t)
        self._rings.add_to(out, t, lambda r: r.row)
        slip = self._slip_sign * self.profile.slip_deg_per_min * t / 60.0
        out[2] += slip - (1.0 - self.profile.twist_follow) * twist
        return out

    def channels(self, t: ArrayLike) -> dict[str, Array]:
        """Every channel (degrees) at times ``t``: the bone's keyframes plus oscillations, and
        the strap's ``rx``, ``ry``, ``rz`` (the board relative to the bone, link axes)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        c = self._degrees(t)
        strap = self._strap_degrees(c[_CHANNELS.index("tw")], t)
        return dict(zip(_CHANNELS + _STRAP, np.concatenate([c, strap])))

    @staticmethod
    def _bone(c: Array) -> Array:
        """q_WL of the bone (the ideally worn board) from its channels in radians (module docstring)."""
        az, el, tw, sx, sy = c[:5]
        sway = Q.from_rotvec(np.stack([sx, sy, np.zeros_like(sx)], axis=-1))
        return Q.multiply(Q.multiply(_aim(-az, el, tw), sway), Q.conjugate(IDEAL_MOUNT))

    def root(self, t: ArrayLike) -> Array:
        """q_WL(t) of the bone, the ideally worn board: where the arm really is."""
        return self._bone(np.radians(self._degrees(np.atleast_1d(np.asarray(t, dtype=float)))))

    def strap(self, t: ArrayLike) -> Array:
        """q_m(t) = exp(r): the board turned on the bone by the strap and the soft tissue, (N, 4)
        (module docstring): the motion's mount, about STRAP_PIVOT_M."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return Q.from_rotvec(np.radians(self._strap_degrees(self._twist_degrees(t), t)).T)

    def _bone_pointing(self, t: float) -> Array:
        """The bone's body-frame unit direction at ``t``, sway and tremor included."""
        return Q.rotate(self.root([t]), (0.0, 0.0, -1.0))[0]

    def shoulder(self, t: Array, q_root: Array) -> Array:
        """s(t): the shoulder joint's position (body frame, m), (N, 3), given the bone's q_WL
        ``q_root`` at ``t``: risen with the arm, bounced by walking (class docstring)."""
        up = Q.rotate(q_root, (0.0, 0.0, -1.0))[:, 2]  # the arm's pointing: -1 hanging, 1 straight up
        out = np.outer(SHOULDER_RISE_M, (1.0 + up) / 2.0)
        self._trunk.add_to(out, t, lambda w: "xyz".index(w.channel))
        return out.T

    @staticmethod
    def _elbow(c: Array) -> Array:
        """The elbow angle (N, 1) from the channels in radians."""
        return c[_CHANNELS.index("flex")][:, None]

    def joints(self, t: ArrayLike) -> Array:
        """The elbow angle in radians, (N, 1)."""
        return self._elbow(np.radians(self._degrees(np.atleast_1d(np.asarray(t, dtype=float)))))

    def pose(self, t: ArrayLike) -> tuple[Array, Array]:
        """:meth:`root` and :meth:`joints` together, from one evaluation of the channels."""
        rad = np.radians(self._degrees(np.atleast_1d(np.asarray(t, dtype=float))))
        return self._bone(rad), self._elbow(rad)

    def forget_before(self, t: float) -> None:
        """Let go of the motion before ``t`` (keyframes, ended oscillations): a script that is
        extended for an hour stays small and fast. The motion from ``t`` on is unchanged."""
        self._keyframes.forget_before(t)
        self._waves.forget_before(t)
        self._trunk.forget_before(t)
        self._rings.forget_before(t)

    @property
    def motion(self) -> Motion:
        """The arm as a live :class:`tracker.sim.Motion` (segments added later change it): the
        bone, and the board turned on it by :meth:`strap`. What the simulator moves."""
        return Motion(self.root, self.joints, self.pose, self.strap, STRAP_PIVOT_M, self.shoulder)

    def build(self) -> Session:
        """The session so far; later segments added to this script do not change it."""
        frozen = copy.deepcopy(self)
        return Session(frozen.motion, self.now, list(self.launches), list(self.idle_intervals),
                       self.calibration_intervals, list(self.segments))


def session(profile: PlayerProfile = PlayerProfile(), seed: int = 0, gestures: int = 5,
            idle_s: float | tuple[float, float] = (4.0, 10.0), calibration: bool = True,
            hold_on_s: float = 0.0) -> Session:
    """Calibration, then idle and gesture in turn (``gestures`` of them), ending idle.

    ``idle_s``: each idle stretch's length, or a (low, high) range to draw it
    from; 0 leaves the idle stretches out. ``hold_on_s``: the calibration's
    arm-down hold that much longer (:meth:`Script.calibration`).
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
        script.calibration(hold_on_s)
    for k in range(gestures + 1):
        if lengths[k] > 0:
            script.idle(float(lengths[k]))
        if k < gestures:
            script.gesture()
    return script.build()
