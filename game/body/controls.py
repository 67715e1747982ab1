"""Input sources: the tracker, or keyboard and mouse, each making the same ArmPose.

Whatever the source, the game gets an :class:`~game.body.pose.ArmPose` per frame,
so one avatar and one gesture machine serve every player. The keyboard and
mouse source builds the pose a worn board would report (for the ideal
mounting, :class:`~game.body.avatar.Wearing`'s default), so it needs no
calibration. The tracker source reads a board in the background
(:mod:`tracker.link`), runs :mod:`game.body.tracking`, and keeps the last seconds
of raw readings for the live plots.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from dataclasses import dataclass
from typing import Callable, Iterable

import numpy as np
from mypy_extensions import mypyc_attr

from tracker import protocol as P
from tracker.fusion import qmath as qm
from tracker.link import Link, LinkError, LinkHealth, LinkSettings

from .avatar import Wearing
from .pose import ArmPose
from .tracking import Tracking

PLOT_SECONDS = 4.0
PLOT_RATE = 200
RECENT_SECONDS = 6.0  # "hold still" judges up to 5 s (tracker.calibration.LONGER_HOLD_S)


@dataclass
class KeyboardMouse:
    """Mouse aims, a key or button raises the arm, another flexes the elbow.

    ``aim_x``/``aim_y`` in -1..1 (screen centre 0; right and up positive) map
    to azimuth +-60 deg and elevation 60..120 deg from hanging; the arm and
    the elbow move toward their targets with a short time constant, as a real
    arm would, so the gesture machine's dwell times see realistic motion.
    """

    raise_tau_s: float = 0.08
    flex_tau_s: float = 0.05
    raised: bool = False
    flexed: bool = False
    aim_x: float = 0.0
    aim_y: float = 0.0
    elevation_deg: float = 0.0
    azimuth_deg: float = 0.0
    flex_deg: float = 0.0
    t: float = 0.0
    mount: tuple[float, float, float, float] = Wearing().mount

    def update(self, dt: float) -> ArmPose:
        """Move the arm toward the inputs for ``dt`` seconds and return its pose."""
        self.t += dt
        target_el = 90.0 + 30.0 * max(-1.0, min(1.0, self.aim_y)) if self.raised else 0.0
        target_az = 60.0 * max(-1.0, min(1.0, self.aim_x)) if self.raised else self.azimuth_deg
        target_flex = 100.0 if self.flexed else 0.0
        k_arm = 1.0 - math.exp(-dt / self.raise_tau_s)
        k_flex = 1.0 - math.exp(-dt / self.flex_tau_s)
        self.elevation_deg += k_arm * (target_el - self.elevation_deg)
        self.azimuth_deg += k_arm * (target_az - self.azimuth_deg)
        self.flex_deg += k_flex * (target_flex - self.flex_deg)
        return ArmPose(self.quaternion(), self.flex_deg, self.t)

    def quaternion(self) -> tuple[float, float, float, float]:
        """The board's q_WS for the arm at (azimuth, elevation): body-frame arm times the ideal mount^-1.

        The hanging arm (-z) is raised forward about x by the elevation and then
        turned about z by minus the azimuth (azimuth positive to the right).
        """
        half = 0.5 * math.radians(self.elevation_deg)  # scalar maths: numpy's per-call cost is most of this
        arm = qm.mul(qm.about_z(-math.radians(self.azimuth_deg)), (math.cos(half), math.sin(half), 0.0, 0.0))
        return qm.mul(arm, qm.conj(qm.as_quat(self.mount)))


@dataclass(frozen=True)
class SourceState:
    """What the game asks of an input source, taken once a frame (so a frame sees one state however
    the link's thread moves on meanwhile, and a replay can give the same): whether it is usable or
    failed, whether the board is there now, and its HELLO."""

    opened: bool = False  # opening is over (usable, or failed: ``error``)
    error: str | None = None
    connected: bool = False
    hello: P.Hello | None = None

    def to_json(self) -> dict:
        return {"opened": self.opened, "error": self.error, "connected": self.connected,
                "hello": self.hello.to_json() if self.hello else None}

    @classmethod
    def from_json(cls, d: dict) -> "SourceState":
        hello = d.get("hello")
        return cls(bool(d["opened"]), d.get("error"), bool(d["connected"]),
                   P.Hello.from_json(hello) if hello else None)


@mypyc_attr(allow_interpreted_subclasses=True)  # the Board setup's simulated maker (game.ui.board_setup) is one
class SampleInput:
    """Board samples through :mod:`game.body.tracking` to ArmPoses, keeping the last seconds of raw ones.

    The recent raw samples serve "hold still" and the live plots (bounded
    memory). Subclasses say where the samples come from (:meth:`arrived`);
    ``on_poll``, when set, hears every poll's samples (a session recording).
    """

    def __init__(self, tracking: Tracking | None = None) -> None:
        self.tracking = tracking or Tracking()
        self.status = ""  # what the source is doing, in words (the HUD shows it)
        self.error: str | None = None  # why the source cannot be used, if it cannot
        self.opened = threading.Event()  # set once the source is usable (or has failed)
        self.last_pose: ArmPose | None = None
        self.last_seq: int | None = None
        self.recent: deque[P.RawSample] = deque(maxlen=int(RECENT_SECONDS * PLOT_RATE))
        self.on_poll: Callable[[list[P.RawSample | P.FusedSample]], None] | None = None

    def feed(self, samples: Iterable[P.RawSample | P.FusedSample]) -> ArmPose | None:
        """Run every sample through the pipeline; the newest pose (or the last one)."""
        for s in samples:
            self.last_pose = self.tracking.feed(s)
            self.last_seq = s.seq
            if isinstance(s, P.RawSample):
                self.recent.append(s)
        return self.last_pose

    def poll(self) -> ArmPose | None:
        """Feed what arrived since the last call; the newest pose (or the last one)."""
        samples = self.arrived()
        if self.on_poll is not None:
            self.on_poll(samples)
        return self.feed(samples)

    def arrived(self) -> list[P.RawSample | P.FusedSample]:
        """The samples that arrived since the last call."""
        raise NotImplementedError

    def state(self) -> SourceState:
        """This moment's :class:`SourceState`."""
        return SourceState(self.opened.is_set(), self.error, self.connected, self.hello_now())

    def hello_now(self) -> P.Hello | None:
        """The board's HELLO while it is connected (None: none yet, or a source without one)."""
        return None

    @property
    def connected(self) -> bool:
        return self.opened.is_set() and self.error is None

    def health(self) -> LinkHealth | None:
        return None

    def close(self) -> None:
        """Let go of the source."""

    def plot_series(self) -> dict[str, np.ndarray]:
        """The last PLOT_SECONDS of gyroscope, accelerometer and flex readings, for the live plots."""
        samples = list(self.recent)[-int(PLOT_SECONDS * PLOT_RATE):]
        return {"gyroscope (rad/s)": np.array([s.gyr for s in samples]).reshape(-1, 3),
                "accelerometer (m/s2)": np.array([s.acc for s in samples]).reshape(-1, 3),
                "flex (ADC)": np.array([s.flex_adc for s in samples]).reshape(-1, 1)}


class TrackerInput(SampleInput):
    """A board read in the background; :meth:`poll` gives the newest ArmPose.

    Opening (the handshake can take two seconds) happens in a thread, so the
    window stays responsive; ``status`` says what is going on in words.
    """

    def __init__(self, settings: LinkSettings, tracking: Tracking | None = None,
                 tap: Callable[[bytes], None] | None = None) -> None:
        """``tap`` sees every byte read from the board (a session recording's)."""
        super().__init__(tracking)
        self.link = Link(settings)
        self.link.tap = tap
        self.status = f"connecting to {settings.port}..."
        threading.Thread(target=self._open, name="tracker-open", daemon=True).start()

    def _open(self) -> None:
        try:
            hello = self.link.open()
            self.status = f"board on {self.link.settings.port}" + (f" (firmware {hello.firmware})" if hello else "")
        except LinkError as e:
            self.error = str(e)
            self.status = str(e)
        self.opened.set()

    @property
    def connected(self) -> bool:
        return super().connected and self.link.connected

    def health(self) -> LinkHealth | None:
        return self.link.health() if self.opened.is_set() and self.error is None else None

    def arrived(self) -> list[P.RawSample | P.FusedSample]:
        """Every waiting sample (none before the link is open)."""
        if not self.opened.is_set() or self.error:
            return []
        return self.link.drain()

    def hello_now(self) -> P.Hello | None:
        return self.link.hello if self.connected else None

    def close(self) -> None:
        if self.opened.is_set() and self.error is None:
            self.link.close()
