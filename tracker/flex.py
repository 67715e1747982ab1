"""The elbow flex sensor: ADC -> volts -> ohms -> degrees, per-user calibration, streaming.

The circuit (Zhu & Shi, sec. 4, Fig. 4). The flex sensor is the feedback
resistor of an op-amp whose non-inverting input sits at Vref; a constant
current flows from Vcc through Rf into the inverting node and on through the
sensor, so the output is linear in the sensor's resistance:

    Vout = Vref - I * Rflex          (eq. 1)
    I    = (Vcc - Vref) / Rf         (eq. 2)

With Vcc 5.0 V, Vref 2.5 V, Rf 51 kOhm: I = 2.5 V / 51 kOhm = 49.0 uA, so
12 kOhm (straight) gives 1.912 V and 50 kOhm (fully bent) 0.049 V. The Metro
Mini's 10-bit ADC (5 V reference) reads floor(V * 1024 / 5) (ATmega328P data
sheet, sec. 24.7): 391 straight, 10 bent, 10.04 counts per kOhm.

The paper's map, theta = -(adc - 390) / 3 (eq. 3, its "V_out" is the ADC
count), agrees with the circuit at the straight end (390 vs 391.5) and puts
3 counts in a degree, i.e. 0.299 kOhm per degree. A sensor linear in angle
(the paper's own assumption) with that slope reaches 50 kOhm at
381.5 / 3 = 127 degrees, so :data:`FULL_BEND_DEG` = 127 makes the physical
model and the paper's map agree within half a degree over the whole range,
and 127 degrees lies within a normal elbow's active flexion (about 0-145).
The paper's "0-90 degree" range then covers 12 to 39 kOhm; its map extended
to the 10 counts of a full bend would read 127 degrees.

Two remarks on the circuit. Above Rf (51 kOhm) eq. 1 asks for a negative
output, which a single-supply op-amp cannot give: a full bend leaves only
about 10 counts (0.05 V) above the 0 V rail, and an open (unplugged) sensor
drives the output to that rail too; :meth:`FlexCircuit.volts` clips to the
supply. A shorted sensor reads Vref (512 counts), far above "straight".

The paper's listed weaknesses (sec. 6) -- the response differs from person to
person, the sensor fatigues, a badly worn sensor does not respond -- are met
by a per-user :class:`FlexCalibration` from poses, a range that follows the
player (:class:`FlexTracker`), and a status for a sensor at a rail or stuck.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import asdict, dataclass, fields, replace
from enum import Enum
from typing import NamedTuple, Sequence

import numpy as np
from mypy_extensions import mypyc_attr
from numpy.typing import ArrayLike, NDArray

from .atomic import atomic_write
from .userjson import JSONInputError, read_json

Array = NDArray[np.float64]
FloatOrArray = float | Array  # one count, or many (the same arithmetic on either)

FULL_BEND_DEG = 127.0  # where the paper's 3 counts/degree put 50 kOhm (module docstring)
CALIBRATION_KIND = "energyball.flex_calibration"
CALIBRATION_VERSION = 1
MAX_BENT_DEG = 180.0  # a saved calibration's full bend: no elbow folds further
MIN_SPAN_COUNTS = 20.0  # straight and bent poses closer than this: the sensor is not responding


class FlexCalibrationError(ValueError):
    """A flex calibration that cannot be used: bad poses, or a broken file."""


@dataclass(frozen=True)
class FlexCircuit:
    """The op-amp stage and the ADC (Zhu & Shi, sec. 4, eqs. 1-2)."""

    vcc_v: float = 5.0  # supply
    vref_v: float = 2.5  # non-inverting input
    rf_ohm: float = 51e3  # reference resistor
    adc_ref_v: float = 5.0  # the ATmega328P's AVcc reference
    adc_bits: int = 10

    @property
    def current_a(self) -> float:
        """I = (Vcc - Vref) / Rf (eq. 2)."""
        return (self.vcc_v - self.vref_v) / self.rf_ohm

    @property
    def adc_max(self) -> int:
        """The largest count, 1023 for 10 bits."""
        return 2**self.adc_bits - 1

    @property
    def lsb_v(self) -> float:
        """Volts per count: Vref_adc / 2^bits."""
        return self.adc_ref_v / 2**self.adc_bits

    def volts(self, ohms: ArrayLike) -> Array:
        """Vout = Vref - I * Rflex (eq. 1), clipped to the op-amp's supply rails."""
        volts = self.vref_v - self.current_a * np.asarray(ohms, dtype=float)
        return np.clip(volts, 0.0, self.vcc_v)

    def ohms(self, volts: ArrayLike) -> Array:
        """Rflex = (Vref - Vout) / I, eq. 1 solved for the resistance."""
        return (self.vref_v - np.asarray(volts, dtype=float)) / self.current_a

    def adc(self, volts: ArrayLike) -> NDArray[np.int64]:
        """The count the ADC reads: floor(V / LSB), within 0..adc_max (ATmega328P, sec. 24.7)."""
        counts = np.floor(np.asarray(volts, dtype=float) / self.lsb_v)
        return np.clip(counts, 0, self.adc_max).astype(np.int64)

    def volts_at(self, adc: ArrayLike) -> Array:
        """The voltage a count stands for: the centre of its bin, (adc + 1/2) LSB."""
        return (np.asarray(adc, dtype=float) + 0.5) * self.lsb_v

    def count_at(self, ohms: float) -> float:
        """The real count whose bin centre is the voltage at ``ohms`` (inverse of :meth:`volts_at`)."""
        return float(self.volts(ohms)) / self.lsb_v - 0.5


@dataclass(frozen=True)
class FlexSensor:
    """Resistance against elbow angle: linear between straight and fully bent.

    Linear in angle is the paper's assumption (Zhu & Shi, sec. 4), which it also
    warns is only approximate; a person's real response is captured by a
    :class:`FlexCalibration` instead. Defaults: 12 kOhm straight, 50 kOhm at
    :data:`FULL_BEND_DEG` (sec. 4).
    """

    straight_ohm: float = 12e3
    bent_ohm: float = 50e3
    bent_deg: float = FULL_BEND_DEG

    def ohms(self, deg: ArrayLike) -> Array:
        """Resistance at elbow angle ``deg``."""
        slope = (self.bent_ohm - self.straight_ohm) / self.bent_deg
        return self.straight_ohm + slope * np.asarray(deg, dtype=float)

    def degrees(self, ohms: ArrayLike) -> Array:
        """Elbow angle at resistance ``ohms`` (the inverse of :meth:`ohms`)."""
        slope = (self.bent_ohm - self.straight_ohm) / self.bent_deg
        return (np.asarray(ohms, dtype=float) - self.straight_ohm) / slope


def adc_from_degrees(deg: ArrayLike, sensor: FlexSensor = FlexSensor(),
                     circuit: FlexCircuit = FlexCircuit()) -> NDArray[np.int64]:
    """Degrees -> ohms -> volts -> ADC count: what the board reads (the simulator's model)."""
    return circuit.adc(circuit.volts(sensor.ohms(deg)))


def degrees_from_adc(adc: ArrayLike, sensor: FlexSensor = FlexSensor(),
                     circuit: FlexCircuit = FlexCircuit()) -> Array:
    """ADC count -> volts -> ohms -> degrees through the circuit (eqs. 1-2), not clamped."""
    return sensor.degrees(circuit.ohms(circuit.volts_at(adc)))


@mypyc_attr(native_class=False)  # a plain class even when compiled (README, "The compiled build")
@dataclass(frozen=True)
class FlexCalibration:
    """One person's map from ADC count to elbow angle.

    The straight pose reads ``adc_straight`` (0 degrees), the fully bent pose
    ``adc_bent`` (``bent_deg``). With u = (adc - adc_straight) / (adc_bent -
    adc_straight) the angle is

        deg = bent_deg * (u + curve * u * (u - 1)),   u clipped to [0, 1],

    every quadratic in the count through the two poses; ``curve`` = 0 is a
    line. |curve| <= 1 keeps the map monotonic on the range. Only the two
    ends move when :class:`FlexTracker` follows a player beyond the range.
    """

    adc_straight: float
    adc_bent: float
    bent_deg: float = FULL_BEND_DEG
    curve: float = 0.0

    def __post_init__(self) -> None:
        # read untyped: a value from a file may be anything, and this is where it is checked
        values = tuple(getattr(self, f.name) for f in fields(self))
        if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in values):
            raise FlexCalibrationError(f"flex calibration values must be finite numbers: {values}")
        if self.adc_straight == self.adc_bent:
            raise FlexCalibrationError("flex calibration: straight and bent read the same count")
        if self.bent_deg <= 0:
            raise FlexCalibrationError(f"flex calibration: bent angle {self.bent_deg} must be > 0")
        if abs(self.curve) > 1:
            raise FlexCalibrationError(
                f"flex calibration: curve {self.curve:.3f} would make the angle run backwards "
                "(|curve| <= 1); was the middle pose held at the angle asked for?")

    def degrees(self, adc: ArrayLike) -> Array:
        """Elbow angle for ``adc`` (0 to ``bent_deg`` at the range's ends and beyond)."""
        return np.asarray(self._angle(np.clip(self.position(np.asarray(adc, dtype=float)), 0.0, 1.0)))

    def degrees_one(self, adc: float) -> float:
        """:meth:`degrees` of one count, on plain floats (no numpy call per sample)."""
        return float(self._angle(min(1.0, max(0.0, float(self.position(adc))))))

    def position(self, adc: FloatOrArray) -> FloatOrArray:
        """u: where ``adc`` lies on the range, 0 straight, 1 bent (beyond: below 0, above 1)."""
        return (adc - self.adc_straight) / (self.adc_bent - self.adc_straight)

    def _angle(self, u: FloatOrArray) -> FloatOrArray:
        """The class doc's map from u in [0, 1] to degrees."""
        return self.bent_deg * (u + self.curve * u * (u - 1.0))

    @classmethod
    def paper(cls) -> FlexCalibration:
        """Zhu & Shi's map theta = -(adc - 390) / 3 (eq. 3) over its 0-90 degree range."""
        return cls(adc_straight=390.0, adc_bent=390.0 - 3.0 * 90.0, bent_deg=90.0)

    @classmethod
    def from_model(cls, sensor: FlexSensor = FlexSensor(),
                   circuit: FlexCircuit = FlexCircuit()) -> FlexCalibration:
        """The map of the circuit model: equal to :func:`degrees_from_adc` on the range."""
        return cls(circuit.count_at(sensor.straight_ohm), circuit.count_at(sensor.bent_ohm), sensor.bent_deg)

    @classmethod
    def from_poses(cls, straight: ArrayLike, bent: ArrayLike, bent_deg: float = FULL_BEND_DEG,
                   middle: Sequence[tuple[ArrayLike, float]] = (),
                   adc_max: int = FlexCircuit().adc_max) -> FlexCalibration:
        """Fit a person's map from the ADC samples read while holding poses.

        ``straight`` and ``bent`` are the samples of the straight arm and the
        full bend (called ``bent_deg``); each of ``middle`` is (samples, the
        angle held, e.g. 90 against a table edge). Each pose counts by its
        mean. Two poses give a line; with middle poses ``curve`` is their
        least-squares fit, an exact quadratic through one (Zhu & Shi, sec. 6:
        the response differs from person to person).
        """
        s0, s1 = _pose_mean(straight, "straight", adc_max), _pose_mean(bent, "bent", adc_max)
        if abs(s1 - s0) < MIN_SPAN_COUNTS:
            raise FlexCalibrationError(
                f"flex calibration: straight ({s0:.1f}) and bent ({s1:.1f}) read almost the same; "
                "is the flex sensor strapped across the elbow?")
        x, y = [], []
        for samples, deg in middle:
            if not 0 < deg < bent_deg:
                raise FlexCalibrationError(f"flex calibration: a middle pose at {deg} degrees "
                                           f"must lie between 0 and {bent_deg}")
            u = (_pose_mean(samples, f"{deg}-degree", adc_max) - s0) / (s1 - s0)
            x.append(u * (u - 1.0))
            y.append(deg / bent_deg - u)
        x_, y_ = np.array(x), np.array(y)
        curve = float(x_ @ y_ / (x_ @ x_)) if x and x_ @ x_ > 0 else 0.0
        return cls(s0, s1, bent_deg, curve)

    def to_json(self) -> dict:
        """The calibration as a JSON object, tagged with its kind and version."""
        return {"kind": CALIBRATION_KIND, "version": CALIBRATION_VERSION, **asdict(self)}

    @classmethod
    def from_json(cls, data: object) -> FlexCalibration:
        """Read :meth:`to_json`'s object; :class:`FlexCalibrationError` if it is not one.

        Beyond the class's own checks, a file's counts must lie on the 10-bit
        ADC's scale and its full bend within :data:`MAX_BENT_DEG`.
        """
        if not isinstance(data, dict) or data.get("kind") != CALIBRATION_KIND:
            raise FlexCalibrationError(
                f"not a flex calibration (expected kind {CALIBRATION_KIND!r})")
        if data.get("version") != CALIBRATION_VERSION:
            raise FlexCalibrationError(f"flex calibration version {data.get('version')!r} is not "
                                       f"supported (this program reads {CALIBRATION_VERSION})")
        names = [f.name for f in fields(cls)]
        missing = [n for n in names if n not in data]
        if missing:
            raise FlexCalibrationError(f"flex calibration is missing {', '.join(missing)}")
        if any(isinstance(data[n], bool) for n in names):
            raise FlexCalibrationError("flex calibration values must be numbers")
        cal = cls(**{n: data[n] for n in names})
        adc_max = FlexCircuit().adc_max
        if not (0 <= cal.adc_straight <= adc_max and 0 <= cal.adc_bent <= adc_max):
            raise FlexCalibrationError(f"flex calibration counts must lie within the ADC's 0-{adc_max}, "
                                       f"not {cal.adc_straight:g} and {cal.adc_bent:g}")
        if not cal.bent_deg <= MAX_BENT_DEG:
            raise FlexCalibrationError(f"flex calibration: bent angle {cal.bent_deg:g} must be at most "
                                       f"{MAX_BENT_DEG:g} degrees")
        return cal

    def save(self, path: str | os.PathLike) -> None:
        """Write atomically: the old file or the new one, never half of one."""
        atomic_write(path, json.dumps(self.to_json(), indent=2) + "\n")

    @classmethod
    def load(cls, path: str | os.PathLike) -> FlexCalibration:
        """Read a saved calibration; :class:`FlexCalibrationError` naming the file if broken.

        A missing file raises ``FileNotFoundError`` (a person not calibrated yet).
        """
        try:
            return cls.from_json(read_json(path))
        except JSONInputError as e:
            raise FlexCalibrationError(f"{path}: not a flex calibration (bad JSON: {e.problem})") from None
        except FlexCalibrationError as e:
            raise FlexCalibrationError(f"{path}: {e}") from None


def _pose_mean(samples: ArrayLike, what: str, adc_max: int) -> float:
    """The mean count of a held pose's samples; a clear error if they are unusable."""
    s = np.asarray(samples, dtype=float).ravel()
    if s.size == 0 or not np.all(np.isfinite(s)):
        raise FlexCalibrationError(f"flex calibration: no usable samples for the {what} pose")
    if np.any((s <= 0) | (s >= adc_max)):
        raise FlexCalibrationError(f"flex calibration: the {what} pose reads the ADC rail "
                                   "(is the flex sensor plugged in?)")
    return float(s.mean())


class FlexStatus(Enum):
    """The health of the flex signal."""

    OK = "ok"
    RAIL = "rail"  # the ADC reads 0 or full scale: unplugged (open) sensor or broken circuit
    STUCK = "stuck"  # the ADC has not changed for a long time: a loose or dead sensor


@dataclass(frozen=True)
class FlexParams:
    """How :class:`FlexTracker` smooths, adapts and judges the signal."""

    min_cutoff_hz: float = 1.5  # 1-euro cutoff when still: 1 count (0.35 deg) of noise -> 0.06 deg
    beta: float = 0.05  # 1-euro cutoff rise per deg/s: a 200 deg/s ramp -> 6.5 ms lag (class doc)
    d_cutoff_hz: float = 1.0  # 1-euro cutoff of the speed estimate (Casiez et al.'s default)
    range_tau_s: float = 1.0  # time constant with which the range follows readings beyond it
    rail_counts: int = 1  # this close to 0 or full scale is a rail (a full bend reads ~10)
    stuck_after_s: float = 10.0  # an ADC unchanged this long is reported stuck
    adc_max: int = FlexCircuit().adc_max


class FlexReading(NamedTuple):
    """One tracked flex sample (a named tuple: the cheapest record to make per sample)."""

    deg: float  # smoothed elbow angle, 0 = straight
    raw_deg: float  # the same sample through the calibration, unsmoothed
    status: FlexStatus


@dataclass
class FlexState:
    """What :class:`FlexTracker` remembers between samples."""

    calibration: FlexCalibration  # the range as adapted to the player so far
    deg: float | None = None  # smoothed angle (None before the first good sample)
    speed_dps: float = 0.0  # smoothed angular speed (1-euro's derivative)
    raw_deg: float = 0.0
    t: float = 0.0  # time of the last good sample
    adc: int | None = None  # last count seen
    changed_t: float = 0.0  # when the count last changed


def _alpha(cutoff_hz: float, dt: float) -> float:
    """Smoothing factor of a one-pole low-pass: 1 / (1 + tau / dt), tau = 1 / (2 pi fc)."""
    return 1.0 / (1.0 + 1.0 / (2.0 * math.pi * cutoff_hz * dt)) if dt > 0 else 0.0


class FlexTracker:
    """Streaming ADC count -> elbow angle: calibration, range following, smoothing, health.

    Smoothing is the 1-euro filter (Casiez, Roussel, Vogel, "1 Euro Filter: A
    Simple Speed-based Low-pass Filter for Noisy Input in Interactive Systems",
    CHI 2012): a one-pole low-pass whose cutoff rises with the smoothed speed,
    fc = min_cutoff + beta |d deg/dt|, so a still arm is steady and a snapping
    elbow (the launch gesture, Zhu & Shi, sec. 5) lags by only 1 / (2 pi fc).
    As in the paper's own algorithm (its Fig. 1 listing: dx = (x -
    x_hat_prev) * rate), the speed is the new raw angle less the previous
    *smoothed* one: it includes what the output still lags behind, so the
    cutoff rises with the lag and the output catches up sooner. On a steady
    ramp of v deg/s sampled every dt the lag tau is again 1 / (2 pi fc),
    with the speed seen as v (1 + tau / dt), which makes
    (2 pi beta v / dt) tau^2 + 2 pi (min_cutoff + beta v) tau = 1: at
    200 deg/s and 200 Hz 6.5 ms, where a speed differenced between raw
    angles gives 13.8 ms. During a brief wave the gain is larger still: the
    speed's own low-pass (``d_cutoff_hz``) has no time to settle, and the
    lag term does not wait for it. After a spike the raw angle is
    far from the smoothed one and the output returns at once, instead of
    lingering at the spike's depth while the cutoff falls back.

    Range following: a count beyond the calibrated straight or bent end pulls
    that end towards it with time constant ``range_tau_s``, so a brief spike
    barely moves it while a player who really reaches further (or a fatigued
    sensor, Zhu & Shi, sec. 6) widens the range within seconds.

    Health: a count at a rail holds the last good angle and does not move the
    range; a count unchanged for ``stuck_after_s`` is reported stuck.
    """

    def __init__(self, calibration: FlexCalibration | None = None,
                 params: FlexParams | None = None) -> None:
        self.params = params or FlexParams()
        self.state = FlexState(calibration or FlexCalibration.from_model())

    def reset(self) -> None:
        """Forget the signal's history; keep the (adapted) calibration."""
        self.state = FlexState(self.state.calibration)

    def update(self, adc: int, t: float) -> FlexReading:
        """Track one ADC count read at time ``t`` (seconds, increasing)."""
        p, s = self.params, self.state
        if s.adc != adc:
            s.adc, s.changed_t = adc, t
        if adc <= p.rail_counts or adc >= p.adc_max - p.rail_counts:
            return FlexReading(s.deg or 0.0, s.raw_deg, FlexStatus.RAIL)
        dt = max(0.0, t - s.t) if s.deg is not None else 0.0
        self._follow_range(adc, dt)
        raw = s.calibration.degrees_one(adc)
        if s.deg is None:
            s.deg = raw
        else:
            speed = (raw - s.deg) / dt if dt > 0 else s.speed_dps
            s.speed_dps += _alpha(p.d_cutoff_hz, dt) * (speed - s.speed_dps)
            s.deg += _alpha(p.min_cutoff_hz + p.beta * abs(s.speed_dps), dt) * (raw - s.deg)
        s.raw_deg, s.t = raw, t
        stuck = t - s.changed_t >= p.stuck_after_s
        return FlexReading(s.deg, raw, FlexStatus.STUCK if stuck else FlexStatus.OK)

    def _follow_range(self, adc: int, dt: float) -> None:
        """Pull the range's end that ``adc`` lies beyond towards it (see the class doc)."""
        c = self.state.calibration
        u = c.position(adc)
        if u < 0:
            end, value = "adc_straight", c.adc_straight
        elif u > 1:
            end, value = "adc_bent", c.adc_bent
        else:
            return  # within the range: nothing to follow
        k = 1.0 - math.exp(-dt / self.params.range_tau_s)
        self.state.calibration = replace(c, **{end: value + k * (adc - value)})
