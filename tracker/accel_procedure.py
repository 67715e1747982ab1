"""The guided accelerometer calibration: a streaming procedure for a terminal or a screen.

The maker lays the board on a table with each of its six faces up in turn
(each sensor axis once up, once down), then leans it on one of its edges
against something (a book, a mug) at about 45 deg, a new way each time, for
``tilted`` more poses. Fed one raw sample at a time, the procedure says which
face to put up next (or to lean the board), recognises which face is up or
whether the board leans far enough from every face and every pose captured,
shows how long the board has been still, and captures the pose by itself
once the board has been still for ``hold_s`` on a face or a lean it has not
captured yet. At the end it solves offset, scale and misalignment with
:func:`tracker.calibration.six_pose_calibration` (Tedaldi, Pretto and
Menegatti, ICRA 2014: static poses, a cost on the calibrated norms against
g; the six-position method of IEEE Std 1293-1998, annex A, for the start).

Why the leaning poses. The MPU-9250's accelerometer has a cross-axis
sensitivity of +-2 % (PS-MPU-9250A-01 rev. 1.1, table 2): each axis reads up
to 2 % of the force along the other two, a skew that leans gravity by up to
a degree or so in some orientations and not in others, so the tilt the
fusion keeps changes as the arm turns. The six faces' norms do not see it
(to first order a face's norm holds its own axis's scale alone); Tedaldi's
triangular misalignment needs at least three still poses between the faces,
and four (``tilted``) leave one to spare. A board on a table does not hold
such a pose by itself, hence the edge against a book.

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

The turns. Between the poses the board is turned by 45 to 180 deg, and the
gyroscope's integral over each turn against gravity's directions before and
after gives the gyroscope's sensitivity matrix (:mod:`tracker.gyro_scale`):
:meth:`AccelProcedure.calibration` keeps them with the accelerometer's fit. A
pulled cable or a stretch lost on the link breaks the chain of turns there.

Warming. A board just powered up warms for minutes, and its zero-g level
moves with the die's temperature (up to 1.5 mg per degC, PS-MPU-9250A-01
table 2): poses held a minute apart on a warming board disagree by several
mg, and the fit puts that into the scale and the skew. So no pose is held
while the die's temperature changes faster than 1 degC a minute, or before
that has been measured for 10 s (:mod:`tracker.warming`); the status says
how fast it warms and the board may lie where it is meanwhile. A board that
sends no temperature (a firmware before the TEMP frame) is not waited for.

Faces. The face up is the sensor axis nearest the measured specific force
(:func:`tracker.calibration.pose_label`); a board leaning more than
``max_tilt`` from it (20 deg, as :class:`tracker.calibration.PoseParams`)
has no face up. A leaning pose counts once the board leans ``lean_apart``
(25 deg) or more from every face and from every leaning pose captured
before (nearer one, it is that pose again). Gravity's direction is what the
accelerometer measures at rest (+g on the up axis, ARCHITECTURE.md).
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
from .warming import DieWarming, WarmingParams

FACES: tuple[str, ...] = ("+z", "-z", "+x", "-x", "+y", "-y")  # the order the maker is asked for
TILTED = "tilted"  # what is asked (and up) after the faces: a leaning pose
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
    ``tilted``: leaning poses after the faces (module docstring; 0 leaves the misalignment
    the identity, as before they were asked for); ``lean_apart``: how far a leaning pose
    leans from every face and every leaning pose before it. ``warming``: how fast the die
    may warm while a pose is held (module docstring).
    """

    hold_s: float = 2.0
    still: RestParams = field(default_factory=_still_params)
    pose: PoseParams = field(default_factory=PoseParams)
    moved_after_s: float = 0.3
    max_gap_s: float = 0.25
    turns: SensitivityParams = field(default_factory=SensitivityParams)  # the gyroscope's fit from the turns
    tilted: int = 4
    lean_apart: float = 25.0 * DEG
    warming: WarmingParams = field(default_factory=WarmingParams)


@dataclass(frozen=True)
class AccelStatus:
    """What the procedure shows now (read-only, for a terminal or a game screen).

    ``asked``: the face to put up next, or :data:`TILTED` for a leaning pose
    (None once all are captured); ``up``: the face up now, or :data:`TILTED`
    for a new lean (None while turning, leaning too little, or too near a pose
    captured); ``still_s``: how long the board has been still on ``up``;
    ``captured``: the poses captured so far, in order (faces, then "tilted 1",
    "tilted 2", ...); ``total``: how many poses are asked in all;
    ``message``: one line for the maker; ``done``: all captured;
    ``waiting``: no pose is held until the die's temperature settles (module
    docstring); ``warming``: how fast it changes, degC per minute (None before
    it has been measured, or from a board that sends no temperature).
    """

    asked: str | None
    up: str | None
    still_s: float
    captured: tuple[str, ...]
    message: str
    done: bool
    total: int = len(FACES)
    waiting: bool = False
    warming: float | None = None

    @property
    def leaning(self) -> int:
        """How many leaning poses are asked in all."""
        return self.total - len(FACES)

    @property
    def leaned(self) -> int:
        """How many leaning poses are captured."""
        return sum(pose not in FACES for pose in self.captured)


@dataclass
class _Hold:
    """The pose being held: its face, since when, the samples of its still run (bounded)."""

    face: str | None = None
    since: float = 0.0  # device time the face came up
    acc: deque[tuple[float, float, float]] = field(default_factory=deque)
    gyr: deque[tuple[float, float, float]] = field(default_factory=deque)
    mag: deque[tuple[float, float, float] | None] = field(default_factory=deque)
    t: deque[float] = field(default_factory=deque)

    def clear(self) -> None:
        self.acc.clear()
        self.gyr.clear()
        self.mag.clear()
        self.t.clear()


class AccelProcedure:
    """The accelerometer's procedure, streaming (module docstring). Feed raw samples; read :attr:`status`."""

    def __init__(self, params: AccelProcedureParams = AccelProcedureParams()) -> None:
        if not (params.hold_s > 0.0 and params.moved_after_s >= 0.0 and params.max_gap_s > 0.0
                and params.tilted >= 0):
            raise ValueError(f"AccelProcedureParams need a hold and a gap above 0 s and no negative "
                             f"count of leaning poses: {params}")
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
        self._warming = DieWarming(params.warming)
        self._pose_die: dict[str, float | None] = {}  # ... when each pose was captured
        self._pose_mag: dict[str, Array] = {}  # the magnetometer's mean raw reading over each pose, uT
        self._leans: dict[str, Array] = {}  # each leaning pose's direction of gravity (unit, raw)
        self._status = AccelStatus(FACES[0], None, 0.0, (), f"put {FACES[0]} up, flat on the table", False,
                                   self.total)

    @property
    def status(self) -> AccelStatus:
        """What the procedure shows now."""
        return self._status

    @property
    def captured(self) -> tuple[str, ...]:
        """The poses captured so far, in order (faces, then leaning poses)."""
        return tuple(self._poses)

    @property
    def total(self) -> int:
        """How many poses the procedure asks for: the six faces and the leaning poses."""
        return len(FACES) + self.params.tilted

    def _asked(self) -> str | None:
        face = next((f for f in FACES if f not in self._poses), None)
        return face or (TILTED if len(self._poses) < self.total else None)

    def _leaning(self, acc: tuple[float, float, float], tilt: float) -> str | None:
        """The pose of a board leaning ``tilt`` from the nearest face, when a leaning pose is asked:
        the leaning pose captured within ``lean_apart`` of ``acc`` (the nearest), else :data:`TILTED`
        when it leans ``lean_apart`` from every face, else None."""
        if self._asked() != TILTED:
            return None
        g = _unit(np.array(acc, dtype=float))
        leans = {key: math.acos(min(1.0, float(g @ up))) for key, up in self._leans.items()}
        nearest = min(leans, key=leans.__getitem__, default=None)
        if nearest is not None and leans[nearest] < self.params.lean_apart:
            return nearest
        return TILTED if tilt >= self.params.lean_apart else None

    def interrupted(self) -> None:
        """The link was lost (a pulled cable): the pose being held is forgotten, the captured kept.

        The next sample starts afresh, whatever its time (the board restarts its
        clock when it powers up again).
        """
        self._restart()
        self._warming.reset()
        self._last_t = None
        self._linked = False
        self._hold.face = None
        self._moved = ""
        asked = self._asked()
        kept = f"{len(self._poses)} of {self.total} poses kept"
        self._status = AccelStatus(asked, None, 0.0, self.captured,
                                   f"the board was disconnected: the pose being held is forgotten, {kept}"
                                   + (f"; {self._ask(asked)}" if asked else ""), asked is None, self.total)

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
        if self._die is not None:
            self._warming.update(t, self._die)
        gap = math.inf if self._last_t is None else t - self._last_t
        self._last_t = t
        up, tilt = pose_label(acc)
        face = up if tilt <= self.params.pose.max_tilt else self._leaning(acc, tilt)
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
        if self._waiting:  # no pose is held before the die settles (module docstring)
            self._hold.clear()
            self._hold.since, held = t, 0.0
        elif face is not None and face not in self._poses:
            if held > 0.0:
                self._keep(t, acc, gyr, sample.mag)
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

    def _keep(self, t: float, acc: tuple[float, float, float], gyr: tuple[float, float, float],
              mag: tuple[float, float, float] | None) -> None:
        """Add a still sample to the hold, dropping those older than ``hold_s``."""
        h = self._hold
        h.t.append(t)
        h.acc.append(acc)
        h.gyr.append(gyr)
        h.mag.append(mag)
        while h.t and h.t[0] < t - self.params.hold_s:
            h.t.popleft()
            h.acc.popleft()
            h.gyr.popleft()
            h.mag.popleft()

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
            if face == TILTED:
                face = f"{TILTED} {len(self._leans) + 1}"
                self._leans[face] = _unit(pose.acc.mean(axis=0))
            self._poses[face] = pose
            self._pose_die[face] = self._die
            fields = [m for m in h.mag if m is not None and all(math.isfinite(x) for x in m)]
            if len(fields) == len(h.mag):  # the magnetometer read all along: its mean, for the alignment
                self._pose_mag[face] = np.mean(np.array(fields, dtype=float), axis=0)
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

    @property
    def _waiting(self) -> bool:
        """Whether the poses wait for the die to settle (module docstring): a board that sends its
        temperature, not yet measured long enough or warming too fast."""
        return self._die is not None and not self._warming.settled

    def _ask(self, asked: str) -> str:
        """The line asking for the pose ``asked``."""
        if asked != TILTED:
            return f"put {asked} up, flat on the table"
        return (f"lean the board on an edge against something, about 45 deg, a new way "
                f"(leaning pose {len(self._leans) + 1} of {self.params.tilted})")

    def _describe(self, face: str | None, held: float, tilt: float) -> AccelStatus:
        """The status for the pose ``face`` now (a face, a leaning pose, :data:`TILTED` or None), held still
        for ``held`` s; ``tilt``: how far the board leans from the nearest face."""
        asked, hold, total = self._asked(), self.params.hold_s, self.total
        captured, rate = self.captured, self._warming.rate
        if asked is None:
            return AccelStatus(None, face, 0.0, captured, f"all {total} poses captured", True, total, warming=rate)
        if self._waiting:
            text = f"{self._warming_text()}; meanwhile {self._ask(asked)}"
        elif face is None:
            if asked == TILTED:
                lean = f" (it leans {tilt / DEG:.0f} deg from a face, {self.params.lean_apart / DEG:.0f} needed)"
            else:
                lean = f" (it leans {tilt / DEG:.0f} deg from a face)" if tilt < 45.0 * DEG else ""
            text = f"{self._ask(asked)}{lean}"
        elif face in self._poses:
            if not self._left and face == captured[-1]:
                text = f"captured {face}: now {self._ask(asked)}"
            elif held >= self.params.moved_after_s:  # set down on it, not passing over it
                text = f"{face} is already captured: {self._ask(asked)}"
            else:
                text = self._ask(asked)
        else:
            where = "leaning" if face == TILTED else f"{face} up"
            instead = "" if face == asked else f", in place of {asked}"
            text = f"hold still: {held:.1f} s of {hold:.1f} ({where}{instead})"
            if self._moved and held >= self.params.moved_after_s:
                self._moved = ""
            elif self._moved:
                text = f"{self._moved}: {text}"
        return AccelStatus(asked, face, held, captured, text, False, total, self._waiting, rate)

    def _warming_text(self) -> str:
        """Why the poses wait for the die (module docstring)."""
        warming, rate = self.params.warming, self._warming.rate
        if rate is None:
            return f"measuring how fast the board warms ({self._warming.measured_s:.0f} s of {warming.min_span_s:g})"
        return (f"the board is {'warming' if rate > 0 else 'cooling'} {abs(rate):.1f} degC a minute: the poses wait "
                f"until that is under {warming.max_c_per_min:g} (a few minutes after power-on)")

    def result(self) -> SixPoseResult:
        """Offset, scale and (with three or more leaning poses) misalignment from the captured poses
        (:func:`tracker.calibration.six_pose_calibration`).

        Raises ValueError before all the poses are captured.
        """
        left = self.params.tilted - len(self._leans)
        missing = [f for f in FACES if f not in self._poses] + ([f"{left} leaning"] if left else [])
        if missing:
            raise ValueError(f"the accelerometer calibration is not finished: {len(self._poses)} of "
                             f"{self.total} poses captured ({', '.join(missing)} missing)")
        leaning = [self._poses[key] for key in self._leans]
        return six_pose_calibration([self._poses[f] for f in FACES], leaning, misalignment=len(leaning) >= 3,
                                    params=self.params.pose)

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
        temps = list(self._pose_die.values())
        ref = float(np.mean(temps)) if all(c is not None for c in temps) else 0.0
        cal = replace(self.calibration_of(result, board_id), gyro_scale=gyro.matrix, acc_offset_ref_c=np.array(ref))
        return replace(cal, pose_fields=self._pose_fields(cal)), gyro

    def _pose_fields(self, cal: BoardCalibration) -> Array:
        """The poses' rows of :attr:`tracker.calibration.BoardCalibration.pose_fields`: the magnetometer's mean
        raw reading and gravity's calibrated direction, for each pose the magnetometer read all along."""
        rows = np.zeros_like(cal.pose_fields)
        for i, (face, mag) in enumerate(list(self._pose_mag.items())[:len(rows)]):
            up = cal.apply_arrays(self._poses[face].acc.mean(axis=0), np.zeros(3)).acc
            rows[i] = (*mag, *_unit(up), 1.0)
        return rows


def _largest_off_diagonal(matrix: Array) -> float:
    return float(np.max(np.abs(matrix - np.diag(np.diag(matrix)))))


def misalignment_text(matrix: Array) -> str:
    """The accelerometer's misalignment (unit diagonal) in a few words: its largest off-diagonal entry."""
    off = _largest_off_diagonal(matrix)
    return f"misalignment up to {off * 100:.2f} %" if off else "misalignment not measured"


def sensitivity_text(matrix: Array) -> str:
    """The gyroscope's sensitivity matrix in a few words: its diagonal and its largest cross-axis term."""
    if np.array_equal(matrix, np.eye(3)):
        return "sensitivities not measured"
    off = _largest_off_diagonal(matrix)
    cross = f"cross-axis up to {off * 100:.2f} %" if off else "cross-axis not measured"
    return f"sensitivities ({' '.join(f'{x:.4f}' for x in np.diag(matrix))}), {cross}"
