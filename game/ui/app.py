"""The game's screens and main loop (pygame).

Screens: title menu, guided calibration, play, pause, game over with high
scores, settings, and the board setup (the maker's accelerometer and
magnetometer calibrations, :mod:`game.ui.board_setup`). Each is a small class with ``handle(event)``,
``update(dt)`` and ``draw(surface)``; they return the next screen (or None to
stay). :class:`App` owns the window and everything the screens share, and
:meth:`App.frame` advances one frame from a list of events, so tests drive
the real app with injected events under the dummy video driver.
"""

from __future__ import annotations

import gc
import math
import sys
from pathlib import Path
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Callable, Protocol

import numpy as np
import pygame

from tracker import protocol as P
from tracker import signals
from tracker.accel_procedure import FACES, TILTED
from tracker.calibration import LONGER_HOLD, LONGER_HOLD_S, BoardCalibration, board_id_of, load_for_hello
from tracker.link import LinkSettings, find_boards
from tracker.maker_sim import SimulatedMaker, cold

from ..body.avatar import Avatar, BodySettings, Wearing
from ..body.controls import KeyboardMouse, SampleInput, SourceState, TrackerInput
from ..body.gestures import GestureEvent, GestureMachine, GestureSettings
from ..body.pose import ArmPose
from ..body.wearing import HOLD_S, arm_down, arm_down_then_forward, last_held, recenter
from ..world.arena import Arena, ArenaSettings
from ..world.arena_model import Controls
from ..replay.log import SessionLog, SessionRecorder
from .audio import Audio
from .session_events import RECORDED, event_json, session_summary
from .board_setup import (ACCEL, ACCEL_DONE, FAILED, MAG, MAG_DONE, WARM, WARM_DONE, WARM_WAIT, BoardSetup,
                          Follower, MakerInput, calibration_notice, fresh_samples)
from .preferences import (Preferences, Score, add_score, load_preferences, load_scores, save_preferences,
                          step_flex_on, storage_notice)
from .render import Renderer

if TYPE_CHECKING:  # the virtual board is imported only when one is used
    from tracker.board import VirtualBoard
    from tracker.motion import MotionSource

WINDOW = (1280, 720)
GET_READY_S = 2.0
VIRTUAL_CALIBRATED = ("the virtual player wears its board as designed and does not follow prompts: "
                      "it needs no wearing calibration (Play starts at once)")
BOARD_SCAN_S = 2.0
NOTICE_LINES = 4  # the menu shows the latest notices (start-up ones are also printed on stderr)
WHITE, RED, GREEN, YELLOW = (240, 240, 240), (230, 70, 60), (90, 220, 120), (250, 210, 80)
ACCENT_BLUE = (90, 170, 255)


class Screen(Protocol):
    def handle(self, event: pygame.event.Event) -> "Screen | None": ...
    def update(self, dt: float) -> "Screen | None": ...
    def draw(self, surface: pygame.Surface) -> None: ...


# ----------------------------------------------------------------- shared state


@dataclass
class Game:
    """Everything the screens share: input, avatar, gestures, arena, audio, renderer, files."""

    prefs: Preferences
    audio: Audio
    renderer: Renderer
    keyboard: KeyboardMouse = field(default_factory=KeyboardMouse)
    tracker: SampleInput | None = None  # a TrackerInput, or the headless match's wire
    arena: Arena = field(default_factory=Arena)
    gestures: GestureMachine = field(default_factory=GestureMachine)
    avatar: Avatar = field(default_factory=Avatar)
    scores: list[Score] = field(default_factory=list)
    notices: list[str] = field(default_factory=list)
    calibrated: bool = False
    show_plots: bool = False
    fps: float = 0.0
    board_offer: str | None = None  # a board plugged in while on keyboard
    seed: int = 0
    config_dir: Path | None = None
    virtual_board: "VirtualBoard | None" = None  # the simulated board behind --virtual
    walker: Callable[[], Controls] | None = None  # who walks the player (None: the keyboard)
    on_launch: Callable[[GestureEvent], None] | None = None  # told of every launch (headless matches)
    arena_settings: ArenaSettings | None = None  # the rounds' arena (None: the defaults)
    board_id: str | None = None  # the connected board's (from its HELLO), once its calibration is loaded
    board_uncalibrated: bool = False  # that board has no saved calibration: the menu offers the setup
    told_uncalibrated: set[str] = field(default_factory=set)  # boards the player was told so (once each)
    link_state: SourceState = SourceState()  # the input source's, taken at the frame's start
    log: SessionLog | None = None  # hears the session (a recording, or a replay comparing)
    window: tuple[int, int] = WINDOW  # the window's size (the mouse aims across it)
    board_virtual: bool = False  # the board is the virtual player's
    # None: open the port (a replay's gives its own)
    board_opener: Callable[[str | None, bool], SampleInput] | None = None

    # -------------------------------------------------------- input

    @property
    def source(self) -> str:
        return "board" if self.tracker else "keyboard"

    def pose(self, dt: float) -> ArmPose:
        """This frame's arm pose from the active source."""
        if self.tracker:
            pose = self.tracker.poll()
            if pose is not None:
                return pose
        return self.keyboard.update(dt)

    def wear(self, wearing: Wearing) -> None:
        """Put on the "forward" a wearing calibration or a recenter found; it is kept while
        the magnetometer's heading settles (game.body.heading_anchor)."""
        self.avatar.wearing = wearing
        if self.tracker:
            self.tracker.tracking.anchor_heading()

    def use_board(self, port: str | None, virtual: bool = False) -> None:
        """Switch to a board (a port, or a virtual one) read in the background (a replay's
        ``board_opener`` gives the recorded one instead)."""
        self.close_board()
        self.use_source((self.board_opener or self._open_board)(port, virtual), virtual)

    def _open_board(self, port: str | None, virtual: bool) -> SampleInput:
        if virtual:
            from tracker.board import VirtualBoard

            from ..sim.virtual_player import VirtualPlayer
            self.virtual_board = VirtualBoard(VirtualPlayer(seed=self.seed)).start()
            port = self.virtual_board.port
        return TrackerInput(LinkSettings(port), tap=self.log.wire if isinstance(self.log, SessionRecorder) else None)

    def use_source(self, source: SampleInput, virtual: bool = False) -> None:
        """Take arm poses from ``source`` (a board, or the headless match's wire); calibrate anew.

        ``virtual``: the virtual player's board, worn as designed and deaf to prompts: it needs (and
        allows) no wearing calibration, and its calibration files are its own."""
        self.tracker = source
        self.board_virtual = virtual
        self.link_state = SourceState()
        if self.log is not None:
            source.on_poll = self.log.poll
            self.log.source("board", source.tracking.board.to_json(), virtual)
        self.calibrated = virtual
        self.board_id = None  # its calibration is loaded once it says who it is
        self.avatar.wearing = Wearing()

    def use_keyboard(self) -> None:
        self.close_board()
        if self.log is not None:
            self.log.source("keyboard", None, False)
        self.avatar.wearing = Wearing()
        self.calibrated = True  # keyboard poses are made for the ideal wearing

    def hello(self) -> P.Hello | None:
        """The connected board's HELLO (None: no board, not connected yet, or one that sent none)."""
        return self.link_state.hello if self.tracker else None

    def boards_folder(self) -> Path | None:
        """Where board calibrations live: beside the settings when the app was given a folder, else
        :func:`tracker.calibration.boards_dir`."""
        return self.config_dir / "boards" if self.config_dir is not None else None

    def board_id_of(self, hello: P.Hello) -> str:
        """The board's calibration file's id; the virtual board's never names a real board's file."""
        return board_id_of(hello, virtual=self.board_virtual)

    def load_board_calibration(self) -> None:
        """Once a board has said who it is: load its saved calibration and apply it; a board with none
        is said so once (and the menu offers the setup), and plays without."""
        hello = self.hello()
        if hello is None or self.board_id_of(hello) == self.board_id:
            return
        calibration, loaded = load_for_hello(hello, self.boards_folder(), virtual=self.board_virtual)
        self.board_id = self.board_id_of(hello)
        self.apply_board_calibration(calibration)
        self.board_uncalibrated = not calibration.procedures
        notice = calibration_notice(calibration, loaded)
        if self.board_uncalibrated and self.board_id in self.told_uncalibrated:
            return
        if self.board_uncalibrated:
            self.told_uncalibrated.add(self.board_id)
        self.notices.append(notice)
        print(f"energyball: {notice}", file=sys.stderr)

    def apply_board_calibration(self, calibration: BoardCalibration) -> None:
        """Correct the board's samples with ``calibration`` from now on (the filter starts afresh)."""
        if self.tracker:
            self.tracker.tracking.board = calibration
            self.tracker.tracking.reset()
        self.board_uncalibrated = not calibration.procedures

    def close_board(self) -> None:
        self.board_id = None
        self.link_state = SourceState()
        if self.tracker:
            self.tracker.close()
            self.tracker = None
        if self.virtual_board:
            self.virtual_board.stop()
            self.virtual_board = None

    def link_lost(self) -> bool:
        """A board was connected and is not now (cable pulled)."""
        state = self.link_state
        return bool(self.tracker and state.opened and state.error is None and not state.connected)

    def walking(self) -> Controls:
        """This step's walking input: the walker's, or the keys'."""
        controls = self.walker() if self.walker else movement()
        if self.log is not None:
            self.log.walking(controls)
        return controls

    # -------------------------------------------------------- the round

    def new_round(self) -> None:
        if self.log is not None:
            self.log.round(self.arena_settings)
        self.arena = Arena(self.arena_settings, seed=self.seed)
        self.gestures = GestureMachine(self.gesture_settings())
        self.avatar = Avatar(BodySettings(side=self.prefs.side), self.avatar.wearing)
        self.stand_avatar()

    def place_avatar(self) -> None:
        """The avatar where the arena's player stands, turned the way he faces (play: posed by the
        frame's update)."""
        player = self.arena.player
        self.avatar.position, self.avatar.body_yaw = (player.x, player.y), player.yaw

    def stand_avatar(self) -> None:
        """The avatar placed and posed where the player stands: the menu and the calibration show him
        at the start as play will."""
        self.place_avatar()
        self.avatar.forward_kinematics()

    def gesture_settings(self) -> GestureSettings:
        p = self.prefs
        return GestureSettings(raise_deg=p.raise_deg, lower_deg=min(35.0, p.raise_deg - 10.0),
                               flex_on_deg=p.flex_on_deg, flex_off_deg=p.flex_off_deg)

    def hud(self) -> dict:
        health = self.tracker.health() if self.tracker else None
        link = ("keyboard + mouse" if not self.tracker else
                self.tracker.status if health is None else
                f"board {health.rate_hz:.0f} Hz, loss {100 * health.loss:.1f}%")
        return {"score": self.arena.score, "wave": self.arena.wave, "health": self.arena.player.health,
                "ball": self.gestures.state.value, "charge": self.gestures.charge, "input": link,
                "calibrated": self.calibrated, "fps": self.fps, "magnetometer": self.magnetometer_warning(),
                "notice": f"board found on {self.board_offer}: press B to use it" if self.board_offer else ""}

    def magnetometer_warning(self) -> str:
        """"magnetometer off: <why>" while the board's filter has switched its magnetometer off, else ""."""
        tracking = getattr(self.tracker, "tracking", None)
        if tracking is None or not tracking.filter.flags.mag_unusable:
            return ""
        return tracking.filter.status


# ----------------------------------------------------------------- screens


def menu_step(key: int) -> int:
    """-1 for up (arrow or W), +1 for down (arrow or S), 0 for any other key."""
    return -1 if key in (pygame.K_UP, pygame.K_w) else 1 if key in (pygame.K_DOWN, pygame.K_s) else 0


@dataclass
class Menu:
    game: Game
    items: tuple[str, ...] = ("Play", "Calibrate", "Settings", "Board setup", "Quit")
    selected: int = 0

    def handle(self, event: pygame.event.Event) -> Screen | None:
        if event.type != pygame.KEYDOWN:
            return None
        if step := menu_step(event.key):
            self.selected = (self.selected + step) % len(self.items)
        elif event.key in (pygame.K_RETURN, pygame.K_SPACE):
            self.game.audio.play("click")
            return self.choose(self.items[self.selected])
        elif event.key == pygame.K_ESCAPE:
            return Quit()
        return None

    def choose(self, item: str) -> Screen:
        if item == "Play":
            if not self.game.calibrated:
                return Calibration(self.game, then_play=True)
            self.game.new_round()
            return Play(self.game)
        if item == "Calibrate":
            if self.game.board_virtual:  # deaf to prompts: holding a pose is not what it does
                self.game.notices.append(VIRTUAL_CALIBRATED)
                return self
            return Calibration(self.game, then_play=False)
        if item == "Settings":
            return Settings(self.game)
        if item == "Board setup":
            return BoardSetupScreen(self.game)
        return Quit()

    def update(self, dt: float) -> Screen | None:
        return None

    def labels(self) -> list[str]:
        """The items as shown: the board setup offered while the connected board has no saved calibration."""
        game = self.game
        return [f"{item}  (not done for this board)" if item == "Board setup" and game.board_uncalibrated
                else f"{item}  (not needed: virtual player)" if item == "Calibrate" and game.board_virtual
                else item for item in self.items]

    def draw(self, surface: pygame.Surface) -> None:
        r = self.game.renderer
        r.draw_world(surface, self.game.arena, self.game.avatar, 0.0)
        r.draw_title(surface, "ENERGYBALL", "raise your arm, flex, snap it straight")
        r.draw_menu(surface, self.labels(), self.selected, surface.get_height() // 2 - 40)
        r.draw_footer(surface, [f"input: {self.game.hud()['input']}", *self.game.notices[-NOTICE_LINES:]])


@dataclass
class Calibration:
    """Guided wearing calibration: arm down (and gyro bias), then arm forward."""

    game: Game
    then_play: bool
    step: str = "down"  # "down", "longer" (a slow tremor's longer hold), "forward", "done", "failed"
    clock: float = -GET_READY_S  # negative: getting ready
    poses: dict[str, list[ArmPose]] = field(default_factory=lambda: {step: [] for step in HOLD_S})
    message: str = ""
    bias_learned: bool = True  # the hold gave the gyroscope's bias (else the filter learns it in play)

    def instruction(self) -> str:
        keyboard = self.game.tracker is None
        if self.step == "down":
            return "Hold your arm straight down, still" + (" (keyboard: leave R up)" if keyboard else "")
        if self.step == "longer":
            return "Keep it down and still a little longer (your arm trembles slowly)"
        if self.step == "forward":
            return "Raise your arm straight forward to shoulder height" + (" (keyboard: hold R)" if keyboard else "")
        return self.message

    def handle(self, event: pygame.event.Event) -> Screen | None:
        arm_input(self.game.keyboard, event, self.game.window)
        if event.type == pygame.KEYDOWN:
            if event.key == pygame.K_ESCAPE:
                return Menu(self.game)
            if event.key == pygame.K_r and self.step == "failed":
                return Calibration(self.game, self.then_play)
            if event.key in (pygame.K_RETURN, pygame.K_SPACE) and self.step == "done":
                return self.finish()
        return None

    def finish(self) -> Screen:
        if self.then_play:
            self.game.new_round()
            return Play(self.game)
        return Menu(self.game)

    def update(self, dt: float) -> Screen | None:
        game = self.game
        pose = game.pose(dt)
        game.avatar.update(pose)
        if self.step not in HOLD_S:
            return None
        self.clock += dt
        if self.clock >= 0:
            self.poses[self.step].append(pose)
        if self.clock >= HOLD_S[self.step]:
            self.complete_step()
        return None

    def complete_step(self) -> None:
        game = self.game
        if self.step in ("down", "longer"):
            bias = None
            if game.tracker and game.tracker.recent:
                longer = self.step == "longer"  # judged over the whole hold, with its longer low-pass
                newest = game.tracker.recent[-1].t
                span = LONGER_HOLD_S if longer else HOLD_S["down"]
                hold = [s for s in game.tracker.recent if s.t >= newest - span]
                bias, self.poses["down"] = game.tracker.tracking.hold_still(hold, LONGER_HOLD if longer else None)
                if bias.hold_longer:  # what looked like a turn may be a slow tremor: hold on
                    self.step, self.clock = "longer", 0.0
                    return None
                # A hold too shaky for the bias is no reason to lock the player out: the filter
                # learns the bias in play. The pose decides (arm_down says if the arm moved).
                self.bias_learned = bias.ok
            result = arm_down(game.avatar, last_held(self.poses["down"]))
            if game.log is not None:
                game.log.hold("down", result, bias)
            if not result.ok:
                return self.fail(result.message)
            game.avatar.wearing = result.wearing  # the arm's axis only: "forward" comes next
            self.step, self.clock = "forward", -GET_READY_S
            game.audio.play("click")
            return None
        result = arm_down_then_forward(game.avatar, last_held(self.poses["down"]), last_held(self.poses["forward"]))
        if game.log is not None:
            game.log.hold("forward", result, None)
        if not result.ok:
            return self.fail(result.message)
        game.wear(result.wearing)
        game.calibrated = True
        later = "" if self.bias_learned else " (the gyroscope's bias is learned as you play)"
        self.step, self.message = "done", f"Calibrated{later}! Press Enter."
        game.audio.play("wave")
        return None

    def fail(self, message: str) -> None:
        self.step, self.message = "failed", f"{message}. R: try again, Esc: back"
        self.game.audio.play("miss")

    def draw(self, surface: pygame.Surface) -> None:
        r = self.game.renderer
        r.draw_world(surface, self.game.arena, self.game.avatar, 0.0)
        w, h = surface.get_size()
        r.draw_arm_view(surface, self.game.avatar, pygame.Rect(w - 340, 80, 320, 240))
        if self.step in HOLD_S:
            left = -self.clock if self.clock < 0 else HOLD_S[self.step] - self.clock
            r.draw_countdown(surface, left, ("Get ready. " if self.clock < 0 else "") + self.instruction())
        else:
            r.draw_banner(surface, self.instruction(), GREEN if self.step == "done" else RED)


@dataclass
class Play:
    game: Game

    def handle(self, event: pygame.event.Event) -> Screen | None:
        game = self.game
        if event.type == pygame.KEYDOWN:
            if event.key in (pygame.K_ESCAPE, pygame.K_p):
                game.audio.stop_loops()
                return Pause(game, "Paused")
            if event.key == pygame.K_F1:
                game.show_plots = not game.show_plots
            if event.key == pygame.K_c and game.tracker:
                game.wear(recenter(game.avatar, game.pose(0.0)))
            if event.key == pygame.K_b and game.board_offer:
                game.use_board(game.board_offer)
                game.board_offer = None
                return Calibration(game, then_play=True)
        arm_input(game.keyboard, event, game.window)
        return None

    def update(self, dt: float) -> Screen | None:
        game = self.game
        if game.link_lost():
            return Pause(game, "The board went away (cable pulled?). Plug it back in: the game waits.",
                         resume_when=lambda: not game.link_lost())
        arena = game.arena
        game.place_avatar()
        state = game.avatar.update(game.pose(dt))
        gestures = game.gestures.update(state)
        for event in gestures:
            if event.kind == "launch":
                arena.launch(tuple(state.hand), event.direction, event.charge)
                if game.on_launch:
                    game.on_launch(event)
        arena.hold(*held_ball(game, state))
        charge_hum(game)
        events = arena.advance(dt, game.walking())
        if game.log is not None:
            game.log.events(events, gestures)
        game.renderer.react(events)
        sounds(game, events)
        if arena.game_over:
            return GameOver(game)
        return None

    def draw(self, surface: pygame.Surface) -> None:
        game = self.game
        game.renderer.draw_world(surface, game.arena, game.avatar, 1.0 / max(game.fps, 30.0))
        game.renderer.draw_hud(surface, game.hud())
        game.renderer.draw_minimap(surface, game.arena)
        if game.show_plots and game.tracker:
            w, h = surface.get_size()
            game.renderer.draw_plots(surface, game.tracker.plot_series(), pygame.Rect(w - 420, h - 330, 400, 300))


def arm_input(kb: KeyboardMouse, event: pygame.event.Event, window: tuple[int, int]) -> None:
    """Keyboard and mouse arm controls: R or the right button raises, F, Space or the left flexes; the
    mouse aims across the ``window``."""
    if event.type in (pygame.KEYDOWN, pygame.KEYUP):
        down = event.type == pygame.KEYDOWN
        if event.key == pygame.K_r:
            kb.raised = down
        elif event.key in (pygame.K_f, pygame.K_SPACE):
            kb.flexed = down
    elif event.type in (pygame.MOUSEBUTTONDOWN, pygame.MOUSEBUTTONUP):
        down = event.type == pygame.MOUSEBUTTONDOWN
        if event.button == 3:
            kb.raised = down
        elif event.button == 1:
            kb.flexed = down
    elif event.type == pygame.MOUSEMOTION:
        w, h = window
        kb.aim_x = 2.0 * event.pos[0] / w - 1.0
        kb.aim_y = 1.0 - 2.0 * event.pos[1] / h


def held_ball(game: Game, state) -> tuple[tuple[float, float, float], str, float]:
    """Where the ball in the hand is drawn for the gesture state (Zhu & Shi, Fig. 1)."""
    g = game.gestures
    kind = g.state.value
    if kind == "idle":  # at the shoulder
        x, y, z = state.shoulder
        return (float(x), float(y), float(z) + 0.25), kind, 0.0
    hx, hy, hz = state.hand
    if kind == "loading":  # floats up from the ground to the hand
        sx, sy, _ = state.shoulder
        up = g.progress
        return (float(sx + (hx - sx) * up), float(sy + (hy - sy) * up), float(hz * up + 0.1)), kind, 0.0
    return (float(hx), float(hy), float(hz) + 0.12), kind, g.charge


def movement() -> Controls:
    """WASD walks, Q/E or the arrow keys turn."""
    keys = pygame.key.get_pressed()
    forward = (keys[pygame.K_w] or keys[pygame.K_UP]) - (keys[pygame.K_s] or keys[pygame.K_DOWN])
    strafe = keys[pygame.K_d] - keys[pygame.K_a]
    turn = (keys[pygame.K_q] or keys[pygame.K_LEFT]) - (keys[pygame.K_e] or keys[pygame.K_RIGHT])
    return Controls(float(forward), float(strafe), float(turn))


def charge_hum(game: Game) -> None:
    """While the ball spins, a hum that rises with its charge (three levels)."""
    if game.gestures.state.value != "spinning":
        if game.audio.looping:
            game.audio.stop_loops()
        return
    wanted = f"charge_{1 + min(2, int(3 * game.gestures.charge))}"
    if wanted not in game.audio.looping:
        game.audio.stop_loops()
        game.audio.loop(wanted)


def sounds(game: Game, events) -> None:
    names = {"launch": "launch", "hit": "hit", "miss": "miss", "wall": "wall", "hurt": "hurt", "wave": "wave",
             "game_over": "game_over"}
    for e in events:
        if e.kind == "spawn":
            game.audio.play_variant("groan")
        elif e.kind in names:
            game.audio.play(names[e.kind])


@dataclass
class Pause:
    game: Game
    reason: str
    resume_when: Callable[[], bool] | None = None

    def handle(self, event: pygame.event.Event) -> Screen | None:
        if event.type == pygame.KEYDOWN:
            if event.key in (pygame.K_ESCAPE, pygame.K_p) and self.resume_when is None:
                return Play(self.game)
            if event.key == pygame.K_q:
                return Menu(self.game)
            if event.key == pygame.K_k and self.resume_when is not None:
                self.game.use_keyboard()
                return Play(self.game)
        return None

    def update(self, dt: float) -> Screen | None:
        self.game.pose(dt)  # keep reading the link
        if self.resume_when is not None and self.resume_when():
            return Play(self.game)
        return None

    def draw(self, surface: pygame.Surface) -> None:
        r = self.game.renderer
        r.draw_world(surface, self.game.arena, self.game.avatar, 0.0)
        r.draw_hud(surface, self.game.hud())
        r.draw_minimap(surface, self.game.arena)
        r.draw_banner(surface, self.reason, YELLOW)
        keys = "K: play on keyboard, Q: menu" if self.resume_when else "Esc: resume, Q: menu"
        w, h = surface.get_size()
        r.draw_panel(surface, [keys], pygame.Rect(w // 2 - 200, h // 2 + 60, 400, 40))


@dataclass
class GameOver:
    game: Game
    rank: int | None = None

    def __post_init__(self) -> None:
        game = self.game
        entry = Score(game.prefs.player, int(game.arena.score), int(game.arena.wave))
        try:
            game.scores, self.rank = add_score(game.scores, entry, game.config_dir)
        except OSError as e:
            game.notices.append(f"could not save the high scores: {e}")

    def handle(self, event: pygame.event.Event) -> Screen | None:
        if event.type == pygame.KEYDOWN and event.key in (pygame.K_RETURN, pygame.K_SPACE, pygame.K_ESCAPE):
            return Menu(self.game)
        return None

    def update(self, dt: float) -> Screen | None:
        return None

    def draw(self, surface: pygame.Surface) -> None:
        game = self.game
        r = game.renderer
        r.draw_world(surface, game.arena, game.avatar, 0.0)
        r.draw_banner(surface, f"GAME OVER  -  score {int(game.arena.score)}, wave {game.arena.wave}", RED)
        lines = [("> " if i == self.rank else "  ") + f"{i + 1:2d}. {s.name:12s} {s.score:7d}  wave {s.wave}"
                 for i, s in enumerate(game.scores)]
        w, h = surface.get_size()
        text = ["HIGH SCORES", *lines, "", "Enter: menu"]
        r.draw_panel(surface, text, pygame.Rect(w // 2 - 230, h // 2 + 50, 460, 24 + 24 * len(text)))


@dataclass
class Settings:
    game: Game
    selected: int = 0
    items: tuple[str, ...] = ("Input", "Arm", "Launch flex", "Volume", "Music", "Fullscreen", "Back")

    def values(self) -> list[str]:
        p = self.game.prefs
        return [p.input, p.side, f"{p.flex_on_deg:.0f} / {p.flex_off_deg:.0f} deg", f"{p.volume:.1f}",
                f"{p.music_volume:.1f}", "on" if p.fullscreen else "off", ""]

    def handle(self, event: pygame.event.Event) -> Screen | None:
        if event.type != pygame.KEYDOWN:
            return None
        if step := menu_step(event.key):
            self.selected = (self.selected + step) % len(self.items)
        elif event.key in (pygame.K_LEFT, pygame.K_RIGHT, pygame.K_a, pygame.K_d):
            self.change(1 if event.key in (pygame.K_RIGHT, pygame.K_d) else -1)
        elif event.key == pygame.K_ESCAPE or (event.key == pygame.K_RETURN and self.items[self.selected] == "Back"):
            return self.leave()
        return None

    def change(self, step: int) -> None:
        game, p = self.game, self.game.prefs
        item = self.items[self.selected]
        if item == "Input":
            choices = ["auto", "keyboard", "virtual", *[b.device for b in find_boards()]]
            current = choices.index(p.input) if p.input in choices else 0
            p = replace(p, input=choices[(current + step) % len(choices)])
        elif item == "Arm":
            p = replace(p, side="left" if p.side == "right" else "right")
        elif item == "Launch flex":
            p = step_flex_on(p, step)
        elif item == "Volume":
            p = replace(p, volume=round(min(1.0, max(0.0, p.volume + 0.1 * step)), 1))
        elif item == "Music":
            p = replace(p, music_volume=round(min(1.0, max(0.0, p.music_volume + 0.1 * step)), 1))
        elif item == "Fullscreen":
            p = replace(p, fullscreen=not p.fullscreen)
            if pygame.display.get_surface():
                pygame.display.toggle_fullscreen()
        game.prefs = p
        game.audio.set_volume(p.volume)
        game.audio.set_music_volume(p.music_volume)

    def leave(self) -> Screen:
        game = self.game
        try:
            save_preferences(game.prefs, game.config_dir)
        except OSError as e:
            game.notices.append(f"could not save the settings: {e}")
        apply_input(game)
        game.avatar = Avatar(BodySettings(side=game.prefs.side), game.avatar.wearing)
        return Menu(game)

    def update(self, dt: float) -> Screen | None:
        return None

    def draw(self, surface: pygame.Surface) -> None:
        r = self.game.renderer
        r.draw_world(surface, self.game.arena, self.game.avatar, 0.0)
        r.draw_title(surface, "SETTINGS", "up/down: choose, left/right: change, Esc: save and back")
        labels = [f"{name}: {value}" if value else name for name, value in zip(self.items, self.values())]
        y0 = surface.get_height() // 3 + 30
        r.draw_menu(surface, labels, self.selected, y0)


SETUP_STEPS = ("accelerometer", "magnetometer", "warm-up")


@dataclass
class BoardSetupScreen:
    """"Board setup": the maker's three calibrations with pictures (:mod:`game.ui.board_setup` holds the logic).

    The board's raw samples come from the game's input (its ``recent``); with
    ``--virtual`` a simulated maker takes the virtual board from the player while
    the screen is up, follows the prompts, and hands it back on leaving.
    """

    game: Game
    setup: BoardSetup | None = None  # None until a board has said who it is
    clock: float = 0.0
    last: P.RawSample | None = None  # the newest sample already fed
    lent: "MotionSource | None" = None  # the virtual board's player while the simulated maker holds it
    cooled: bool = False  # the simulated maker has powered the board up cold for this warm-up

    def handle(self, event: pygame.event.Event) -> Screen | None:
        if event.type != pygame.KEYDOWN:
            return None
        if event.key == pygame.K_ESCAPE:
            return self.leave()
        setup = self.setup
        if setup is None:
            return None
        if event.key == pygame.K_r:
            setup.redo()
        elif event.key == pygame.K_m and setup.phase == ACCEL:
            setup.start(MAG)
        elif event.key == pygame.K_s and setup.phase == WARM_WAIT:
            setup.start(WARM)
        elif event.key in (pygame.K_RETURN, pygame.K_SPACE) and setup.next():
            self.game.audio.play("click")
            return self.leave()
        return None

    def leave(self) -> Screen:
        """Back to the menu; the virtual board goes back to its player."""
        board = self.game.virtual_board
        if self.lent is not None and board is not None:
            board.motion = self.lent
        self.lent = None
        return Menu(self.game)

    def update(self, dt: float) -> Screen | None:
        game = self.game
        self.clock += dt
        game.pose(dt)  # reads the link: new samples land in the input's recent ones
        if self.setup is None:
            self.setup = self.begin()
            return None
        if game.link_lost():
            self.setup.interrupted()
            return None
        self.cool_the_board()
        if game.tracker is not None:
            samples = fresh_samples(game.tracker.recent, self.last)
            if samples:
                self.last = samples[-1]
            before = self.setup.phase
            self.setup.feed(samples)
            if self.setup.phase != before and self.setup.phase in (ACCEL_DONE, MAG_DONE, WARM_DONE, FAILED):
                game.audio.play("miss" if self.setup.phase == FAILED else "wave")
        return None

    def begin(self) -> BoardSetup | None:
        """The setup for the connected board, once it has said who it is (a simulated maker with --virtual)."""
        game = self.game
        hello = game.hello()
        if hello is None or game.tracker is None:
            return None
        # What came before (read by this frame's poll) is not the maker's: the procedures start after it.
        self.last = game.tracker.recent[-1] if game.tracker.recent else None
        maker: Follower | None = None
        if isinstance(game.tracker, MakerInput):
            maker = game.tracker.maker
        elif game.virtual_board is not None:
            maker = self.lend_virtual_board(game.virtual_board)
        return BoardSetup(game.board_id_of(hello), game.tracker.tracking.board, game.boards_folder(), maker,
                          game.apply_board_calibration)

    def cool_the_board(self) -> None:
        """The warm-up waits for a board powered up cold: the simulated maker unplugs its board until it is
        cold and plugs it back in, once each time the step waits (a player does it by hand)."""
        setup, game = self.setup, self.game
        if setup is None or setup.phase != WARM_WAIT:
            self.cooled = False
            return
        if self.cooled:
            return
        self.cooled = True
        board = game.virtual_board
        if isinstance(game.tracker, MakerInput):
            game.tracker.power_cycle()
        elif self.lent is not None and board is not None and isinstance(board.motion, SimulatedMaker):
            board.pull_cable()
            board.motion = cold(board.motion, board.motion.rate_hz)
            board.plug_in()  # its clock starts again

    def lend_virtual_board(self, board: "VirtualBoard") -> Follower:
        """Hand the virtual board to a simulated maker until the screen is left: the same board (the
        virtual player's errors, drawn from the same seed) lying on a table."""
        from ..sim.virtual_player import VirtualPlayer
        self.lent = board.motion
        errors = self.lent.script.profile.sensor_errors() if isinstance(self.lent, VirtualPlayer) else None
        maker = SimulatedMaker(errors, seed=self.game.seed)
        board.motion = maker
        return maker

    def draw(self, surface: pygame.Surface) -> None:
        game = self.game
        r = game.renderer
        r.draw_backdrop(surface, game.arena)
        w, h = surface.get_size()
        setup = self.setup
        phase = setup.phase if setup else ACCEL
        shown = setup.failed_phase if phase == FAILED and setup is not None else phase  # the step it belongs to
        step = 2 if shown in (WARM_WAIT, WARM, WARM_DONE) else 1 if shown in (MAG, MAG_DONE) else 0
        title = "BOARD SETUP" + (f"  -  board {setup.board_id}" if setup else "")
        r.draw_setup_header(surface, title, SETUP_STEPS, step)
        top, gap = int(h * 0.11), 20
        pictures = pygame.Rect(gap, top, w - 2 * gap, int(h * 0.56))
        text = pygame.Rect(gap, pictures.bottom + gap, w - 2 * gap, h - pictures.bottom - 2 * gap)
        if setup is None:
            r.draw_setup_text(surface, text, self.waiting(), [], "Esc: back", warn=game.tracker is None)
            return
        third = (pictures.width - 2 * gap) // 3
        now = pygame.Rect(pictures.left, pictures.top, third, pictures.height)
        captured = setup.accel_status.captured if step == 0 else ()
        r.draw_board(surface, now, setup.gravity, "the board now", None, captured, 0.25 * math.sin(0.5 * self.clock))
        rest = pygame.Rect(now.right + gap, pictures.top, pictures.right - now.right - gap, pictures.height)
        (self.draw_accel, self.draw_mag, self.draw_warm)[step](surface, rest, setup)
        lines = [*setup.figures, setup.saved, setup.notice]
        warn = phase == FAILED or setup.disconnected or bool(phase == MAG and setup.mag_status.problem)
        r.draw_setup_text(surface, text, setup.message(), [line for line in lines if line], setup.keys(), warn)

    def draw_accel(self, surface: pygame.Surface, rect: pygame.Rect, setup: BoardSetup) -> None:
        """The pose to make next (on a turning board), the six faces, the stillness, the poses captured."""
        r = self.game.renderer
        status = setup.accel_status
        half = (rect.width - 20) // 2
        target = pygame.Rect(rect.left, rect.top, half, rect.height)
        asked = status.asked
        face = asked if asked in FACES else None
        title = f"next: put {asked} up" if face else \
            f"next: lean it on an edge ({status.leaned + 1} of {status.leaning})" if asked else "all poses captured"
        up = np.zeros(3)
        if face:
            up["xyz".index(face[1])] = 1.0 if face[0] == "+" else -1.0
        else:
            up[2], up[0] = 1.0, 1.0 if asked else 0.0  # a leaning pose: 45 deg between +z and +x
        r.draw_board(surface, target, up, title, face, status.captured, 0.35 * math.sin(0.7 * self.clock))
        side = pygame.Rect(target.right + 20, rect.top, rect.right - target.right - 20, rect.height)
        surface.blit(r.sprites.panel(side.width, side.height), side)
        r.draw_face_chips(surface, pygame.Rect(side.left + 12, side.top + 20, side.width - 24, 48), face,
                          status.captured, status.up, self.clock)
        hold = setup.accel.params.hold_s
        where = "leaning" if status.up == TILTED else f"on {status.up}" if status.up else ""
        still = "every pose held still" if status.done else \
            f"still {status.still_s:.1f} s of {hold:.1f}" + (f" {where}" if where else "")
        meter = pygame.Rect(side.left + 16, side.top + 100, side.width - 32, 48)
        if status.waiting:
            self.draw_warming(surface, meter, status.warming, setup.accel.params.warming.max_c_per_min)
        else:
            r.draw_meter(surface, meter, still, 1.0 if status.done else status.still_s / hold, GREEN)
        r.draw_meter(surface, pygame.Rect(side.left + 16, side.top + 180, side.width - 32, 48),
                     f"poses captured: {len(status.captured)} of {status.total}", len(status.captured) / status.total,
                     YELLOW)

    def draw_warming(self, surface: pygame.Surface, rect: pygame.Rect, rate: float | None, limit: float) -> None:
        """The die's warming while the poses wait for it (tracker.warming): full once it is under ``limit``."""
        if rate is None:
            self.game.renderer.draw_meter(surface, rect, "measuring the board's warming", 0.0, YELLOW)
            return
        self.game.renderer.draw_meter(surface, rect, f"warming {rate:.1f} degC/min (poses wait until under {limit:g})",
                                      min(1.0, limit / max(abs(rate), 1e-9)), YELLOW)

    def draw_mag(self, surface: pygame.Surface, rect: pygame.Rect, setup: BoardSetup) -> None:
        """The sphere of directions filling in, the coverage against what is needed, the field now."""
        r = self.game.renderer
        status = setup.mag_status
        meter_h = 64
        sphere = pygame.Rect(rect.left, rect.top, rect.width, rect.height - meter_h - 12)
        r.draw_direction_sphere(surface, sphere, setup.directions(), status.covered)
        need = setup.mag.params.target_coverage
        meter = pygame.Rect(rect.left, sphere.bottom + 12, rect.width, meter_h)
        surface.blit(r.sprites.panel(meter.width, meter.height), meter)
        r.draw_meter(surface, meter.inflate(-32, -16),
                     f"directions covered: {100 * status.coverage:.0f} % of the {100 * need:.0f} % needed"
                     f"   -   field now {status.field_ut:.0f} uT", status.coverage / need,
                     GREEN if status.ready else ACCENT_BLUE)

    def draw_warm(self, surface: pygame.Surface, rect: pygame.Rect, setup: BoardSetup) -> None:
        """The time the board has lain warming, its still seconds, the die's temperature and its rise."""
        r = self.game.renderer
        status = setup.warm_status
        surface.blit(r.sprites.panel(rect.width, rect.height), rect)
        params = setup.warm.params
        row = pygame.Rect(rect.left + 16, rect.top + 24, rect.width - 32, 48)
        if setup.phase == WARM_WAIT:
            label, share = "waiting for the board to be plugged in cold", 0.0
        else:
            label, share = f"warming {status.elapsed_s / 60:.1f} of {params.duration_s / 60:.0f} min", \
                status.elapsed_s / params.duration_s
        r.draw_meter(surface, row, label, share, ACCENT_BLUE)
        still = f"still seconds: {status.still_s} (the fit needs {params.min_still_s:.0f})"
        r.draw_meter(surface, row.move(0, 80), still, status.still_s / params.min_still_s, GREEN)
        die = "the die's temperature: not read yet" if status.die_c is None else \
            f"the die's temperature: {status.die_c:.2f} degC, risen {status.rise_c:.2f} (the fit needs " \
            f"{params.min_rise_c:.1f})"
        r.draw_meter(surface, row.move(0, 160), die, status.rise_c / params.min_rise_c, YELLOW)

    def waiting(self) -> str:
        """What the screen says before a board has identified itself."""
        game = self.game
        if game.tracker is None:
            return "No board connected: plug one in (the menu offers it), or start the game with --virtual"
        if game.link_state.connected and game.hello() is None:
            return "The board did not identify itself (not the EnergyBall firmware?): it cannot be set up here"
        return f"Waiting for the board: {game.tracker.status}"


class Quit:
    """The screen that ends the loop."""

    def handle(self, event: pygame.event.Event) -> None:
        return None

    def update(self, dt: float) -> None:
        return None

    def draw(self, surface: pygame.Surface) -> None:
        return None


# ----------------------------------------------------------------- input choice


def apply_input(game: Game) -> None:
    """Open the input source the preferences name; a board that is not there means keyboard."""
    choice = game.prefs.input
    if choice == "keyboard":
        game.use_keyboard()
    elif choice == "virtual":
        game.use_board(None, virtual=True)
    elif choice == "auto":
        boards = find_boards()
        if boards:
            game.use_board(boards[0].device)
        else:
            game.use_keyboard()
            game.notices.append("no board found: playing on keyboard and mouse (R raise, F flex, mouse aims)")
    else:
        game.use_board(choice)


# ----------------------------------------------------------------- the app


class WindowError(Exception):
    """The game window cannot open here (SDL's reason in the message)."""


class App:
    """The window, the clock and the current screen."""

    def __init__(self, prefs: Preferences | None = None, input_choice: str | None = None,
                 config_dir: Path | None = None, seed: int = 0, size: tuple[int, int] = WINDOW,
                 draws: bool = True, session: Callable[[Game], SessionLog | None] | None = None) -> None:
        """``session`` makes the session's log once the game exists (a recording, or a replay's)."""
        pygame.init()
        # The link's reader thread must get the GIL promptly while frames draw: switch
        # threads every 0.5 ms rather than Python's default 5 ms (input latency).
        sys.setswitchinterval(0.0005)
        loaded, notices = load_preferences(config_dir) if prefs is None else (prefs, [])
        if input_choice:
            try:
                loaded = replace(loaded, input=input_choice)
            except ValueError as e:  # a port name no port has (the command line should refuse it first)
                notices.append(f"{e}; using {loaded.input!r}")
        flags = pygame.RESIZABLE | (pygame.FULLSCREEN if loaded.fullscreen else 0)
        try:
            with signals.deferred():  # set_mode loads the window's icon through Python and drops what that
                # raises: an ending signal arriving then (Ctrl-C, SIGTERM) would be lost, so it waits for the window
                self.surface = pygame.display.set_mode(size, flags)
        except pygame.error as e:  # no display here, or none that can make this window
            raise WindowError(str(e)) from None
        pygame.display.set_caption("EnergyBall")
        audio = Audio(volume=loaded.volume, music_volume=loaded.music_volume)
        audio.start()  # opens the mixer now, so a missing audio device is noticed here
        scores, score_notices = load_scores(config_dir)
        file_notices = [*notices, *score_notices, storage_notice(config_dir)]
        for notice in filter(None, file_notices):  # also for a player who looks at the terminal
            print(f"energyball: {notice}", file=sys.stderr)
        self.game = Game(loaded, audio, Renderer(self.surface.get_size()), scores=scores,
                         seed=seed, config_dir=config_dir, window=self.surface.get_size())
        if session is not None:
            self.game.log = session(self.game)
        if draws:  # a headless match that never draws skips the drawing's preparations
            self.game.renderer.prepare(self.surface.get_size())
        self.game.notices += [n for n in (*file_notices, audio.notice) if n]
        apply_input(self.game)
        self.game.new_round()
        self.screen: Screen = Menu(self.game)
        self.clock = pygame.time.Clock()
        self._scan = 0.0
        self.scans_for_boards = True  # a replay does not look for boards: its board is the recorded one
        audio.music(True)
        # What exists now lives as long as the game: keep it out of the collector's full
        # passes, which otherwise stall a frame by tens of milliseconds now and then.
        gc.collect()
        gc.freeze()

    @property
    def running(self) -> bool:
        return not isinstance(self.screen, Quit)

    def frame(self, events: list[pygame.event.Event], dt: float, draw: bool = True) -> None:
        """One frame: events, logic and (unless ``draw`` is False: headless matches) drawing."""
        game = self.game
        game.link_state = game.tracker.state() if game.tracker else SourceState()
        if game.log is not None:
            recorded = [event_json(e) for e in events if e.type in RECORDED]
            game.log.frame(dt, recorded, game.link_state if game.tracker else None)
        for event in events:
            if event.type == pygame.QUIT:
                self.screen = Quit()
                return
            if event.type == pygame.KEYDOWN and event.key == pygame.K_F11:
                pygame.display.toggle_fullscreen()
            if event.type == pygame.VIDEORESIZE:
                game.renderer.prepare(event.size)
                game.window = tuple(event.size)
            nxt = self.screen.handle(event)
            if nxt is not None:
                self.screen = nxt
        nxt = self.screen.update(dt)
        if nxt is not None:
            self.screen = nxt
        game.load_board_calibration()
        if game.tracker and game.link_state.error:  # the board could not be opened: say so, play on
            game.notices.append(f"{game.link_state.error}; playing on keyboard and mouse")
            game.use_keyboard()
        self._offer_board(dt)
        game.fps = 0.9 * game.fps + 0.1 * (1.0 / dt) if dt > 0 else game.fps
        if draw:
            self.surface = pygame.display.get_surface() or self.surface
            self.screen.draw(self.surface)

    def _offer_board(self, dt: float) -> None:
        """On keyboard, look for a board now and then; offer to switch to it."""
        game = self.game
        self._scan += dt
        if game.tracker or self._scan < BOARD_SCAN_S or not self.scans_for_boards:
            return
        self._scan = 0.0
        boards = find_boards()
        game.board_offer = boards[0].device if boards else None

    def run(self) -> int:
        """The main loop, until the window closes or the player quits."""
        while self.running:
            dt = self.clock.tick(120) / 1000.0
            self.frame(pygame.event.get(), min(dt, 0.1))
            pygame.display.flip()
        self.close()
        return 0

    def close(self) -> None:
        if isinstance(self.game.log, SessionRecorder):
            self.game.log.close(session_summary(self.game))
        self.game.close_board()
        self.game.audio.close()
        pygame.quit()
        gc.unfreeze()  # what __init__ froze may be collected again (several apps in one process)
