"""The "Board setup" screen's logic: the maker's three calibrations, on the game's board input.

The same procedures as ``armtracker calibrate accel``, ``calibrate mag`` and
``calibrate thermal`` (:mod:`tracker.accel_procedure`, :mod:`tracker.mag_procedure`,
:mod:`tracker.thermal`), fed the raw samples the game's input keeps
(:class:`game.body.controls.SampleInput`'s ``recent``), one phase after the other:

``accel``  put each face up in turn, then lean the board on an edge a few times (the procedure
           captures a still pose by itself)
``accel_done``  the fit's residual, saved; Enter goes on to the magnetometer
``mag``  turn the board slowly through all orientations until enough directions are covered
``mag_done``  the residual, the field's strength and dip, saved; Enter goes on to the warm-up
``warm_wait``  unplug the board for ten minutes so that it cools, plug it in: a board whose clock
           says it powered up moments ago starts the warm-up (S starts it on the board as it is);
           Enter is back to the menu without it
``warm``  the board lies still while it warms (ten minutes)
``warm_done``  the bias's slope in the temperature, the warming seen, saved; Enter is back to the menu
``failed``  a fit the procedure refused (its one-line reason); R does the procedure again

Each fit is saved at once to the board's file (:func:`tracker.calibration.save_procedure`,
keeping the other procedure's fields) and handed to the game to apply. A
pulled cable forgets only the pose being held (:meth:`BoardSetup.interrupted`);
the procedure resumes when the board is back. With ``--virtual`` a simulated
maker (:class:`tracker.maker_sim.SimulatedMaker`) reads every status and does
what it asks. No pygame here: the screen (:class:`game.ui.app.BoardSetupScreen`)
draws what :class:`BoardSetup` holds.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Protocol, TypeVar

import numpy as np

from tracker import protocol as P
from tracker.accel_procedure import AccelProcedure, AccelStatus, misalignment_text, sensitivity_text
from tracker.board import BoardSettings, hello as board_hello
from tracker.calibration import (MG, BoardCalibration, CalibrationFileError, ProcedureRecord, SixPoseResult,
                                 damage, load, save_procedure)
from tracker.magfit import MagFitError
from tracker.mag_procedure import MagProcedure, MagResult, MagStatus, bin_directions
from tracker.maker_sim import SimulatedMaker, cold
from tracker.protocol import RawSample
from tracker.thermal import FRESH_POWER_S, NEGLIGIBLE, ThermalProcedure, ThermalStatus, thermal_calibration

from ..body.controls import SampleInput
from ..body.tracking import Tracking

ACCEL, ACCEL_DONE, MAG, MAG_DONE, FAILED = "accel", "accel_done", "mag", "mag_done", "failed"
WARM_WAIT, WARM, WARM_DONE = "warm_wait", "warm", "warm_done"
RUNNING = (ACCEL, MAG, WARM)
Status = TypeVar("Status", AccelStatus, MagStatus, ThermalStatus)


class Follower(Protocol):
    """Someone who reads the procedure's status and does what it asks (the simulated maker)."""

    def follow(self, status: AccelStatus | MagStatus | ThermalStatus) -> None: ...


def fresh_samples(recent: deque[RawSample], last: RawSample | None) -> list[RawSample]:
    """The samples of ``recent`` that came after ``last`` (oldest first); all of them when
    ``last`` is no longer there (the input started again, or more arrived than it keeps)."""
    out: list[RawSample] = []
    for s in reversed(recent):
        if s is last:
            break
        out.append(s)
    out.reverse()
    return out


def accel_fit(board_id: str, procedure: AccelProcedure, result: SixPoseResult
              ) -> tuple[BoardCalibration, ProcedureRecord]:
    """The accelerometer procedure's fields (the accelerometer's and the gyroscope's calibration), and its
    record (now)."""
    fitted, _ = procedure.calibration(result, board_id)
    return fitted, ProcedureRecord.now(ACCEL, {"residual_m_s2": result.residual})


def mag_fit(board_id: str, result: MagResult) -> tuple[BoardCalibration, ProcedureRecord]:
    """The magnetometer's fields of a fit, and the procedure's record (now)."""
    fitted = BoardCalibration(board_id, mag_hard_iron=np.array(result.fit.offset),
                              mag_soft_iron=result.soft_iron)
    return fitted, ProcedureRecord.now(MAG, {"residual_ut": result.residual_ut, "strength_ut": result.strength_ut,
                                             "dip_deg": result.dip_deg})


@dataclass
class BoardSetup:
    """The procedures for one board, one phase at a time (module docstring).

    ``board_id``: the board's file (:func:`tracker.calibration.board_id_of`); ``calibration``:
    the board's as loaded (None: none saved), updated as each fit is saved; ``directory``: where
    board files live (None: :func:`tracker.calibration.boards_dir`); ``maker``: told every
    status (``--virtual``); ``applied``: called with the board's calibration as saved (every
    procedure's fields), for the game to use it at once.
    """

    board_id: str
    calibration: BoardCalibration | None = None  # the board's as loaded or last saved (its accelerometer's
    # fields serve the magnetometer's dip)
    directory: Path | None = None
    maker: Follower | None = None
    applied: Callable[[BoardCalibration], None] | None = None
    phase: str = ACCEL
    accel: AccelProcedure = field(default_factory=AccelProcedure)
    mag: MagProcedure = field(default_factory=MagProcedure)
    warm: ThermalProcedure = field(default_factory=ThermalProcedure)
    failed_phase: str = ACCEL  # which procedure R does again once failed
    problem: str = ""  # why the last fit was refused, or why it could not be saved
    saved: str = ""  # where the last fit went, in words
    figures: list[str] = field(default_factory=list)  # the last fit's figures, one line each
    gravity: tuple[float, float, float] | None = None  # the latest raw specific force (m/s^2): the board "now"
    disconnected: bool = False
    notice: str = ""  # what the board's file holds that saving will replace (a damaged file), until saved

    def __post_init__(self) -> None:
        self.notice = damage(self.board_id, self.directory)

    # ---------------------------------------------------------- what the screen shows

    @property
    def accel_status(self) -> AccelStatus:
        return self.accel.status

    @property
    def mag_status(self) -> MagStatus:
        return self.mag.status

    @property
    def warm_status(self) -> ThermalStatus:
        return self.warm.status

    @staticmethod
    def directions() -> np.ndarray:
        """The magnetometer procedure's direction bins (n, 3), in :attr:`MagStatus.covered`'s order."""
        return bin_directions()

    def message(self) -> str:
        """One line for the maker: the procedure's own, or the result's."""
        if self.disconnected:
            return "the board is disconnected: plug it back in, the procedure resumes where it was"
        if self.phase == ACCEL:
            return self.accel.status.message
        if self.phase == MAG:
            return self.mag.status.message
        if self.phase == WARM_WAIT:
            return ("the sensors' warm-up drift: unplug the board for ten minutes so that it cools, then plug it "
                    "back in and leave it lying still while it warms (ten minutes)")
        if self.phase == WARM:
            return self.warm.status.message
        if self.phase == FAILED:
            return self.problem
        done = {ACCEL_DONE: "accelerometer", MAG_DONE: "magnetometer", WARM_DONE: "warm-up drift"}[self.phase]
        return f"{done} calibrated" + (f": {self.problem}" if self.problem else "")

    def keys(self) -> str:
        """The keys that work now, in words."""
        if self.phase == ACCEL:
            return "R: start again   M: skip to the magnetometer   Esc: back"
        if self.phase in (MAG, WARM):
            return "R: start again   Esc: back"
        if self.phase == ACCEL_DONE:
            return "Enter: on to the magnetometer   R: redo   Esc: back"
        if self.phase == MAG_DONE:
            return "Enter: on to the warm-up   R: redo   Esc: back"
        if self.phase == WARM_WAIT:
            return "S: start now (the board powered up cold)   Enter: done without it   Esc: back"
        if self.phase == WARM_DONE:
            return "Enter: done   R: redo   Esc: back"
        return "R: try again   Esc: back"

    # ---------------------------------------------------------- input

    def feed(self, samples: list[RawSample]) -> None:
        """Run the phase's procedure over new raw samples; the maker reads the status after them."""
        if not samples:
            return
        self.disconnected = False
        self.gravity = samples[-1].acc
        if self.phase == ACCEL:
            if self._run(self.accel.feed, samples).done:
                self._finish_accel()
        elif self.phase == MAG:
            status = self._run(self.mag.feed, samples)
            if status.ready or status.problem:  # enough covered, or what will refuse the fit is known
                self._finish_mag()
        elif self.phase == WARM_WAIT and samples[0].t < FRESH_POWER_S:
            self.start(WARM)  # the board's clock starts at power-up: it was just plugged in
        if self.phase == WARM and self._run(self.warm.feed, samples).done:
            self._finish_warm()

    def _run(self, feed: Callable[[RawSample], Status], samples: list[RawSample]) -> Status:
        """The running procedure (its ``feed``) over the samples; the maker reads the status after them."""
        for sample in samples:
            status = feed(sample)
        if self.maker:
            self.maker.follow(status)
        return status

    def interrupted(self) -> None:
        """The link was lost: the running procedure forgets only what was in progress."""
        if self.disconnected:
            return
        self.disconnected = True
        if self.phase == ACCEL:
            self.accel.interrupted()
        elif self.phase == MAG:
            self.mag.interrupted()
        elif self.phase == WARM:
            self.warm.interrupted()

    # ---------------------------------------------------------- keys

    def next(self) -> bool:
        """Enter: from the accelerometer's result on to the magnetometer, from the magnetometer's on to
        the warm-up; True when all is done (the warm-up's result, or the warm-up skipped)."""
        if self.phase in (WARM_WAIT, WARM_DONE):
            return True
        if self.phase == ACCEL_DONE:
            self.start(MAG)
        elif self.phase == MAG_DONE:
            self.start(WARM_WAIT)
        return False

    def redo(self) -> None:
        """R: the current (or the failed, or the last finished) procedure from the start."""
        phase = {FAILED: self.failed_phase, ACCEL_DONE: ACCEL, MAG_DONE: MAG, WARM: WARM_WAIT,
                 WARM_DONE: WARM_WAIT}.get(self.phase, self.phase)
        self.start(phase)

    def start(self, phase: str) -> None:
        """Begin ``phase`` (ACCEL, MAG, WARM_WAIT or WARM: S on WARM_WAIT) afresh."""
        if phase == ACCEL:
            self.accel = AccelProcedure(self.accel.params)
        elif phase == MAG:
            accel = self.calibration if self.calibration and self.calibration.record(ACCEL) else None
            self.mag = MagProcedure(self.mag.params, accel=accel)
        elif phase == WARM:
            self.warm = ThermalProcedure(self.warm.params)
        self.phase, self.problem, self.saved, self.figures = phase, "", "", []

    # ---------------------------------------------------------- results

    def _finish_accel(self) -> None:
        result = self.accel.result()
        if not result.ok:
            return self._fail(ACCEL, result.message)
        fitted, record = accel_fit(self.board_id, self.accel, result)
        self.figures = [f"residual {result.residual:.3f} m/s^2 over the {self.accel.total} poses",
                        "offset " + ", ".join(f"{v * 1000 / P.STANDARD_GRAVITY:+.0f}" for v in result.offset) + " mg",
                        "scale " + ", ".join(f"{v:.4f}" for v in result.scale) + ", "
                        + misalignment_text(result.misalignment),
                        "gyroscope " + sensitivity_text(fitted.gyro_scale)]
        self._save(ACCEL_DONE, fitted, record)

    def _finish_mag(self) -> None:
        try:
            result = self.mag.finish()
        except MagFitError as e:
            return self._fail(MAG, str(e))
        self.figures = [f"residual {result.residual_ut:.2f} uT (noise {result.noise_ut:.2f})",
                        f"field strength {result.strength_ut:.1f} uT, dip {result.dip_deg:.1f} deg",
                        "hard iron " + ", ".join(f"{v:+.1f}" for v in result.fit.offset) + " uT",
                        result.alignment.describe()]
        self._save(MAG_DONE, *mag_fit(self.board_id, result))

    def _finish_warm(self) -> None:
        result = self.warm.result()
        if not result.ok:
            return self._fail(WARM_WAIT, result.problem)
        warmed = f"warmed {result.rise_c:.2f} degC over {result.seconds} still seconds"
        if result.negligible:
            self.figures = [warmed, NEGLIGIBLE]
        else:
            slope = ", ".join(f"{v:+.4f}" for v in np.degrees(result.slope))
            self.figures = [f"bias slope {slope} deg/s per degC", warmed, f"residual {result.residual_dps:.3f} deg/s",
                            "accelerometer " + ", ".join(f"{v:+.3f}" for v in result.acc_slope / MG) + " mg per degC"]
        self._save(WARM_DONE, *thermal_calibration(self.board_id, result))

    def _fail(self, phase: str, problem: str) -> None:
        self.phase, self.failed_phase, self.problem = FAILED, phase, problem

    def _save(self, phase: str, fitted: BoardCalibration, record: ProcedureRecord) -> None:
        """Save the fit to the board's file (keeping the other procedure's fields) and apply what was saved."""
        self.phase = phase
        try:
            path, damaged = save_procedure(self.board_id, fitted, record, self.directory)
        except CalibrationFileError as e:
            self.problem = f"not saved: {e}"
            return
        self.saved = f"saved to {path}" + (f" (the damaged file kept as {damaged})" if damaged else "")
        self.notice = ""
        try:
            self.calibration = load(self.board_id, self.directory)
        except CalibrationFileError as e:  # changed or removed since: the game keeps what it had
            self.problem = str(e)
            return
        if self.applied:
            self.applied(self.calibration)


def calibration_notice(calibration: BoardCalibration, loaded: str) -> str:
    """What the game says when a board connects: what was loaded, or that nothing was (offering the setup)."""
    if calibration.procedures:
        return loaded
    return f"{loaded}: choose Board setup in the menu to calibrate the board (it plays without)"


class MakerInput(SampleInput):
    """A simulated maker's board in simulated time, without a pty or a clock: each :meth:`poll` brings
    ``frame_s`` more of its samples (the firmware's rate, quantised as the firmware does).

    For the screenshots and quick tests: the frames they draw follow the maker
    exactly and the same every run. ``energyball --virtual`` serves the same
    kind of maker on a pty, in real time (:meth:`game.ui.app.BoardSetupScreen.lend_virtual_board`).
    """

    def __init__(self, maker: SimulatedMaker, frame_s: float, tracking: Tracking | None = None) -> None:
        super().__init__(tracking)
        self.maker, self.frame_s = maker, frame_s
        s = BoardSettings()
        self.hello = board_hello(s.rate_hz, P.Mode.RAW, True, s.acc_fs_g, s.gyr_fs_dps, P.BoardError.NONE, True)
        self.t = 0.0  # the board's time, s
        self._next = 0  # the index of the next sample
        self.status = "a simulated maker's board (simulated time)"
        self.opened.set()

    def hello_now(self) -> P.Hello | None:
        return self.hello

    def power_cycle(self) -> None:
        """The maker unplugs the board, lets it cool, and plugs it back in: its next power-on (the
        warm-up starts again from cold) and its clock from 0."""
        self.maker = cold(self.maker, self.maker.rate_hz)
        self.t, self._next = 0.0, 0

    def arrived(self) -> list[P.RawSample | P.FusedSample]:
        """The samples of the next ``frame_s``."""
        self.t += self.frame_s
        rate = self.hello.rate_hz
        samples: list[P.RawSample | P.FusedSample] = []
        while self._next <= self.t * rate:
            samples.append(self.maker.raw_sample(self._next / rate, self._next))
            self._next += 1
        return samples
