"""The sensors' warm-up calibration: the gyroscope's bias and the accelerometer's zero-g level as
lines in the die's temperature, a streaming procedure.

Why. The MPU-9250's zero-rate output moves with its temperature (+-30 deg/s
over -40 to +85 degC, PS-MPU-9250A-01 table 1). A board warms by a few degC
after power-on and on a warm arm, so its bias drifts by up to 4 deg/s over
ten minutes (:class:`tracker.sim.ErrorModel`). While the arm is raised,
part of that drift turns about the vertical, where gravity cannot see it,
and the heading walks away; the fusion can only learn it late. The die's
temperature comes with the samples (the TEMP frame, PROTOCOL.md sec. 4.3),
so the part of the drift that is a function of it can be predicted instead.

The procedure. The maker powers the board up cold (unplugged for ten
minutes or more) and leaves it lying still while it warms, ``duration_s``
(10 minutes). Fed one raw sample at a time, it averages the gyroscope and
the temperature over each second of the board's clock; a second in which the
board moved is left out (:func:`tracker.calibration.window_motion`, VQF's rest
thresholds about the second's mean: Laidig and Seel, Information Fusion 91,
2023, sec. 3.2). At the end it fits each axis's bias as a straight line in
the temperature by least squares,

    b(T) = b0 + c (T - T_ref),   T_ref the mean temperature of the still seconds,

the linear temperature model of MEMS gyroscope compensation (a few degC
lie well within a line's reach; Liu, Liu, Xu and Zhao 2018,
doi 10.1007/978-3-030-03766-6_2, fit second-order models over tens of
degrees). c and T_ref are what the board's calibration keeps
(:class:`tracker.calibration.BoardCalibration`'s ``gyro_thermal`` and
``gyro_thermal_ref_c``); b0 is not: the start-up hold and the fusion learn
the bias of the day, and the line predicts how it moves from there.

A rise below ``min_rise_c`` is a warm-up too small to measure: below
0.24 deg/s at the data sheet's steepest slope, nothing worth predicting.
From a board seen powering up (its clock read less than :data:`FRESH_POWER_S`
at the first sample; the maker was asked to power it up cold) that is a
finding, kept as such: the slopes are zero, ``warmed`` False, and the
fusion knows the warm-up is accounted for
(:meth:`tracker.calibration.BoardCalibration.gyro_thermal_known`), so it
does not take the start's bias error for a drift
(:class:`tracker.fusion.default.DefaultParams` ``drift_settle_t``). From a
board already on, a small rise says only that it was warm: refused. The
port's first opening resets an Arduino (:mod:`tracker.link`), so a board
plugged in warm a moment before also reads a fresh clock: the saved line
says what to do then (:data:`NEGLIGIBLE`).

Refused, with the reason: samples without a temperature (a firmware before
the TEMP frame), fewer than ``min_still_s`` still seconds, a rise below
``min_rise_c`` from a board that was not seen powering up. What no calibration can know: the
share of a warm-up that differs from one warming to the next (thermal
hysteresis, about a quarter; :class:`tracker.sim.ErrorModel`). The fusion's
bias tracking learns that in play (:mod:`tracker.fusion.default`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .calibration import DEG, MG, BoardCalibration, ProcedureRecord, RestParams, window_motion
from .protocol import RawSample

Array = NDArray[np.float64]

FRESH_POWER_S = 20.0  # a board whose clock reads less than this powered up just now: its warm-up is all to come
NEGLIGIBLE = ("a negligible warm-up, kept as such (if the board was warm when plugged in, "
              "unplug it for ten minutes and run this again)")


@dataclass(frozen=True)
class ThermalParams:
    """Settings of :class:`ThermalProcedure` (module docstring)."""

    duration_s: float = 600.0  # how long the board warms on the table
    min_still_s: float = 120.0  # still seconds the fit needs
    min_rise_c: float = 1.0  # the least warming that gives a slope worth keeping
    still: RestParams = RestParams(gyr_max_rate=math.inf)  # a seconds' stillness; the bias may be large


@dataclass(frozen=True)
class ThermalResult:
    """The fit: ``slope`` (rad/s per degC, per axis) about ``ref_c``; ``acc_slope`` the accelerometer's
    zero-g level's (m/s^2 per degC); ``rise_c`` the warming seen, ``residual_dps`` the RMS of the
    still seconds about the gyroscope's lines; ``problem`` why it was refused ("" when it was not)."""

    slope: Array = field(default_factory=lambda: np.zeros(3))
    acc_slope: Array = field(default_factory=lambda: np.zeros(3))
    ref_c: float = 0.0
    rise_c: float = 0.0
    residual_dps: float = 0.0
    seconds: int = 0
    problem: str = ""
    warmed: bool = True  # False: a rise below the minimum (negligible from cold, else refused)

    @property
    def ok(self) -> bool:
        return not self.problem

    @property
    def negligible(self) -> bool:
        """A board seen powering up that barely warmed: its warm-up, zero slopes, is kept."""
        return self.ok and not self.warmed


@dataclass(frozen=True)
class ThermalStatus:
    """What the procedure shows: time on the table, still seconds, the die's temperature and its rise
    so far, why the latest second was not still (or ""), whether it is done, what went wrong."""

    elapsed_s: float = 0.0
    still_s: int = 0
    die_c: float | None = None
    rise_c: float = 0.0
    moved: str = ""
    done: bool = False
    problem: str = ""

    @property
    def message(self) -> str:
        """One line for the maker."""
        if self.problem:
            return self.problem
        if self.die_c is None:
            return "waiting for the board's samples"
        head = f"leave the board still while it warms: die {self.die_c:.2f} degC (+{self.rise_c:.2f})"
        return head + (f"; this second was left out: {self.moved}" if self.moved else "")


def fit_thermal(die_c: Array, gyr: Array, acc: Array, params: ThermalParams = ThermalParams(),
                seen_powering_up: bool = False) -> ThermalResult:
    """Each axis's bias as a line in the temperature (module docstring), from still seconds' means:
    ``die_c`` (N,) degC, ``gyr`` (N, 3) rad/s and ``acc`` (N, 3) m/s^2 (the accelerometer's lines: the
    board lies still, so its reading moves only as its zero-g level does).
    Refused below the params' minimums, but for a rise too small to measure from a board seen
    powering up (``seen_powering_up``): a negligible warm-up, zero slopes."""
    n = len(die_c)
    if n < params.min_still_s:
        return ThermalResult(seconds=n, problem=f"only {n} s of the board lying still (the fit needs "
                                                f"{params.min_still_s:.0f}): keep it still and run this again")
    rise = float(np.max(die_c) - np.min(die_c))
    ref = float(np.mean(die_c))
    if rise < params.min_rise_c:
        if seen_powering_up:
            spread = float(np.sqrt(np.mean((gyr - gyr.mean(axis=0)) ** 2))) / DEG
            return ThermalResult(ref_c=ref, rise_c=rise, residual_dps=spread, seconds=n, warmed=False)
        return ThermalResult(rise_c=rise, seconds=n, warmed=False, problem=(
            f"the board warmed by only {rise:.2f} degC (at least {params.min_rise_c:.1f} is needed) and was "
            "not seen powering up: unplug it for ten minutes so that it starts cold, then run this again"))
    x = np.column_stack([np.ones(n), die_c - ref])
    coef, *_ = np.linalg.lstsq(x, np.column_stack([gyr, acc]), rcond=None)
    residual = gyr - x @ coef[:, :3]
    return ThermalResult(coef[1, :3], coef[1, 3:], ref, rise, float(np.sqrt(np.mean(residual**2))) / DEG, n)


def thermal_calibration(board_id: str, result: ThermalResult) -> tuple[BoardCalibration, ProcedureRecord]:
    """A fit's fields of the board's calibration (the slope about its reference; b0 is the day's), and the
    procedure's record (now) with its figures: the warming seen, the slope's length, the residual."""
    fitted = BoardCalibration(board_id, gyro_thermal=result.slope, gyro_thermal_ref_c=np.array(result.ref_c),
                              acc_thermal=result.acc_slope)
    figures = {"rise_c": result.rise_c, "slope_dps_per_c": float(np.linalg.norm(result.slope)) / DEG,
               "residual_dps": result.residual_dps,
               "acc_slope_mg_per_c": float(np.linalg.norm(result.acc_slope)) / MG}
    return fitted, ProcedureRecord.now("thermal", figures)


class ThermalProcedure:
    """The warm-up calibration, fed one raw sample at a time (module docstring)."""

    def __init__(self, params: ThermalParams = ThermalParams()) -> None:
        self.params = params
        self._t0: float | None = None  # board time of the first sample
        self._second: list[tuple[float, tuple[float, float, float], tuple[float, float, float]]] = []
        self._index = -1  # the second being gathered
        self._means: list[tuple[float, Array, Array]] = []  # still seconds: (die degC, gyro rad/s, acc m/s^2)
        self._first_c: float | None = None
        self._seen_powering_up: bool | None = None  # the board's clock read under FRESH_POWER_S at the first sample
        self._status = ThermalStatus()

    @property
    def status(self) -> ThermalStatus:
        return self._status

    def interrupted(self) -> None:
        """The cable was pulled: the second being gathered is dropped; the board's clock starts again
        when it is back, and the seconds gathered so far are kept (the temperature tells where they lie)."""
        self._second, self._index, self._t0 = [], -1, None

    def feed(self, sample: RawSample) -> ThermalStatus:
        """Take one sample; the status after it."""
        if self._status.done:
            return self._status
        die = sample.die_c
        if die is None:
            self._status = ThermalStatus(done=True, problem=(
                "the board sends no temperature (its firmware predates the TEMP frame, PROTOCOL.md "
                "sec. 4.3): flash the current firmware (firmware/README.md)"))
            return self._status
        if self._t0 is None:
            self._t0 = sample.t - self._status.elapsed_s
        if self._first_c is None:
            self._first_c, self._seen_powering_up = die, sample.t < FRESH_POWER_S
        elapsed = sample.t - self._t0
        index = math.floor(elapsed)
        moved = self._status.moved
        if index != self._index:
            moved = self._close_second()
            self._index = index
        self._second.append((die, sample.gyr, sample.acc))
        done = elapsed >= self.params.duration_s
        self._status = ThermalStatus(elapsed, len(self._means), die, die - self._first_c, moved, done)
        return self._status

    def _close_second(self) -> str:
        """Keep the second just gathered if the board lay still in it; why not, or ""."""
        rows, self._second = self._second, []
        if len(rows) < 2:
            return ""
        gyr, acc = np.array([r[1] for r in rows]), np.array([r[2] for r in rows])
        why = window_motion(gyr, acc, self.params.still)
        if why is None:
            self._means.append((float(np.mean([r[0] for r in rows])), gyr.mean(axis=0), acc.mean(axis=0)))
        return why or ""

    def result(self) -> ThermalResult:
        """The fit of the still seconds gathered (:func:`fit_thermal`), or why there is none."""
        if self._status.problem:
            return ThermalResult(problem=self._status.problem)
        self._close_second()
        die = np.array([m[0] for m in self._means])
        gyr = np.array([m[1] for m in self._means]).reshape(-1, 3)
        acc = np.array([m[2] for m in self._means]).reshape(-1, 3)
        return fit_thermal(die, gyr, acc, self.params, bool(self._seen_powering_up))
