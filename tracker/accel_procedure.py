"""The guided six-pose accelerometer calibration: a streaming procedure for a terminal or a screen.

The maker lays the board on a table with each of its six faces up in turn
(each sensor axis once up, once down). Fed one raw sample at a time, the
procedure says which face to put up next, recognises which face is up,
shows how long the board has been still, and captures the pose by itself
once the board has been still for ``hold_s`` on a face it has not captured
yet. After six it solves offset and scale with
:func:`tracker.calibration.six_pose_calibration` (Tedaldi, Pretto and
Menegatti, ICRA 2014: static poses, a cost on the calibrated norms against
g; the six-position method of IEEE Std 1293-1998, annex A, for the start).

Misalignment is not asked for: solving it needs at least three more still
poses in orientations between the faces (tilted about 45 deg), which a board
on a table does not hold by itself; the MPU-9250's cross-axis sensitivity is
+-2 % (PS-MPU-9250A-01 rev. 1.1, table 2), and the result's misalignment is
the identity.

Stillness. A sample is still while the gyroscope and the accelerometer stay
within VQF's rest thresholds of their own low-passed values
(:class:`tracker.calibration.RestDetector`; Laidig and Seel, "VQF", Information
Fusion 91, 2023, sec. 3.2: 2 deg/s and 0.5 m/s^2 about a second-order
low-pass of 0.5 s). VQF's bound on the low-passed rate itself is dropped:
the procedure runs on an uncalibrated board, whose gyroscope may read up to
+-35 deg/s while still (a profile's bias and warm-up; PS-MPU-9250A-01 table
1), and stillness is judged by deviations alone. A board lying on a table
passes easily (noise 0.1 m/s^2 and 0.3 deg/s per sample even at twice the
data sheet's noise); a board being turned at more than a few degrees per
second does not, because its gravity reading runs away from its own
low-pass. When the hold is complete, the captured window is checked again
in the window form (:func:`tracker.calibration.window_motion`: every sample
within the thresholds of the window's mean), which
:func:`~tracker.calibration.six_pose_calibration` applies to its poses too.

The turns. Between the poses the board is turned by 90 and 180 deg, and the
gyroscope's integral over each turn against gravity's directions before and
after gives the gyroscope's three sensitivities (:mod:`tracker.gyro_scale`):
:meth:`AccelProcedure.calibration` keeps them with the accelerometer's fit. A
pulled cable or a stretch lost on the link breaks the chain of turns there.

Faces. The face up is the sensor axis nearest the measured specific force
(:func:`tracker.calibration.pose_label`); a board leaning more than
``max_tilt`` from it (20 deg, as :class:`tracker.calibration.PoseParams`)
has no face up. Gravity's direction is what the accelerometer measures at
rest (+g on the up axis, ARCHITECTURE.md).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from .calibration import (DEG, BoardCalibration, Pose, PoseParams, RestDetector, RestParams, SixPoseResult,
                          pose_label, six_pose_calibration, window_motion)
from .gyro_scale import SensitivityFit, SensitivityParams, Turn, fit_sensitivity, integrate_turn
from .protocol import RawSample

FACES: tuple[str, ...] = ("+z", "-z", "+x", "-x", "+y", "-y")  # the order the maker is asked for
Array = NDArray[np.float64]


def _unit(v: Array) -> Array:
    return v / np.linalg.norm(v)


def _still_params() -> RestParams:
    """VQF's rest thresholds without its bound on the rate itself (module docstring)."""
    return RestParams(gyr_max_rate=math.inf)


@dataclass(frozen=True)
class AccelProcedureParams:
    """Settings of :class:`AccelProcedure`.

    ``hold_s``: seconds still on one face that capture it (1-2 s of averaging
    take the accelerometer's noise, 300 ug/sqrt(Hz), to about 0.2 mg).
    ``still``: the stillness thresholds (module docstring). ``pose``: the
    six-pose solver's settings; its ``max_tilt`` (20 deg) is how far the board
    may lean from a face. ``moved_after_s``: a hold broken after this long is
    reported as "the board moved" (a shorter one is just the board being set
    down). ``max_gap_s``: samples further apart than this (a stretch lost on
    the link) break the hold. ``turns``: the gyroscope's fit from the turns between the poses.
    """

    hold_s: float = 2.0
    still: RestParams = field(default_factory=_still_params)
    pose: PoseParams = field(default_factory=PoseParams)
    moved_after_s: float = 0.3
    max_gap_s: float = 0.25
    turns: SensitivityParams = field(default_factory=SensitivityParams)  # the gyroscope's fit from the turns


@dataclass(frozen=True)
class AccelStatus:
    """What the procedure shows now (read-only, for a terminal or a game screen).

    ``asked``: the face to put up next (None once all six are captured); ``up``:
    the face up now (None while turning or leaning too far); ``still_s``: how
    long the board has been still on ``up``; ``captured``: faces captured so
    far, in order; ``message``: one line for the maker; ``done``: all six
    captured.
    """

    asked: str | None
    up: str | None
    still_s: float
    captured: tuple[str, ...]
    message: str
    done: bool


@dataclass
class _Hold:
    """The pose being held: its face, since when, the samples of its still run (bounded)."""

    face: str | None = None
    since: float = 0.0  # device time the face came up
    acc: deque[tuple[float, float, float]] = field(default_factory=deque)
    gyr: deque[tuple[float, float, float]] = field(default_factory=deque)
    t: deque[float] = field(default_factory=deque)

    def clear(self) -> None:
        self.acc.clear()
        self.gyr.clear()
        self.t.clear()


class AccelProcedure:
    """The six-pose procedure, streaming (module docstring). Feed raw samples; read :attr:`status`."""

    def __init__(self, params: AccelProcedureParams = AccelProcedureParams()) -> None:
        if not (params.hold_s > 0.0 and params.moved_after_s >= 0.0 and params.max_gap_s > 0.0):
            raise ValueError(f"AccelProcedureParams need a hold and a gap above 0 s: {params}")
        self.params = params
        self._detector = RestDetector(params.still)
        self._hold = _Hold()
        self._poses: dict[str, Pose] = {}
        self._last_t: float | None = None
        self._moved = ""  # why the last hold broke, shown until a new hold is under way
        self._left = True  # the board has left the face captured last
        self._since: list[tuple[float, float, float, float]] = []  # t and rates since the last pose (the turns)
        self._linked = False  # _since runs unbroken from the last pose captured
        self._last_pose: tuple[Array, Array] | None = None  # its mean rate (the bias there) and specific force
        self._turns: list[Turn] = []
        self._die: float | None = None  # the die's temperature at the latest sample (degC; None: not sent)
        self._pose_die: dict[str, float | None] = {}  # ... when each pose was captured
        self._status = AccelStatus(FACES[0], None, 0.0, (), f"put {FACES[0]} up, flat on the table", False)

    @property
    def status(self) -> AccelStatus:
        """What the procedure shows now."""
        return self._status

    @property
    def captured(self) -> tuple[str, ...]:
        """The faces captured so far, in order."""
        return tuple(self._poses)

    def _asked(self) -> str | None:
        return next((f for f in FACES if f not in self._poses), None)

    def interrupted(self) -> None:
        """The link was lost (a pulled cable): the pose being held is forgotten, the captured kept.

        The next sample starts afresh, whatever its time (the board restarts its
        clock when it powers up again).
        """
        self._restart()
        self._last_t = None
        self._linked = False
        self._hold.face = None
        self._moved = ""
        asked = self._asked()
        kept = f"{len(self._poses)} of 6 faces kept"
        self._status = AccelStatus(asked, None, 0.0, self.captured,
                                   f"the board was disconnected: the pose being held is forgotten, {kept}"
                                   + (f"; put {asked} up" if asked else ""), asked is None)

    def _restart(self) -> None:
        """Forget the stillness and the held samples (the face is kept)."""
        self._detector.reset()
        self._hold.clear()

    def feed(self, sample: RawSample) -> AccelStatus:
        """Take one raw sample; the status after it."""
        t, acc, gyr = sample.t, sample.acc, sample.gyr
        if self._asked() is None:
            return self._status
        self._die = sample.die_c
        gap = math.inf if self._last_t is None else t - self._last_t
        self._last_t = t
        up, tilt = pose_label(acc)
        face = up if tilt <= self.params.pose.max_tilt else None
        if 0.0 < gap <= self.params.max_gap_s:
            self._detector.update(gyr, acc, gap)
        else:
            self._restart()
            self._linked = False
        self._follow_turn(t, gyr)
        if face != self._hold.face:
            self._broken(f"the board left {self._hold.face}", t)
            self._hold.face = face
            self._left = self._left or not self._poses or face != self.captured[-1]
        held = min(self._detector.still_for, t - self._hold.since) if face else 0.0
        if face is not None and face not in self._poses:
            if held > 0.0:
                self._keep(t, acc, gyr)
            else:
                self._broken("the board moved", t)
            if held >= self.params.hold_s - 1e-9:
                self._capture(face, t)
                held = 0.0
        self._status = self._describe(face, held, tilt)
        return self._status

    def _follow_turn(self, t: float, gyr: tuple[float, float, float]) -> None:
        """Keep the rates since the last pose while they run unbroken (and not too long)."""
        if not self._linked or len(self._since) >= self.params.turns.max_turn_samples:
            self._since.clear()
            self._linked = False
            return
        self._since.append((t, gyr[0], gyr[1], gyr[2]))

    def _keep(self, t: float, acc: tuple[float, float, float], gyr: tuple[float, float, float]) -> None:
        """Add a still sample to the hold, dropping those older than ``hold_s``."""
        h = self._hold
        h.t.append(t)
        h.acc.append(acc)
        h.gyr.append(gyr)
        while h.t and h.t[0] < t - self.params.hold_s:
            h.t.popleft()
            h.acc.popleft()
            h.gyr.popleft()

    def _broken(self, what: str, t: float) -> None:
        """The hold under way ends without a capture: remember why (if it had lasted), start over at ``t``."""
        h = self._hold
        if h.face is not None and h.face not in self._poses and h.t \
                and h.t[-1] - h.t[0] >= self.params.moved_after_s:
            self._moved = f"{what} during the pose"
        h.clear()
        h.since = t

    def _capture(self, face: str, t: float) -> None:
        """Keep the held window as the pose of ``face``, unless it was not still after all."""
        h = self._hold
        pose = Pose(np.array(h.acc), np.array(h.gyr))
        moved = window_motion(pose.gyr, pose.acc, self.params.pose.rest) \
            if len(h.t) >= self.params.pose.min_samples else f"too few samples ({len(h.t)})"
        if moved is None:
            self._poses[face] = pose
            self._pose_die[face] = self._die
            self._moved, self._left = "", False
            rate, acc = pose.gyr.mean(axis=0), pose.acc.mean(axis=0)
            if self._linked and self._last_pose is not None and len(self._since) >= 2:
                x = np.array(self._since)
                rotation, jacobian = integrate_turn(x[:, 0], x[:, 1:], self._last_pose[0], rate)
                self._turns.append(Turn(rotation, jacobian, self._last_pose[1], acc))
            self._last_pose, self._linked = (rate, acc), True
            self._since = [(t, *h.gyr[-1])]
        else:
            self._moved = f"the board moved during the pose ({moved})"
        h.clear()
        h.since = t

    def _describe(self, face: str | None, held: float, tilt: float) -> AccelStatus:
        """The status for the face up now, held still for ``held`` s."""
        asked, hold = self._asked(), self.params.hold_s
        captured = self.captured
        if asked is None:
            return AccelStatus(None, face, 0.0, captured, "all six faces captured", True)
        if face is None:
            lean = f" (it leans {tilt / DEG:.0f} deg from a face)" if tilt < 45.0 * DEG else ""
            text = f"put {asked} up, flat on the table{lean}"
        elif face in self._poses:
            if not self._left and face == captured[-1]:
                text = f"captured {face}: now put {asked} up"
            elif held >= self.params.moved_after_s:  # set down on it, not passing over it
                text = f"{face} is already captured: put {asked} up"
            else:
                text = f"put {asked} up, flat on the table"
        else:
            instead = "" if face == asked else f", in place of {asked}"
            text = f"hold still: {held:.1f} s of {hold:.1f} ({face} up{instead})"
            if self._moved and held >= self.params.moved_after_s:
                self._moved = ""
            elif self._moved:
                text = f"{self._moved}: {text}"
        return AccelStatus(asked, face, held, captured, text, False)

    def result(self) -> SixPoseResult:
        """Offset and scale from the six captured poses (:func:`tracker.calibration.six_pose_calibration`).

        Raises ValueError before all six faces are captured.
        """
        missing = [f for f in FACES if f not in self._poses]
        if missing:
            raise ValueError(f"the accelerometer calibration is not finished: not all six faces captured "
                             f"({', '.join(missing)} missing)")
        return six_pose_calibration([self._poses[f] for f in FACES], params=self.params.pose)

    def gyro_fit(self, result: SixPoseResult) -> SensitivityFit:
        """The gyroscope's sensitivities from the turns between the poses (:mod:`tracker.gyro_scale`),
        gravity's directions calibrated by ``result``."""
        cal = self.calibration_of(result)

        def gravity(acc: Array) -> Array:
            return _unit(cal.apply_arrays(acc, np.zeros(3)).acc)

        return fit_sensitivity([replace(tr, before=gravity(tr.before), after=gravity(tr.after)) for tr in self._turns],
                               self.params.turns)

    @staticmethod
    def calibration_of(result: SixPoseResult, board_id: str = "default") -> BoardCalibration:
        """The accelerometer's fields of a six-pose ``result``."""
        return BoardCalibration(board_id, acc_offset=result.offset, acc_scale=result.scale,
                                acc_misalignment=result.misalignment)

    def calibration(self, result: SixPoseResult, board_id: str = "default") -> tuple[BoardCalibration, SensitivityFit]:
        """This procedure's fields: the accelerometer's from ``result`` and the die's mean temperature
        over its poses (0 when the board sent none: :class:`BoardCalibration`), the gyroscope's
        sensitivities from the turns (kept at 1 where their fit was refused: the fit says why)."""
        gyro = self.gyro_fit(result)
        temps = [self._pose_die.get(f) for f in FACES]
        ref = float(np.mean(temps)) if all(c is not None for c in temps) else 0.0
        return replace(self.calibration_of(result, board_id), gyro_scale=np.diag(gyro.scale),
                       acc_offset_ref_c=np.array(ref)), gyro
