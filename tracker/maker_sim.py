"""The simulated maker: a person at a table who calibrates a simulated board by following the prompts.

:class:`SimulatedMaker` is a :class:`tracker.motion.MotionSource`: what the
board's sensors read at time t, its errors included (:mod:`tracker.sim`'s
error models; :func:`tracker.sim.realistic_errors` by default). Served by
:class:`tracker.board.VirtualBoard` (``VirtualBoard(motion=maker)``) it is a
board on a table; :meth:`SimulatedMaker.follow` reads a procedure's prompt
and acts on it: for :class:`tracker.accel_procedure.AccelStatus` it turns the
board to the asked face and lets it lie still, for
:class:`tracker.mag_procedure.MagStatus` it tumbles the board slowly through
every orientation. :func:`run_maker` does the same offline, as fast as the
simulator goes, for tests and the gesture evaluation.

The board on a table. No tremor, sway or strap reaches it (the maker's hand
lets go of a board lying on a face). Each move to a face starts after a
reaction time of 0.4-0.8 s (a choice reaction to a prompt: A. T. Welford,
"Reaction times", Academic Press 1980, ch. 3: 0.3-0.6 s for a few choices,
and reading the line), takes 1.5 s with the minimum-jerk profile of a
reaching hand (T. Flash and N. Hogan, "The coordination of arm movements",
J. Neurosci. 5 (1985) 1688-1703), and ends on the face with a random
heading and a lean of up to 2 deg (the table, the board's components). A
leaning pose props the board on an edge against a book, 45 deg between two
faces (:data:`EDGE_AXES`, about each axis in turn), within
:data:`PROP_DEG` (a book's edge and a board's width are not exact). The
board turns about its own centre: it does not wander through the room's
field disturbance (:class:`tracker.sim.MagneticErrors`), which near a fixed
point is just part of the local field.

The tumble for the magnetometer is the one a maker watching the sphere of
directions fill in ends up making: the board spins steadily (a turn in
about 4 s, 90 deg/s) about an axis that tilts slowly from the field's
direction to its opposite and back (48 s), so the field's direction in the
board's frame spirals over the whole sphere (a turn of the spiral every
4 s, 30 deg apart: about one bin of :func:`tracker.magfit.coverage`); the
spin starts smoothly.

Refusals to exercise, as a real maker causes them: ``nudges`` (the hand
bumps the board, rocking it 8 deg for 0.4 s), ``repeat_face`` (after the
first capture the maker lifts the board and lays it on the same face
again, before obeying), ``magnet`` (a magnet brought near the board for a
while: :class:`Magnet`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from . import quat as Q
from .accel_procedure import TILTED, AccelProcedure, AccelStatus
from .board import BoardSettings, acc_lsb, counts, gyr_lsb
from .calibration import MG, BoardCalibration, SixPoseResult
from .mag_procedure import MagProcedure, MagResult, MagStatus
from .magfit import MagFitError
from .motion import SensorReading
from .protocol import MAG_UT_PER_COUNT, RawSample, temp_counts
from .sim import (Chain, LinkSpec, Motion, SampleStream, SensorErrors, SensorSpec, Simulator,
                  die_rise_c, die_temperature, realistic_errors)
from .sim_board import ACC_FS_G, GYR_FS_DPS
from .thermal import ThermalParams, ThermalProcedure, ThermalResult, ThermalStatus, thermal_calibration

Array = NDArray[np.float64]
Vec3 = tuple[float, float, float]

RATE_HZ = BoardSettings.rate_hz  # the firmware's default sample rate
TURN_S = 1.5  # a move from face to face
REACTION_S = (0.4, 0.8)  # the delay before a prompt is acted on, drawn per prompt
LEAN_DEG = 2.0  # a board lying on a face leans up to this far
TUMBLE_SPIN_S = 4.0  # a turn of the tumble's spin (90 deg/s), drawn within +-20 %
TUMBLE_SWING_S = 48.0  # the spin axis tilts from the field's direction to its opposite and back
EASE_S = 1.0  # the tumble's smooth start
NUDGE_DEG, NUDGE_S = 8.0, 0.4
THERMAL_RATE_HZ = 10  # the warm-up's samples: any rate serves its per-second means; few are quick to simulate
THERMAL_POWER_ON = 2  # the warm-up's power-on of the board (0: the other procedures', 1: play's)
BLOCK_S = 3.0  # simulated at once: a block's own cost is about that of 100 samples; a prompt that changes
# the motion within a block computed has it computed again (SimulatedMaker._replan), the same up to the change
BLOCK_MIN = 600  # samples a block holds at least (at a low rate, 3 s would be mostly the block's own cost)
FACE_AXES = {"+x": (1.0, 0.0, 0.0), "-x": (-1.0, 0.0, 0.0), "+y": (0.0, 1.0, 0.0),
             "-y": (0.0, -1.0, 0.0), "+z": (0.0, 0.0, 1.0), "-z": (0.0, 0.0, -1.0)}
# The leaning poses: the board on an edge against a book, 45 deg between two faces, about each axis in turn.
EDGE_AXES = ((1.0, 0.0, 1.0), (0.0, 1.0, 1.0), (1.0, 1.0, 0.0), (-1.0, 0.0, 1.0))
PROP_DEG = 8.0  # a board propped against a book leans up to this far from the edge's 45 deg


def extreme_errors() -> SensorErrors:
    """The catalogue's extremes (``game/profiles/worst_plausible.json``: 10 deg/s of gyroscope bias
    warming by 4 deg/s, 200 uT of hard iron, 20 % of soft iron, 40 uT of room disturbance, twice
    the data sheet's noise)."""
    return realistic_errors(gyro_bias_dps=10.0, gyro_warmup_dps=4.0, mag_hard_iron_ut=200.0,
                            mag_soft_iron_pct=20.0, mag_disturbance_ut=40.0, noise_scale=2.0)


def maker_errors(errors: SensorErrors | None = None) -> SensorErrors:
    """A freshly made board's errors: ``errors``, :func:`tracker.sim.realistic_errors` by default (its
    accelerometer's sensitivity within the data sheet's +-3 %: what the six-pose calibration is for)."""
    return errors if errors is not None else realistic_errors()


@dataclass(frozen=True)
class Magnet:
    """A magnet near the board from ``start_s`` to ``stop_s`` (the maker's seconds).

    Its field at the board, ``field_ut`` in the room's frame (ENU), fades in
    and out over ``ramp_s`` (a raised cosine). The board turns about its own
    centre, so a magnet lying still nearby adds a constant field in the room.
    The default, 200 uT, is a 10 mm neodymium cube (moment about 1 A m^2:
    remanence 1.3 T over mu_0, times its volume) 10 cm away on its axis:
    B = mu_0 / (4 pi) 2 m / r^3 (the dipole field, J. D. Jackson, "Classical
    Electrodynamics", 3rd ed., eq. 5.56). It is added to what the magnetometer
    reads, after the board's soft iron (which would change it by 20 % at
    most: a field refused anyway).
    """

    start_s: float
    stop_s: float
    field_ut: Vec3 = (0.0, 0.0, 200.0)
    ramp_s: float = 0.5

    def at(self, t: Array) -> Array:
        """The magnet's field (N, 3) at the maker's times ``t`` (N,)."""
        up = np.clip((t - self.start_s) / self.ramp_s, 0.0, 1.0)
        down = np.clip((self.stop_s - t) / self.ramp_s, 0.0, 1.0)
        share = 0.5 - 0.5 * np.cos(np.pi * np.minimum(up, down))
        return share[:, None] * np.asarray(self.field_ut)


def _min_jerk(s: Array) -> Array:
    """10 s^3 - 15 s^4 + 6 s^5 on [0, 1] (Flash and Hogan 1985), clipped outside."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10.0 - 15.0 * s + 6.0 * s**2)


def _eased_time(tau: Array) -> Array:
    """The integral of :func:`_min_jerk` (tau / EASE_S) dtau: time whose rate rises smoothly from 0 to 1."""
    s = np.clip(tau / EASE_S, 0.0, 1.0)
    ramp = EASE_S * s**4 * (2.5 - 3.0 * s + s**2)
    return ramp + np.maximum(tau - EASE_S, 0.0)


@dataclass(frozen=True)
class _Move:
    """From ``q0`` at ``t0`` to ``q1`` by ``t1`` (minimum jerk), then lying still at ``q1``."""

    t0: float
    t1: float
    q0: Array
    q1: Array
    face: str | None  # the face it ends on (None: lifted, between faces)

    def at(self, t: Array) -> Array:
        return Q.slerp(self.q0, self.q1, _min_jerk((t - self.t0) / (self.t1 - self.t0)))


@dataclass(frozen=True)
class _Tumble:
    """Turning on from ``q0`` at ``t0``: a spiral about the field's direction (module docstring)."""

    t0: float
    q0: Array
    spin_s: float  # seconds per turn of the spin
    field: Array  # the field's direction in the room (unit)
    face: None = None

    def at(self, t: Array) -> Array:
        u = _eased_time(np.maximum(t - self.t0, 0.0))
        tilt = 0.5 * np.pi * (1.0 - np.cos(2.0 * np.pi * u / TUMBLE_SWING_S))
        spin = 2.0 * np.pi * u / self.spin_s
        to_field = Q.from_two_vectors((0.0, 0.0, 1.0), self.field)
        turn = Q.multiply(Q.from_axis_angle((1.0, 0.0, 0.0), tilt), Q.from_axis_angle((0.0, 0.0, 1.0), spin))
        room = Q.multiply(to_field, Q.multiply(turn, Q.conjugate(to_field)))
        return Q.multiply(room, self.q0)


_Segment = _Move | _Tumble
Counts = tuple[tuple[int, int, int], tuple[int, int, int], tuple[int, int, int], int, int]
# acc, gyr, mag, flex ADC, the die's TEMP_OUT


@dataclass(frozen=True)
class _Block:
    """Samples simulated together: their index (block number), the board's counts and, as plain
    lists, the readings' values (a :class:`tracker.motion.SensorReading` is made only when asked
    for: the offline procedures take the counts alone)."""

    index: int
    counts: list[Counts]
    acc: list[list[float]] = field(default_factory=list)
    gyr: list[list[float]] = field(default_factory=list)
    mag: list[list[float]] = field(default_factory=list)
    q: list[list[float]] = field(default_factory=list)
    adc: list[int] = field(default_factory=list)
    die_c: list[float] = field(default_factory=list)

    def reading(self, i: int) -> SensorReading:
        """Sample ``i``'s reading."""
        a, g, m, q = self.acc[i], self.gyr[i], self.mag[i], self.q[i]
        return SensorReading(acc=(a[0], a[1], a[2]), gyr=(g[0], g[1], g[2]), mag=(m[0], m[1], m[2]),
                             flex_deg=0.0, flex_adc=self.adc[i], q=(q[0], q[1], q[2], q[3]), die_c=self.die_c[i])


class SimulatedMaker:
    """A maker at a table with a simulated board (module docstring); a :class:`tracker.motion.MotionSource`.

    ``errors``: the board's (:func:`maker_errors`); ``seed``: the board's error
    draws (the same seed as a :class:`tracker.sim.Simulator` gives the same
    board) and the maker's own choices; ``rate_hz``: the board's sample rate;
    ``power_on``: which power-on of the board this is (:class:`tracker.sim.ErrorModel`'s warm-up);
    ``powered_s``: how long it had been on before the maker starts (0: just plugged in, its die warming).
    Time is the board's clock (seconds since power-up); when the board powers
    up again (its clock restarts) the maker's world goes on where it was.
    """

    def __init__(self, errors: SensorErrors | None = None, seed: int = 0, rate_hz: float = RATE_HZ,
                 magnet: Magnet | None = None, nudges: Sequence[float] = (), repeat_face: bool = False,
                 power_on: int = 0, powered_s: float = 0.0) -> None:
        self.errors = maker_errors(errors)
        self.seed, self.rate_hz = seed, rate_hz
        self.magnet, self.nudges, self.repeat_face = magnet, tuple(nudges), repeat_face
        self._rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(7,)))
        start = Q.from_axis_angle((0.0, 0.0, 1.0), self._rng.uniform(0.0, 2.0 * np.pi))
        self._plan: tuple[_Segment, ...] = (_Move(-1.0, 0.0, start, start, "+z"),)
        self._simulator = Simulator(Chain((LinkSpec("board", 0.0),), (SensorSpec("imu", 0, (0.0, 0.0, 0.0)),)),
                                    Motion(self._root, lambda t: np.zeros((len(t), 0))), self.errors, seed=seed,
                                    power_on=power_on, powered_s=powered_s)
        self._stream: SampleStream = self._simulator.stream(rate_hz)
        self._block_n = max(BLOCK_MIN, int(BLOCK_S * rate_hz))  # samples per block
        self._cache = _Block(-1, [])
        self._epoch = 0.0  # the maker's time at the board's latest power-up
        self._board_t = 0.0  # the board's latest time asked for
        self.now = 0.0  # the maker's time of the latest reading
        self._repeated = False
        self._wait_until = -math.inf  # the maker does nothing new before this time

    # ------------------------------------------------------------------ the motion

    def _root(self, t: Array) -> Array:
        """The board's orientation q_WS at the maker's times ``t`` (its plan, then the nudges)."""
        plan = self._plan
        q = np.empty((len(t), 4))
        starts = np.array([s.t0 for s in plan])
        which = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(plan) - 1)
        for i in np.unique(which):
            q[which == i] = plan[i].at(t[which == i])
        for t_n in self.nudges:
            s = np.clip((t - t_n) / NUDGE_S, 0.0, 1.0)
            q = Q.multiply(q, Q.from_axis_angle((1.0, 0.0, 0.0), math.radians(NUDGE_DEG) * np.sin(np.pi * s) ** 2))
        return q

    def reading(self, t: float) -> SensorReading:
        """What the board's sensors read at board time ``t`` (errors included, not yet quantised)."""
        self._advance(t)
        block, i = self._sample(self.now)
        return block.reading(i)

    def _advance(self, t: float) -> None:
        """The maker's clock at board time ``t``: a probe at 0 (the hello, or a power-up) leaves it
        where it is; a board time going back is a power-up (the maker's world goes on)."""
        if t == 0.0 and self._board_t > 0.0:
            return
        if t < self._board_t:  # the board powered up again
            self._epoch = self.now + 1.0 / self.rate_hz
        self._board_t = t
        self.now = self._epoch + t

    def _sample(self, t: float) -> tuple[_Block, int]:
        """The block holding the sample at the maker's time ``t``, and its row there."""
        b, i = divmod(round(t * self.rate_hz), self._block_n)
        cache = self._cache  # once: follow() in another thread may drop it meanwhile
        if cache.index != b:
            cache = self._cache = self._block(b)
        return cache, i

    def _block(self, b: int) -> _Block:
        """Block ``b`` of samples simulated, as the board's counts (:func:`tracker.board.quantise`'s
        rule, at the firmware's default full scales) and the readings' values."""
        n = self._block_n
        data = self._stream.block(b * n, (b + 1) * n)
        acc, gyr, mag = data.acc[:, 0], data.gyr[:, 0], data.mag[:, 0]
        q = data.truth.q_sensors[:, 0]
        if self.magnet is not None:
            mag = mag + Q.rotate(Q.conjugate(q), self.magnet.at(data.t))
        adc, die = data.flex_adc.tolist(), data.die_c.tolist()
        counted = [((a[0], a[1], a[2]), (g[0], g[1], g[2]), (m[0], m[1], m[2]), int(f), temp_counts(c))
                   for a, g, m, f, c in zip(counts(acc, acc_lsb(ACC_FS_G)).tolist(),
                                            counts(gyr, gyr_lsb(GYR_FS_DPS)).tolist(),
                                            counts(mag, MAG_UT_PER_COUNT).tolist(), adc, die)]
        return _Block(b, counted, acc.tolist(), gyr.tolist(), mag.tolist(), q.tolist(), adc, die)

    def raw_sample(self, t: float, seq: int = 0) -> RawSample:
        """The raw sample the board sends at board time ``t``: :meth:`reading` quantised as the firmware
        does (:func:`tracker.board.quantise`), at its default full scales."""
        self._advance(t)
        block, i = self._sample(self.now)
        acc, gyr, mag, flex, temp = block.counts[i]
        return RawSample(t, round(t * 1e6) & 0xFFFFFFFF, seq & 0xFFFF, acc, gyr, mag, flex, ACC_FS_G, GYR_FS_DPS,
                         temp_counts=temp)

    # ------------------------------------------------------------------ following the prompts

    def _replan(self, segment: _Segment) -> None:
        """Start ``segment`` (from where the plan has the board then), dropping what was planned after."""
        kept = tuple(s for s in self._plan if s.t0 < segment.t0)
        self._plan = kept + (segment,)
        if (self._cache.index + 1) * self._block_n >= segment.t0 * self.rate_hz:
            self._cache = _Block(-1, [])

    def _where(self, t: float) -> Array:
        return self._root(np.array([t]))[0]

    def _face_q(self, face: str, t: float) -> Array:
        """The board tipped over from where the plan has it at ``t`` onto ``face`` (a face, or "tilted k":
        the k-th of :data:`EDGE_AXES`): the least turn that brings that axis up, then a new heading
        (within +-20 deg) and a small lean (:data:`PROP_DEG` on an edge, :data:`LEAN_DEG` on a face)."""
        q = self._where(t)
        tilted = face.startswith(TILTED)
        axis = np.array(EDGE_AXES[(int(face.split()[-1]) - 1) % len(EDGE_AXES)] if tilted else FACE_AXES[face])
        tip = Q.from_two_vectors(Q.rotate(q, axis / np.linalg.norm(axis)), (0.0, 0.0, 1.0))
        heading = Q.from_axis_angle((0.0, 0.0, 1.0), math.radians(self._rng.uniform(-20.0, 20.0)))
        azimuth = self._rng.uniform(0.0, 2.0 * np.pi)
        lean = Q.from_axis_angle((math.cos(azimuth), math.sin(azimuth), 0.0),
                                 math.radians(self._rng.uniform(0.0, PROP_DEG if tilted else LEAN_DEG)))
        return Q.multiply(lean, Q.multiply(heading, Q.multiply(tip, q)))

    def _move(self, face: str | None) -> None:
        """After a reaction time, turn the board onto ``face`` (None: lift it 60 deg off the face it is on)."""
        t0 = self.now + self._rng.uniform(*REACTION_S)
        q0 = self._where(t0)
        q1 = Q.multiply(Q.from_axis_angle((1.0, 0.0, 0.0), math.radians(60.0)), q0) if face is None \
            else self._face_q(face, t0)
        self._replan(_Move(t0, t0 + TURN_S, q0, q1, face))

    def follow(self, status: AccelStatus | MagStatus | ThermalStatus) -> None:
        """Act on a procedure's prompt (module docstring); a prompt already being acted on changes nothing.
        The warm-up calibration asks for nothing: the board lies where it was laid down."""
        if isinstance(status, ThermalStatus):
            return
        current = self._plan[-1]
        if isinstance(status, MagStatus):
            if not isinstance(current, _Tumble):
                t0 = self.now + self._rng.uniform(*REACTION_S)
                field = np.asarray(self._simulator.earth_field_ut)  # and a magnet's, if one is near then
                if self.magnet is not None:
                    field = field + self.magnet.at(np.array([t0]))[0]
                field = field / np.linalg.norm(field)
                self._replan(_Tumble(t0, self._where(t0), TUMBLE_SPIN_S * self._rng.uniform(0.8, 1.2), field))
            return
        if status.done or status.asked is None:
            return
        if self._busy():
            return
        if self.repeat_face and not self._repeated and len(status.captured) == 1 \
                and status.up == status.captured[0]:
            self._repeated = True  # lift it, then lay it on the same face again
            self._move(None)
            back = self._plan[-1].t0 + TURN_S + 0.3
            self._replan(_Move(back, back + TURN_S, self._where(back), self._face_q(status.up, back), status.up))
            self._wait_until = back + TURN_S + 2.0  # and reads what the procedure says about it
        else:
            target = status.asked if status.asked != TILTED else f"{TILTED} {status.leaned + 1}"
            if current.face != target:
                self._move(target)

    def _busy(self) -> bool:
        """Whether a planned move has not ended yet (the maker finishes what it is doing)."""
        current = self._plan[-1]
        return self.now < self._wait_until or isinstance(current, _Move) and current.t1 > self.now

    # ------------------------------------------------------------------ the truth

    def true_calibration(self) -> BoardCalibration:
        """The board's true errors in :class:`tracker.calibration.BoardCalibration`'s convention.

        The simulator measures acc = (diag(s) + C) a + o and mag = D (S R^T h + b) + o_m
        (:mod:`tracker.sim`), so acc_offset = o, and with K = (diag(s) + C)^-1 acc_scale = K's
        diagonal and acc_misalignment = K diag(1 / acc_scale) (unit diagonal); mag_hard_iron =
        D b + o_m, and with M = D S the soft iron is the symmetric W with W^T W
        proportional to (M M^T)^-1, normalised to det W = 1 as the fit is
        (:mod:`tracker.magfit`: only W up to a scale and a rotation is observable):
        W = |det M|^(1/3) (M M^T)^(-1/2). gyro_bias: the offset at power-on; gyro_scale: the
        inverse of the gyroscope's drawn sensitivity matrix diag(s) + C. gyro_thermal and acc_thermal: this
        power-on's warm-ups over the die's rise (:func:`tracker.sim.die_temperature`), about the
        temperature at power-on (acc_offset, gyro_bias: the offsets there, whenever the maker started).
        """
        data = self._simulator.stream(self.rate_hz).block(0, 1)
        d, o_m = data.scale["mag"][0], data.offset["mag"][0]
        m = d[:, None] * data.soft_iron[0]
        values, vectors = np.linalg.eigh(m @ m.T)
        w = abs(np.linalg.det(m)) ** (1.0 / 3.0) * (vectors / np.sqrt(values)) @ vectors.T
        gyr = self.errors.gyr
        rise = die_rise_c(gyr)
        slope, acc_slope = ((data.warmup["gyr"][0] / rise, data.warmup["acc"][0] / rise) if gyr.warmup
                            else (np.zeros(3), np.zeros(3)))
        acc = np.linalg.inv(np.diag(data.scale["acc"][0]) + data.cross["acc"][0])
        power_on_c = die_temperature(gyr, np.zeros(()))
        return BoardCalibration(gyro_bias=data.offset["gyr"][0], acc_offset=data.offset["acc"][0],
                                acc_scale=np.diag(acc).copy(), acc_misalignment=acc / np.diag(acc)[None, :],
                                mag_hard_iron=d * data.hard_iron[0] + o_m, mag_soft_iron=0.5 * (w + w.T),
                                gyro_thermal=slope, gyro_thermal_ref_c=power_on_c,
                                gyro_scale=np.linalg.inv(np.diag(data.scale["gyr"][0]) + data.cross["gyr"][0]),
                                acc_thermal=acc_slope,
                                acc_offset_ref_c=power_on_c)


def calibration_errors(fitted: BoardCalibration, truth: BoardCalibration) -> dict[str, float]:
    """The errors a calibration leaves against the truth (the issue's four figures).

    ``acc_offset_error_mg``: the worst axis's offset error in mg (1 g = 9.80665 m/s^2);
    ``acc_scale_error_pct``: the worst axis's fitted scale over the true, less one, in %;
    ``mag_hard_iron_error_ut``: the length of the hard iron's error; ``mag_soft_iron_error_pct``:
    the largest element of the soft iron's error (the matrices are near the identity), in %, the
    truth's turned into the fitted accelerometer's frame (the rotation Q of the polar decomposition
    F T^-1 = Q P, below: the magnetometer is aligned to that frame, :mod:`tracker.mag_alignment`);
    ``gyro_thermal_error_dps_per_c``: the length of the warm-up slope's error, deg/s per degC;
    ``acc_thermal_error_mg_per_c``: the length of the zero-g level's slope's error, mg per degC. The
    offsets are compared at the temperature the fitted ones were measured at (the truth's moved
    there along its slope) when the fitted calibration knows it;
    ``gyro_scale_error_pct``: the worst axis's fitted sensitivity over the true, less one, in %;
    ``acc_skew_error_pct``: with F the fitted accelerometer's matrix (acc_misalignment diag(acc_scale))
    and T the true one, the largest entry of the symmetric part of F T^-1 - I, in % (what no rotation
    of the frame explains: the scale and the skew left); ``gyro_matrix_error_pct``: the largest entry of
    the gyroscope's fitted matrix times the true one's inverse less F T^-1, in % (the gyroscope against the
    accelerometer's calibrated frame, the frame the fusion works in).
    """
    acc_left = _acc_matrix(fitted) @ np.linalg.inv(_acc_matrix(truth))
    true_offset = truth.acc_offset + (truth.acc_thermal * (fitted.acc_offset_ref_c - truth.acc_offset_ref_c)
                                      if fitted.acc_offset_temperature_known else 0.0)
    return {
        "acc_offset_error_mg": float(np.max(np.abs(fitted.acc_offset - true_offset))) / MG,
        "acc_scale_error_pct": float(np.max(np.abs(fitted.acc_scale / truth.acc_scale - 1.0))) * 100.0,
        "mag_hard_iron_error_ut": float(np.linalg.norm(fitted.mag_hard_iron - truth.mag_hard_iron)),
        "mag_soft_iron_error_pct": float(np.max(np.abs(fitted.mag_soft_iron
                                                        - _rotation(acc_left) @ truth.mag_soft_iron))) * 100.0,
        "gyro_thermal_error_dps_per_c": math.degrees(float(np.linalg.norm(fitted.gyro_thermal - truth.gyro_thermal))),
        "acc_thermal_error_mg_per_c": float(np.linalg.norm(fitted.acc_thermal - truth.acc_thermal)) / MG,
        "gyro_scale_error_pct": float(np.max(np.abs(np.diag(fitted.gyro_scale) / np.diag(truth.gyro_scale)
                                                   - 1.0))) * 100.0,
        "acc_skew_error_pct": float(np.max(np.abs(0.5 * (acc_left + acc_left.T) - np.eye(3)))) * 100.0,
        "gyro_matrix_error_pct": float(np.max(np.abs(fitted.gyro_scale @ np.linalg.inv(truth.gyro_scale)
                                                     - acc_left))) * 100.0,
    }


def _rotation(m: Array) -> Array:
    """The rotation Q of the polar decomposition m = Q P (U V^T of m's singular value decomposition)."""
    u, _, vt = np.linalg.svd(m)
    return u @ vt


def _acc_matrix(cal: BoardCalibration) -> Array:
    """The accelerometer's calibration as one matrix: acc_misalignment diag(acc_scale)."""
    return cal.acc_misalignment * cal.acc_scale[None, :]


@dataclass
class MakerRun:
    """What :func:`run_maker` did: ``result`` (a :class:`tracker.calibration.SixPoseResult` or a
    :class:`tracker.mag_procedure.MagResult`; None when refused), ``error`` (the refusal's line, or
    ""), ``history`` ((maker's time, message) each time the message changed) and ``seconds`` taken."""

    result: SixPoseResult | MagResult | ThermalResult | None
    error: str
    history: list[tuple[float, str]] = field(default_factory=list)
    seconds: float = 0.0


def run_maker(procedure: AccelProcedure | MagProcedure | ThermalProcedure, maker: SimulatedMaker,
              limit_s: float = 600.0, pull_cable: tuple[float, float] | None = None,
              watch: Callable[[float, AccelStatus | MagStatus | ThermalStatus], None] | None = None) -> MakerRun:
    """Run ``procedure`` offline on ``maker``'s board, as fast as the simulator goes.

    Each sample of the board (its rate, quantised as the firmware does) is fed
    to the procedure and the maker follows the status, until the accelerometer
    procedure (or the warm-up's) is done or the magnetometer procedure is ready or sees a problem
    (then it is finished), or ``limit_s`` of the maker's time pass from its start.
    ``pull_cable`` = (at_s, for_s): the cable is pulled at ``at_s`` (maker's
    time) for ``for_s``: the procedure is told (``interrupted()``), and the
    board powers up again, its clock from zero. ``watch`` sees every status.
    """
    run = MakerRun(None, "")
    k0, k, seq, start = 0, 0, 0, maker.now
    status: AccelStatus | MagStatus | ThermalStatus = procedure.status
    while True:
        t = (k - k0) / maker.rate_hz
        if pull_cable is not None and maker.now >= pull_cable[0]:
            procedure.interrupted()
            run.history.append((maker.now, procedure.status.message))
            maker.now += pull_cable[1]
            pull_cable, k0, t = None, k, 0.0
            seq = 0
        status = procedure.feed(maker.raw_sample(t, seq))
        k, seq = k + 1, seq + 1
        if not run.history or run.history[-1][1] != status.message:
            run.history.append((maker.now, status.message))
        if watch is not None:
            watch(maker.now, status)
        maker.follow(status)
        if isinstance(status, (AccelStatus, ThermalStatus)) and status.done \
                or isinstance(status, MagStatus) and (status.ready or status.problem):
            break
        if maker.now - start >= limit_s:
            run.error = f"the procedure did not finish in {limit_s:g} s: {status.message}"
            run.seconds = maker.now - start
            return run
    run.seconds = maker.now - start
    try:
        run.result = procedure.finish() if isinstance(procedure, MagProcedure) else procedure.result()
    except MagFitError as e:
        run.error = str(e)
    if isinstance(run.result, SixPoseResult) and not run.result.ok:
        run.error = run.result.message
    if isinstance(run.result, ThermalResult) and not run.result.ok:
        run.error = run.result.problem
    return run


def cold(maker: SimulatedMaker, rate_hz: float) -> SimulatedMaker:
    """``maker``'s board unplugged until it is cold and plugged back in, sampled at ``rate_hz``: a power-on
    of its own (:data:`THERMAL_POWER_ON`), so its warm-up starts again, and its clock from 0."""
    return SimulatedMaker(maker.errors, maker.seed, rate_hz, power_on=THERMAL_POWER_ON)


def warm_up(maker: SimulatedMaker, params: ThermalParams = ThermalParams()) -> MakerRun:
    """The warm-up calibration (:mod:`tracker.thermal`) on ``maker``'s board: powered up cold (:func:`cold`)
    and left lying still, sampled at :data:`THERMAL_RATE_HZ`."""
    board = cold(maker, THERMAL_RATE_HZ)
    return run_maker(ThermalProcedure(params), board, limit_s=params.duration_s + 1.0)


def calibrate(maker: SimulatedMaker, thermal: bool = True) -> tuple[BoardCalibration, list[str]]:
    """The procedures on ``maker``'s board, accelerometer first (its result serves the dip), then the
    magnetometer, then (``thermal``) the warm-up: the calibration found (the defaults where a procedure
    failed) and the failures' lines."""
    six = AccelProcedure()
    accel = run_maker(six, maker)
    cal, problems = BoardCalibration(), []
    if isinstance(accel.result, SixPoseResult) and not accel.error:
        cal, gyro = six.calibration(accel.result)
        if not gyro.ok:
            problems.append(f"the gyroscope's sensitivities were not measured: {gyro.problem}")
    else:
        problems.append(f"accelerometer calibration failed: {accel.error}")
    mag = run_maker(MagProcedure(accel=cal), maker)
    if isinstance(mag.result, MagResult) and not mag.error:
        cal = replace(cal, mag_hard_iron=np.array(mag.result.fit.offset), mag_soft_iron=mag.result.soft_iron)
    else:
        problems.append(f"magnetometer calibration failed: {mag.error}")
    if thermal:
        warm = warm_up(maker)
        if isinstance(warm.result, ThermalResult) and not warm.error:
            cal = cal.with_procedure(*thermal_calibration(cal.board_id, warm.result))
        else:
            problems.append(f"warm-up calibration failed: {warm.error}")
    return cal, problems


def recovered_errors(seeds: int = 4) -> dict:
    """The errors the procedures leave on simulated boards, the worst over ``seeds`` seeds, for the
    typical board (:func:`maker_errors`) and the catalogue's extremes (:func:`extreme_errors`)."""
    report: dict = {"seeds": seeds}
    for name, errors in (("typical", maker_errors()), ("extreme", extreme_errors())):
        worst: dict[str, float] = {}
        failures = []
        for seed in range(seeds):
            maker = SimulatedMaker(errors, seed)
            cal, problems = calibrate(maker)
            failures += [f"seed {seed}: {p}" for p in problems]
            for key, value in calibration_errors(cal, maker.true_calibration()).items():
                worst[key] = round(max(worst.get(key, 0.0), value), 3)
        report[name] = {**worst, "failures": failures}
    return report
