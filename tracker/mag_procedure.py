"""The guided magnetometer calibration: turn the board through all orientations, fit its iron.

Fed one raw sample at a time while the maker turns the board slowly through
every orientation, the procedure keeps the readings (bounded:
:class:`tracker.magfit.OnlineMagFit`'s store, one reading per 5 uT cube of
the reading space), shows live how much of the sphere of directions they
cover (:func:`tracker.magfit.coverage`'s 40 equal-area bins, about a centre
refitted every half second), and at the end fits the board's hard and soft
iron with :func:`tracker.magfit.fit_ellipsoid` (Li and Griffiths, "Least
squares ellipsoid specific fitting", GMP 2004, sec. 3; the model of NXP
AN4246, sec. 2-5).

It refuses, each with one line:

- too little coverage: the ellipsoid's nine parameters need readings from
  most directions (``min_coverage``);
- a magnet or iron near the board: the earth's field is 22-67 uT at its
  surface (NOAA/BGS, "The US/UK World Magnetic Model for 2020-2025",
  technical report, 2020, sec. 4; the IGRF-13 gives the same range), so
  :data:`tracker.magfit.FIELD_MAX_UT` (90 uT, with room for 20 % of soft
  iron) bounds the fitted strength. A magnet shows as readings that span
  more than the earth's field can: turning the board moves a reading by at
  most twice the field's strength on any axis, whatever the hard iron, so a
  span beyond 2 x 90 uT is refused as soon as it happens; and an AK8963
  overflow (its HOFL flag, beyond +-4912 uT) is one;
- a field that changes during the procedure: the readings of a field that
  is the same in every orientation lie on one ellipsoid, up to the
  magnetometer's noise. The noise is measured in the same readings: the
  second difference of consecutive readings, m_k+1 - 2 m_k + m_k-1, has
  variance 6 sigma^2 per axis for white noise of variance sigma^2, while a
  board turning at 90 deg/s changes it by 0.003 uT (omega^2 |h| dt^2 at 200
  Hz); a reading held from the one before (the AK8963 measures at 100 Hz,
  the board may sample at 200) is left out (:class:`_Noise`). A kept reading,
  the mean of ``average`` raw ones, n of them fresh, then lies about
  sigma_r = sigma / sqrt(n) off the ellipsoid along its radius, and the
  RMS over hundreds of readings is within a few percent of sigma_r. A fit
  whose residual exceeds ``noise_factor`` sigma_r + ``residual_floor_ut``
  (or ``max_residual`` of the strength, :data:`tracker.magfit.MAX_RESIDUAL`,
  as :func:`tracker.magfit.judge`) means the field changed (a magnet or
  steel moved, or the board moved through a disturbed room). Measured on
  the simulated maker: a 20 uT field added for 6 s of the tumble leaves
  1.1-1.3 uT of residual and 3-4 % of soft-iron error, and is refused; 10 uT
  leaves 0.4 uT and 1 %.

It reports the fit's residual, the field's strength and its dip, the angle
of the calibrated field below the horizontal: sin(dip) = -h . a / (|h| |a|),
a the accelerometer's specific force (up at rest). So that nothing but
sums is kept, the mean over the samples of h . a / |a| is computed from
running sums: with h = R W (m - b), sum(a_k^T R W (m_k - b)) = trace(R W
(sum m_k u_k^T - b sum u_k^T)), u_k = a_k / |a_k|, over the samples whose |a|
is within 10 % of g (the board turned slowly, not shaken), R the turn onto
the accelerometer's frame (below). With the board's accelerometer
calibration given, its offsets (up to 60 mg, 3.4 deg of gravity's
direction) do not bias the dip.

The frame. The accelerometer's procedure keeps, for each of its still
poses, the magnetometer's mean reading and gravity's calibrated direction
(:attr:`tracker.calibration.BoardCalibration.pose_fields`); with the fit's
hard and soft iron they turn the magnetometer's calibrated frame onto the
accelerometer's (:mod:`tracker.mag_alignment`: the dip is the same in every
orientation), and the saved soft iron includes that turn (R W). Still
poses, not the pairs kept while turning: a turning board's field and
specific force are read at instants milliseconds apart (the low-pass
filters' delays, the AK8963's 100 Hz), worth most of a degree at 90 deg/s,
and a spiral about the field's direction leaves a direction of the turn
unseen (measured on the simulated maker: the pairs left 0.6-4 % of soft-iron
error where the poses leave under 0.5 %). Without the poses (no accelerometer
calibration, or one from before they were kept, or no magnetometer during it)
the turn is the identity and the result says why.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .calibration import GRAVITY, BoardCalibration
from .mag_alignment import Alignment, AlignmentParams, fit_alignment

MIN_POSES = 4  # still poses the alignment needs: three unknown angles and the dip
from .magfit import (BINS, EARTH_MAX_UT, EARTH_MIN_UT, ELLIPSOID, ELLIPSOID_COVERAGE, FIELD_MAX_UT, FIELD_MIN_UT,
                     MAX_RESIDUAL, MagFit, MagFitError, OnlineMagFit, OnlineParams, bin_directions, bin_index,
                     fit_ellipsoid, fit_sphere)
from .protocol import RawSample

__all__ = ["MagProcedure", "MagProcedureParams", "MagResult", "MagStatus", "bin_directions"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class MagProcedureParams:
    """Settings of :class:`MagProcedure`.

    ``target_coverage``: the share of the 40 direction bins the readings
    should visit before the procedure is ready (the soft iron's six
    parameters are held the better the more of the sphere the readings
    cover); ``min_coverage``: below this share a fit is refused
    (:data:`tracker.magfit.ELLIPSOID_COVERAGE`, the least at which
    :func:`~tracker.magfit.fit_ellipsoid` fits the soft iron). ``average``:
    consecutive readings averaged into one kept (in tens, 20 Hz at 200 Hz:
    the noise down by sqrt(10), while a board turning at 90 deg/s moves 4.5
    deg in a group, whose mean lies 0.01 uT inside the sphere). ``max_residual``:
    the residual, as a share of the strength, beyond which the field changed
    (:data:`tracker.magfit.MAX_RESIDUAL`); ``noise_factor`` and
    ``residual_floor_ut``: the residual the measured noise explains (module
    docstring), beyond which the field changed too. ``field_min_ut``/``field_max_ut``:
    the strengths the earth's field can show through the board's soft iron
    (module docstring). ``refit_every_s``: seconds between the live refits of
    the centre (and, once enough is covered, of the whole fit). ``store``: how
    the readings are kept (:class:`tracker.magfit.OnlineParams`; only its
    store is used). ``still_tolerance``: samples whose |a| is within this
    share of g count toward the dip; ``alignment``:
    :func:`tracker.mag_alignment.fit_alignment`'s.
    """

    target_coverage: float = 0.9
    min_coverage: float = ELLIPSOID_COVERAGE
    max_residual: float = MAX_RESIDUAL
    noise_factor: float = 1.5
    residual_floor_ut: float = 0.3
    field_min_ut: float = FIELD_MIN_UT
    field_max_ut: float = FIELD_MAX_UT
    refit_every_s: float = 0.5
    average: int = 10
    store: OnlineParams = field(default_factory=OnlineParams)
    still_tolerance: float = 0.1
    alignment: AlignmentParams = field(default_factory=AlignmentParams)


@dataclass(frozen=True)
class MagStatus:
    """What the procedure shows now (read-only).

    ``coverage``: share of the sphere of directions covered, 0-1; ``covered``:
    per direction bin (the order of :func:`bin_directions`); ``field_ut``: the
    magnitude of the latest raw reading; ``problem``: "" or what stops a fit
    now (one line); ``message``: one line for the maker; ``ready``: enough
    coverage to finish (:meth:`MagProcedure.finish` then fits, or refuses with
    ``problem``).
    """

    coverage: float
    covered: tuple[bool, ...]
    field_ut: float
    problem: str
    message: str
    ready: bool


@dataclass(frozen=True)
class MagResult:
    """The calibration found: ``fit`` (hard iron ``fit.offset``, soft iron ``fit.soft_iron``), the
    calibrated field's strength and dip below the horizontal (degrees), the fit's residual (RMS
    of |calibrated| - strength, uT), the turn onto the accelerometer's frame (``alignment``) and
    the noise a kept reading carries as measured (sigma_r of the module docstring, uT: what the
    residual was judged against)."""

    fit: MagFit
    strength_ut: float
    dip_deg: float
    residual_ut: float
    alignment: Alignment = field(default_factory=Alignment)
    noise_ut: float = 0.0

    @property
    def soft_iron(self) -> Array:
        """The soft iron to save: the fit's, turned onto the accelerometer's frame (R W)."""
        return self.alignment.rotation @ np.array(self.fit.soft_iron)


@dataclass
class _DipSums:
    """Running sums for the dip (module docstring): sum m u^T (rows), sum u, count."""

    mu: list[float] = field(default_factory=lambda: [0.0] * 9)
    u: list[float] = field(default_factory=lambda: [0.0] * 3)
    n: int = 0

    def add(self, m: tuple[float, float, float], a: tuple[float, float, float]) -> None:
        norm = math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
        u = (a[0] / norm, a[1] / norm, a[2] / norm)
        for i in range(3):
            self.u[i] += u[i]
            for j in range(3):
                self.mu[3 * i + j] += m[i] * u[j]
        self.n += 1

    def dip_deg(self, fit: MagFit, rotation: Array) -> float:
        """The dip of the calibrated field below the horizontal, degrees (nan with no samples), the field
        turned by ``rotation`` onto the accelerometer's frame (module docstring)."""
        if not self.n:
            return math.nan
        w, b = rotation @ np.array(fit.soft_iron), np.array(fit.offset)
        up = float(np.trace(w @ (np.reshape(self.mu, (3, 3)) - np.outer(b, self.u)))) / (self.n * fit.field_ut)
        return math.degrees(math.asin(max(-1.0, min(1.0, -up))))


@dataclass
class _Noise:
    """The magnetometer's white noise from second differences of consecutive readings (module docstring).

    A reading the same as the one before is the one before, held: the AK8963
    measures at 100 Hz and the firmware sends its latest measurement with every
    sample (firmware/energyball/imu.h), so at 200 Hz each comes twice. Held
    readings add no noise of their own: they are left out of the differences
    (counted in, every second difference spans one fresh step instead of two,
    and its variance is 2 sigma^2 instead of 6), and a mean of ``average``
    readings holds only its fresh ones' noise (:meth:`mean_sigma_ut`): counted
    twice, sigma_r looked sqrt(6) smaller. A fresh measurement equal to the
    last on all three axes (per axis a difference of 0.85 uT RMS rounds to no
    0.15-uT count about 7 % of the time, so some 3e-4 for all three) is taken
    as held too, which changes nothing measurable.
    """

    CLIP_UT = 20.0  # a second difference beyond this (a jump) counts as this

    previous: list[tuple[float, float, float]] = field(default_factory=list)  # the last two fresh readings
    sum_sq: float = 0.0
    n: int = 0
    seen: int = 0  # readings, held ones included
    fresh: int = 0  # readings that were new measurements

    def restart(self) -> None:
        """The next reading does not follow the last (a gap in the samples)."""
        self.previous = []

    def add(self, m: tuple[float, float, float]) -> None:
        self.seen += 1
        if self.previous and m == self.previous[-1]:
            return  # held
        self.fresh += 1
        if len(self.previous) == 2:
            (a0, a1, a2), (b0, b1, b2) = self.previous
            d = ((m[0] - 2.0 * b0 + a0) ** 2 + (m[1] - 2.0 * b1 + a1) ** 2 + (m[2] - 2.0 * b2 + a2) ** 2)
            self.sum_sq += min(d, self.CLIP_UT * self.CLIP_UT)
            self.n += 1
            self.previous = [self.previous[1], m]
        else:
            self.previous.append(m)

    def sigma_ut(self) -> float:
        """The noise's standard deviation per axis, uT (0 before three readings)."""
        return math.sqrt(self.sum_sq / (18.0 * self.n)) if self.n else 0.0

    def mean_sigma_ut(self, average: int) -> float:
        """The noise of a mean of ``average`` consecutive readings, uT per axis: sigma over the root of the
        fresh readings among them (the share seen so far)."""
        return self.sigma_ut() / math.sqrt(max(1.0, average * self.fresh / self.seen)) if self.seen else 0.0


class MagProcedure:
    """The magnetometer procedure, streaming (module docstring). Feed raw samples; read :attr:`status`.

    ``accel``: the board's accelerometer calibration, if done, for the dip.
    """

    def __init__(self, params: MagProcedureParams = MagProcedureParams(),
                 accel: BoardCalibration | None = None) -> None:
        if not (0.0 < params.min_coverage <= params.target_coverage <= 1.0 and params.refit_every_s > 0.0
                and params.average >= 1):
            raise ValueError(f"MagProcedureParams need 0 < min_coverage <= target_coverage <= 1, a refit "
                             f"period above 0 s and an average of at least 1: {params}")
        self.params = params
        self._accel = accel
        self._store = OnlineMagFit(params.store)
        self._dip = _DipSums()
        self._low = [math.inf] * 3  # each axis's smallest and largest reading, uT
        self._high = [-math.inf] * 3
        self._group: list[float] = [0.0, 0.0, 0.0, 0.0]  # the readings being averaged: sums and count
        self._noise = _Noise()
        self._centre: tuple[float, float, float] | None = None
        self._covered: set[int] = set()  # the direction bins covered ...
        self._flags: tuple[bool, ...] = (False,) * BINS  # ... and per bin, for the status
        self._refit_t: float | None = None
        self._magnet = ""  # a magnet seen (kept: its readings are kept)
        self._fitted = ""  # what the latest live fit found wrong
        self._field = 0.0
        self._status = self._describe("turn the board slowly through all orientations")

    @property
    def status(self) -> MagStatus:
        """What the procedure shows now."""
        return self._status

    @property
    def readings(self) -> int:
        """Readings kept."""
        return self._store.kept

    def interrupted(self) -> None:
        """The link was lost (a pulled cable): the readings are kept and the procedure resumes."""
        self._refit_t = None
        self._group = [0.0, 0.0, 0.0, 0.0]
        self._noise.restart()
        self._status = self._describe(f"the board was disconnected: the {self.readings} readings so far are "
                                      f"kept; turn it on through the directions not yet covered")

    def feed(self, sample: RawSample) -> MagStatus:
        """Take one raw sample; the status after it."""
        m = sample.mag
        if sample.mag_overflow:
            self._magnet = ("a magnet near the board: the magnetometer overflowed (a field beyond its "
                            "+-4912 uT); keep magnets away and start again")
        if m is None or not all(math.isfinite(x) for x in m):
            self._status = self._describe("no magnetometer reading: is the board's AK8963 connected?")
            return self._status
        self._field = math.sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2])
        self._noise.add(m)
        self._average(m)
        c = self._accel.apply(sample).acc if self._accel is not None else sample.acc
        a = (float(c[0]), float(c[1]), float(c[2]))
        g = math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
        if abs(g - GRAVITY) <= self.params.still_tolerance * GRAVITY:
            self._dip.add(m, a)
        if self._refit_t is None or not 0.0 <= sample.t - self._refit_t < self.params.refit_every_s:
            self._refit_t = sample.t
            self._refit()
        self._status = self._describe(self._progress())
        return self._status

    def _average(self, m: tuple[float, float, float]) -> None:
        """Add ``m`` to the group being averaged; a full group's mean is kept (and its bin covered)."""
        g = self._group
        g[0], g[1], g[2], g[3] = g[0] + m[0], g[1] + m[1], g[2] + m[2], g[3] + 1.0
        if g[3] < self.params.average:
            return
        mean = (g[0] / g[3], g[1] / g[3], g[2] / g[3])
        self._group = [0.0, 0.0, 0.0, 0.0]
        self._store.add(mean)
        self._span(mean)
        c = self._centre
        if c is not None:
            b = int(bin_index(np.array([[mean[0] - c[0], mean[1] - c[1], mean[2] - c[2]]]))[0])
            if b not in self._covered:
                self._cover(self._covered | {b})

    def _cover(self, bins: set[int]) -> None:
        """Take ``bins`` as the direction bins covered (the status's flags are worked out once here,
        not for every sample)."""
        self._covered = bins
        self._flags = tuple(i in bins for i in range(BINS))

    def _span(self, m: tuple[float, float, float]) -> None:
        """Widen each axis's range by ``m``; more than the earth's field can span is a magnet."""
        for i in range(3):
            self._low[i] = min(self._low[i], m[i])
            self._high[i] = max(self._high[i], m[i])
        span = max(h - lo for h, lo in zip(self._high, self._low))
        limit = 2.0 * self.params.field_max_ut
        if span > limit and not self._magnet:
            self._magnet = (f"a magnet or iron near the board: its readings span {span:.0f} uT, more than the "
                            f"{limit:.0f} uT the earth's field ({EARTH_MIN_UT:.0f}-{EARTH_MAX_UT:.0f} uT) can "
                            f"as the board turns; keep magnets and steel away and start again")

    def _refit(self) -> None:
        """The centre and the bins covered about it; with enough covered, the whole fit's verdict."""
        x = self._store.readings()
        if len(x) < 4:
            return
        try:
            sphere = fit_sphere(x, min_coverage=0.0)
        except MagFitError:
            return
        if sphere.field_ut < self.params.field_min_ut:  # a cloud of noise about a board lying still
            self._centre = None
            self._cover(set())
            return
        centre = np.array(sphere.offset)
        self._centre = (float(centre[0]), float(centre[1]), float(centre[2]))
        d = x - centre
        self._cover(set(bin_index(d[np.linalg.norm(d, axis=1) > 0.0]).tolist()))
        self._fitted = ""
        if len(self._covered) / BINS >= self.params.target_coverage:
            try:
                self._fitted = self._judge(self._fit(x))
            except MagFitError as e:
                self._fitted = str(e)

    def _fit(self, x: Array) -> MagFit:
        """The ellipsoid through the readings; :class:`MagFitError` when the soft iron is not held."""
        p = self.params
        fit = fit_ellipsoid(x, min_coverage=p.min_coverage, ellipsoid_coverage=p.min_coverage)
        if fit.model != ELLIPSOID:
            raise MagFitError("the readings do not hold the soft iron: turn the board through more orientations")
        return fit

    def _judge(self, fit: MagFit) -> str:
        """Why ``fit`` is no calibration ("" when it is): a magnet, a changing field, no earth's field."""
        p = self.params
        earth = f"the earth's is {EARTH_MIN_UT:.0f}-{EARTH_MAX_UT:.0f} uT"
        if fit.field_ut > p.field_max_ut:
            return (f"a magnet or iron near the board: the field is {fit.field_ut:.0f} uT and {earth}; "
                    f"keep magnets and steel away and start again")
        noise = self._noise.mean_sigma_ut(p.average)
        limit = min(p.max_residual * fit.field_ut, p.noise_factor * noise + p.residual_floor_ut)
        if fit.residual_ut > limit:
            return (f"the field changed during the procedure: the readings leave a residual of "
                    f"{fit.residual_ut:.1f} uT of the {fit.field_ut:.0f} uT field, where the magnetometer's noise "
                    f"explains {noise:.1f} uT (at most {limit:.1f} uT); did a magnet or steel move near the board? "
                    f"start again")
        if fit.field_ut < p.field_min_ut:
            return f"the field is only {fit.field_ut:.0f} uT and {earth}: is the magnetometer working?"
        return ""

    def _progress(self) -> str:
        """The maker's line while nothing is wrong."""
        share, need = len(self._covered) / BINS, self.params.target_coverage
        if share >= need:
            return (f"{share:.0%} of the directions covered: enough to finish "
                    f"(turning on fills the rest)")
        return f"turn the board slowly through all orientations: {share:.0%} covered ({need:.0%} needed)"

    def _describe(self, message: str) -> MagStatus:
        problem = self._magnet or self._fitted
        share = len(self._covered) / BINS
        return MagStatus(share, self._flags, self._field, problem,
                         problem or message, share >= self.params.target_coverage)

    def finish(self) -> MagResult:
        """Fit the readings kept: the calibration, or :class:`tracker.magfit.MagFitError` saying in one
        line why not (too little coverage, a magnet near, the field changed during the procedure)."""
        if self._magnet:
            raise MagFitError(self._magnet)
        x = self._store.readings()
        if len(x) < 4:
            raise MagFitError(f"too little coverage: {len(x)} magnetometer readings; turn the board "
                              f"through all orientations")
        fit = self._fit(x)
        problem = self._judge(fit)
        if problem:
            raise MagFitError(problem)
        alignment = self._alignment(fit)
        return MagResult(fit, fit.field_ut, self._dip.dip_deg(fit, alignment.rotation), fit.residual_ut, alignment,
                         self._noise.mean_sigma_ut(self.params.average))

    def _alignment(self, fit: MagFit) -> Alignment:
        """The turn onto the accelerometer's frame, from the accelerometer procedure's still poses (module
        docstring)."""
        poses = self._accel.pose_fields if self._accel is not None else np.zeros((0, 7))
        poses = poses[poses[:, 6] > 0]
        if len(poses) < MIN_POSES:
            return Alignment(problem=f"{len(poses)} still poses of the accelerometer's procedure with magnetometer "
                                     f"readings ({MIN_POSES} needed): run calibrate accel first")
        field = (poses[:, :3] - np.array(fit.offset)) @ np.array(fit.soft_iron).T
        return fit_alignment(field, poses[:, 3:6], self.params.alignment)
