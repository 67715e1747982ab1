"""From board samples to ArmPose: calibration, the default filter and the flex sensor.

This is the tracker side of the game's input (ARCHITECTURE.md: protocol ->
calibration / flex -> fusion -> ArmPose). Raw samples go through the board's
calibration (gyro bias, accelerometer), the ``default`` filter and the flex
tracker; fused samples (the board's own estimate, the paper's mode) pass
straight through. The "hold still" step of the wearing calibration gives the
filter its gyro bias here, and the first sample after a start tells it the
board's age (device time starts at power-up), so a board still warming up has
its bias's drift learned from the start. Once the wearing calibration or a
recenter has taken "forward" (:meth:`Tracking.anchor_heading`), the pose keeps
it while the magnetometer's heading settles (:mod:`game.body.heading_anchor`).
The ``default`` filter gets the accelerometer moved to the shoulder
(:mod:`tracker.lever_arm`): the arm's turns about the shoulder taken off, at
the rate its bias estimate corrects, so its inclination, and with it the bias
it learns in motion, sees gravity rather than the arm's swings.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from tracker import protocol as P
from tracker.calibration import BiasResult, BoardCalibration, StartupParams, startup_bias
from tracker.flex import FlexCalibration, FlexTracker
from tracker.fusion.base import Filter
from tracker.fusion.default import DefaultFilter, for_mpu9250
from tracker.fusion.qmath import about_z, as_vec, mul
from tracker.lever_arm import LeverArm

from .heading_anchor import HeadingAnchor
from .pose import ArmPose

MAX_GAP_S = 0.5  # a longer gap in device time (link loss) restarts the time base


def game_filter() -> DefaultFilter:
    """The filter the game fuses with: the default one for the board's start-up rate, its
    accelerometer moved to the shoulder (:func:`tracker.fusion.default.for_mpu9250`)."""
    return for_mpu9250(P.BOOT_RATE_HZ, at_shoulder=True)


@dataclass
class Tracking:
    """Turns a stream of board samples into ArmPoses."""

    use_magnetometer: bool = True
    board: BoardCalibration = field(default_factory=BoardCalibration)
    flex_calibration: FlexCalibration | None = None
    # at_shoulder: ``lever`` moves the accelerometer to the shoulder; another filter: tracker.fusion.make
    filter: Filter = field(default_factory=game_filter)
    flex: FlexTracker = field(init=False)
    anchor: HeadingAnchor = field(default_factory=HeadingAnchor)  # "forward" as the field's heading settles
    lever: LeverArm = field(default_factory=LeverArm)  # the accelerometer moved to the shoulder
    _last_t: float | None = None
    _dt: float = 0.005

    def __post_init__(self) -> None:
        self.flex = FlexTracker(self.flex_calibration)

    def reset(self) -> None:
        """Start over (a new board, or the board restarted)."""
        self.filter.reset()
        self.flex.reset()
        self.lever.reset()
        self.anchor = HeadingAnchor()
        self._last_t = None

    def anchor_heading(self) -> None:
        """The wearing calibration took "forward" from the pose just given: from now on the
        turns of the magnetometer's heading that settle the start's error leave it (HeadingAnchor)."""
        f = self.filter
        if isinstance(f, DefaultFilter) and self._last_t is not None:
            f.reference_taken()
            self.anchor.set(self._last_t, f.heading, f.heading_spread, f.provisional_heading, f.taken_back)

    def feed(self, sample: P.RawSample | P.FusedSample) -> ArmPose:
        """The arm pose after one sample."""
        if isinstance(sample, P.FusedSample):
            return ArmPose(sample.q, sample.flex_deg, sample.t)
        t = sample.t
        if self._last_t is None and isinstance(self.filter, DefaultFilter):
            # device time is the board's age (its clock starts at power-up); a calibrated warm-up is
            # corrected only where the board sends its die's temperature
            self.filter.power_on(t, self.board.gyro_thermal_known and sample.temp_counts is not None)
        dt = self._step(t)
        acc, gyr, mag = self.board.apply(sample)
        if isinstance(self.filter, DefaultFilter):  # (the filters compared with it are fed as they were)
            b = self.filter.bias
            acc = self.lever.at_shoulder((gyr[0] - b[0], gyr[1] - b[1], gyr[2] - b[2]), (acc[0], acc[1], acc[2]),
                                         self.filter.quat, dt, self.filter.params.acc_lead_s)
        q = self.filter.update(gyr, acc, mag if self.use_magnetometer else None, dt)
        if self.anchor.t0 is not None and isinstance(self.filter, DefaultFilter):
            f = self.filter
            offset = self.anchor.follow(t, f.heading, f.provisional_heading, f.taken_back)
            if offset:  # a clean field (or none) leaves it 0: no turn to compose per sample
                q = mul(about_z(-offset), q)
        return ArmPose(q, self.flex.update(sample.flex_adc, t).deg, t)

    def _step(self, t: float) -> float:
        """The time since the last sample; the last good one after a gap or a restart."""
        if self._last_t is not None and 0.0 < t - self._last_t < MAX_GAP_S:
            self._dt = t - self._last_t
        self._last_t = t
        return self._dt

    def hold_still(self, samples: Sequence[P.RawSample],
                   params: StartupParams | None = None) -> tuple[BiasResult, list[ArmPose]]:
        """"Hold still": the gyro bias over these samples (judged with ``params``, the default
        hold's when None), and the hold's poses redone with it.

        The bias goes to the filter if the samples were still. Either way the
        samples are run again from a fresh filter state (keeping the best bias
        known), since the filter first ran through the hold with the bias
        uncorrected; the poses of the hold are what the wearing calibration uses.
        """
        raw = [s for s in samples if isinstance(s, P.RawSample)]
        if not raw:
            return BiasResult(False, "no raw samples arrived (is the board streaming raw data?)",
                              np.zeros(3), np.zeros(3), 0.0), []
        t = np.array([s.t for s in raw])
        acc = np.array([s.acc for s in raw])
        known = all(s.temp_counts is not None for s in raw)
        die = np.array([s.die_c for s in raw], dtype=float) if known else None
        calibrated = self.board.apply_arrays(acc, [s.gyr for s in raw], None, die)
        result = startup_bias(t, calibrated.gyr, calibrated.acc, params)  # both in the calibrated frame
        if isinstance(self.filter, DefaultFilter):  # the filter that estimates the bias keeps the best known
            bias = as_vec(result.bias) if result.ok else self.filter.get_state().bias
            self.reset()
            state = self.filter.get_state()
            state.bias = bias
            self.filter.set_state(state)
        else:
            self.reset()
        return result, [self.feed(s) for s in raw]
