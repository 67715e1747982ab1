"""Re-scoring a recorded session: its sensor stream through another filter or other gesture settings.

A researcher's use of a session recording. While a replay plays the
recorded game, a second pipeline runs beside it on the same input: each
frame's polled samples (:attr:`Frame.polls <game.replay.replay.Frame>`)
through the ``--filter`` named, with the game's board calibration and flex
tracking (``default``: the game's own, :func:`game.body.tracking.game_filter`;
any other: :func:`tracker.fusion.make`), posed on a copy of the game's
avatar (its wearing, position and turn), and the arm's state through a
gesture machine with the ``--gestures`` settings. With only other gesture
settings, the second machine reads the game's own arm state, frame by
frame, so the comparison isolates the thresholds. The game itself plays
on as recorded.

The launches of the two are then matched in time: a launch of the other
pipeline within ``MATCH_S`` of one of the game's is the same throw
(``moved`` if its time or aim differ), the game's launches left over
``disappear``, the other's ``appear``.
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass, field

from tracker.figures import figure, save_png
from tracker.fusion import make
from tracker.fusion.default import DefaultFilter

from ..body.avatar import Avatar, ArmState
from ..body.gestures import GestureEvent, GestureMachine, GestureSettings
from ..body.tracking import Tracking, game_filter
from . import samples as S

MATCH_S = 0.5  # launches this close in time are the same throw
MOVED_S = 0.005  # a throw whose launch time moved more than this (one sample) has moved
MOVED_DEG = 0.5  # or whose aim turned more than this


@dataclass
class Track:
    """One pipeline's arm and gestures over time, for the plot and the comparison."""

    t: list[float] = field(default_factory=list)
    elevation_deg: list[float] = field(default_factory=list)
    flex_deg: list[float] = field(default_factory=list)
    state: list[str] = field(default_factory=list)
    launches: list[dict] = field(default_factory=list)  # {"t", "direction", "charge"}

    def add(self, arm: ArmState, state: str, launches: list[dict]) -> None:
        self.t.append(arm.t)
        self.elevation_deg.append(arm.elevation_deg)
        self.flex_deg.append(arm.flex_deg)
        self.state.append(state)
        self.launches += launches


class Rescorer:
    """The second pipeline of a replay (see the module's docstring)."""

    def __init__(self, filter_name: str | None, gestures: GestureSettings | None) -> None:
        self.filter_name = filter_name
        self.other_gestures = gestures is not None
        self.machine = GestureMachine(gestures)
        self.tracking: Tracking | None = None
        self.avatar = Avatar()
        self.game_track, self.other_track = Track(), Track()
        self._board: object = None
        self._last_t: float | None = None
        self._anchored: float | None = None  # when the game's tracking last took "forward"
        self.samples = 0  # fed to the other filter

    def frame(self, game, polls: list[list[S.Sample]], gestures: list[list]) -> None:
        """After one replayed frame: the game's arm and launches (``gestures``: the frame's gesture events
        as a recording holds them), and the other pipeline's."""
        arm = game.avatar.state
        if arm is None or arm.t == self._last_t:
            return  # the game did not pose the arm in this frame (not playing)
        self._last_t = arm.t
        self.game_track.add(arm, game.gestures.state.value,
                            [{"t": g[1], "direction": g[2:5], "charge": g[5]} for g in gestures if g[0] == "launch"])
        other = self._other_arm(game, polls) if self.filter_name else arm
        if other is not None:
            events = self.machine.update(other)
            self.other_track.add(other, self.machine.state.value, [_launch(e) for e in events if e.kind == "launch"])

    def _other_arm(self, game, polls: list[list[S.Sample]]) -> ArmState | None:
        """The arm as the other filter has it after this frame's samples."""
        source = game.tracker
        if source is None:
            return None
        if self.tracking is None or source.tracking.board is not self._board:  # a new calibration: start again
            self._board = source.tracking.board
            other = game_filter() if self.filter_name == DefaultFilter.name else make(self.filter_name)
            self.tracking = Tracking(board=source.tracking.board, filter=other,
                                     flex_calibration=source.tracking.flex_calibration)
        pose = None
        for batch in polls:
            self.samples += len(batch)
            for s in batch:
                pose = self.tracking.feed(s)
        if pose is None:
            return None
        taken = source.tracking.anchor.t0
        if taken is not None and taken != self._anchored:  # the game took "forward" again
            self._anchored = taken
            self.tracking.anchor_heading()
        self.avatar.body, self.avatar.wearing = game.avatar.body, game.avatar.wearing
        self.avatar.position, self.avatar.body_yaw = game.avatar.position, game.avatar.body_yaw
        return self.avatar.update(pose)

    def compare(self) -> dict:
        """The launches that appear, disappear or move against the game's."""
        theirs = list(self.other_track.launches)
        moved, gone = [], []
        for mine in self.game_track.launches:
            near = min(theirs, key=lambda e: abs(e["t"] - mine["t"]), default=None)
            if near is None or abs(near["t"] - mine["t"]) > MATCH_S:
                gone.append(mine)
                continue
            theirs.remove(near)
            turn = _angle_deg(mine["direction"], near["direction"])
            if abs(near["t"] - mine["t"]) > MOVED_S or turn > MOVED_DEG:
                moved.append({"from": mine, "to": near, "dt_s": near["t"] - mine["t"], "aim_turned_deg": turn})
        return {"filter": self.filter_name or "the game's", "gestures": asdict(self.machine.settings),
                "samples": self.samples, "launches": len(self.game_track.launches),
                "other_launches": len(self.other_track.launches),
                "appeared": theirs, "disappeared": gone, "moved": moved}


def _launch(e: GestureEvent) -> dict:
    return {"t": e.t, "direction": list(e.direction), "charge": e.charge}


def _angle_deg(a, b) -> float:
    dot = sum(x * y for x, y in zip(a, b))
    return math.degrees(math.acos(max(-1.0, min(1.0, dot))))


STATES = ("idle", "loading", "spinning", "fired")  # the gesture machine's states, bottom to top in the plot


def plot(rescorer: Rescorer, path: str | os.PathLike, title: str) -> None:
    """The elbow angle, the arm's elevation and the gesture state over time, the game's and the other
    pipeline's, launches marked (game: solid, other: dashed); a PNG at ``path``."""
    fig = figure(10, 7)
    axes = fig.subplots(3, 1, sharex=True)
    tracks = ((rescorer.game_track, "the game", "-"), (rescorer.other_track, _other_name(rescorer), "--"))
    for track, name, style in tracks:
        axes[0].plot(track.t, track.elevation_deg, style, label=name, linewidth=1)
        axes[1].plot(track.t, track.flex_deg, style, label=name, linewidth=1)
        axes[2].step(track.t, [STATES.index(s) if s in STATES else -1 for s in track.state], style,
                     where="post", label=name, linewidth=1)
        for ax in axes:
            for launch in track.launches:
                ax.axvline(launch["t"], linestyle=style, color="tab:red", alpha=0.5, linewidth=0.8)
    axes[0].set_ylabel("elevation (deg)")
    axes[1].set_ylabel("elbow flex (deg)")
    axes[2].set_yticks(range(len(STATES)), STATES)
    axes[2].set_xlabel("board time (s); red lines: launches")
    axes[0].set_title(title)
    axes[0].legend(loc="upper right")
    save_png(fig, path)


def _other_name(rescorer: Rescorer) -> str:
    who = rescorer.filter_name or "the game's"
    return f"{who} filter" + (", the other gesture settings" if rescorer.other_gestures else "")
