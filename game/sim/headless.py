"""Headless simulated matches: a bot wears a simulated board, and every layer runs as in a real game.

One match, frame by frame (``FRAME_HZ``, simulated time):

1. The bot (:mod:`game.sim.bot`) sees the screen and the arena. It presses keys,
   walks, and writes its arm's next moves into its motion script.
2. The board (:class:`tracker.sim_board.SimBoard`) runs its firmware loop up to the frame's
   time. The sensor simulator (:mod:`tracker.sim`) measures the bot's arm
   at 200 Hz, with MPU-9250 errors and the flex circuit. Each sample is
   quantised and framed as the firmware does it. The injected link faults
   (:class:`tracker.board.Faults`) corrupt or drop bytes, or stall the loop.
3. The bytes cross the wire: in memory, or with ``pty`` through a real
   pseudo-terminal read by pyserial.
4. The app's own frame (:meth:`game.ui.app.App.frame`) runs the rest:
   :class:`WireInput` decodes the frames (:class:`tracker.protocol.FrameDecoder`)
   and feeds :mod:`game.body.tracking`. That is the ``default`` filter with the
   board's six-pose accelerometer calibration, done once by its maker and
   simulated here, and the flex tracker. Then come the screens, the bot's
   guided calibration, the avatar, the gesture machine and the arena.
   Drawing is skipped unless ``render``.

Launches are scored against the bot's intentions with the gesture evaluation's
rules (:func:`game.sim.gesture_eval.score_launches`), in the body frame. A launch
the match ended before it could be seen is not counted. Every random draw is
seeded from the match's seed, so a match's results (all but ``timing``) are
the same run after run and on any number of worker processes.
"""

from __future__ import annotations

import gc
import math
import multiprocessing
import os
import signal
import pty
import resource
import statistics
import sys
import tempfile
import time
import tty
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

from mypy_extensions import mypyc_attr



def without_window() -> None:
    """SDL's dummy video and audio drivers, and no SDL signal handlers: for an app nobody watches."""
    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
    # Signals are ours (tracker.signals): SDL would otherwise take SIGINT and SIGTERM wherever they are left
    # at their defaults (a pool's worker) and turn them into a quit event that a headless match never reads.
    os.environ.setdefault("SDL_NO_SIGNAL_HANDLERS", "1")


without_window()

from tracker import compiled, protocol as P, signals  # noqa: E402
from tracker.board import Faults  # noqa: E402
from tracker.sim_board import SimBoard  # noqa: E402

from ..body.controls import SampleInput  # noqa: E402
from ..body.gestures import GestureEvent  # noqa: E402
from ..body.tracking import Tracking  # noqa: E402
from ..replay.log import SessionRecorder  # noqa: E402
from ..world.arena import ArenaSettings  # noqa: E402
from ..world.arena_model import Controls  # noqa: E402
from .bot import DIFFICULTIES, Bot, Screen  # noqa: E402
from .gesture_eval import MATCH_AFTER_S, TrialResult, maker_calibration, score_launches  # noqa: E402
from .motion_model import PlayerProfile  # noqa: E402

FRAME_HZ = 60  # the game's frame rate in simulated time
SIZE = (640, 360)  # the dummy window's size when rendering
PROGRESS_S = 60  # simulated seconds between progress lines within a match (one worker)
MAX_SETUP_S = 90.0  # menu and calibration take at most this long, or the match is abandoned
GC_YOUNGEST = 50_000  # during a match, the cycle collector's youngest generation is collected after this
# many more allocations than frees of tracked objects, not Python's default 700: each board block, decoded
# frame and pose lives briefly, and at 700 the collections (most of them finding nothing) took 5-9 % of a
# match; a pass of the youngest generation at 50,000 takes a few ms, and the older two keep their thresholds


@mypyc_attr(native_class=False)  # a plain class even when compiled (README, "The compiled build")
@dataclass(frozen=True)
class MatchConfig:
    """One match's settings (JSON-able through ``dataclasses.asdict``)."""

    seed: int = 0
    duration_s: float = 120.0  # play time (after the calibration) at most
    difficulty: str = "normal"
    profile: PlayerProfile = PlayerProfile()
    faults: Faults = Faults()
    endless: bool = False  # zombies do no harm: the match lasts its whole duration (soak runs)
    render: bool = False  # draw every frame (the dummy video driver)
    pty: bool = False  # the bytes go through a real pty and pyserial
    record_dir: str | None = None  # keep a session recording of the match there (match-SEED.ebs)

    def __post_init__(self) -> None:
        if self.difficulty not in DIFFICULTIES:
            raise ValueError(f"difficulty must be one of {', '.join(DIFFICULTIES)}, not {self.difficulty!r}")
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise ValueError(f"duration must be a positive number of seconds, not {self.duration_s!r}")


# ----------------------------------------------------------------- the wire


class MemoryWire:
    """Bytes handed straight from the board to the host."""

    label = "simulated board (in memory)"

    def __init__(self) -> None:
        self._pending = bytearray()

    def write(self, data: bytes) -> None:
        self._pending += data

    def read(self) -> bytes:
        data, self._pending = bytes(self._pending), bytearray()
        return data

    def close(self) -> None:
        pass


class PtyWire:
    """Bytes through a real pseudo-terminal: the board writes its end, the host reads the port with pyserial.

    The host reads exactly as many bytes as were written (a pty may hand
    them over a little later), so the match stays deterministic.
    """

    def __init__(self, timeout_s: float = 5.0) -> None:
        import serial  # the pty path needs pyserial; the in-memory one does not
        self._master, slave = pty.openpty()
        tty.setraw(self._master)
        self.port_name = os.ttyname(slave)
        self._slave = slave
        self.port = serial.Serial(self.port_name, baudrate=P.DEFAULT_BAUD, timeout=timeout_s)
        self.label = f"simulated board on {self.port_name}"
        self._pending = 0

    def write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            n = os.write(self._master, view)
            view = view[n:]
        self._pending += len(data)

    def read(self) -> bytes:
        data = self.port.read(self._pending)
        if len(data) < self._pending:
            raise OSError(f"the pty delivered {len(data)} of {self._pending} bytes in time")
        self._pending = 0
        return data

    def close(self) -> None:
        self.port.close()
        for fd in (self._master, self._slave):
            os.close(fd)


class WireInput(SampleInput):
    """The game's input from the wire: frames decoded, samples through :mod:`game.body.tracking`."""

    def __init__(self, wire: MemoryWire | PtyWire, tracking: Tracking,
                 tap: Callable[[bytes], None] | None = None) -> None:
        """``tap`` sees every byte read from the wire (a session recording's)."""
        super().__init__(tracking)
        self.wire = wire
        self.tap = tap
        self.decoder = P.FrameDecoder()
        self.samples_decoded = 0
        self.status = wire.label
        self.opened.set()

    def arrived(self) -> list[P.RawSample | P.FusedSample]:
        data = self.wire.read()
        if self.tap is not None and data:
            self.tap(data)
        packets = self.decoder.feed(data)
        samples: list[P.RawSample | P.FusedSample] = [p for p in packets if isinstance(p, P.RawSample)]
        self.samples_decoded += len(samples)
        return samples


# ----------------------------------------------------------------- one match


@dataclass
class Observed:
    """What the match records as it runs: launches (body frame) and when play ran."""

    launches: list[GestureEvent] = field(default_factory=list)
    play_start: float | None = None
    play_end: float | None = None
    rss_mb: list[float] = field(default_factory=list)  # after the first minute of play, at the end
    calibration_failures: int = 0  # the guided calibration's attempts that failed (the bot tried again)
    calibration_step: str = ""  # the calibration step last seen


def _body_frame(event: GestureEvent, body_yaw: float) -> GestureEvent:
    """The event with its world direction turned into the body's frame (undo the body's yaw)."""
    x, y, z = event.direction
    c, s = math.cos(body_yaw), math.sin(body_yaw)
    return replace(event, direction=(c * x + s * y, -s * x + c * y, z))


def _peak_rss_mb() -> float:
    """The process's peak resident memory, MB (getrusage counts kB on Linux, bytes on macOS)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * (1 if sys.platform == "darwin" else 1024) / 1e6


def _rss_mb() -> float:
    """The process's resident memory now, MB (Linux /proc; the peak elsewhere)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6
    except OSError:
        return _peak_rss_mb()


def run_match(config: MatchConfig, progress: Callable[[str], None] | None = None) -> dict:
    """Play one match; its report (``timing`` holds the wall-clock figures).

    ``progress`` hears how the match goes every ``PROGRESS_S`` of play. The
    cycle collector runs less often meanwhile (:data:`GC_YOUNGEST`).
    """
    threshold = gc.get_threshold()
    gc.set_threshold(GC_YOUNGEST, threshold[1], threshold[2])
    try:
        return _play(config, progress)
    finally:
        gc.set_threshold(*threshold)


def _play(config: MatchConfig, progress: Callable[[str], None] | None) -> dict:
    """:func:`run_match`'s match."""
    import pygame

    from ..ui.app import App, Calibration, GameOver, Menu, Play
    from ..ui.preferences import Preferences
    from ..ui.session_events import recorder

    prepare0 = time.perf_counter()  # the board built and calibrated by its maker, the app built
    profile, seed = config.profile, config.seed
    bot = Bot(DIFFICULTIES[config.difficulty], profile, seed)
    sim = profile.simulator(bot.script.motion, seed)
    board = SimBoard(sim, bot.script.take_edits, replace(config.faults, seed=seed))
    wire = PtyWire() if config.pty else MemoryWire()
    seen = Observed()
    keys = {"return": pygame.K_RETURN, "r": pygame.K_r}
    screens: dict[type, str] = {Menu: "menu", Calibration: "calibration", Play: "play",
                                GameOver: "game_over"}
    with tempfile.TemporaryDirectory(prefix="energyball-match-") as folder:
        session = recorder(Path(config.record_dir) / f"match-{seed}.ebs") if config.record_dir else None
        app = App(Preferences(input="keyboard", volume=0.0, music_volume=0.0), config_dir=Path(folder),
                  seed=seed, size=SIZE, draws=config.render, session=session)
        game = app.game
        if config.endless:
            game.arena_settings = ArenaSettings(contact_damage_per_s=0.0)
        board_calibration, problem = maker_calibration(profile, seed)
        if problem and progress:  # the match goes on with what the maker's calibration gave
            progress(f"seed {seed}: {problem}")
        source = WireInput(wire, Tracking(board=board_calibration),
                           tap=game.log.wire if isinstance(game.log, SessionRecorder) else None)
        game.use_source(source)
        walking = [Controls()]
        game.walker = lambda: walking[0]
        game.on_launch = lambda event: seen.launches.append(_body_frame(event, game.avatar.body_yaw))
        wire.write(board.hello())
        wall0 = time.perf_counter()  # play: from the board's hello to the end
        frame, t, next_report = 0, 0.0, float(PROGRESS_S)
        try:
            while True:
                screen = app.screen
                if seen.play_start is None and isinstance(screen, Play):
                    seen.play_start = t
                playing = 0.0 if seen.play_start is None else t - seen.play_start
                if isinstance(screen, GameOver) or playing >= config.duration_s or \
                        (seen.play_start is None and t > MAX_SETUP_S):
                    break
                if playing >= 60.0 and len(seen.rss_mb) == 0:
                    seen.rss_mb.append(_rss_mb())
                if progress and playing >= next_report:
                    next_report += PROGRESS_S
                    progress(f"  seed {config.seed}: {playing:.0f} s played, score {game.arena.score}, "
                             f"wave {game.arena.wave}, health {game.arena.player.health:.0f}, "
                             f"{t / (time.perf_counter() - wall0):.0f}x")
                frame += 1
                t = frame / FRAME_HZ
                view = _screen(screen, screens)
                if view.step == "failed" and seen.calibration_step != "failed":
                    seen.calibration_failures += 1
                seen.calibration_step = view.step
                action = bot.act(t, view, game.arena, game.avatar.world_pos[f"{game.avatar.body.side}_upper_arm"])
                walking[0] = action.controls
                wire.write(board.run_until(t))
                events = [pygame.event.Event(pygame.KEYDOWN, key=keys[k], mod=0, unicode="") for k in action.keys]
                app.frame(events, 1.0 / FRAME_HZ, draw=config.render)
        finally:
            seen.play_end = t
            seen.rss_mb.append(_rss_mb())
            app.close()
            wire.close()
    return _report(config, bot, board, source, game.arena, seen, (wall0 - prepare0, time.perf_counter() - wall0))


def _screen(screen: object, names: dict[type, str]) -> Screen:
    """What the bot sees of the app's current screen (``names``: the app's screen classes)."""
    name = next((n for cls, n in names.items() if isinstance(screen, cls)), type(screen).__name__)
    return Screen(name, str(getattr(screen, "step"))) if name == "calibration" else Screen(name)


def _report(config: MatchConfig, bot: Bot, board: SimBoard, source: WireInput, arena, seen: Observed,
            walls: tuple[float, float]) -> dict:
    """The match's report; ``walls``: the wall seconds of its preparation (the simulated maker's
    calibrations of its board, the app built) and of its play (``sim_speed`` is the play's)."""
    prepare_s, wall_s = walls
    t_end = seen.play_end or 0.0
    result = TrialResult(true_launches=len(bot.launches))
    unmatched = score_launches(bot.launches, bot.script.idle_intervals, seen.launches, result)
    unseen = sum(1 for x in unmatched if x.t_straight + MATCH_AFTER_S > t_end)  # the match ended first
    intended = result.true_launches - unseen
    detected = len(seen.launches)
    stats = source.decoder.stats
    survived = 0.0 if seen.play_start is None else t_end - seen.play_start
    report = {
        "seed": config.seed, "difficulty": config.difficulty, "duration_s": round(t_end, 4),
        "score": int(arena.score), "kills": arena.kills, "shots": arena.shots, "hits": arena.hits,
        "wall_hits": arena.wall_hits, "obstacle_violations": arena.obstacle_violations,
        "town": arena.town.layout,
        "waves": arena.wave, "survived_s": round(survived, 4), "game_over": bool(arena.game_over),
        "abandoned": seen.play_start is None,  # play never began: setup gave up after MAX_SETUP_S
        "calibration_failures": seen.calibration_failures,
        "intended_launches": intended, "detected_launches": detected,
        "false_launches": result.false_launches,
        "launch_precision": round(result.matched / detected, 4) if detected else None,
        "launch_recall": round(result.matched / intended, 4) if intended else None,
        "aim_error_deg_median": round(statistics.median(result.aim_errors_deg), 3) if result.aim_errors_deg else None,
        "latency_ms_median": round(statistics.median(result.latencies_ms), 2) if result.latencies_ms else None,
        "frames_sent": board.tally.frames_sent, "frames_decoded": source.samples_decoded,
        "crc_errors": stats.crc_errors, "dropped": stats.dropped,
        "injected": {"bytes_corrupted": board.injector.bytes_corrupted,
                     "bytes_dropped": board.injector.bytes_dropped,
                     "frames_damaged": board.tally.frames_damaged,
                     "damaged_header_intact": board.tally.damaged_header_intact,
                     "samples_stalled": board.tally.samples_stalled},
    }
    report["timing"] = {"compiled": bool(compiled.modules()),
                        "prepare_s": round(prepare_s, 3), "wall_s": round(wall_s, 3),
                        "sim_speed": round(t_end / wall_s, 1),
                        "rss_mb_after_first_minute": round(seen.rss_mb[0], 1) if len(seen.rss_mb) > 1 else None,
                        "rss_mb_end": round(seen.rss_mb[-1], 1),
                        "peak_rss_mb": round(_peak_rss_mb(), 1)}
    return report


# ----------------------------------------------------------------- many matches


def run_matches(configs: list[MatchConfig], workers: int = 1,
                progress: Callable[[str], None] | None = None) -> dict:
    """Play the matches (on ``workers`` processes); the report with per-match results and a summary.

    Ctrl-C, SIGTERM or SIGHUP (:mod:`tracker.signals`) ends the run early: the
    match in play is dropped, and the report covers the matches finished by
    then, with ``interrupted`` naming the signal (None when every match was played).
    """
    wall0 = time.perf_counter()
    reports: list[dict] = []
    interrupted: str | None = None
    if progress:
        progress(_build_note())
    try:
        if workers > 1 and len(configs) > 1:
            _run_on_workers(configs, workers, reports, progress)
        else:
            for config in configs:
                reports.append(run_match(config, progress))
                _progress(progress, reports[-1], len(configs), len(reports))
    except KeyboardInterrupt as e:
        interrupted = signals.name_of(e)
    wall = time.perf_counter() - wall0
    return {"matches": reports, "summary": summarise(reports, wall), "interrupted": interrupted}


def _run_on_workers(configs: list[MatchConfig], workers: int, reports: list[dict],
                    progress: Callable[[str], None] | None) -> None:
    """Play the matches on a pool of processes, appending each report in order as it comes.

    The workers leave ending signals to this process (a Ctrl-C reaches the
    whole process group), which stops them at once when it is interrupted.
    """
    pool = multiprocessing.Pool(workers, initializer=_worker_signals)
    try:
        for report in pool.imap(run_match, configs):
            reports.append(report)
            _progress(progress, report, len(configs), len(reports))
        pool.close()
    except BaseException:
        pool.terminate()
        raise
    finally:
        pool.join()


def _worker_signals() -> None:
    """In a worker: Ctrl-C is the parent's to handle; SIGTERM and SIGHUP (the parent's terminate) end it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGHUP, signal.SIG_DFL)


def _build_note() -> str:
    """Which build runs: the speed figures depend on it."""
    n = len(compiled.modules())
    if n:
        return f"compiled build ({n} modules compiled)"
    return ("pure Python build; `ENERGYBALL_COMPILE=1 .venv/bin/pip install -e .` makes matches about "
            "twice as fast (README, \"The compiled build\")")


def _progress(progress: Callable[[str], None] | None, r: dict, total: int, done: int) -> None:
    if progress and r["abandoned"]:
        progress(f"match {done}/{total} (seed {r['seed']}): abandoned, play never began within "
                 f"{MAX_SETUP_S:.0f} s of setup (the bot could not get through calibration)")
    elif progress:
        progress(f"match {done}/{total} (seed {r['seed']}, {r['difficulty']}): score {r['score']}, "
                 f"{r['kills']} kills, survived {r['survived_s']:.0f} s, launches {r['detected_launches']}/"
                 f"{r['intended_launches']}, {r['false_launches']} false, {r['timing']['sim_speed']:.0f}x")


def summarise(reports: list[dict], wall_s: float) -> dict:
    """Totals and means over the matches; wall-clock figures under ``timing``."""
    def total(key: str) -> int:
        return sum(r[key] for r in reports)

    def mean(key: str) -> float | None:
        values = [r[key] for r in reports if r[key] is not None]
        return round(statistics.fmean(values), 4) if values else None

    detected, intended = total("detected_launches"), total("intended_launches")
    matched = detected - total("false_launches")
    simulated = sum(r["duration_s"] for r in reports)
    return {
        "matches": len(reports),
        **{k: total(k) for k in ("kills", "shots", "hits", "wall_hits", "obstacle_violations",
                                 "intended_launches", "detected_launches",
                                 "false_launches", "frames_sent", "frames_decoded", "crc_errors", "dropped",
                                 "calibration_failures")},
        "launch_precision": round(matched / detected, 4) if detected else None,
        "launch_recall": round(matched / intended, 4) if intended else None,
        **{f"mean_{k}": mean(k) for k in ("score", "survived_s", "kills", "waves", "aim_error_deg_median")},
        "game_overs": sum(1 for r in reports if r["game_over"]),
        "abandoned": sum(1 for r in reports if r["abandoned"]),
        "timing": {"compiled": bool(compiled.modules()), "wall_s": round(wall_s, 3),
                   "prepare_s": round(sum(r["timing"]["prepare_s"] for r in reports), 3),
                   "simulated_s": round(simulated, 2),
                   "sim_speed": round(simulated / wall_s, 1) if wall_s > 0 else None},
    }


def configs(seed: int, matches: int, **settings) -> list[MatchConfig]:
    """``matches`` match settings with seeds ``seed``, ``seed + 1``, ..."""
    return [MatchConfig(seed=seed + k, **settings) for k in range(matches)]
