"""The maker's calibrations in the terminal: ``armtracker calibrate accel``, ``calibrate mag``, ``calibrate show``.

The procedures themselves (what to ask for, when a pose is captured, the
fits) are :mod:`tracker.accel_procedure` and :mod:`tracker.mag_procedure`,
which the game's Board setup screen runs too. This module is their terminal
side: it feeds them the link's raw samples, shows their status on a live line
(:class:`Terminal`), says what happened on lines that stay (prompts, captures,
refusals, a pulled cable and the board's return), saves the result in the
board's file (:func:`tracker.calibration.save_procedure`: atomically, the other
procedure's fields kept, a damaged file copied aside first) and reports it, as
JSON with ``--json``.

With ``--virtual`` a simulated maker (:class:`tracker.maker_sim.SimulatedMaker`)
holds the virtual board and follows the same prompts (:meth:`follow` after
every poll), so the whole procedure runs unattended through a real pty, and
the report adds the errors left after the fit against the simulated board's
true errors (:func:`tracker.maker_sim.calibration_errors`).

A pulled cable: the link reconnects by itself (:mod:`tracker.link`); the
procedure is told (``interrupted()``: captured poses and readings are kept)
and carries on when the board is back. Ctrl-C, SIGTERM or SIGHUP end the
command with nothing saved (the file is written only once the fit is done,
atomically), exit 128 + the signal's number.
"""

from __future__ import annotations

import contextlib
import json
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import IO, TYPE_CHECKING, Callable, Generic, Iterator, Protocol, Sequence, TypeVar

import numpy as np

from . import calibration as C
from .accel_procedure import FACES, TILTED, AccelProcedure, AccelStatus, misalignment_text, sensitivity_text
from .link import Link
from .mag_procedure import MagProcedure, MagStatus
from .magfit import MagFitError
from .protocol import BoardError, Hello, RawSample
from .thermal import NEGLIGIBLE, ThermalParams, ThermalProcedure, ThermalStatus, thermal_calibration

if TYPE_CHECKING:  # the virtual board and the simulated maker are POSIX only (a pty): imported when used
    from .board import VirtualBoard
    from .maker_sim import SimulatedMaker

POLL_S = 0.02  # how often the loop drains the link, feeds the procedure and redraws (50 Hz)
LIVE_INTERVAL_S = 0.25  # the live line on a terminal; elsewhere (a log, a test) once a second
ACCEL_SECONDS = 600.0  # the longest an accelerometer calibration may take (a fresh board waits minutes) before refused
MAG_SECONDS = 180.0  # the same for the magnetometer: turning through all orientations takes a minute or two
THERMAL_SECONDS = ThermalParams().duration_s  # how long the warm-up calibration watches the board warm
MINUTE_S = 60.0  # the warm-up's narration: a line a minute
THERMAL_GRACE_S = 30.0  # the warm-up counts the board's seconds: a pulled cable's may come later
COVERAGE_STEP = 0.25  # say so each time another quarter of the directions is covered
SETTLED_S = 0.5  # a board this long on a face captured already was laid there, not turned past it (0.2 s)

# Which way each face is for a maker holding the board (the MPU-9250's axes, printed on breakouts).
FACE_HINTS = {"+z": "chip side up", "-z": "chip side down", "+x": "the x arrow pointing up",
              "-x": "the x arrow pointing down", "+y": "the y arrow pointing up",
              "-y": "the y arrow pointing down", TILTED: "on an edge against a book, about 45 deg, a new way"}
# How `calibrate show` writes a procedure's figures (ProcedureRecord.figures), by name.
FIGURES = {"residual_m_s2": "residual {:.4f} m/s^2", "residual_ut": "residual {:.2f} uT",
           "strength_ut": "field {:.1f} uT", "dip_deg": "dip {:.1f} deg", "rise_c": "warmed {:.2f} degC",
           "slope_dps_per_c": "slope {:.3f} deg/s per degC", "residual_dps": "residual {:.3f} deg/s",
           "acc_slope_mg_per_c": "accelerometer {:.3f} mg per degC"}
# The figures --json reports against the simulated board's truth (tracker.maker_sim.calibration_errors).
TRUTH_ERRORS = {"accel": ("acc_offset_error_mg", "acc_scale_error_pct", "acc_skew_error_pct", "gyro_scale_error_pct",
                          "gyro_matrix_error_pct"),
                "mag": ("mag_hard_iron_error_ut", "mag_soft_iron_error_pct"),
                "thermal": ("gyro_thermal_error_dps_per_c", "acc_thermal_error_mg_per_c")}

Status = TypeVar("Status", AccelStatus, MagStatus, ThermalStatus)
Shown = TypeVar("Shown", covariant=True)


class Procedure(Protocol[Shown]):
    """What the loop needs of :class:`AccelProcedure`, :class:`MagProcedure` and :class:`ThermalProcedure`."""

    @property
    def status(self) -> Shown: ...

    def feed(self, sample: RawSample) -> Shown: ...

    def interrupted(self) -> None: ...


class CalibrationRefused(Exception):
    """A procedure that gave no calibration (nothing saved), worded for the maker."""


# ----------------------------------------------------------------- the terminal


class Terminal:
    """The live status line and the lines that stay, on stderr.

    On a terminal the live line is redrawn in place at most every
    :data:`LIVE_INTERVAL_S`; elsewhere it is written as a plain line once a
    second. A line that stays first clears the live line.
    """

    def __init__(self, stream: IO[str] | None = None) -> None:
        self.stream = stream or sys.stderr
        self.tty = self.stream.isatty()
        self._next = 0.0
        self._live = False

    def show(self, text: str) -> None:
        now = time.monotonic()
        if now < self._next:
            return
        self._next = now + (LIVE_INTERVAL_S if self.tty else 1.0)
        self._write("\r\x1b[K" + text if self.tty else text + "\n")
        self._live = self.tty

    def say(self, text: str) -> None:
        self._write(("\r\x1b[K" if self._live else "") + text + "\n")
        self._live = False
        self._next = 0.0  # the live line again at once, below it

    def done(self) -> None:
        """Clear the live line (a terminal's cursor goes back to the line's start)."""
        if self._live:
            self._write("\r\x1b[K")
            self._live = False

    def _write(self, text: str) -> None:
        """One write, so that a signal never cuts a line in two (its handler runs between calls)."""
        self.stream.write(text)
        self.stream.flush()


# ----------------------------------------------------------------- the loop


@dataclass
class LinkWatch:
    """Notices a pulled cable and the board's return from the link's state at each poll.

    An outage is the link disconnected, or a reconnection that happened between
    two polls (so one too short to be seen disconnected still counts).
    """

    reconnects: int
    outage: bool = False
    interruptions: int = 0

    def update(self, connected: bool, reconnects: int) -> tuple[bool, bool]:
        """(the board went away, it came back) since the last poll."""
        lost = back = False
        if (not connected or reconnects != self.reconnects) and not self.outage:
            self.outage, lost = True, True
            self.interruptions += 1
        self.reconnects = reconnects
        if connected and self.outage:
            self.outage, back = False, True
        return lost, back


@dataclass
class Steps(Generic[Status]):
    """How the loop treats one procedure: when it is finished, its live line, what to say as it goes."""

    finished: Callable[[Status], bool]
    live: Callable[[Status], str]
    narrate: Callable[[Status | None, Status, "Terminal"], None]


def run_procedure(link: Link, procedure: Procedure[Status], steps: Steps[Status], term: Terminal,
                  seconds: float, maker: SimulatedMaker | None = None) -> tuple[Status, int]:
    """Feed the link's raw samples to ``procedure`` until it is finished or ``seconds`` pass.

    Each poll: drain the link, feed the raw samples, tell the procedure of a
    pulled cable (after the samples that came before it), say what changed,
    let the simulated maker follow the prompt, redraw the live line. Returns
    the last status and how many times the board went away.
    """
    watch = LinkWatch(link.health().reconnects)
    end = time.monotonic() + seconds
    status = procedure.status
    steps.narrate(None, status, term)
    while True:
        connected, reconnects = link.connected, link.health().reconnects  # before draining: see above
        for s in link.drain():
            if isinstance(s, RawSample):
                procedure.feed(s)
        lost, back = watch.update(connected, reconnects)
        if lost:
            procedure.interrupted()
            term.say("the board went away (cable pulled?): waiting for it to come back; "
                     "what was captured is kept")
        if back:
            term.say("the board is back: carrying on")
        previous, status = status, procedure.status
        steps.narrate(previous, status, term)
        if steps.finished(status) or time.monotonic() >= end:
            term.done()
            return status, watch.interruptions
        if maker is not None:
            maker.follow(status)
        term.show(("[board away] " if watch.outage else "") + steps.live(status))
        time.sleep(POLL_S)


# ----------------------------------------------------------------- accelerometer


def _face(face: str) -> str:
    return "a leaning pose (" + FACE_HINTS[face] + ")" if face == TILTED else f"{face} up ({FACE_HINTS[face]})"


@dataclass
class AccelNarrator:
    """Says the first prompt, a board warming too fast for the poses and when it has settled, each capture
    and the next face, a face laid down again after its capture, and a board that moved during a pose.

    A captured face is said to be "already captured" only once the board has
    stayed on it for :data:`SETTLED_S`: a turn between two faces passes others
    for a fifth of a second or so, and that is no mistake of the maker's.
    """

    again: tuple[str, float] | None = None  # the captured face up again, since when (monotonic s)
    said_again: bool = False
    said_warming: bool = False

    def __call__(self, before: AccelStatus | None, st: AccelStatus, term: Terminal) -> None:
        if before is None:
            term.say("lay the board flat, each face up in turn"
                     + (f", then lean it on an edge {st.leaning} times" if st.leaning else "")
                     + "; a pose is captured once the board has lain still on it for a moment. "
                     + f"Put {_face(st.asked or FACES[0])}")
            return
        if st.waiting and st.warming is not None and not self.said_warming:
            self.said_warming = True
            term.say(st.message)
        if before.waiting and not st.waiting and st.warming is not None:
            term.say(f"the board's temperature has settled ({st.warming:+.1f} degC a minute): the poses can be held")
        for face in st.captured[len(before.captured):]:
            term.say(f"captured {face} ({len(st.captured)} of {st.total})"
                     + (f"; now {'make' if st.asked == TILTED else 'put'} {_face(st.asked)}" if st.asked else ""))
        if "moved" in st.message and "moved" not in before.message:
            term.say(st.message)
        again = st.up if st.up is not None and "already captured" in st.message else None
        if again is None or self.again is None or self.again[0] != again:
            self.again, self.said_again = ((again, time.monotonic()) if again else None), False
        elif not self.said_again and time.monotonic() - self.again[1] >= SETTLED_S:
            term.say(st.message)
            self.said_again = True


def live_accel(st: AccelStatus) -> str:
    marks = " ".join(f if f in st.captured else "--" for f in FACES)
    if st.leaning:
        marks += f" lean {st.leaned}/{st.leaning}"
    return f"[{marks}]  {st.message}"


def finish_accel(board_id: str, procedure: AccelProcedure, status: AccelStatus,
                 seconds: float) -> tuple[C.BoardCalibration, C.ProcedureRecord, dict, list[str]]:
    """The calibration of a finished accelerometer procedure, its record, its report; refused when
    not all six faces were captured in time or their fit failed."""
    if not status.done:
        missing = [f for f in FACES if f not in status.captured]
        left = status.leaning - status.leaned
        todo = missing + ([f"{left} leaning pose{'s' if left > 1 else ''}"] if left else [])
        warm = (f"; the board was still warming ({status.warming:+.1f} degC a minute): leave it on a few minutes "
                "and run this again") if status.waiting and status.warming is not None else ""
        raise CalibrationRefused(f"only {len(status.captured)} of {status.total} poses captured in {seconds:g} s "
                                 f"({', '.join(todo)} still to do){warm}; nothing was saved")
    result = procedure.result()
    if not result.ok:
        raise CalibrationRefused(f"{result.message}; nothing was saved")
    fitted, gyro = procedure.calibration(result, board_id)
    values = {"faces": list(status.captured), "acc_offset": fitted.acc_offset.tolist(),
              "acc_scale": fitted.acc_scale.tolist(), "acc_misalignment": fitted.acc_misalignment.tolist(),
              "residual_m_s2": result.residual, "gyro_scale": gyro.matrix.tolist(), "gyro_turns": gyro.turns,
              "gyro_residual_deg": gyro.residual_deg}
    gyro_line = (f"gyroscope: {sensitivity_text(gyro.matrix)} from {gyro.turns} turns between the "
                 f"poses, residual {gyro.residual_deg:.3f} deg") if gyro.ok else \
        f"gyroscope: sensitivities not measured ({gyro.problem}); kept at 1"
    return fitted, C.ProcedureRecord.now("accel", {"residual_m_s2": result.residual}), values, \
        [f"accelerometer: {result.message}", gyro_line]


# ----------------------------------------------------------------- magnetometer


@dataclass
class MagNarrator:
    """Says the first prompt, each further quarter of coverage and each new problem."""

    said_coverage: float = 0.0
    said_problem: str = ""

    def __call__(self, before: MagStatus | None, st: MagStatus, term: Terminal) -> None:
        if before is None:
            term.say("turn the board slowly through all orientations (every face up, every heading), "
                     "away from magnets, speakers and steel")
        while st.coverage >= self.said_coverage + COVERAGE_STEP:
            self.said_coverage += COVERAGE_STEP
            term.say(f"{self.said_coverage:.0%} of the directions covered")
        if st.problem and st.problem != self.said_problem:
            term.say(st.problem)
        self.said_problem = st.problem


def live_mag(st: MagStatus) -> str:
    return f"covered {st.coverage:4.0%}  field {st.field_ut:6.1f} uT  {st.message}"


def finish_mag(board_id: str, procedure: MagProcedure, status: MagStatus,
               seconds: float) -> tuple[C.BoardCalibration, C.ProcedureRecord, dict, list[str]]:
    """The magnetometer procedure's fit as a calibration, its record, its report; refused with the
    procedure's reason (too little coverage, a magnet, a changing field)."""
    try:
        result = procedure.finish()
    except MagFitError as e:
        late = "" if status.ready or status.problem else f"after {seconds:g} s, "
        raise CalibrationRefused(f"{late}{e}; nothing was saved") from None
    fitted = C.BoardCalibration(board_id, mag_hard_iron=np.array(result.fit.offset),
                                mag_soft_iron=result.soft_iron)
    figures = {"residual_ut": result.residual_ut, "strength_ut": result.strength_ut, "dip_deg": result.dip_deg}
    aligned = result.alignment
    values = {"coverage": status.coverage, "mag_hard_iron": fitted.mag_hard_iron.tolist(),
              "mag_soft_iron": fitted.mag_soft_iron.tolist(), **figures,
              "alignment_deg": aligned.turn_deg, "alignment_problem": aligned.problem, "noise_ut": result.noise_ut}
    line = (f"magnetometer: hard iron ({_numbers(fitted.mag_hard_iron, '{:+.1f}')}) uT, soft iron rows "
            f"{_rows(fitted.mag_soft_iron)}; residual {result.residual_ut:.2f} uT (noise {result.noise_ut:.2f}), field "
            f"{result.strength_ut:.1f} uT, dip {result.dip_deg:.1f} deg; {aligned.describe()}")
    return fitted, C.ProcedureRecord.now("mag", figures), values, [line]


# ----------------------------------------------------------------- the sensors' warm-up drift


@dataclass
class ThermalNarrator:
    """Says the first prompt, a line each minute, and each new reason a second was left out."""

    said_minutes: int = 0
    said_moved: str = ""

    def __call__(self, before: ThermalStatus | None, st: ThermalStatus, term: Terminal) -> None:
        if before is None:
            term.say("the sensors' warm-up drift: power the board up cold (unplugged for ten minutes or more) and "
                     "leave it lying still while it warms; nothing to do until it is done")
        minutes = int(st.elapsed_s // MINUTE_S)
        if minutes > self.said_minutes and st.die_c is not None:
            self.said_minutes = minutes
            term.say(f"{minutes} min: die {st.die_c:.2f} degC (+{st.rise_c:.2f}), {st.still_s} still seconds")
        if st.moved and st.moved != self.said_moved:
            term.say(f"a second was left out: {st.moved}")
        self.said_moved = st.moved


def live_thermal(st: ThermalStatus) -> str:
    return f"[{st.elapsed_s / MINUTE_S:4.1f} min]  {st.message}"


def finish_thermal(board_id: str, procedure: ThermalProcedure, status: ThermalStatus,
                   seconds: float) -> tuple[C.BoardCalibration, C.ProcedureRecord, dict, list[str]]:
    """The warm-up's fit as a calibration, its record, its report; refused when the board stopped
    sending before the end, sent no temperature, lay still too little or barely warmed."""
    if not status.done:
        raise CalibrationRefused(f"the board was watched for {status.elapsed_s:.0f} of {seconds:g} s; "
                                 "nothing was saved")
    result = procedure.result()
    if not result.ok:
        raise CalibrationRefused(f"{result.problem}; nothing was saved")
    fitted, record = thermal_calibration(board_id, result)
    values = {"still_s": result.seconds, "gyro_thermal": result.slope.tolist(),
              "gyro_thermal_ref_c": result.ref_c, "acc_thermal": result.acc_slope.tolist(), **dict(record.figures)}
    if result.negligible:
        return fitted, record, values, [f"warm-up drift: warmed {result.rise_c:.2f} degC from power-up: {NEGLIGIBLE}"]
    slope = _numbers(np.degrees(result.slope), '{:+.4f}')
    line = (f"warm-up drift: gyroscope bias slope ({slope}) deg/s per degC about "
            f"{result.ref_c:.2f} degC; warmed {result.rise_c:.2f} degC, residual {result.residual_dps:.3f} deg/s")
    acc_line = f"accelerometer zero-g slope ({_numbers(result.acc_slope / C.MG, '{:+.3f}')}) mg per degC"
    return fitted, record, values, [line, acc_line]


# ----------------------------------------------------------------- the commands


@dataclass(frozen=True)
class VirtualMaker:
    """The simulated board and maker of ``--virtual``.

    The board's errors are :func:`tracker.sim.realistic_errors` with the figures
    given (None: its typical ones).
    The maker's slips: a magnet brought near at ``magnet_at`` s, the board
    bumped at ``nudges``, the first face laid down twice (``repeat_face``). The board had been
    on ``powered_s`` before (0: just plugged in, its die warming: :mod:`tracker.warming`).
    """

    seed: int = 0
    noise_scale: float = 1.0
    hard_iron_ut: float | None = None
    soft_iron_pct: float | None = None
    room_ut: float | None = None
    magnet_at: float | None = None
    nudges: tuple[float, ...] = ()
    repeat_face: bool = False
    powered_s: float = 0.0

    def maker(self) -> SimulatedMaker:
        from .maker_sim import Magnet, SimulatedMaker
        from .sim import realistic_errors
        figures = {"mag_hard_iron_ut": self.hard_iron_ut, "mag_soft_iron_pct": self.soft_iron_pct,
                   "mag_disturbance_ut": self.room_ut}
        errors = realistic_errors(noise_scale=self.noise_scale, **{k: v for k, v in figures.items() if v is not None})
        magnet = Magnet(self.magnet_at, self.magnet_at + 10.0) if self.magnet_at is not None else None
        return SimulatedMaker(errors, seed=self.seed, magnet=magnet, nudges=self.nudges,
                              repeat_face=self.repeat_face, powered_s=self.powered_s)


@contextlib.contextmanager
def unplugging(board: VirtualBoard, at: float, seconds: float) -> Iterator[None]:
    """Pull the virtual board's cable ``at`` seconds from now and plug it in ``seconds`` later."""
    stop = threading.Event()

    def run() -> None:
        if stop.wait(at):
            return
        board.pull_cable()
        if not stop.wait(seconds):
            board.plug_in()

    thread = threading.Thread(target=run, name="unplug", daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join(timeout=2)


def board_identity(link: Link, procedure: str, virtual: bool) -> tuple[Hello, str]:
    """The board's HELLO and id; refused for a board that did not identify itself, or a magnetometer
    procedure on a board without one."""
    hello = link.hello
    if hello is None:
        raise CalibrationRefused(f"the board on {link.settings.port} did not identify itself (no HELLO): "
                                 "calibrating needs the EnergyBall firmware's raw samples (firmware/README.md)")
    if procedure == "mag" and (hello.mag_whoami == 0 or BoardError.MAG_MISSING in hello.errors):
        raise CalibrationRefused(f"the board on {link.settings.port} reports no magnetometer in its HELLO "
                                 "(AK8963 missing): there is nothing to calibrate")
    return hello, C.board_id_of(hello, virtual)


@dataclass
class Report:
    """What a procedure's command prints: ``values`` as JSON, ``lines`` as text."""

    values: dict = field(default_factory=dict)
    lines: list[str] = field(default_factory=list)


def calibrate(name: str, link: Link, term: Terminal, seconds: float | None = None,
              maker: SimulatedMaker | None = None) -> Report:
    """Run procedure ``name`` ("accel" or "mag") on the link's board, save its result, say what was done.

    ``maker``: the simulated maker holding the virtual board (then the board's
    file is the virtual one's, and the report adds the errors left against the
    board's true errors). :class:`CalibrationRefused` when no calibration came
    of it; nothing is saved then.
    """
    hello, board_id = board_identity(link, name, maker is not None)
    path = C.calibration_path(board_id)
    term.say(f"calibrating the {C.PROCEDURE_TITLES[name]} of board {board_id} (firmware {hello.firmware}) "
             f"on {link.settings.port}; the result goes to {path}")
    damaged = C.damage(board_id)
    if damaged:
        term.say(f"{damaged}; saving this calibration will replace it, keeping a copy as {path.name}.damaged")
    limit = seconds or {"accel": ACCEL_SECONDS, "mag": MAG_SECONDS, "thermal": THERMAL_SECONDS}[name]
    if name == "thermal":
        thermal = ThermalProcedure(ThermalParams(duration_s=limit))
        t_steps: Steps[ThermalStatus] = Steps(lambda s: s.done, live_thermal, ThermalNarrator())
        t_status, interruptions = run_procedure(link, thermal, t_steps, term, limit + THERMAL_GRACE_S, maker)
        fitted, record, values, lines = finish_thermal(board_id, thermal, t_status, limit)
    elif name == "accel":
        accel = AccelProcedure()
        a_steps: Steps[AccelStatus] = Steps(lambda s: s.done, live_accel, AccelNarrator())
        a_status, interruptions = run_procedure(link, accel, a_steps, term, limit, maker)
        fitted, record, values, lines = finish_accel(board_id, accel, a_status, limit)
    else:
        saved_cal, _ = C.load_or_default(board_id)  # its accelerometer calibration, if done, for the dip
        mag = MagProcedure(accel=saved_cal if saved_cal.record("accel") else None)
        m_steps: Steps[MagStatus] = Steps(lambda s: s.ready or bool(s.problem), live_mag, MagNarrator())
        m_status, interruptions = run_procedure(link, mag, m_steps, term, limit, maker)
        fitted, record, values, lines = finish_mag(board_id, mag, m_status, limit)
    saved, copied = C.save_procedure(board_id, fitted, record)
    lines.append(f"saved to {saved}" + (f" (the damaged file was kept as {copied})" if copied else ""))
    values = {"procedure": name, "board_id": board_id, "path": str(saved),
              "damaged_copy": str(copied) if copied else None, "done_at": record.done_at,
              "interruptions": interruptions, **values}
    if maker is not None:
        from .maker_sim import calibration_errors
        errors = calibration_errors(fitted, maker.true_calibration())
        values.update({k: errors[k] for k in TRUTH_ERRORS[name]})
        lines.append("left against the simulated board's true errors: "
                     + ", ".join(f"{k} {errors[k]:.3f}" for k in TRUTH_ERRORS[name]))
    return Report(values, lines)


def _numbers(v: Sequence[float] | np.ndarray, fmt: str) -> str:
    return " ".join(fmt.format(float(x)) for x in v)


def _rows(m: np.ndarray) -> str:
    return " ".join(f"({_numbers(row, '{:.4f}')})" for row in m)


# ----------------------------------------------------------------- calibrate show


def show_board(cal: C.BoardCalibration) -> list[str]:
    """``calibrate show``'s lines for one board: each procedure, when, its figures and values."""
    lines = [f"board {cal.board_id}: {C.calibration_path(cal.board_id)}"]
    default = C.BoardCalibration(cal.board_id)
    for name, title in C.PROCEDURE_TITLES.items():
        record = cal.record(name)
        changed = any(not np.array_equal(getattr(cal, f), getattr(default, f)) for f in C.PROCEDURES[name])
        if record is None and not changed:
            lines.append(f"  {title:13s}  not calibrated (armtracker calibrate {name})")
            continue
        figures = ", ".join(FIGURES.get(k, k + " {:g}").format(v) for k, v in record.figures) if record else ""
        lines.append(f"  {title:13s}  {record.when if record else 'date unknown'}"
                     + (f"  {figures}" if figures else ""))
        if name == "accel":
            lines.append(f"  {'':13s}  offset ({_numbers(cal.acc_offset, '{:+.4f}')}) m/s^2, "
                         f"scale ({_numbers(cal.acc_scale, '{:.5f}')}), {misalignment_text(cal.acc_misalignment)}; "
                         f"gyroscope {sensitivity_text(cal.gyro_scale)}")
        elif name == "thermal" and not (cal.gyro_thermal.any() or cal.acc_thermal.any()):
            lines.append(f"  {'':13s}  a negligible warm-up: no slope to keep")
        elif name == "thermal":
            lines.append(f"  {'':13s}  bias slope ({_numbers(np.degrees(cal.gyro_thermal), '{:+.4f}')}) deg/s "
                         f"per degC about {float(cal.gyro_thermal_ref_c):.2f} degC; accelerometer zero-g slope "
                         f"({_numbers(cal.acc_thermal / C.MG, '{:+.3f}')}) mg per degC")
        else:
            lines.append(f"  {'':13s}  hard iron ({_numbers(cal.mag_hard_iron, '{:+.2f}')}) uT, "
                         f"soft iron rows {_rows(cal.mag_soft_iron)}")
    return lines


def show(as_json: bool) -> tuple[str, list[str]]:
    """What ``calibrate show`` prints on stdout, and the one-line problems of files it could not read."""
    folder = C.boards_dir()
    boards = C.saved_boards()
    good = [b for b in boards if isinstance(b, C.BoardCalibration)]
    bad = [str(b) for b in boards if isinstance(b, C.CalibrationFileError)]
    if as_json:
        return json.dumps({"folder": str(folder),
                           "boards": [{**b.to_json(), "path": str(C.calibration_path(b.board_id))} for b in good],
                           "damaged": bad}), bad
    if not boards:
        return (f"no board calibration saved yet in {folder}: connect the board and run "
                "`armtracker calibrate accel`, then `armtracker calibrate mag` (and, from cold, "
                "`armtracker calibrate thermal`)"), bad
    return "\n".join(line for b in good for line in show_board(b)), bad
