"""Playing a session recording again: the same game, frame by frame, compared with what it recorded.

The recording holds every input the game took (:mod:`game.replay.log`):
each frame's time step and input events, the input source's state, every
poll's samples, the walking input. A replay starts the same game (seed,
settings, window size, the board calibrations that were saved) and hands
it those inputs at the same points: the input events to the app, the polls'
samples through a :class:`ReplaySource` in place of the board, the walking
through the game's walker. Everything after that is the game's own code, so
it does what it did: the same poses, gestures, zombies, hits and score. What
the replay's game did is compared with what the recording says it did,
frame by frame; the first difference is reported, never hidden.

A recording cut off (a crash, a pulled plug) replays up to its last
complete block, and the report says where it stopped.
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Iterator, Protocol

from tracker.calibration import BoardCalibration
from tracker.recording import RecordingError, summarize
from tracker.session_recording import BinaryRecord, SessionReader

from ..body.controls import SampleInput, SourceState
from ..body.tracking import Tracking
from ..world.arena import ArenaSettings
from ..world.arena_model import Controls
from . import samples as S
from .log import Happened, SessionLog
from .rescore import Rescorer


@dataclass
class Frame:
    """One recorded frame: what the game was given in it, and what it did."""

    dt: float
    events: list[dict]
    link: SourceState | None = None  # the source's state from this frame on (None: unchanged)
    sources: list[dict] = field(default_factory=list)  # input switches, in order
    polls: list[list[S.Sample]] = field(default_factory=list)  # each poll's samples, in order
    walk: Controls | None = None  # the walking input from this frame on (None: unchanged)
    arena: list[dict | None] = field(default_factory=list)  # the settings of each round begun in it
    holds: list[dict] = field(default_factory=list)  # calibration holds, as recorded
    happened: Happened | None = None


def frames(reader: SessionReader) -> Iterator[Frame]:
    """The recording's frames, in order; the records before the first frame form a frame of dt 0
    (the input chosen at the start)."""
    current = Frame(0.0, [])
    for record in reader.records():
        if isinstance(record, BinaryRecord):
            if record.channel == S.SAMPLES:
                current.polls.append(S.unpack(record.data))
            continue
        kind = record["type"]
        if kind == "frame":
            yield current
            current = Frame(float(record["dt"]), list(record["events"]))
        elif kind == "link":
            current.link = None if record["keyboard"] else SourceState.from_json(record)
        elif kind == "source":
            current.sources.append(record)
        elif kind == "walk":
            current.walk = Controls(*record["c"])
        elif kind == "round":
            current.arena.append(record["arena"])
        elif kind == "hold":
            current.holds.append(record)
        elif kind == "happened":
            current.happened = Happened(record["t"], record["arena"], record["gestures"])
    yield current


class ReplaySource(SampleInput):
    """A board in a replay: each poll gives the recorded poll's samples; its state is the recorded one."""

    def __init__(self, tracking: Tracking) -> None:
        super().__init__(tracking)
        self.frame = Frame(0.0, [])
        self.recorded = SourceState()
        self._next = 0
        self.status = "a recorded board"
        self.opened.set()

    def begin(self, frame: Frame) -> None:
        """The next frame's polls and state."""
        self.frame, self._next = frame, 0
        if frame.link is not None:
            self.recorded = frame.link

    def arrived(self) -> list[S.Sample]:
        if self._next >= len(self.frame.polls):
            return []  # a poll the recording does not have: the games differ, and the comparison will say so
        self._next += 1
        return self.frame.polls[self._next - 1]

    def state(self) -> SourceState:
        return self.recorded


@dataclass
class Difference:
    """The first frame where the replay did not do what the recording says."""

    frame: int
    t: float
    recorded: dict | None
    replayed: dict | None

    def to_json(self) -> dict:
        return {"frame": self.frame, "t": self.t, "recorded": self.recorded, "replayed": self.replayed}


@dataclass
class ReplayReport:
    """What a replay found: the summary, the events, the first difference, and where it stopped."""

    header: dict
    frames: int = 0
    t: float = 0.0
    events: list[dict] = field(default_factory=list)
    summary: dict = field(default_factory=dict)
    difference: Difference | None = None
    stopped: str | None = None  # why the recording ended early (cut off, damaged)
    holds: list[dict] = field(default_factory=list)  # the calibration holds, as recorded
    link: dict | None = None  # the board's link, from its bytes in the recording (None: no board)

    def to_json(self) -> dict:
        launches = [{"t": e["t"], "direction": g[2:5], "charge": g[5]}
                    for e in self.events for g in e["gestures"] if g[0] == "launch"]
        return {"recorded": {k: self.header.get(k) for k in ("created", "game_version", "seed", "input")},
                "frames": self.frames, "seconds": round(self.t, 6), "summary": self.summary,
                "launches": launches, "holds": self.holds, "link": self.link,
                "same_as_recorded": self.difference is None,
                "difference": self.difference.to_json() if self.difference else None,
                "stopped": self.stopped, "events": self.events}


class Viewer(Protocol):
    """Who watches a replay in a window (:mod:`game.ui.replay_window`)."""

    def drawing(self, t: float) -> bool:
        """Whether the frame at game time ``t`` is to be drawn (not while seeking ahead)."""

    def after(self, app: object, t: float) -> bool:
        """The frame at ``t`` is done (and drawn if asked): show it; False to stop the replay."""


def replay(path: str | Path, viewer: Viewer | None = None, rescorer: Rescorer | None = None) -> ReplayReport:
    """Play a session recording again: headless, or in a window a ``viewer`` watches; a ``rescorer``
    runs its second pipeline beside it (:mod:`game.replay.rescore`)."""
    if viewer is None:
        from ..sim.headless import without_window
        without_window()
    from ..ui.app import App, Play
    from ..ui.preferences import Preferences
    from ..ui.session_events import event_from_json, session_summary

    reader = SessionReader(path)
    header = reader.header
    report = ReplayReport(header)
    log = SessionLog()
    with tempfile.TemporaryDirectory(prefix="energyball-replay-") as folder:
        _saved_boards(Path(folder), header.get("boards", {}))
        prefs = replace(Preferences(**header["settings"]), input="keyboard", volume=0.0, music_volume=0.0)
        app = App(prefs, config_dir=Path(folder), seed=int(header["seed"]), size=tuple(header["window"]),
                  draws=viewer is not None, session=lambda game: log)
        game = app.game
        app.scans_for_boards = False
        source: list[ReplaySource] = []
        pending: list[dict] = []

        def open_board(port: str | None, virtual: bool) -> SampleInput:
            recorded = pending.pop(0) if pending else {"calibration": None}
            calibration = recorded.get("calibration")
            board = BoardCalibration.from_json(calibration) if calibration else BoardCalibration()
            source[:] = [ReplaySource(Tracking(board=board))]
            return source[0]

        game.board_opener = open_board
        walking = [Controls()]
        game.walker = lambda: walking[0]
        for number, frame in enumerate(frames(reader)):
            pending[:] = [r for r in frame.sources if r["kind"] == "board"]
            if number == 0:  # the input chosen at the start
                for r in frame.sources:
                    if r["kind"] == "board":
                        game.use_board(None, r["virtual"])
                    else:
                        game.use_keyboard()
                continue
            report.holds += frame.holds
            if frame.arena:  # the round begun in this frame is in an arena of these settings
                game.arena_settings = ArenaSettings(**frame.arena[-1]) if frame.arena[-1] else None
            if source:
                source[0].begin(frame)
            if frame.walk is not None:
                walking[0] = frame.walk
            done = len(log.happened)
            playing = isinstance(app.screen, Play)
            app.frame([event_from_json(e) for e in frame.events], frame.dt,
                      draw=viewer is not None and viewer.drawing(log.t))
            report.frames, report.t = number, log.t
            replayed = log.happened[done].to_json() if len(log.happened) > done else None
            if rescorer is not None and playing:
                rescorer.frame(game, frame.polls, replayed["gestures"] if replayed else [])
            recorded = frame.happened.to_json() if frame.happened else None
            if report.difference is None and replayed != recorded:
                report.difference = Difference(number, log.t, recorded, replayed)
            if viewer is not None and not viewer.after(app, log.t) or not app.running:
                break
        report.summary = session_summary(game)
        app.close()
    report.events = [h.to_json() for h in log.happened]
    report.stopped = reader.stopped
    report.link = _link(path)
    return report


def _link(path: str | Path) -> dict | None:
    """The board's link as its bytes in the recording tell it (decoded as ``armtracker decode`` does)."""
    try:
        summary = summarize(path)
    except RecordingError:  # no board in the session (the keyboard)
        return None
    out = summary.to_json()
    return {key: out[key] for key in ("samples", "crc_errors", "dropped", "bytes_skipped", "duration_s",
                                      "board_restarts")}


def _saved_boards(folder: Path, boards: dict) -> None:
    """The board calibrations that were saved when the session was recorded, in the replay's folder."""
    (folder / "boards").mkdir()
    for name, content in boards.items():
        if Path(name).name == name and name.endswith(".json"):
            (folder / "boards" / name).write_text(json.dumps(content), encoding="utf-8")
