"""The sensor simulator: a kinematic chain carrying virtual MPU-9250s and the flex circuit.

The body is seed 003's chain of rigid links on hinges (sec. 2.1) made 3-D:
the root link turns freely (3 DoF) about its joint, which stays at the world
origin; every further link hangs on a hinge at the far end of the link before
it. A link's frame sits at its own joint, coincides with its parent's frame
when the hinge angle is zero (seed 003, sec. 2.1), and the link runs
``length_m`` along ``direction`` in it. So, with ``q_k`` the orientation of
link k in the world and ``o_k`` its joint's position,

    q_0 = root(t),    q_k = q_{k-1} * exp(hinge_k theta_k(t) / 2),
    o_0 = 0,          o_k = o_{k-1} + R(q_{k-1}) l_{k-1} d_{k-1},

the 3-D form of seed 003's r_i = R_i {0, l_i, 0} and s_k = sum r_i + h_k.
A sensor sits at ``position_m`` in its link's frame, turned by ``mount``
(q_LS: a wearing offset, seed 000 sec. 6). What it feels:

    gyr = 2 Im(q_WS^-1 dq_WS/dt)     body angular rate (q' = q w / 2, Sola 2017)
    acc = R_WS^T (p'' - g)            specific force, g = (0, 0, -9.81) (seed 003, sec. 2.1)
    mag = R_WS^T m                    the earth's field m, ENU, in microtesla

Trajectories are plain functions of time, so their derivatives are taken
numerically by fourth-order central differences with a step of 0.5 ms:
truncation O(h^4) (below 1e-8 m/s^2 and rad/s for arm motions up to a few
hertz), rounding near 1e-8 m/s^2 and 1e-11 rad/s (the acceleration's stencil
multiplies a position's last digit by 2e7; about 1e-6 after 1000 s, where t
itself loses digits). The stencil is summed term by term, so every sample is
rounded alike wherever it sits in a batch. Trajectories should be smooth: at a jump of the third derivative the
samples within 1 ms err by O(h x jump).

Sensor errors (seed 003, sec. 3: white noise, zero offset, both; MPU-9250
data-sheet figures) are white noise, a constant offset, a random-walk drift,
a scale error, quantisation and saturation (:class:`ErrorModel`). Random
numbers come from ``numpy.random.SeedSequence(seed, spawn_key=...)`` keyed by
sensor kind and block of sample indices, so an error is a function of the
sample index alone: a batch and a stream (:meth:`Simulator.stream`, which
:class:`SimulatedSource` and so the virtual board read) give the same values
for the same seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import quat
from .flex import FlexCircuit, FlexSensor
from .motion import EARTH_FIELD_UT, GRAVITY, SensorReading
from .protocol import MAG_UT_PER_COUNT, STANDARD_GRAVITY

Array = NDArray[np.float64]
Vec3 = tuple[float, float, float]

_H = 5e-4  # s, the differentiation step
_D1 = np.array([1.0, -8.0, 0.0, 8.0, -1.0]) / (12.0 * _H)  # f'  at the centre of 5 points
_D2 = np.array([-1.0, 16.0, -30.0, 16.0, -1.0]) / (12.0 * _H**2)  # f''
_STENCIL = np.arange(-2, 3) * _H
STENCIL_REACH_S = 2 * _H  # a simulated sample depends on the motion this close to its time, no further
_CHUNK = 4096  # samples per block of random numbers
_KINDS = ("gyr", "acc", "mag", "flex")

# MPU-9250 product specification (PS-MPU-9250A-01 rev. 1.1), sec. 3.1-3.2; AK8963 in 16-bit mode.
GYR_NOISE_DENSITY = math.radians(0.01)  # rad/s/sqrt(Hz)
GYR_OFFSET_MAX = math.radians(5.0)  # rad/s, initial zero-rate offset tolerance
ACC_NOISE_DENSITY = 300e-6 * STANDARD_GRAVITY  # m/s^2/sqrt(Hz)
ACC_OFFSET_MAX = 60e-3 * STANDARD_GRAVITY  # m/s^2, zero-g initial tolerance (x, y)
SCALE_TOLERANCE = 0.03  # initial sensitivity tolerance, gyroscope and accelerometer
MAG_FULL_SCALE_UT = 4912.0


@dataclass(frozen=True)
class LinkSpec:
    """A rigid link: its length along ``direction`` (its own frame), and its hinge."""

    name: str
    length_m: float
    direction: Vec3 = (0.0, 0.0, -1.0)  # unit, from the link's joint to its far end
    hinge: Vec3 = (0.0, 1.0, 0.0)  # hinge axis in the parent's frame; unused for the root


@dataclass(frozen=True)
class SensorSpec:
    """An IMU on a link: where (link frame, from the link's joint) and how it is turned."""

    name: str
    link: int
    position_m: Vec3
    mount: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)  # q_LS


@dataclass(frozen=True)
class Chain:
    """Links (the first is the root), the sensors on them, the joint the flex sensor spans."""

    links: tuple[LinkSpec, ...]
    sensors: tuple[SensorSpec, ...]
    flex_link: int | None = None  # the link whose hinge the flex sensor spans (None: none)

    @cached_property
    def hinges(self) -> Array:
        """The hinge axes of the links after the root, (L - 1, 3)."""
        return np.reshape([link.hinge for link in self.links[1:]], (-1, 3))

    @cached_property
    def arms(self) -> tuple[list[int], Array]:
        """Where each joint after the root, then each sensor, sits on the link it hangs from:
        that link's index and the vector from its joint in its frame, (L - 1 + S, 3)."""
        reaches = [link.length_m * np.asarray(link.direction) for link in self.links[:-1]]
        positions = [np.asarray(s.position_m, dtype=float) for s in self.sensors]
        index = list(range(len(self.links) - 1)) + [s.link for s in self.sensors]
        return index, np.reshape(reaches + positions, (-1, 3))


@dataclass(frozen=True)
class Motion:
    """Trajectories, vectorised over times ``t`` of shape (N,)."""

    root: Callable[[Array], Array]  # t -> q_W0 (N, 4), the root link's orientation
    joints: Callable[[Array], Array]  # t -> hinge angles (N, links - 1), radians
    pose: Callable[[Array], tuple[Array, Array]] | None = None  # t -> both, if cheaper at once

    def at(self, t: Array) -> tuple[Array, Array]:
        """The root's orientations and the hinge angles at ``t``."""
        return self.pose(t) if self.pose is not None else (self.root(t), self.joints(t))


@dataclass(frozen=True)
class ErrorModel:
    """What one sensor adds to the truth, axis by axis (seed 003, sec. 3).

    measured = saturate(quantise((1 + scale) truth + offset + drift + noise)),
    with the scale and offset drawn once per axis, uniformly within their
    bounds (data sheets give tolerances, not distributions), the drift a
    random walk and the noise white. Units are the sensor's (rad/s, m/s^2,
    microtesla, volts for the flex circuit).
    """

    noise_density: float = 0.0  # white noise per sqrt(Hz): std = density * sqrt(rate)
    offset_max: float = 0.0  # constant offset, drawn in [-offset_max, offset_max]
    drift: float = 0.0  # random walk per sqrt(s): after T seconds std drift * sqrt(T)
    scale_max: float = 0.0  # scale-factor error (fraction), drawn in [-scale_max, scale_max]
    resolution: float = 0.0  # one least significant bit; 0 = continuous
    full_scale: float = math.inf  # readings saturate at +-full_scale


@dataclass(frozen=True)
class SensorErrors:
    """Error models of the gyroscope, accelerometer, magnetometer and flex circuit (volts)."""

    gyr: ErrorModel = ErrorModel()
    acc: ErrorModel = ErrorModel()
    mag: ErrorModel = ErrorModel()
    flex: ErrorModel = ErrorModel()  # before the ADC, which quantises and saturates itself


def mpu9250(noise: bool = True, offset: bool = True, scale: bool = False,
            acc_fs_g: int = 16, gyr_fs_dps: int = 2000) -> SensorErrors:
    """MPU-9250 data-sheet errors; seed 003 (sec. 3) ran noise only, offset only, and both.

    Seed 003 assumed calibrated scale factors, hence ``scale`` off by default.
    Quantisation and saturation are those of 16-bit counts at the full scales
    (the virtual board's defaults). The AK8963's data gives no noise figure, so
    the magnetometer is only quantised (0.15 uT) and saturated.
    """
    gyr_fs, acc_fs = math.radians(gyr_fs_dps), acc_fs_g * STANDARD_GRAVITY
    return SensorErrors(
        gyr=ErrorModel(noise_density=GYR_NOISE_DENSITY * noise, offset_max=GYR_OFFSET_MAX * offset,
                       scale_max=SCALE_TOLERANCE * scale, resolution=gyr_fs / 32768,
                       full_scale=gyr_fs),
        acc=ErrorModel(noise_density=ACC_NOISE_DENSITY * noise, offset_max=ACC_OFFSET_MAX * offset,
                       scale_max=SCALE_TOLERANCE * scale, resolution=acc_fs / 32768,
                       full_scale=acc_fs),
        mag=ErrorModel(resolution=MAG_UT_PER_COUNT, full_scale=MAG_FULL_SCALE_UT),
    )


@dataclass(frozen=True)
class Truth:
    """The true state at times ``t``: N samples, L links, S sensors."""

    t: Array  # (N,)
    q_links: Array  # (N, L, 4) q_W,link
    joints: Array  # (N, L - 1) hinge angles, radians
    q_sensors: Array  # (N, S, 4) q_WS
    gyr: Array  # (N, S, 3) body angular rate, rad/s
    acc: Array  # (N, S, 3) specific force, m/s^2
    mag: Array  # (N, S, 3) microtesla
    flex_deg: Array  # (N,) the flexed joint in degrees (0 without one)


@dataclass(frozen=True)
class SimData:
    """Simulated measurements (as :class:`Truth`'s shapes), the truth, the drawn constants."""

    t: Array
    gyr: Array
    acc: Array
    mag: Array
    flex_adc: NDArray[np.int64]  # (N,)
    truth: Truth
    offset: dict[str, Array]  # the constant offsets drawn, by kind ("gyr", "acc", "mag", "flex")
    scale: dict[str, Array]  # the scale factors 1 + error drawn, by kind


def _stencil_sum(weights: Array, x: Array) -> Array:
    """sum_i weights_i x[i], term by term: every sample is rounded alike (a BLAS product's
    rounding depends on where in the array a sample is, so a block and a batch would differ)."""
    total = weights[0] * x[0]
    for w, xi in zip(weights[1:], x[1:]):
        total = total + w * xi
    return total


def _rng(seed: int, *key: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=key))


class _ErrorProcess:
    """One kind of sensor's errors as a function of the sample index (same index, same error)."""

    def __init__(self, model: ErrorModel, shape: tuple[int, ...], rate_hz: float,
                 seed: int, kind: int) -> None:
        self.model, self.shape, self._key = model, shape, (seed, kind)
        rng = _rng(seed, kind, 0)
        self.offset = rng.uniform(-model.offset_max, model.offset_max, shape)
        self.scale = 1.0 + rng.uniform(-model.scale_max, model.scale_max, shape)
        self._white_std = model.noise_density * math.sqrt(rate_hz)
        self._step_std = model.drift / math.sqrt(rate_hz)
        self._walk_starts = [np.zeros(shape)]  # the drift before each block
        self._block: tuple[int, Array] | None = None  # the latest block, for streaming

    def _normal(self, stream: int, block: int) -> Array:
        return _rng(*self._key, stream, block).standard_normal((_CHUNK, *self.shape))

    def _random_block(self, b: int) -> Array:
        if self._block is None or self._block[0] != b:
            while len(self._walk_starts) <= b:
                j = len(self._walk_starts) - 1
                self._walk_starts.append(self._walk_starts[j]
                                         + self._step_std * self._normal(2, j).sum(axis=0))
            x = self._white_std * self._normal(1, b) if self._white_std else np.zeros(())
            if self._step_std:
                walk = self._step_std * np.cumsum(self._normal(2, b), axis=0)
                x = x + self._walk_starts[b] + walk
            self._block = (b, np.broadcast_to(x, (_CHUNK, *self.shape)))
        return self._block[1]

    def measure(self, truth: Array, k: NDArray[np.int64]) -> Array:
        """The measurement of ``truth`` (k, *shape) taken as samples number ``k``."""
        m = self.model
        x = self.scale * truth + self.offset
        if self._white_std or self._step_std:
            noise = np.empty_like(x)
            for b in np.unique(k // _CHUNK):
                at = k // _CHUNK == b
                noise[at] = self._random_block(int(b))[k[at] % _CHUNK]
            x = x + noise
        if m.resolution > 0:
            x = np.round(x / m.resolution) * m.resolution
        return np.clip(x, -m.full_scale, m.full_scale)


@dataclass(frozen=True)
class Simulator:
    """A chain in motion, its sensors' errors, the flex circuit and the earth's field."""

    chain: Chain
    motion: Motion
    errors: SensorErrors = SensorErrors()
    flex_sensor: FlexSensor = FlexSensor()
    flex_circuit: FlexCircuit = FlexCircuit()
    earth_field_ut: Vec3 = EARTH_FIELD_UT
    seed: int = 0

    def _forward(self, t: Array) -> tuple[Array, Array, Array, Array]:
        """Link orientations, joint angles, sensor orientations and positions at ``t`` (M,)."""
        links, sensors = self.chain.links, self.chain.sensors
        root, joints = self.motion.at(t)
        hinges = len(links) - 1
        angles = np.asarray(joints, dtype=float).reshape(len(t), -1 if len(t) else hinges)
        if angles.shape[1] != hinges:
            raise ValueError(f"the motion gives {angles.shape[1]} joint angles; "
                             f"the chain has {hinges} hinges")
        turns = quat.from_axis_angle(self.chain.hinges, angles)
        q_links = np.empty((len(t), len(links), 4))
        q_links[:, 0] = quat.normalize(root)
        for k in range(1, len(links)):
            q_links[:, k] = quat.multiply(q_links[:, k - 1], turns[:, k - 1])
        index, vectors = self.chain.arms
        arms = quat.rotate(q_links[:, index], vectors)
        origins = np.zeros((len(t), len(links), 3))
        np.cumsum(arms[:, :len(links) - 1], axis=1, out=origins[:, 1:])
        idx = index[len(links) - 1:]
        q_sensors = quat.multiply(q_links[:, idx], [s.mount for s in sensors])
        return q_links, angles, q_sensors, origins[:, idx] + arms[:, len(links) - 1:]

    def truth(self, t: ArrayLike) -> Truth:
        """The true orientations, rates, specific forces and fields at times ``t`` (s)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        n, m = len(t), len(t) * len(self.chain.sensors)  # samples; samples times sensors
        q_links, angles, q_s, p_s = self._forward((_STENCIL[:, None] + t).ravel())
        q_s = q_s.reshape(5, m, 4)  # stencil point; sample and sensor; component
        q = q_s[2]
        q_s = q_s * np.sign(np.sum(q_s * q, axis=-1, keepdims=True))  # one sign along the stencil
        inv = quat.conjugate(q)
        gyr = 2.0 * quat.multiply(inv, _stencil_sum(_D1, q_s))[:, 1:]
        world = _stencil_sum(_D2, p_s.reshape(5, m, 3)) + np.array([0.0, 0.0, GRAVITY])
        acc, mag = quat.rotate(inv, np.array([world, np.broadcast_to(self.earth_field_ut, world.shape)]))
        centre, shape = slice(2 * n, 3 * n), (n, len(self.chain.sensors))
        fl = self.chain.flex_link
        flex = np.degrees(angles[centre, fl - 1]) if fl is not None else np.zeros(n)
        return Truth(t, q_links[centre], angles[centre], q.reshape(*shape, 4), gyr.reshape(*shape, 3),
                     acc.reshape(*shape, 3), mag.reshape(*shape, 3), flex)

    def stream(self, rate_hz: float) -> SampleStream:
        """The samples at t = k / ``rate_hz``, measured a block at a time on request."""
        return SampleStream(self, rate_hz)

    def simulate(self, duration_s: float, rate_hz: float) -> SimData:
        """``round(duration * rate)`` samples at t = k / rate, measured and true."""
        return self.stream(rate_hz).block(0, round(duration_s * rate_hz))


class SampleStream:
    """A simulator sampled at ``rate_hz``: sample k is at t = k / rate.

    Its errors are functions of the sample index (:class:`_ErrorProcess`) and
    every sample is computed alike, so ``block(k0, k1)`` is rows k0 to k1 - 1
    of ``sim.simulate(..., rate_hz)``, whatever the blocks asked for before.
    Nothing is computed ahead: the motion may be extended between calls for
    times after those of the blocks already taken.
    """

    def __init__(self, sim: Simulator, rate_hz: float) -> None:
        self.sim, self.rate_hz = sim, rate_hz
        n = len(sim.chain.sensors)
        shapes = {"gyr": (n, 3), "acc": (n, 3), "mag": (n, 3), "flex": ()}
        self._processes = {kind: _ErrorProcess(getattr(sim.errors, kind), shapes[kind], rate_hz,
                                               sim.seed, i) for i, kind in enumerate(_KINDS)}

    def block(self, k0: int, k1: int) -> SimData:
        """Samples number ``k0`` to ``k1 - 1``, measured and true."""
        if not 0 <= k0 <= k1:
            raise ValueError(f"a block of samples needs 0 <= k0 <= k1, not {k0} and {k1}")
        k = np.arange(k0, k1)
        truth = self.sim.truth(k / self.rate_hz)
        p, circuit = self._processes, self.sim.flex_circuit
        volts = circuit.volts(self.sim.flex_sensor.ohms(truth.flex_deg))
        return SimData(truth.t, p["gyr"].measure(truth.gyr, k), p["acc"].measure(truth.acc, k),
                       p["mag"].measure(truth.mag, k), circuit.adc(p["flex"].measure(volts, k)),
                       truth, {kind: q.offset for kind, q in p.items()},
                       {kind: q.scale for kind, q in p.items()})


@dataclass
class SimulatedSource:
    """The simulator as a :class:`tracker.motion.MotionSource` for the virtual board.

    It samples at ``rate_hz`` (set it to the board's rate): ``reading(t)`` is
    sample k = round(t * rate_hz), the same as row k of
    ``sim.simulate(..., rate_hz)``, computed a block of samples at a time.
    Quantisation is left to the board, which does it like the firmware
    (:func:`tracker.board.quantise`); the error models' own, if any, agree.
    """

    sim: Simulator
    rate_hz: float = 200.0
    sensor: int = 0  # which of the chain's sensors the board carries
    block: int = 256  # samples computed together
    _stream: SampleStream = field(init=False, repr=False)
    _cache: dict[int, list[SensorReading]] = field(init=False, repr=False, default_factory=dict)

    def __post_init__(self) -> None:
        self._stream = self.sim.stream(self.rate_hz)

    def reading(self, t: float) -> SensorReading:
        b, i = divmod(round(t * self.rate_hz), self.block)
        if b not in self._cache:
            self._cache = {b: self._readings(b)}
        return self._cache[b][i]

    def _readings(self, b: int) -> list[SensorReading]:
        data, s = self._stream.block(b * self.block, (b + 1) * self.block), self.sensor
        return [SensorReading(acc=tuple(data.acc[n, s].tolist()), gyr=tuple(data.gyr[n, s].tolist()),
                              mag=tuple(data.mag[n, s].tolist()), flex_deg=float(data.truth.flex_deg[n]),
                              flex_adc=int(data.flex_adc[n]), q=tuple(data.truth.q_sensors[n, s].tolist()))
                for n in range(len(data.t))]


# ------------------------------------------------------------------ presets


def arm_chain(upper_arm_m: float = 0.30, forearm_m: float = 0.27, sensor_m: float = 0.30) -> Chain:
    """Seed 000's arm: the IMU on the upper arm near the elbow, the elbow a hinge about its y.

    The root is the upper arm turning about the shoulder; at identity it hangs
    along -z with the sensor
    ``sensor_m`` below the shoulder. The forearm hinges about the sensor's y
    axis (seed 000, sec. 3; ARCHITECTURE.md); a positive flex swings it toward
    the sensor's -x. The flex sensor spans that hinge. Add the hand (0.08 m)
    to ``forearm_m`` for the fingertips.
    """
    return Chain(
        links=(LinkSpec("upper_arm", upper_arm_m), LinkSpec("forearm", forearm_m)),
        sensors=(SensorSpec("imu", 0, (0.0, 0.0, -sensor_m)),),
        flex_link=1,
    )


def arm_swing(raise_rad: float = 0.6, raise_period_s: float = 4.0, yaw_rad: float = 0.4,
              yaw_period_s: float = 7.0, twist_rad: float = 0.3, twist_period_s: float = 5.0,
              flex_deg: float = 110.0, flex_period_s: float = 3.0) -> Motion:
    """A smooth arm motion exercising all three shoulder rotations and the elbow.

    q_root = Rz(yaw) Ry(raise) Rz(twist): the upper arm raised by up to
    2 * ``raise_rad`` in its flexion plane (toward -x, as the elbow flexes),
    swung about the vertical and twisted about its own axis; the elbow flexes
    from 0 to ``flex_deg`` and back. All are cosines, smooth at every order.
    """
    def wave(t: Array, amplitude: float, period: float) -> Array:
        return amplitude * np.sin(2 * np.pi * t / period)

    def lift(t: Array, amplitude: float, period: float) -> Array:
        return amplitude * (1 - np.cos(2 * np.pi * t / period))

    def root(t: Array) -> Array:
        yaw = quat.from_axis_angle((0, 0, 1), wave(t, yaw_rad, yaw_period_s))
        lifted = quat.from_axis_angle((0, 1, 0), lift(t, raise_rad, raise_period_s))
        twist = quat.from_axis_angle((0, 0, 1), wave(t, twist_rad, twist_period_s))
        return quat.multiply(quat.multiply(yaw, lifted), twist)

    def joints(t: Array) -> Array:
        return np.radians(lift(t, flex_deg / 2, flex_period_s))[:, None]

    return Motion(root, joints)


def arm_source(rate_hz: float = 200.0, seed: int = 0) -> SimulatedSource:
    """The virtual board's default wearer: :func:`arm_swing` on :func:`arm_chain` with MPU-9250 errors."""
    return SimulatedSource(Simulator(arm_chain(), arm_swing(), mpu9250(), seed=seed), rate_hz)


def finger_chain(lengths_m: Vec3 = (0.045, 0.025, 0.020), sensor_at: float = 0.5) -> Chain:
    """Seed 003's finger (sec. 2.1): three phalanges on hinges about x, each along its y.

    The root is the metacarpus, of zero length, so the first joint (MCP) is
    at the origin; its orientation is known (seed 003 tracks it optically).
    Sensors sit on phalanges 1 and 2 (counted from 0 at the metacarpus, as the
    paper's phalanges 1 and 2) at ``sensor_at`` of their length (alpha_k).
    The lengths are a typical adult index finger (assumed: the paper gives none).
    """
    links = (LinkSpec("metacarpus", 0.0, (0.0, 1.0, 0.0)),) + tuple(
        LinkSpec(f"phalanx{i}", length, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
        for i, length in enumerate(lengths_m))
    sensors = tuple(SensorSpec(f"imu{i}", i + 1, (0.0, sensor_at * lengths_m[i], 0.0))
                    for i in (1, 2))
    return Chain(links, sensors)


def grasp(move_s: float, delay_s: float = 0.2) -> Motion:
    """Seed 003's test motion (sec. 3): still for ``delay_s``, the straight finger extends
    to -28 degrees at the first joint over move/3, then flexes it to 90 degrees and the
    other two joints to 85 degrees together over 2 move/3; the metacarpus stays still.

    Each segment follows the minimum-jerk profile 10 s^3 - 15 s^4 + 6 s^5 (Flash and
    Hogan 1985; the paper does not give its profile): position, speed and acceleration
    are continuous, the jerk jumps at the ends of a segment.
    """
    t1, t2 = delay_s + move_s / 3, delay_s + move_s

    def ease(t: Array, start: float, end: float) -> Array:
        s = np.clip((t - start) / (end - start), 0.0, 1.0)
        return s**3 * (10 - 15 * s + 6 * s**2)

    def joints(t: Array) -> Array:
        extend, flex = ease(t, delay_s, t1), ease(t, t1, t2)
        mcp = np.radians(-28.0 * extend + (90.0 + 28.0) * flex)
        pip = np.radians(85.0) * flex
        return np.stack([mcp, pip, pip], axis=-1)

    return Motion(lambda t: quat.identity(np.shape(t)), joints)
