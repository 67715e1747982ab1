"""The sensor simulator: a kinematic chain carrying virtual MPU-9250s and the flex circuit.

The body is the chain of rigid links on hinges of Inertial Sensor Based Solution
for Finger Motion Tracking (Computers 9(2):40, 2020; sec. 2.1) made 3-D: the
root link turns freely (3 DoF) about its joint, which stays at the world origin
unless the motion moves it (``Motion.shoulder``: a shoulder that rises with the arm, a trunk that bounces as it walks);
every further link hangs on a hinge at the far end of the link before it. A
link's frame sits at its own joint, coincides with its parent's frame when the
hinge angle is zero (the finger-tracking paper, sec. 2.1), and the link runs
``length_m`` along ``direction`` in it. So, with ``q_k`` the orientation of link
k in the world and ``o_k`` its joint's position,

    q_0 = root(t),    q_k = q_{k-1} * exp(hinge_k theta_k(t) / 2),
    o_0 = s(t),       o_k = o_{k-1} + R(q_{k-1}) l_{k-1} d_{k-1},

the 3-D form of the finger-tracking paper's r_i = R_i {0, l_i, 0} and s_k = sum r_i + h_k.
A sensor sits at ``position_m`` in its link's frame, turned by ``mount``
(q_LS: a wearing offset, Zhu & Shi, sec. 6), and the motion may turn it on
its link as time goes (``Motion.mount``: a board rocking on soft tissue),
q_WS = q_k q_m(t) q_LS. What it feels:

    gyr = 2 Im(q_WS^-1 dq_WS/dt)     body angular rate (q' = q w / 2, Sola 2017)
    acc = R_WS^T (p'' - g)            specific force, g = (0, 0, -9.81) (the finger-tracking paper, sec. 2.1)
    mag = R_WS^T m                    the earth's field m, ENU, in microtesla

Trajectories are plain functions of time, so their derivatives are taken
numerically by fourth-order central differences with a step of 0.5 ms:
truncation O(h^4) (below 1e-8 m/s^2 and rad/s for arm motions up to a few
hertz), rounding near 1e-8 m/s^2 and 1e-11 rad/s (the acceleration's stencil
multiplies a position's last digit by 2e7; about 1e-6 after 1000 s, where t
itself loses digits). The stencil is summed term by term, so every sample is
rounded alike wherever it sits in a batch. Trajectories should be smooth: at a jump of the third derivative the
samples within 1 ms err by O(h x jump).

Sensor errors (the finger-tracking paper, sec. 3: white noise, zero offset, both; MPU-9250
data-sheet figures) are white noise, a constant offset, a warm-up drift of
that offset, a random-walk drift, a scale error, quantisation and saturation
(:class:`ErrorModel`). A real board adds its own magnetic errors and a room's
field (:class:`MagneticErrors`), the flex sensor's own dynamics
(:class:`FlexDynamics`) and the MPU-9250's low-pass filters
(:attr:`SensorErrors.dlpf`, :mod:`tracker.mpu_dlpf`); :func:`realistic_errors`
builds a typical board.
Random numbers come from ``numpy.random.SeedSequence(seed, spawn_key=...)``
keyed by sensor kind and block of sample indices, so an error is a function
of the sample index alone: a batch and a stream (:meth:`Simulator.stream`,
which :class:`SimulatedSource` and so the virtual board read) give the same
values for the same seed. The flex sensor's hysteresis and creep remember
the past; :class:`SampleStream` keeps their state so that its blocks are
still the batch's rows. Every error defaults to none, and the draws of each
kind of error have their own spawn keys, so adding one leaves the others'
values unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import quat
from .flex import FlexCircuit, FlexSensor
from .mpu_dlpf import INTERNAL_HZ, Dlpf, Response
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
_KINDS = ("gyr", "acc", "mag", "flex")  # their index is their spawn key: 0-3
_WARMUP_KEY = 3  # a kind's warm-up direction: spawn key (kind, 3), beside (kind, 0-2)
_MAG_KEY = 4  # the board's hard and soft iron, and the room's field
_FLEX_KEY = 5  # the flex sensor's nonlinearity
_POWER_ON_KEY = 6  # a kind's warm-up direction at one power-on: spawn key (kind, 6, power_on)
_CROSS_KEY = 7  # a kind's cross-axis sensitivities: spawn key (kind, 7)
_MAG_MODES = 4  # spatial modes of the room's field disturbance

# MPU-9250 product specification (PS-MPU-9250A-01 rev. 1.1), sec. 3.1-3.2; AK8963 in 16-bit mode.
GYR_NOISE_DENSITY = math.radians(0.01)  # rad/s/sqrt(Hz)
GYR_OFFSET_MAX = math.radians(5.0)  # rad/s, initial zero-rate offset tolerance
ACC_NOISE_DENSITY = 300e-6 * STANDARD_GRAVITY  # m/s^2/sqrt(Hz)
ACC_OFFSET_MAX = 60e-3 * STANDARD_GRAVITY  # m/s^2, zero-g initial tolerance (x, y)
SCALE_TOLERANCE = 0.03  # initial sensitivity tolerance, gyroscope and accelerometer
CROSS_AXIS_TOLERANCE = 0.02  # cross-axis sensitivity, gyroscope and accelerometer (tables 1 and 2)
MAG_FULL_SCALE_UT = 4912.0
# The AK8963's data sheet (MS1356-E-02) gives no noise figure. Consumer 3-axis compasses of its
# class do: the Bosch BMM150 data sheet (BST-BMM150-DS001, electrical specification) gives an
# output noise of 0.3-1.0 uT RMS per axis by its power preset, 0.6 uT at its regular preset. We
# take 0.6 uT RMS at the AK8963's 100 Hz continuous mode (4 counts of 0.15 uT) as white noise.
MAG_NOISE_RMS_UT = 0.6
MAG_RATE_HZ = 100.0  # the AK8963's continuous measurement mode 2 (data sheet MS1356-E-02), the firmware's
MAG_NOISE_DENSITY = MAG_NOISE_RMS_UT / math.sqrt(MAG_RATE_HZ)  # uT/sqrt(Hz)
WARMUP_SPAN_S = 600.0  # ErrorModel.warmup is the offset's change over this long after power-on
# The MPU-9250's zero-rate output varies by +-30 deg/s over -40 to +85 degC (PS-MPU-9250A-01, table 1):
# at most 0.24 deg/s per degC. A warm-up of w deg/s warms the die by w / that (die_temperature): the
# steepest slope the data sheet allows, so the least temperature signal for a given drift.
ZRO_TEMPCO_DPS_PER_C = 60.0 / 125.0 / 2.0
ROOM_C = 22.0  # the die's temperature at power-on: a room's
# The accelerometer's zero-g level moves by up to +-1.5 mg per degC of the die (PS-MPU-9250A-01, table 2,
# "zero-g level change vs. temperature", x and y): the bound, taken along the warm-up's drawn direction.
ACC_ZERO_G_TEMPCO = 1.5e-3 * STANDARD_GRAVITY  # m/s^2 per degC
TYPICAL_WARMUP_UNEXPLAINED = 0.2  # share of the warm-up a thermal calibration cannot predict (ErrorModel)

# The "typical" board and player's sensors (realistic_errors; game.sim.motion_model.PlayerProfile's defaults).
# Where each figure comes from: the docstrings of ErrorModel, MagneticErrors, FlexDynamics, realistic_errors.
TYPICAL_GYRO_BIAS_DPS = 1.0  # each gyro axis's offset drawn within +-this (PS-MPU-9250A-01: +-5 at most)
TYPICAL_GYRO_WARMUP_DPS = 1.0  # about 4 degC of warming at the data sheet's 0.24 deg/s per degC
TYPICAL_MAG_HARD_IRON_UT = 30.0
TYPICAL_MAG_SOFT_IRON_PCT = 5.0
TYPICAL_MAG_DISTURBANCE_UT = 5.0
TYPICAL_FLEX_HYSTERESIS_PCT = 4.0
TYPICAL_FLEX_CREEP_PCT = 3.0
TYPICAL_FLEX_NONLINEARITY_PCT = 2.0
TYPICAL_FLEX_NOISE_COUNTS = 0.5  # RMS ADC counts at 200 Hz; the ATmega328P ADC's absolute accuracy is 2 LSB


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
    hinges: Array = field(init=False, repr=False, compare=False)  # the hinge axes after the root, (L - 1, 3)
    # Where each joint after the root, then each sensor, sits on the link it hangs from: that link's
    # index and the vector from its joint in its frame, (L - 1 + S, 3).
    arms: tuple[list[int], Array] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # Built here, not as a cached_property: the compiled build turns one into a plain property,
        # which would build them again for every block of samples.
        object.__setattr__(self, "hinges", np.reshape([link.hinge for link in self.links[1:]], (-1, 3)))
        reaches = [link.length_m * np.asarray(link.direction) for link in self.links[:-1]]
        positions = [np.asarray(s.position_m, dtype=float) for s in self.sensors]
        index = list(range(len(self.links) - 1)) + [s.link for s in self.sensors]
        object.__setattr__(self, "arms", (index, np.reshape(reaches + positions, (-1, 3))))


@dataclass(frozen=True)
class Motion:
    """Trajectories, vectorised over times ``t`` of shape (N,).

    ``mount``, if given, turns the sensors on their links as time goes (a
    board rocking on the soft tissue under a strap): every sensor is turned
    by q_m(t), in its link's frame, about the point ``mount_pivot_m`` from
    the sensor (link frame). With c that vector, the sensor sits at
    position_m + c - R(q_m) c and is turned q_link q_m(t) q_LS: its rate
    gains q_m's, and its acceleration the lever arm's, only as large as c is
    (zero for a rotation about the sensor itself). The links, and so the
    joints and what hangs on them, do not follow it.

    ``shoulder``, if given, moves the root's joint: s(t), its position in
    the world (metres) given the times and the root's orientations there,
    which the whole chain follows; None keeps it at the origin.
    """

    root: Callable[[Array], Array]  # t -> q_W0 (N, 4), the root link's orientation
    joints: Callable[[Array], Array]  # t -> hinge angles (N, links - 1), radians
    pose: Callable[[Array], tuple[Array, Array]] | None = None  # t -> both, if cheaper at once
    mount: Callable[[Array], Array] | None = None  # t -> q_m (N, 4), every sensor turned on its link
    mount_pivot_m: Vec3 = (0.0, 0.0, 0.0)  # what q_m turns the sensor about, from it (link frame)
    shoulder: Callable[[Array, Array], Array] | None = None  # (t, q_W0) -> s(t) (N, 3), the root joint (m)

    def at(self, t: Array) -> tuple[Array, Array]:
        """The root's orientations and the hinge angles at ``t``."""
        return self.pose(t) if self.pose is not None else (self.root(t), self.joints(t))


@dataclass(frozen=True)
class ErrorModel:
    """What one sensor adds to the truth, axis by axis (the finger-tracking paper, sec. 3).

    measured = saturate(quantise((1 + scale) truth + offset + w(t) + drift + noise)),
    with the scale and offset drawn once per axis, uniformly within their
    bounds (data sheets give tolerances, not distributions), the drift a
    random walk and the noise white. Units are the sensor's (rad/s, m/s^2,
    microtesla, volts for the flex circuit).

    The warm-up w(t) is the offset's drift as the board warms after power-on
    (sample 0, t = k / rate):

        w(t) = warmup u (1 - exp(-t / tau)) / (1 - exp(-WARMUP_SPAN_S / tau)),

    a first-order (lumped thermal) approach to the warm temperature, scaled so
    that the offset has moved by exactly ``warmup`` after 600 s. The direction
    u is drawn from the seed: a unit vector per sensor for three-axis sensors
    (so the offset vector moves by ``warmup`` in all), a sign for the flex
    circuit. For the gyroscope, the MPU-9250 product specification
    (PS-MPU-9250A-01, sec. 3.1) gives a ZRO variation of +-30 deg/s over -40 to
    +85 degC, 0.24 deg/s per degC; a board strapped on warms by a few degC
    (its own 0.1 W or so, and the skin's 32-34 degC against a 20-25 degC room),
    so 0-4 deg/s covers 0 to about 17 degC. The time constant is that of a few
    grams of board (heat capacity about 5 J/K) losing heat to still air through
    some 30-60 K/W: 150-300 s, hence ``warmup_tau_s`` = 150 s.

    The die's temperature follows the same curve (:func:`die_temperature`),
    and most of the warm-up is a function of it, which a thermal calibration
    measures (:mod:`tracker.thermal`). Not all: a temperature compensation of
    a MEMS gyroscope's bias removes 73 % of its temperature drift (Liu, Liu,
    Xu and Zhao, "Research on temperature compensation technology of micro-
    electro-mechanical systems gyroscope in strap-down inertial measurement
    unit", 2018, doi 10.1007/978-3-030-03766-6_2; 78 % for a dual-mass MEMS
    gyroscope in a paper on PubMed Central, PMC6523767), the rest being thermal
    hysteresis and gradients that differ from one warming to the next. So a
    share r = ``warmup_unexplained`` of the warm-up takes a direction drawn anew
    at every power-on (:class:`Simulator`'s ``power_on``):

        u = (1 - r) u_board + r u_power_on,

    the board's own direction u_board the same at every power-on. A calibration
    made at one power-on leaves r (u_play - u_calibration) at another: on average
    r 4/3 of the warm-up (the mean distance of two random points on the unit
    sphere is 4/3), so r = 0.2 leaves the 27 % the compensation above left.

    A sensor with an output rate of its own (``rate_hz``) below the sample rate
    makes a reading at each of its ticks, t = m / rate_hz, which the board reads
    at its first sample at or after the tick and sends again at every sample
    until the next one (the firmware holds the AK8963's reading between its
    100 Hz measurements: firmware/energyball/imu.h). Each reading's white noise
    is that of one measurement at that rate: std = density * sqrt(rate_hz).
    """

    noise_density: float = 0.0  # white noise per sqrt(Hz): std = density * sqrt(rate)
    offset_max: float = 0.0  # constant offset, drawn in [-offset_max, offset_max]
    drift: float = 0.0  # random walk per sqrt(s): after T seconds std drift * sqrt(T)
    scale_max: float = 0.0  # scale-factor error (fraction), drawn in [-scale_max, scale_max]
    cross_axis_max: float = 0.0  # cross-axis sensitivity (fraction), each of C's off-diagonals within +-this
    resolution: float = 0.0  # one least significant bit; 0 = continuous
    full_scale: float = math.inf  # readings saturate at +-full_scale
    warmup: float = 0.0  # the offset's change over the first WARMUP_SPAN_S after power-on (sample 0)
    warmup_tau_s: float = 150.0  # thermal time constant of the warm-up curve
    warmup_unexplained: float = 0.0  # share r of the warm-up that differs at every power-on (above)
    rate_hz: float = 0.0  # the sensor's own output rate (0: a reading at every sample; below)


@dataclass(frozen=True)
class MagneticErrors:
    """The magnetometer's errors on a real board and in a real room, in microtesla.

    What the AK8963 measures (before the white noise, quantisation and
    saturation of its :class:`ErrorModel`):

        measured = (I + E) R_WS^T (m + d(p)) + h,

    the earth's field m plus the room's disturbance d at the sensor's position
    p, turned into the sensor frame, distorted by the soft iron I + E and
    offset by the hard iron h (the measurement model of magnetometer
    calibration, e.g. Kok and Schoen, "Maximum likelihood calibration of a
    magnetometer using inertial sensors", IFAC World Congress 2014). Per
    sensor, h has magnitude ``hard_iron_ut`` in a drawn direction and E is
    symmetric with each entry drawn uniformly within +-``soft_iron``.

    Ranges. The chip's own zero-field offset may reach +-500 counts of
    0.6 uT, +-300 uT (PS-MPU-9250A-01, sec. 3.3); a board's magnetised parts
    add to it, so 0-200 uT of hard iron. The AK8963's axes may differ in
    sensitivity by up to +-50 % before its fuse-ROM adjustment (data sheet
    MS1356-E-02, sec. 8.3.11); after it, and with a board's soft iron, a few
    percent remain: 0-20 %. The room: magnetic-field mapping indoors finds anomalies of
    tens of microtesla near steel (Li, Gallagher, Dempster and Rizos, "How
    feasible is the use of magnetic field alone for indoor positioning?",
    IPIN 2012; Haverinen and Kemppainen, Robotics and Autonomous Systems 57,
    2009), and in a motion lab de Vries et al. (Gait & Posture 29, 2009,
    535-541) found heading deviations with a standard deviation of 29 deg
    5 cm above the floor and 3 deg above 1 m: 1-10 uT against a 20 uT
    horizontal field. So 0-40 uT, typically a few.

    The disturbance is a sum of ``_MAG_MODES`` spatial modes,
    d(p) = sum_j c_j cos(k_j . p + phi_j), with |k_j| = 2 pi /
    ``disturbance_scale_m`` in drawn directions, c_j perpendicular to k_j (so
    div d = 0, as Gauss's law for magnetism asks) and the |c_j| summing to
    ``disturbance_ut``: |d| <= ``disturbance_ut`` everywhere, its mean over a
    region many wavelengths wide is near zero, and d changes on the scale of
    ``disturbance_scale_m`` as the arm moves through it.
    """

    hard_iron_ut: float = 0.0  # magnitude of the board's constant field offset (direction drawn)
    soft_iron: float = 0.0  # fraction; symmetric distortion I + E, |E_ij| <= soft_iron, drawn
    disturbance_ut: float = 0.0  # bound of the room's field disturbance (its modes' amplitudes' sum)
    disturbance_scale_m: float = 0.4  # the disturbance's wavelength


@dataclass(frozen=True)
class FlexDynamics:
    """The flex sensor's own behaviour, as fractions of its straight-to-bent span.

    Applied to the true elbow angle x (degrees) before the sensor's resistance
    (:meth:`tracker.flex.FlexSensor.ohms`), with span = the sensor's
    ``bent_deg`` and u = clip(x / span, 0, 1):

    - nonlinearity: y = x + ``nonlinearity`` span g(u), g(u) = a1 sin(pi u) +
      a2 sin(2 pi u) with (a1, a2) drawn and scaled so that max |g| = 1: zero
      at both ends, peak ``nonlinearity`` of the span. g is a trigonometric
      polynomial of degree 2 in pi u, so |g'| <= 2 pi (Bernstein's
      inequality) and y stays increasing for ``nonlinearity`` < 1 / (2 pi).
    - hysteresis: the play (backlash) operator of half width r =
      ``hysteresis`` span / 2 on y, z_k = min(max(z_{k-1}, y_k - r), y_k + r)
      (Krasnosel'skii and Pokrovskii, "Systems with Hysteresis", 1989; Brokate
      and Sprekels, "Hysteresis and Phase Transitions", 1996), starting from
      z = 0 (last seen straight):
      a bend read rising lags by r, falling leads by r; the loop is
      ``hysteresis`` of the span wide.
    - creep: the reading relaxes (reads less bent) toward ``creep`` span u
      with time constant ``creep_tau_s``, c' = (creep span u - c) / tau,
      discretised exactly for a target held over each sample interval:
      c_k = a c_{k-1} + (1 - a) T_{k-1}, a = exp(-1 / (rate tau)), c_0 = 0. Held
      at u from power-on the reading is lower by creep span u (1 - exp(-t / tau)).

    reading = z - c. Ranges: resistive (conductive-ink) flex sensors show
    hysteresis and a relaxation of the resistance under a held bend of a few
    percent up to about ten percent of their span, over seconds, and depart
    from a straight line by a few percent (Saggio et al., "Resistive flex
    sensors: a survey", Smart Mater. Struct. 25 (2016) 013001; Tiboni et al.,
    "Test-bench for the characterization of flexion sensors used in
    biomechanics", Electronics 10 (2021) 2994). The profile's range is 0-12 %
    for each.
    """

    hysteresis: float = 0.0  # full width of the hysteresis loop
    creep: float = 0.0  # relaxation of the reading while held fully bent (scaled by the bend)
    creep_tau_s: float = 4.0  # time constant of that relaxation
    nonlinearity: float = 0.0  # peak of the unit's smooth deviation from linear in angle


@dataclass(frozen=True)
class SensorErrors:
    """Error models of the gyroscope, accelerometer, magnetometer and flex circuit (volts),
    the board's and the room's magnetic errors and the flex sensor's dynamics."""

    gyr: ErrorModel = ErrorModel()
    acc: ErrorModel = ErrorModel()
    mag: ErrorModel = ErrorModel()
    flex: ErrorModel = ErrorModel()  # before the ADC, which quantises and saturates itself
    magnetic: MagneticErrors = MagneticErrors()
    flex_dynamics: FlexDynamics = FlexDynamics()
    dlpf: bool = False  # the gyroscope and accelerometer read through the MPU-9250's low-pass
    # filters as the firmware sets them for the sample rate (tracker.mpu_dlpf)


def mpu9250(noise: bool = True, offset: bool = True, scale: bool = False,
            acc_fs_g: int = 16, gyr_fs_dps: int = 2000) -> SensorErrors:
    """MPU-9250 data-sheet errors; the finger-tracking paper (sec. 3) ran noise only, offset only, and both.

    The finger-tracking paper assumed calibrated scale factors, hence ``scale`` off by default;
    ``scale`` brings the cross-axis sensitivities (:class:`ErrorModel`) with the scale factors.
    Quantisation and saturation are those of 16-bit counts at the full scales
    (the virtual board's defaults). The magnetometer has white noise
    (:data:`MAG_NOISE_DENSITY`), is quantised (0.15 uT) and saturated; the
    chip alone, on no board and in no room (see :func:`realistic_errors`).
    """
    gyr_fs, acc_fs = math.radians(gyr_fs_dps), acc_fs_g * STANDARD_GRAVITY
    return SensorErrors(
        gyr=ErrorModel(noise_density=GYR_NOISE_DENSITY * noise, offset_max=GYR_OFFSET_MAX * offset,
                       scale_max=SCALE_TOLERANCE * scale, cross_axis_max=CROSS_AXIS_TOLERANCE * scale,
                       resolution=gyr_fs / 32768, full_scale=gyr_fs),
        acc=ErrorModel(noise_density=ACC_NOISE_DENSITY * noise, offset_max=ACC_OFFSET_MAX * offset,
                       scale_max=SCALE_TOLERANCE * scale, cross_axis_max=CROSS_AXIS_TOLERANCE * scale,
                       resolution=acc_fs / 32768, full_scale=acc_fs),
        mag=ErrorModel(noise_density=MAG_NOISE_DENSITY * noise, resolution=MAG_UT_PER_COUNT,
                       full_scale=MAG_FULL_SCALE_UT, rate_hz=MAG_RATE_HZ),
    )


def realistic_errors(gyro_bias_dps: float = TYPICAL_GYRO_BIAS_DPS, noise_scale: float = 1.0,
                     gyro_warmup_dps: float = TYPICAL_GYRO_WARMUP_DPS,
                     mag_hard_iron_ut: float = TYPICAL_MAG_HARD_IRON_UT,
                     mag_soft_iron_pct: float = TYPICAL_MAG_SOFT_IRON_PCT,
                     mag_disturbance_ut: float = TYPICAL_MAG_DISTURBANCE_UT,
                     flex_hysteresis_pct: float = TYPICAL_FLEX_HYSTERESIS_PCT,
                     flex_creep_pct: float = TYPICAL_FLEX_CREEP_PCT,
                     flex_nonlinearity_pct: float = TYPICAL_FLEX_NONLINEARITY_PCT) -> SensorErrors:
    """A real board's errors from figures in a player profile's units (deg/s, uT, percent).

    :func:`mpu9250` (data-sheet noise, offsets, 16-bit counts, and the
    sensitivities drawn within the data sheet's +-3 % for the gyroscope and the
    accelerometer, PS-MPU-9250A-01 tables 1 and 2: the maker's six-pose
    calibration measures the accelerometer's; no procedure measures the
    gyroscope's, which needs turns of known size) with the
    gyroscope's offsets drawn within +-``gyro_bias_dps`` and warming by
    ``gyro_warmup_dps`` over 10 minutes (:class:`ErrorModel`), the IMU's noise
    densities times ``noise_scale``, the board's and the room's magnetic
    errors (:class:`MagneticErrors`), the flex sensor's dynamics
    (:class:`FlexDynamics`) and :data:`TYPICAL_FLEX_NOISE_COUNTS` of noise on
    the flex circuit. Its gyroscope and accelerometer read through the MPU-9250's
    low-pass filters (:mod:`tracker.mpu_dlpf`: 41 and 44.8 Hz, 5.9 and 4.88 ms late at 200 Hz).
    The accelerometer's zero-g level warms with the die (:func:`die_rise_c`) by
    :data:`ACC_ZERO_G_TEMPCO` per degC, on the gyroscope's warm-up curve, with the
    same share of it drawn anew at every power-on (thermal hysteresis, as the
    gyroscope's: :class:`ErrorModel`).
    The defaults, the TYPICAL_* constants, are a typical
    board within the cited ranges: gyroscope offsets within +-1 deg/s (the
    data sheet allows +-5), 4 degC of warming (1 deg/s, 27 % of it unpredictable
    from the die's temperature on average: :class:`ErrorModel`), 30 uT of hard iron
    and 5 % of soft iron, 5 uT of room disturbance
    (de Vries et al. 2009's 3 deg of heading spread above 1 m, in a 20 uT
    horizontal field, is about 1 uT; a living room's furniture and floor
    more), a flex sensor with 4 % hysteresis, 3 % creep and 2 % nonlinearity
    (Saggio et al. 2016).
    """
    base = mpu9250(scale=True)
    circuit = FlexCircuit()
    gyr = replace(base.gyr, noise_density=base.gyr.noise_density * noise_scale,
                  offset_max=math.radians(gyro_bias_dps), warmup=math.radians(gyro_warmup_dps),
                  warmup_unexplained=TYPICAL_WARMUP_UNEXPLAINED)
    return SensorErrors(
        gyr=gyr,
        acc=replace(base.acc, noise_density=base.acc.noise_density * noise_scale,
                    warmup=ACC_ZERO_G_TEMPCO * die_rise_c(gyr), warmup_unexplained=TYPICAL_WARMUP_UNEXPLAINED),
        mag=replace(base.mag, noise_density=base.mag.noise_density * noise_scale),
        flex=ErrorModel(noise_density=TYPICAL_FLEX_NOISE_COUNTS * circuit.lsb_v / math.sqrt(200.0)),
        magnetic=MagneticErrors(hard_iron_ut=mag_hard_iron_ut, soft_iron=mag_soft_iron_pct / 100.0,
                                disturbance_ut=mag_disturbance_ut),
        flex_dynamics=FlexDynamics(hysteresis=flex_hysteresis_pct / 100.0, creep=flex_creep_pct / 100.0,
                                   nonlinearity=flex_nonlinearity_pct / 100.0),
        dlpf=True,
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
    p_sensors: Array  # (N, S, 3) sensor positions in the world, metres


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
    cross: dict[str, Array]  # the cross-axis matrices C drawn, by kind (ErrorModel; (S, 3, 3), zero diagonal)
    warmup: dict[str, Array]  # the offsets' change after WARMUP_SPAN_S (warmup * u), by kind
    hard_iron: Array  # (S, 3) uT, the board's hard iron drawn
    soft_iron: Array  # (S, 3, 3) the soft-iron matrices I + E drawn
    flex_reading_deg: Array  # (N,) the angle the flex sensor reports, after its dynamics
    die_c: Array  # (N,) the IMU die's temperature, degC (die_temperature)


def _stencil_sum(weights: Array, x: Array) -> Array:
    """sum_i weights_i x[i], term by term: every sample is rounded alike (a BLAS product's
    rounding depends on where in the array a sample is, so a block and a batch would differ)."""
    total = weights[0] * x[0]
    for w, xi in zip(weights[1:], x[1:]):
        total = total + w * xi
    return total


def _rng(seed: int, *key: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=key))


def _directions(rng: np.random.Generator, shape: tuple[int, ...]) -> Array:
    """Random directions: unit vectors (isotropic) along a last axis of 3, else signs."""
    v = rng.standard_normal(shape)
    if shape and shape[-1] == 3:
        return v / np.linalg.norm(v, axis=-1, keepdims=True)
    return np.sign(v)


def _cross_axis(bound: float, shape: tuple[int, ...], rng: np.random.Generator) -> Array:
    """The cross-axis matrices C (:class:`ErrorModel`) of sensors of ``shape`` (..., 3): off-diagonals
    drawn within +-``bound``, the diagonal 0; zeros(shape) for a sensor with no three axes."""
    if not (shape and shape[-1] == 3):
        return np.zeros(shape)
    c = rng.uniform(-bound, bound, (*shape, 3))
    c[..., [0, 1, 2], [0, 1, 2]] = 0.0
    return c


def _matvec(m: Array, v: Array) -> Array:
    """m v over the last axes, summed term by term (every sample rounded alike)."""
    terms = m * v[..., None, :]
    return terms[..., 0] + terms[..., 1] + terms[..., 2]


class _ErrorProcess:
    """One kind of sensor's errors as a function of the sample index (same index, same error)."""

    def __init__(self, model: ErrorModel, shape: tuple[int, ...], rate_hz: float,
                 seed: int, kind: int, power_on: int = 0, powered_s: float = 0.0) -> None:
        self.model, self.shape, self._key, self._powered_s = model, shape, (seed, kind), powered_s
        rng = _rng(seed, kind, 0)
        self.offset = rng.uniform(-model.offset_max, model.offset_max, shape)
        self.scale = 1.0 + rng.uniform(-model.scale_max, model.scale_max, shape)
        self.cross = _cross_axis(model.cross_axis_max, shape, _rng(seed, kind, _CROSS_KEY))
        self.warmup = np.zeros(shape)
        if model.warmup:
            if not model.warmup_tau_s > 0:
                raise ValueError(f"a warm-up needs a time constant above 0 s, not {model.warmup_tau_s}")
            r = model.warmup_unexplained
            self.warmup = model.warmup * ((1.0 - r) * _directions(_rng(seed, kind, _WARMUP_KEY), shape)
                                          + r * _directions(_rng(seed, kind, _POWER_ON_KEY, power_on), shape))
        self.rate_hz = rate_hz
        self._held = 0.0 < model.rate_hz < rate_hz  # a sensor slower than the samples: its readings held
        self._white_std = model.noise_density * math.sqrt(model.rate_hz if self._held else rate_hz)
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
        if m.cross_axis_max:
            x = x + _matvec(self.cross, truth)
        if m.warmup:
            x = x + self._warmup_curve(k).reshape((-1,) + (1,) * len(self.shape)) * self.warmup
        if self._white_std or self._step_std:
            noise = np.empty_like(x)
            blocks, within = np.divmod(k, _CHUNK)
            for b in sorted(set(blocks.tolist())):
                at = blocks == b
                noise[at] = self._random_block(b)[within[at]]
            x = x + noise
        if m.resolution > 0:
            x = np.round(x / m.resolution) * m.resolution
        return np.clip(x, -m.full_scale, m.full_scale)

    def read_at(self, k: NDArray[np.int64]) -> NDArray[np.int64]:
        """The samples whose readings samples ``k`` carry (:class:`ErrorModel`): ``k`` itself, or for a
        sensor with a slower output rate the first sample at or after its latest tick."""
        if not self._held:
            return k
        ratio = self.rate_hz / self.model.rate_hz  # samples per tick
        ticks = np.floor(k / ratio + 1e-9)
        return np.ceil(ticks * ratio - 1e-9).astype(np.int64)

    def _warmup_curve(self, k: NDArray[np.int64]) -> Array:
        return warmup_curve(k / self.rate_hz + self._powered_s, self.model.warmup_tau_s)


def warmup_curve(t: Array, tau_s: float) -> Array:
    """(1 - exp(-t / tau)) / (1 - exp(-WARMUP_SPAN_S / tau)) at ``t`` s after power-on (:class:`ErrorModel`)."""
    return np.expm1(-t / tau_s) / math.expm1(-WARMUP_SPAN_S / tau_s)


def die_rise_c(gyr: ErrorModel) -> float:
    """How far the die warms in the first WARMUP_SPAN_S: the gyroscope's warm-up over the data sheet's
    steepest slope, :data:`ZRO_TEMPCO_DPS_PER_C` (the smallest rise that can move it so far)."""
    return math.degrees(gyr.warmup) / ZRO_TEMPCO_DPS_PER_C


def die_temperature(gyr: ErrorModel, t: Array) -> Array:
    """The IMU die's temperature (degC) at ``t`` s after power-on: :data:`ROOM_C` warming along the
    gyroscope's warm-up curve by :func:`die_rise_c` (one lumped thermal mass, :class:`ErrorModel`)."""
    if not gyr.warmup:
        return np.full(np.shape(t), ROOM_C)
    return ROOM_C + die_rise_c(gyr) * warmup_curve(t, gyr.warmup_tau_s)


class _MagneticProcess:
    """The board's hard and soft iron and the room's field, drawn once (:class:`MagneticErrors`)."""

    def __init__(self, model: MagneticErrors, sensors: int, seed: int) -> None:
        self.model = model
        rng = _rng(seed, _MAG_KEY, 0)
        self.hard_iron = model.hard_iron_ut * _directions(rng, (sensors, 3))
        e = rng.uniform(-model.soft_iron, model.soft_iron, (sensors, 3, 3))
        self.soft_iron = np.eye(3) + np.triu(e) + np.swapaxes(np.triu(e, 1), -1, -2)
        rng = _rng(seed, _MAG_KEY, 1)
        along = _directions(rng, (_MAG_MODES, 3))
        across = rng.standard_normal((_MAG_MODES, 3))
        across -= np.sum(across * along, axis=1, keepdims=True) * along  # c_j perpendicular to k_j
        share = rng.uniform(0.5, 1.5, _MAG_MODES)
        size = model.disturbance_ut * share / share.sum()
        self._amplitudes = size[:, None] * across / np.linalg.norm(across, axis=1, keepdims=True)
        if model.disturbance_ut and not model.disturbance_scale_m > 0:
            raise ValueError(f"a magnetic disturbance needs a scale above 0 m, "
                             f"not {model.disturbance_scale_m}")
        self._wavevectors = along * (2 * math.pi / model.disturbance_scale_m if model.disturbance_ut else 0.0)
        self._phases = rng.uniform(0.0, 2 * math.pi, _MAG_MODES)

    def disturbance(self, p: Array) -> Array:
        """d(p) = sum_j c_j cos(k_j . p + phi_j), uT, at positions ``p`` (..., 3) in metres."""
        d = np.zeros(p.shape)
        for k, c, phase in zip(self._wavevectors, self._amplitudes, self._phases):
            d = d + np.cos(p[..., 0:1] * k[0] + p[..., 1:2] * k[1] + p[..., 2:3] * k[2] + phase) * c
        return d

    def field(self, truth: Truth) -> Array:
        """What the magnetometers feel before their own errors: (I + E) R^T (m + d(p)) + h."""
        if self.model == MagneticErrors():
            return truth.mag
        body = truth.mag
        if self.model.disturbance_ut:
            body = body + quat.rotate(quat.conjugate(truth.q_sensors), self.disturbance(truth.p_sensors))
        return _matvec(self.soft_iron, body) + self.hard_iron


State = tuple[float, float, float]  # the flex dynamics after a sample: play output, creep, creep target


class _FlexProcess:
    """The flex sensor's dynamics (:class:`FlexDynamics`) on the true elbow angle, in degrees.

    Hysteresis and creep remember the past, so the reading of sample k
    depends on every sample before it. The process keeps the state before
    each sample of the latest block, and before every multiple of the random
    numbers' block (4096 samples). A block that starts inside the latest
    block (a stream going on, or the simulated board computing again from an
    edit of the motion) resumes from the state kept there; any other starts
    from the nearest kept state before it, recomputing the true angles in
    between from the motion. A block's start forgets the states kept after
    it, so a motion changed after that start is honoured. So a block equals
    the same rows of a batch, as long as the motion before the block's start
    is what it was when those samples were first computed (the motion may
    change, or forget its past, only after the samples already taken: the
    contract of :class:`SampleStream`).
    """

    def __init__(self, model: FlexDynamics, span_deg: float, rate_hz: float, seed: int) -> None:
        if not 0 <= model.nonlinearity < 1 / (2 * math.pi):
            raise ValueError(f"a flex nonlinearity must lie in [0, 1/(2 pi)) to keep the sensor "
                             f"monotonic, not {model.nonlinearity}")
        if model.creep and not model.creep_tau_s > 0:
            raise ValueError(f"flex creep needs a time constant above 0 s, not {model.creep_tau_s}")
        self.model, self.span = model, span_deg
        self._bow = self._draw_bow(seed)
        self._half_width = model.hysteresis * span_deg / 2
        self._decay = math.exp(-1.0 / (rate_hz * model.creep_tau_s)) if model.creep else 0.0
        self._stateful = model.hysteresis > 0 or model.creep > 0
        self._marks: dict[int, State] = {0: (0.0, 0.0, 0.0)}  # sample index -> the state before it
        self._trail: tuple[int, Array] = (0, np.zeros((1, 3)))  # the states before the latest block's samples

    @staticmethod
    def _draw_bow(seed: int) -> tuple[float, float]:
        """(a1, a2) of g(u) = a1 sin(pi u) + a2 sin(2 pi u), drawn and scaled to max |g| = 1 on [0, 1].

        With c = cos(pi u), g' = 0 where 4 a2 c^2 + a1 c - 2 a2 = 0, and there
        g = sqrt(1 - c^2) (a1 + 2 a2 c): the peak, exactly.
        """
        a1, a2 = (float(a) for a in _rng(seed, _FLEX_KEY).uniform(-1.0, 1.0, 2))
        if a2 == 0.0:
            return 1.0 if a1 >= 0 else -1.0, 0.0
        root = math.sqrt(a1 * a1 + 32.0 * a2 * a2)
        peak = max(abs(math.sqrt(1.0 - c * c) * (a1 + 2.0 * a2 * c))
                   for c in ((-a1 + root) / (8.0 * a2), (-a1 - root) / (8.0 * a2)) if -1.0 <= c <= 1.0)
        return a1 / peak, a2 / peak

    def reading(self, deg: Array, k0: int, earlier: Callable[[int, int], Array]) -> Array:
        """The sensor's angle for the true angles ``deg`` of samples k0, k0 + 1, ...

        ``earlier(ka, kb)`` gives the true angles of samples ka to kb - 1, for a
        block that does not start where a kept state is.
        """
        if not self._stateful:
            return self._bowed(deg) if self.model.nonlinearity else deg
        state = self._state_before(k0, earlier)
        out, states = self._run(deg, k0, state)
        self._trail = (k0, states)
        return out

    def _bowed(self, deg: Array) -> Array:
        """y = x + nonlinearity span g(u), u = clip(x / span, 0, 1)."""
        a1, a2 = self._bow
        u = np.clip(deg / self.span, 0.0, 1.0)
        bow = a1 * np.sin(np.pi * u) + a2 * np.sin(2 * np.pi * u)
        return deg + self.model.nonlinearity * self.span * bow

    def _state_before(self, k0: int, earlier: Callable[[int, int], Array]) -> State:
        for k in [k for k in self._marks if k > k0]:
            del self._marks[k]
        start, states = self._trail
        if start <= k0 < start + len(states):
            h, c, target = states[k0 - start].tolist()
            return h, c, target
        start = max(self._marks)
        h, c, target = self._run(earlier(start, k0), start, self._marks[start])[1][-1].tolist()
        return h, c, target

    def _run(self, deg: Array, k0: int, state: State) -> tuple[Array, Array]:
        """The readings of samples k0, k0 + 1, ... from ``state`` (before k0), and the states before
        each of them and after the last, (N + 1, 3); keeps those before multiples of 4096."""
        r, a, b = self._half_width, self._decay, 1.0 - self._decay
        h, c, target = state
        bowed = self._bowed(deg) if self.model.nonlinearity else deg
        goals = [target] + (self.model.creep * np.clip(deg, 0.0, self.span)).tolist()
        plays, creeps = [h], [c]
        for low, high, goal in zip((bowed - r).tolist(), (bowed + r).tolist(), goals):
            c = a * c + b * goal  # toward the target held over the interval before this sample
            if h < low:
                h = low
            elif h > high:
                h = high
            plays.append(h)
            creeps.append(c)
        states = np.array([plays, creeps, goals]).T
        for k in range(-(-k0 // _CHUNK) * _CHUNK, k0 + len(deg) + 1, _CHUNK):
            h, c, target = states[k - k0].tolist()
            self._marks[k] = (h, c, target)
        return states[1:, 0] - states[1:, 1], states


@dataclass(frozen=True)
class Simulator:
    """A chain in motion, its sensors' errors, the flex circuit and the earth's field."""

    chain: Chain
    motion: Motion
    errors: SensorErrors = SensorErrors()
    flex_sensor: FlexSensor = FlexSensor()
    flex_circuit: FlexCircuit = FlexCircuit()
    earth_field_ut: Vec3 = EARTH_FIELD_UT
    seed: int = 0  # the board's errors (and the room's field)
    power_on: int = 0  # which power-on of that board: the unexplained share of its warm-up (ErrorModel)
    powered_s: float = 0.0  # how long the board had been on before t = 0: its warm-up (and die) that far along

    def _pose(self, t: Array) -> tuple[Array, Array]:
        """The root's orientations and the hinge angles (M, L - 1) at ``t`` (M,), checked."""
        root, joints = self.motion.at(t)
        hinges = len(self.chain.links) - 1
        angles = np.asarray(joints, dtype=float).reshape(len(t), -1 if len(t) else hinges)
        if angles.shape[1] != hinges:
            raise ValueError(f"the motion gives {angles.shape[1]} joint angles; "
                             f"the chain has {hinges} hinges")
        return root, angles

    def _flexed(self, angles: Array) -> Array:
        """The flexed joint in degrees from the hinge angles (0 without one)."""
        fl = self.chain.flex_link
        return np.degrees(angles[:, fl - 1]) if fl is not None else np.zeros(len(angles))

    def flex_deg(self, t: ArrayLike) -> Array:
        """The flexed joint in degrees at times ``t``: :class:`Truth`'s ``flex_deg``, alone."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return self._flexed(self._pose(t)[1])

    def _forward(self, t: Array) -> tuple[Array, Array, Array, Array]:
        """Link orientations, joint angles, sensor orientations and positions at ``t`` (M,)."""
        links, sensors = self.chain.links, self.chain.sensors
        root, angles = self._pose(t)
        turns = quat.from_axis_angle(self.chain.hinges, angles)
        q_links = np.empty((len(t), len(links), 4))
        q_links[:, 0] = quat.normalize(root)
        for k in range(1, len(links)):
            q_links[:, k] = quat.multiply(q_links[:, k - 1], turns[:, k - 1])
        index, vectors = self.chain.arms
        arms = quat.rotate(q_links[:, index], vectors)
        origins = np.zeros((len(t), len(links), 3))
        np.cumsum(arms[:, :len(links) - 1], axis=1, out=origins[:, 1:])
        if self.motion.shoulder is not None:
            origins += np.asarray(self.motion.shoulder(t, q_links[:, 0]), dtype=float)[:, None, :]
        idx = index[len(links) - 1:]
        q_on_links, p_sensors = q_links[:, idx], origins[:, idx] + arms[:, len(links) - 1:]
        mount = self.motion.mount
        if mount is not None:
            q_on_links, p_sensors = self._mounted(mount(t), q_on_links, p_sensors)
        return q_links, angles, quat.multiply(q_on_links, [s.mount for s in sensors]), p_sensors

    def _mounted(self, q_m: Array, q_on_links: Array, p_sensors: Array) -> tuple[Array, Array]:
        """The sensors' links' orientations (M, S, 4) turned by the motion's mount q_m (M, 4), and
        the sensors' positions (M, S, 3) moved by its lever, R_link (c - R(q_m) c) (:class:`Motion`)."""
        q_m = np.asarray(q_m, dtype=float).reshape(len(q_m), 1, 4)
        pivot = np.asarray(self.motion.mount_pivot_m, dtype=float)
        if np.any(pivot):
            p_sensors = p_sensors + quat.rotate(q_on_links, pivot - quat.rotate(q_m, pivot))
        return quat.multiply(q_on_links, q_m), p_sensors

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
        return Truth(t, q_links[centre], angles[centre], q.reshape(*shape, 4), gyr.reshape(*shape, 3),
                     acc.reshape(*shape, 3), mag.reshape(*shape, 3), self._flexed(angles[centre]),
                     p_s[centre])

    def stream(self, rate_hz: float) -> SampleStream:
        """The samples at t = k / ``rate_hz``, measured a block at a time on request."""
        return SampleStream(self, rate_hz)

    def simulate(self, duration_s: float, rate_hz: float) -> SimData:
        """``round(duration * rate)`` samples at t = k / rate, measured and true."""
        return self.stream(rate_hz).block(0, round(duration_s * rate_hz))


FILTERED_CHUNK = 2048  # samples read through the low-pass filters at a time: their 1 kHz truth in memory


class SampleStream:
    """A simulator sampled at ``rate_hz``: sample k is at t = k / rate.

    Its errors are functions of the sample index (:class:`_ErrorProcess`) and
    every sample is computed alike, so ``block(k0, k1)`` is rows k0 to k1 - 1
    of ``sim.simulate(..., rate_hz)``, whatever the blocks asked for before
    (the flex sensor's hysteresis and creep carry state from block to block:
    :class:`_FlexProcess`). Nothing is computed ahead: the motion may be
    extended between calls for times after those of the blocks already taken.
    """

    def __init__(self, sim: Simulator, rate_hz: float) -> None:
        self.sim, self.rate_hz = sim, rate_hz
        n = len(sim.chain.sensors)
        shapes = {"gyr": (n, 3), "acc": (n, 3), "mag": (n, 3), "flex": ()}
        self._processes = {kind: _ErrorProcess(getattr(sim.errors, kind), shapes[kind], rate_hz,
                                               sim.seed, i, sim.power_on, sim.powered_s)
                           for i, kind in enumerate(_KINDS)}
        self._magnetic = _MagneticProcess(sim.errors.magnetic, n, sim.seed)
        self._flex = _FlexProcess(sim.errors.flex_dynamics, sim.flex_sensor.bent_deg, rate_hz, sim.seed)
        dlpf = Dlpf.for_rate(rate_hz)
        self._filters = (dlpf.gyro, dlpf.accel) if sim.errors.dlpf else None

    def _sensed(self, k0: int, k1: int) -> tuple[Truth, Array, Array]:
        """The truth of samples k0 to k1 - 1, and the rates and specific forces the IMU reads at them:
        the truth's, or with :attr:`SensorErrors.dlpf` the truth sampled at the chip's internal 1 kHz
        and read through its low-pass filters (:class:`tracker.mpu_dlpf.Response`; the first
        sample's held before sample 0)."""
        truth = self.sim.truth(np.arange(k0, k1) / self.rate_hz)
        if self._filters is None or k1 <= k0:
            return truth, truth.gyr, truth.acc
        filters = self._filters
        read = [self._filtered(filters, a, min(a + FILTERED_CHUNK, k1)) for a in range(k0, k1, FILTERED_CHUNK)]
        return truth, np.concatenate([g for g, _ in read]), np.concatenate([a for _, a in read])

    def _filtered(self, filters: tuple[Response, Response], k0: int, k1: int) -> tuple[Array, Array]:
        """The rates and specific forces of samples k0 to k1 - 1 (k1 > k0) read through ``filters``
        (the gyroscope's, the accelerometer's)."""
        gyr_filter, acc_filter = filters
        # The internal sample each reading is made at: the last at or before its instant.
        last = np.floor(np.arange(k0, k1) * (INTERNAL_HZ / self.rate_hz) + 1e-9).astype(np.int64)
        first = int(last[0]) - max(gyr_filter.taps, acc_filter.taps) + 1
        inner = self.sim.truth(np.maximum(np.arange(first, int(last[-1]) + 1), 0) / INTERNAL_HZ)
        return gyr_filter.read(inner.gyr, last - first), acc_filter.read(inner.acc, last - first)

    def _true_flex(self, k0: int, k1: int) -> Array:
        """The true elbow angles of samples k0 to k1 - 1, in degrees."""
        return self.sim.flex_deg(np.arange(k0, k1) / self.rate_hz)

    def _mag(self, k: NDArray[np.int64], field: Array) -> Array:
        """The magnetometer's readings that samples ``k`` carry, ``field`` (what it feels at samples ``k``)
        measured at the samples each reading was made (held: :meth:`_ErrorProcess.read_at`)."""
        process, read = self._processes["mag"], self._processes["mag"].read_at(k)
        if not len(k):
            return process.measure(field, k)
        k0, first = int(k[0]), int(read[0])
        if first < k0:  # the block's first reading was made before it
            earlier = self.sim.truth(np.arange(first, k0) / self.rate_hz)
            field = np.concatenate([self._magnetic.field(earlier), field])
        return process.measure(field[read - first], read)

    def block(self, k0: int, k1: int) -> SimData:
        """Samples number ``k0`` to ``k1 - 1``, measured and true."""
        if not 0 <= k0 <= k1:
            raise ValueError(f"a block of samples needs 0 <= k0 <= k1, not {k0} and {k1}")
        k = np.arange(k0, k1)
        truth, gyr, acc = self._sensed(k0, k1)
        p, circuit = self._processes, self.sim.flex_circuit
        flex = self._flex.reading(truth.flex_deg, k0, self._true_flex)
        volts = circuit.volts(self.sim.flex_sensor.ohms(flex))
        mag = self._magnetic
        return SimData(truth.t, p["gyr"].measure(gyr, k), p["acc"].measure(acc, k),
                       self._mag(k, mag.field(truth)), circuit.adc(p["flex"].measure(volts, k)),
                       truth, {kind: q.offset for kind, q in p.items()},
                       {kind: q.scale for kind, q in p.items()}, {kind: q.cross for kind, q in p.items()},
                       {kind: q.warmup for kind, q in p.items()},
                       mag.hard_iron, mag.soft_iron, flex,
                       die_temperature(self.sim.errors.gyr, truth.t + self.sim.powered_s))


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
                              flex_adc=int(data.flex_adc[n]), q=tuple(data.truth.q_sensors[n, s].tolist()),
                              die_c=float(data.die_c[n]))
                for n in range(len(data.t))]


# ------------------------------------------------------------------ presets


def arm_chain(upper_arm_m: float = 0.30, forearm_m: float = 0.27, sensor_m: float = 0.30) -> Chain:
    """Zhu & Shi's arm: the IMU on the upper arm near the elbow, the elbow a hinge about its y.

    The root is the upper arm turning about the shoulder; at identity it hangs
    along -z with the sensor
    ``sensor_m`` below the shoulder. The forearm hinges about the sensor's y
    axis (Zhu & Shi, sec. 3; ARCHITECTURE.md); a positive flex swings it toward
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
    """The virtual board's default wearer: :func:`arm_swing` on :func:`arm_chain`, worn with a
    typical real board's errors (:func:`realistic_errors`)."""
    return SimulatedSource(Simulator(arm_chain(), arm_swing(), realistic_errors(), seed=seed), rate_hz)


def finger_chain(lengths_m: Vec3 = (0.045, 0.025, 0.020), sensor_at: float = 0.5) -> Chain:
    """The finger-tracking paper's finger (sec. 2.1): three phalanges on hinges about x, each along its y.

    The root is the metacarpus, of zero length, so the first joint (MCP) is
    at the origin; its orientation is known (the finger-tracking paper tracks it optically).
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
    """The finger-tracking paper's test motion (sec. 3): still for ``delay_s``, the straight finger extends
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
