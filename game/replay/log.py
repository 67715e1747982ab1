"""What the game tells a session as it runs: a recording writes it, a replay collects it to compare.

The app calls a :class:`SessionLog` at fixed points of each frame (see
``game.ui.app.App.frame``): the frame's time step and input events, the
input source's state when it changes, every poll's samples, the walking
input when it changes, and what happened (the arena's and the gesture
machine's events). A :class:`SessionRecorder` writes all of it to a session
recording (:mod:`tracker.session_recording`); the base class keeps only
what happened, which is what a replay compares with the recording.

Record types (each documented in the file's header, ``RECORDS``):
``frame``  {"dt": s, "events": [input event, ...]}, opening each frame;
``link``   the input source's state (:class:`~game.body.controls.SourceState`) from this frame on;
``source`` the game switched its input: {"kind": "keyboard" | "board", "calibration": board calibration};
``walk``   the walking input from this frame on: [forward, strafe, turn];
``round``  a round begins: {"arena": the arena's settings, or null for the defaults};
``hold``   a calibration hold as it happened: the step, the wearing it gave, the arm-down hold's gyro bias;
``happened`` {"t": game time, "arena": [[kind, x, y, z, value], ...], "gestures": [[kind, t, dx, dy, dz, charge], ...]};
binary channel 1 the samples of one poll (:mod:`game.replay.samples`), in the order polled;
binary channel 0 the board's bytes as they arrived, with the host's receive time;
``summary`` how it ended (score, kills, wave, health); ``end``: the file is complete.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Sequence

from tracker.calibration import BiasResult
from tracker.session_recording import WIRE, SessionWriter

from ..body.controls import SourceState
from ..body.gestures import GestureEvent
from ..body.wearing import CalibrationResult
from ..world.arena import ArenaSettings
from ..world.arena_model import ArenaEvent, Controls
from . import samples as S

RECORDS = {
    "frame": "opens each frame: its time step dt (s) and the input events handled in it",
    "link": "the input source's state from this frame on (opened, error, connected, the board's hello)",
    "source": "the game switched its input (keyboard, or a board, virtual or not, with the calibration it was given)",
    "walk": "the walking input [forward, strafe, turn] from this frame on",
    "round": "a round begins, in an arena with these settings (null: the defaults)",
    "hold": "a calibration hold as it happened: its step, the wearing it gave, the gyroscope bias of the arm-down hold",
    "happened": "what the frame did: arena events [kind, x, y, z, value], gesture events [kind, t, dx, dy, dz, charge]",
    "channel 1": "the samples of one poll, in the order polled (game.replay.samples)",
    "channel 0": "the board's bytes as they arrived (t: host seconds since the session began)",
    "summary": "how the session ended (score, kills, wave, health)",
    "end": "the file is complete",
}


@dataclass
class Happened:
    """One frame's events, as a recording holds them."""

    t: float
    arena: list[list]
    gestures: list[list]

    def to_json(self) -> dict:
        return {"type": "happened", "t": self.t, "arena": self.arena, "gestures": self.gestures}


@dataclass
class SessionLog:
    """Hears the game frame by frame; keeps what happened (a replay's, to compare with the recording)."""

    t: float = 0.0  # game time: the sum of the frames' time steps
    happened: list[Happened] = field(default_factory=list)
    _link: SourceState | None = None
    _walk: Controls | None = None

    def frame(self, dt: float, events: list[dict], link: SourceState | None) -> None:
        """A frame begins: its time step, its input events, its input source's state (None: keyboard)."""
        self.t += dt
        self._frame(dt, events)
        if link != self._link:
            self._link = link
            self._write({"type": "link", **(link or SourceState()).to_json(), "keyboard": link is None})

    def source(self, kind: str, calibration: dict | None, virtual: bool) -> None:
        """The game switched its input: "keyboard", or a "board" (``virtual``: the virtual player's)
        with the calibration it was given."""
        self._write({"type": "source", "kind": kind, "calibration": calibration, "virtual": virtual})

    def poll(self, samples: list[S.Sample]) -> None:
        """One poll of the input source and the samples it gave."""

    def hold(self, step: str, result: CalibrationResult, bias: BiasResult | None) -> None:
        """A calibration hold as it happened: the wearing it gave, and for the arm down the gyroscope's
        bias the hold gave (None: keyboard, no board)."""
        self._write({"type": "hold", "step": step, "ok": result.ok, "message": result.message,
                     "wearing": {"mount": list(result.wearing.mount), "init": list(result.wearing.init)}
                     if result.ok else None,
                     "gyro_bias": None if bias is None else {"ok": bias.ok, "message": bias.message,
                                                             "rad_s": [float(b) for b in bias.bias]}})

    def round(self, settings: ArenaSettings | None) -> None:
        """A round begins in an arena with these settings (None: the defaults)."""
        self._write({"type": "round", "arena": None if settings is None else
                     {f.name: getattr(settings, f.name) for f in fields(settings) if f.init}})

    def walking(self, controls: Controls) -> None:
        if controls != self._walk:
            self._walk = controls
            self._write({"type": "walk", "c": [controls.forward, controls.strafe, controls.turn]})

    def events(self, arena: Sequence[ArenaEvent], gestures: Sequence[GestureEvent]) -> None:
        """What this frame did, if anything."""
        if arena or gestures:
            done = Happened(self.t, [[e.kind, *e.position, e.value] for e in arena],
                            [[str(g.kind), g.t, *g.direction, g.charge] for g in gestures])
            self.happened.append(done)
            self._write(done.to_json())

    def _frame(self, dt: float, events: list[dict]) -> None:
        """Subclasses write the frame."""

    def _write(self, record: dict) -> None:
        """Subclasses write a record."""


class SessionRecorder(SessionLog):
    """Writes the session to a recording as it goes (bounded memory; see :mod:`tracker.session_recording`)."""

    def __init__(self, path: str | Path, header: dict) -> None:
        super().__init__()
        self.writer = SessionWriter(path, header, RECORDS)
        self.happened_count = 0
        self._start = time.monotonic()

    def _frame(self, dt: float, events: list[dict]) -> None:
        self.writer.json({"type": "frame", "dt": dt, "events": events})

    def _write(self, record: dict) -> None:
        self.writer.json(record)

    def events(self, arena: Sequence[ArenaEvent], gestures: Sequence[GestureEvent]) -> None:
        super().events(arena, gestures)
        self.happened_count += len(self.happened)
        self.happened.clear()  # written: memory stays bounded

    def poll(self, samples: list[S.Sample]) -> None:
        self.writer.binary(S.SAMPLES, self.t, S.pack(samples))

    def wire(self, data: bytes) -> None:
        """The board's bytes as they arrived (called from the link's reader thread)."""
        self.writer.binary(WIRE, time.monotonic() - self._start, data)

    def close(self, summary: dict) -> None:
        self.writer.json({"type": "summary", **summary})
        self.writer.close()
