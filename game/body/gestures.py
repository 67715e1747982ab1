"""The energy-ball gesture machine: arm states in, game events out (Zhu & Shi, sec. 5, Fig. 1).

The paper's game "implement[s] the gesture control with a state machine":

``IDLE``      arm pointing down; the ball sits at the shoulder (Fig. 1 left).
``LOADING``   arm raised and pointed out; the ball floats up (Fig. 1 mid-left).
``SPINNING``  forearm flexed; the ball spins fast and its charge grows (Fig. 1 mid-right).
``FIRED``     the forearm waved back to straight shot the ball toward where the
              arm points (Fig. 1 right); the arm is still up, there is no ball.
              "He can restore the position of the ball by flexing his arm
              again": flexing in ``FIRED`` brings a new, spinning ball.

Lowering the arm returns to ``IDLE`` from every state. The transitions and
the events they emit::

    IDLE     --arm raised-------------------------> LOADING    "load"
    LOADING  --forearm flexed---------------------> SPINNING   "spin"
    SPINNING --forearm waved straight-------------> FIRED      "launch" (aim, charge)
    SPINNING --too short a spin, or a slow relax--> LOADING    "load"   (no shot, ball kept)
    FIRED    --forearm flexed again---------------> SPINNING   "reload"
    any      --arm lowered------------------------> IDLE       "idle"

Noise. Every transition needs its condition to hold for a dwell time
(a brief spike does nothing), and each pair of opposite transitions uses two
thresholds (hysteresis: hovering at one threshold with jitter can cross it
at most once, never back). A sample with a NaN (or an unusable pointing, or a
time stamp older than the last one) is ignored: no event, no state change,
the dwell clocks keep running on the samples around it.

Times. A transition's *onset* is the first sample of its dwell; the event
carries the time of *detection* (the sample that completed the dwell). Spin
time runs from the onset of the flex above flex-on to the onset of the
straight forearm below flex-off (the "crossing" below); the charge is that
spin time over ``charge_s``, capped at 1, and a spin shorter than
``min_spin_s`` launches nothing.

The wave. A launch is a wave across the hysteresis band: from the last
sample of the spin still held flexed (the "release": above flex-on, or
sagging below it no faster than the sensor creeps, see below) to the first
of the samples below flex-off that confirm the launch (the "crossing"), in
at most ``max_straighten_s`` (30 deg from flex-on in 0.4 s by default:
faster than 75 deg/s; from a creep-sagged hold at most 7.5 deg less). A
slower straightening is a
relaxation, not a throw: the ball stops spinning and stays (``LOADING``, a
"load" event). So a player who relaxes into the band (say to 40 deg) and
waves from there keeps the ball; flexing above flex-on again and waving
throws it.

The sensor's own drift. A resistive flex sensor's reading creeps toward
straight while the elbow is held bent (issue 12: up to 12 % of the bend,
time constant ~4 s; Saggio et al., "Resistive flex sensors: a survey",
Smart Mater. Struct. 25 (2016) 013001, sec. 5, on creep and hysteresis), so
a spin held just past flex-on may read a few degrees below it after a few
seconds although the player never relaxed. A spin therefore still counts
as held while its flex sags below flex-on no faster than ``creep_dps`` since
the last sample above flex-on (12 % of the 127 deg span over a 4 s time
constant is at most 3.8 deg/s) and no deeper than ``hold_sag`` of the band
(7.5 deg by default; 12 % of 55 deg is 6.6): the relaxation rule times the
wave from the last such sample. A player who relaxes into the band, or
whose forearm wobbles there, moves faster than creep and is not held. The
sensor's hysteresis (a play of up to 12 % of its 127 deg span, +-7.6 deg)
only shifts the reading toward where the elbow came from: a straightened
elbow reads at most that much bent (below flex-off for any straightening to
17 deg or less), a flexed one that much straighter. While the arm is on its way down (below
the lower threshold, dwell not yet over) the forearm's transitions are held,
so relaxing the elbow while lowering the arm ends in ``IDLE``, never in a
launch.

The quick confirmation. The dwell after the crossing costs its whole
length in launch latency. A wave is also recognised by how it got there:
when every step of the flex over the last ``wave_window_s`` (20 ms, four
steps at 200 Hz) straightened the elbow at ``wave_speed_dps`` or faster,
the first sample below flex-off confirms the straightening at once. The
window is a dwell that runs *before* the crossing: noise makes some step of
it flat or rising, and a spike shorter than the window (a glitch of one to
three samples, or the filtered flex's dip and return after one) has a step
that is not a fast extension, so neither confirms; what the quick path
cannot confirm the dwell still can. Everything else about the launch (the
spin time, the relaxation rule, the aim) is judged as after a dwell.

Aim. The unflex itself swings the arm, so the launch direction is the
pointing at the *start of the straightening*: the last local maximum of the
flex before the release, i.e. the latest sample in the ``aim_lookback_s``
before the release whose flex is within ``aim_tolerance_deg`` (jitter) of
the highest flex in that window. Taking the last sample above flex-on (the
release itself) would be simpler, but a deep flex (say 120 deg) is already
halfway through its wave when it passes flex-on, and the arm may be moving
by then; a window ending at the release (rather than a search back over the
whole spin) keeps a player who relaxed from 90 to 60 deg and held there
aiming with where the arm pointed at the end of that hold, not seconds ago.
That sample is already some way into the straightening (a typical 90-120 deg
wave of 0.12-0.25 s, minimum-jerk, loses its first 8 deg in 23-52 ms), and
the straightening's onset kicks the board on the soft tissue under the strap
(a damped rocking of 5-25 Hz, :mod:`game.sim.motion_model`): the aim is the
pointing ``aim_lead_s`` before it, while the board still sat on the held arm,
carried forward to that sample by the arm's mean turn over the ``aim_trend_s``
before (an arm sweeping after a target keeps its sweep; a held one, its aim).
The history the aim needs is bounded (``history_s``, at most
``HISTORY_MAX_SAMPLES`` samples).

Units: seconds and degrees; directions are unit vectors in the world frame
(z up), as in :class:`game.body.avatar.ArmState`. No pygame here.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field, fields
from enum import Enum
from typing import Iterable, Literal, NamedTuple, Sequence, get_args

import numpy as np
from mypy_extensions import mypyc_attr

from .avatar import ArmState

Vec3 = tuple[float, float, float]
EventKind = Literal["load", "spin", "launch", "reload", "idle"]
EVENT_KINDS: tuple[str, ...] = get_args(EventKind)
HISTORY_MAX_SAMPLES = 4096  # a hard bound on the aim history, whatever the sample rate
DOWN: Vec3 = (0.0, 0.0, -1.0)


class GestureState(str, Enum):
    """Where the ball is (Zhu & Shi, Fig. 1)."""

    IDLE = "idle"          # ball at the shoulder
    LOADING = "loading"    # arm up, ball floating up / afloat
    SPINNING = "spinning"  # elbow flexed, ball spinning, charge growing
    FIRED = "fired"        # ball launched, arm still up, no ball


_ANGLES = ("raise_deg", "lower_deg", "flex_on_deg", "flex_off_deg", "aim_tolerance_deg")
_TIMES = ("raise_dwell_s", "lower_dwell_s", "flex_dwell_s", "min_spin_s", "aim_lookback_s", "aim_lead_s",
          "aim_trend_s")
_POSITIVE_TIMES = ("charge_s", "rise_s", "history_s", "wave_window_s")


@mypyc_attr(native_class=False)  # a plain class even when compiled (README, "The compiled build")
@dataclass(frozen=True)
class GestureSettings:
    """Every threshold of the gesture machine, with its default.

    Arm (elevation: 0 = hanging down, 90 = level), with hysteresis:
      ``raise_deg`` 55: above it the arm is raised (IDLE -> LOADING).
      ``lower_deg`` 35: below it the arm is lowered (any -> IDLE); below ``raise_deg``.
    Elbow (flex: 0 = straight), with hysteresis:
      ``flex_on_deg`` 55: above it the forearm is flexed (LOADING -> SPINNING, FIRED -> SPINNING).
      ``flex_off_deg`` 25: below it the forearm is straight (SPINNING -> FIRED); below ``flex_on_deg``.
    Dwell: how long a condition must hold before it counts.
      ``raise_dwell_s`` 0.12, ``lower_dwell_s`` 0.30 (longer: dropping the
      ball by accident costs more than a late load), ``flex_dwell_s`` 0.03
      (both ways: flexing and straightening; six samples at 200 Hz, short
      because every millisecond here is launch latency, and the 30 deg
      hysteresis band already keeps flex jitter out).
    Quick confirmation of a wave (module doc, "The quick confirmation"):
      ``wave_speed_dps`` 150: every step of the flex in the last
      ``wave_window_s`` 0.02 straightening at least this fast confirms the
      crossing below flex-off with no dwell. A quick 90 deg wave (0.1-0.3 s)
      passes flex-off at 300-1500 deg/s; twice the 75 deg/s below which a
      straightening is a relaxation (``max_straighten_s``). ``math.inf``
      turns the quick path off (the dwell alone confirms).
    Spin:
      ``min_spin_s`` 0.15: a shorter spin is no throw (the ball stays, LOADING).
      ``charge_s`` 1.2: the spin time that gives a full charge (charge = spin / charge_s, capped at 1).
      ``hold_sag`` 0.25 and ``creep_dps`` 4: how far (a share of the band
      ``flex_on_deg - flex_off_deg``, 7.5 deg of the default 30; 0 to less
      than 1) and how fast (deg/s) a spin may sag below flex-on and still
      count as held (the release, module doc "The sensor's own drift").
      ``max_straighten_s`` 0.4: the wave from the release to below flex-off
      must take at most this to launch; slower is a relaxation and keeps the
      ball (a quick 90 deg wave takes 0.1-0.3 s, so its 30 deg band 0.03-0.1 s;
      letting a 90 deg flex sag over 1.2 s or more is no throw).
      ``math.inf`` turns the check off (every straightening then launches).
    Aim:
      ``aim_lookback_s`` 0.25: how far before the release the start of the
      straightening is looked for (a 130 deg flex waved at 450 deg/s
      reaches flex-on in 0.17 s).
      ``aim_tolerance_deg`` 8: flex jitter tolerated when finding the start of
      the straightening (above the +-3 deg of a typical flex sensor).
      ``aim_lead_s`` 0.05: how long before that sample the aim is taken (the
      time a typical wave takes to lose the tolerance, module doc "Aim"): the
      board rocks on the soft tissue from the straightening's onset on.
      ``aim_trend_s`` 0.2: over how long the arm's sweep before that is
      measured to carry the aim forward (long enough to average a 3-12 Hz
      tremor's swing out).
      ``history_s`` 1.0: how much of the past the machine keeps for the aim;
      at least ``aim_lookback_s + max_straighten_s + flex_dwell_s`` (when
      ``max_straighten_s`` is finite), so the window is still there at the launch.
    Rendering:
      ``rise_s`` 0.4: how long the ball takes to float up after "load" (:attr:`GestureMachine.progress`).
    """

    raise_deg: float = 55.0
    lower_deg: float = 35.0
    flex_on_deg: float = 55.0
    flex_off_deg: float = 25.0
    raise_dwell_s: float = 0.12
    lower_dwell_s: float = 0.30
    flex_dwell_s: float = 0.03
    wave_speed_dps: float = 150.0
    wave_window_s: float = 0.02
    min_spin_s: float = 0.15
    charge_s: float = 1.2
    hold_sag: float = 0.25
    creep_dps: float = 4.0
    max_straighten_s: float = 0.4
    aim_lookback_s: float = 0.25
    aim_tolerance_deg: float = 8.0
    aim_lead_s: float = 0.05
    aim_trend_s: float = 0.2
    history_s: float = 1.0
    rise_s: float = 0.4

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value):
                raise ValueError(f"{f.name} must be a number, not {value!r}")
        for name in _ANGLES:
            value = getattr(self, name)
            if not 0.0 <= value <= 180.0:
                raise ValueError(f"{name} must be an angle between 0 and 180 degrees, not {value!r}")
        for name in _TIMES:
            value = getattr(self, name)
            if not 0.0 <= value < math.inf:
                raise ValueError(f"{name} must be a time of 0 s or more, not {value!r}")
        for name in _POSITIVE_TIMES:
            value = getattr(self, name)
            if not 0.0 < value < math.inf:
                raise ValueError(f"{name} must be a time of more than 0 s, not {value!r}")
        if not self.max_straighten_s > 0.0:
            raise ValueError(f"max_straighten_s must be more than 0 s (math.inf turns it off), "
                             f"not {self.max_straighten_s!r}")
        if self.lower_deg >= self.raise_deg:
            raise ValueError(f"lower_deg ({self.lower_deg}) must be below raise_deg ({self.raise_deg}): "
                             f"the gap between them is the hysteresis that stops chatter")
        if self.flex_off_deg >= self.flex_on_deg:
            raise ValueError(f"flex_off_deg ({self.flex_off_deg}) must be below flex_on_deg "
                             f"({self.flex_on_deg}): the gap between them is the hysteresis that stops chatter")
        if not 0.0 <= self.creep_dps < math.inf:
            raise ValueError(f"creep_dps must be a speed of 0 deg/s or more, not {self.creep_dps!r}")
        if not 0.0 <= self.hold_sag < 1.0:
            raise ValueError(f"hold_sag must be a share of the flex band from 0 to less than 1, "
                             f"not {self.hold_sag!r}")
        if not self.wave_speed_dps > 0.0:
            raise ValueError(f"wave_speed_dps must be a speed of more than 0 deg/s (math.inf turns the quick "
                             f"confirmation off), not {self.wave_speed_dps!r}")
        if self.history_s < self.wave_window_s:
            raise ValueError(f"history_s ({self.history_s}) must be at least wave_window_s ({self.wave_window_s})")
        needed = self.aim_lookback_s + self.max_straighten_s + self.flex_dwell_s
        if math.isfinite(needed) and self.history_s < needed - 1e-12:
            raise ValueError(f"history_s ({self.history_s}) must be at least aim_lookback_s + max_straighten_s"
                             f" + flex_dwell_s ({needed:g}), or the aim could be forgotten before the launch")


    @property
    def hold_deg(self) -> float:
        """The flex above which a spin still counts as held: flex-on less ``hold_sag`` of the band."""
        return self.flex_on_deg - self.hold_sag * (self.flex_on_deg - self.flex_off_deg)


@mypyc_attr(native_class=False)  # a plain class even when compiled (README, "The compiled build")
@dataclass(frozen=True)
class GestureEvent:
    """Something the game reacts to.

    ``t`` is the time of detection. ``direction`` is a unit vector (world,
    z up): for "launch" the aim (the pointing at the start of the
    straightening), for the other kinds the pointing at ``t``. ``charge`` is
    0..1, the launch's charge; 0 for the other kinds.
    """

    kind: EventKind
    t: float
    direction: Vec3
    charge: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in EVENT_KINDS:
            raise ValueError(f"kind must be one of {', '.join(EVENT_KINDS)}, not {self.kind!r}")
        if not 0.0 <= self.charge <= 1.0:
            raise ValueError(f"charge must be between 0 and 1, not {self.charge!r}")


class Sample(NamedTuple):
    """The part of an ArmState the machine uses and remembers."""

    t: float
    elevation: float
    flex: float
    pointing: Vec3


@dataclass
class Dwell:
    """A condition that must hold, sample after sample, for a while before it counts."""

    since: float | None = None  # the onset: the first sample of the current run

    def step(self, condition: bool, t: float, dwell_s: float) -> bool:
        """Feed one sample; True once the condition has held for ``dwell_s``."""
        if not condition:
            self.since = None
            return False
        if self.since is None:
            self.since = t
        return t - self.since >= dwell_s


@dataclass
class GestureMemory:
    """Everything the machine remembers between samples."""

    state: GestureState = GestureState.IDLE
    t: float | None = None  # the last usable sample's time
    pointing: Vec3 = DOWN  # the last usable sample's pointing
    rise_start: float = -math.inf  # when the ball began to float up
    spin_start: float = 0.0  # the onset of the flex that started the spin
    flexed_last: Sample | None = None  # the last sample of this spin above flex-on
    release: Sample | None = None  # the last sample of this spin held flexed (module doc, "The wave")
    raised: Dwell = field(default_factory=Dwell)
    lowered: Dwell = field(default_factory=Dwell)
    flexed: Dwell = field(default_factory=Dwell)
    straight: Dwell = field(default_factory=Dwell)
    history: deque[Sample] = field(default_factory=lambda: deque(maxlen=HISTORY_MAX_SAMPLES))

    def clear_dwells(self) -> None:
        for dwell in (self.raised, self.lowered, self.flexed, self.straight):
            dwell.since = None


def usable_sample(arm: ArmState, last_t: float | None) -> Sample | None:
    """The sample in ``arm``, or None if it has a NaN, a bad pointing or an old time stamp."""
    try:
        t, elevation, flex = float(arm.t), float(arm.elevation_deg), float(arm.flex_deg)
        pointing = np.asarray(arm.pointing, dtype=float)
    except (TypeError, ValueError, AttributeError):
        return None
    if pointing.shape != (3,):
        return None
    x, y, z = pointing.tolist()
    if not all(map(math.isfinite, (t, elevation, flex, x, y, z))):
        return None
    # np.linalg.norm's own computation for a vector (sqrt of its dot product with
    # itself, the same bits), without its overhead: this runs once per frame.
    norm = math.sqrt(pointing.dot(pointing))
    if norm < 1e-9 or (last_t is not None and t < last_t):
        return None
    return Sample(t, elevation, flex, (x / norm, y / norm, z / norm))


def straightening_start(history: Iterable[Sample], release: Sample, lookback_s: float,
                        tolerance_deg: float) -> Sample:
    """Where the final straightening began: the last local maximum of flex before ``release``.

    Among the samples of ``history`` in ``[release.t - lookback_s, release.t]``
    (and ``release`` itself), the latest whose flex is within ``tolerance_deg``
    of the highest flex among them.
    """
    window = [s for s in history if release.t - lookback_s <= s.t <= release.t] or [release]
    peak = max(s.flex for s in window)
    return next(s for s in reversed(window) if s.flex >= peak - tolerance_deg)


def held_pointing(history: Sequence[Sample], start: Sample, lead_s: float, trend_s: float) -> Vec3:
    """Where the arm pointed at ``start`` as it was held before the straightening (module doc "Aim").

    The sample ``a`` latest at or before ``start.t - lead_s`` (the oldest the history
    still holds if none is: a short ``history_s`` shortens the lead and the trend),
    carried forward linearly to ``start.t`` by the pointing's mean change from the
    sample latest at or before ``a.t - trend_s`` to ``a``, and normalised.
    """
    def at(t: float, fallback: Sample) -> Sample:
        older = [s for s in history if s.t <= t]
        return older[-1] if older else history[0] if history else fallback

    a = at(start.t - lead_s, start)
    b = at(a.t - trend_s, a)
    if a.t <= b.t:
        return a.pointing
    k = (start.t - a.t) / (a.t - b.t)
    x, y, z = (p + k * (p - q) for p, q in zip(a.pointing, b.pointing))
    norm = math.sqrt(x * x + y * y + z * z)
    return (x / norm, y / norm, z / norm) if norm > 1e-9 else a.pointing


def extending_fast(history: Sequence[Sample], window_s: float, speed_dps: float) -> bool:
    """Whether every step of the flex in the last ``window_s`` of ``history`` straightened at ``speed_dps`` or faster.

    At least two steps are needed; a step with no time between its samples must not rise.
    """
    if not history:
        return False
    start = history[-1].t - window_s
    newer = history[-1]
    steps = 0
    for older in reversed(history):
        if older is newer:
            continue
        if older.t < start:
            break
        if not older.flex - newer.flex >= speed_dps * (newer.t - older.t):
            return False
        newer, steps = older, steps + 1
    return steps >= 2


class GestureMachine:
    """Energy-ball gestures from a stream of :class:`ArmState` (Zhu & Shi, sec. 5).

    Feed every avatar update to :meth:`update` and act on the events it
    returns; :attr:`state`, :attr:`charge`, :attr:`progress` and
    :attr:`has_ball` are for drawing the ball between events.
    """

    def __init__(self, settings: GestureSettings | None = None) -> None:
        self._settings = settings if settings is not None else GestureSettings()
        self._memory = GestureMemory()

    # ------------------------------------------------------------- reading

    @property
    def settings(self) -> GestureSettings:
        return self._settings

    @property
    def state(self) -> GestureState:
        return self._memory.state

    @property
    def has_ball(self) -> bool:
        """Whether there is a ball to draw (none between a launch and the reload)."""
        return self._memory.state is not GestureState.FIRED

    @property
    def progress(self) -> float:
        """How far the ball has floated up from the shoulder, 0..1 (1 while spinning)."""
        m = self._memory
        if m.state is GestureState.SPINNING:
            return 1.0
        if m.state is not GestureState.LOADING or m.t is None:
            return 0.0
        return min(1.0, max(0.0, (m.t - m.rise_start) / self._settings.rise_s))

    @property
    def charge(self) -> float:
        """The spinning ball's charge, 0..1 (0 in the other states)."""
        m = self._memory
        if m.state is not GestureState.SPINNING or m.t is None:
            return 0.0
        end = m.straight.since if m.straight.since is not None else m.t
        return self._charge(end - m.spin_start)

    # ------------------------------------------------------------- driving

    def reset(self) -> None:
        """Back to IDLE with no history (a new round, a recalibration)."""
        self._memory = GestureMemory()

    def update(self, arm: ArmState) -> list[GestureEvent]:
        """Feed one arm state; return the events it completes (usually none, at most one)."""
        m, s = self._memory, self._settings
        sample = usable_sample(arm, m.t)
        if sample is None:
            return []
        m.t, m.pointing = sample.t, sample.pointing
        self._remember(sample)
        if m.state is GestureState.IDLE:
            if m.raised.step(sample.elevation > s.raise_deg, sample.t, s.raise_dwell_s):
                m.rise_start = sample.t
                return [self._enter(GestureState.LOADING, "load")]
            return []
        if m.lowered.step(sample.elevation < s.lower_deg, sample.t, s.lower_dwell_s):
            return [self._enter(GestureState.IDLE, "idle")]
        if m.state is GestureState.SPINNING:
            self._hold(sample)
        if m.lowered.since is not None:  # the arm is on its way down: hold the forearm
            m.flexed.since = m.straight.since = None
            return []
        if m.state is GestureState.SPINNING:
            return self._spinning(sample)
        if m.flexed.step(sample.flex > s.flex_on_deg, sample.t, s.flex_dwell_s):
            m.spin_start, m.release, m.flexed_last = m.flexed.since, sample, sample  # type: ignore[assignment]
            kind: EventKind = "spin" if m.state is GestureState.LOADING else "reload"
            return [self._enter(GestureState.SPINNING, kind)]
        return []

    # ------------------------------------------------------------- inside

    def _remember(self, sample: Sample) -> None:
        history = self._memory.history
        history.append(sample)
        while history[0].t < sample.t - self._settings.history_s:
            history.popleft()

    def _charge(self, spin_s: float) -> float:
        return min(1.0, max(0.0, spin_s / self._settings.charge_s))

    def _enter(self, state: GestureState, kind: EventKind, direction: Vec3 | None = None,
               charge: float = 0.0) -> GestureEvent:
        m = self._memory
        m.state = state
        m.clear_dwells()
        assert m.t is not None  # only called on a usable sample
        return GestureEvent(kind, m.t, direction if direction is not None else m.pointing, charge)

    def _hold(self, sample: Sample) -> None:
        """Move the release to ``sample`` if the spin is still held there (module doc, "The wave")."""
        m, s = self._memory, self._settings
        if sample.flex > s.flex_on_deg:
            m.release = m.flexed_last = sample
            return
        top = m.flexed_last
        if top is not None and sample.flex > s.hold_deg and sample.flex >= top.flex - s.creep_dps * (sample.t - top.t):
            m.release = sample

    def _spinning(self, sample: Sample) -> list[GestureEvent]:
        m, s = self._memory, self._settings
        straight = sample.flex < s.flex_off_deg
        if not (m.straight.step(straight, sample.t, s.flex_dwell_s)
                or straight and extending_fast(m.history, s.wave_window_s, s.wave_speed_dps)):
            return []
        crossed, release = m.straight.since, m.release
        assert crossed is not None and release is not None  # set on entering SPINNING
        spin_s = crossed - m.spin_start
        if spin_s < s.min_spin_s or crossed - release.t > s.max_straighten_s:
            m.rise_start = -math.inf  # the ball is already up
            return [self._enter(GestureState.LOADING, "load")]
        start = straightening_start(m.history, release, s.aim_lookback_s, s.aim_tolerance_deg)
        aim = held_pointing(m.history, start, s.aim_lead_s, s.aim_trend_s)
        return [self._enter(GestureState.FIRED, "launch", aim, self._charge(spin_s))]
