"""The real app under the dummy video driver, driven by injected keyboard events."""

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

import json  # noqa: E402

import pygame  # noqa: E402
import pytest  # noqa: E402

from game.ui.app import App, Calibration, GameOver, Menu, Pause, Play  # noqa: E402
from game.ui.preferences import Preferences  # noqa: E402
from game.world.arena_model import Zombie  # noqa: E402

DT = 1 / 60


def key(k, down=True):
    return pygame.event.Event(pygame.KEYDOWN if down else pygame.KEYUP, key=k, mod=0, unicode="")


def frames(app, seconds, events=()):
    app.frame(list(events), DT)
    for _ in range(int(seconds / DT)):
        app.frame([], DT)


@pytest.fixture
def app(tmp_path):
    a = App(Preferences(input="keyboard"), config_dir=tmp_path, seed=3)
    yield a
    a.close()


def test_menu_calibration_play_pause_game_over_on_the_keyboard(app, tmp_path):
    assert isinstance(app.screen, Menu)
    frames(app, 0.1, [key(pygame.K_DOWN), key(pygame.K_RETURN)])  # "Calibrate"
    assert isinstance(app.screen, Calibration)
    frames(app, 5.0)  # get ready, then hold the arm down
    assert app.screen.step == "forward"
    frames(app, 4.5, [key(pygame.K_r)])  # hold R: the arm straight forward
    assert app.screen.step == "done", app.screen.message
    frames(app, 0.1, [key(pygame.K_r, False), key(pygame.K_RETURN)])
    assert isinstance(app.screen, Menu)
    frames(app, 0.1, [key(pygame.K_RETURN)])  # "Play"
    assert isinstance(app.screen, Play)

    # Raise, flex, straighten: a ball flies.
    frames(app, 0.6, [key(pygame.K_r)])
    frames(app, 0.8, [key(pygame.K_f)])
    assert app.game.gestures.state.value == "spinning"
    frames(app, 0.2, [key(pygame.K_f, False)])
    assert app.game.gestures.state.value == "fired"
    assert app.game.arena.balls, "the launch should have put a ball in flight"

    frames(app, 0.1, [key(pygame.K_ESCAPE)])
    assert isinstance(app.screen, Pause)
    t = app.game.arena.time
    frames(app, 0.5)
    assert app.game.arena.time == t  # nothing moves while paused
    frames(app, 0.1, [key(pygame.K_ESCAPE)])
    assert isinstance(app.screen, Play)

    # A zombie at the player's side and almost no health left: game over.
    arena = app.game.arena
    arena.player.health = 1.0
    arena.zombies.append(Zombie(999, arena.player.x + 0.3, arena.player.y, speed=0.5, health=3, phase=0.0))
    for _ in range(600):
        app.frame([], DT)
        if isinstance(app.screen, GameOver):
            break
    assert isinstance(app.screen, GameOver)
    scores = json.loads((tmp_path / "scores.json").read_text())
    assert scores[0]["score"] == arena.score
    frames(app, 0.1, [key(pygame.K_RETURN)])
    assert isinstance(app.screen, Menu)


def test_settings_persist(app, tmp_path):
    frames(app, 0.1, [key(pygame.K_DOWN), key(pygame.K_DOWN), key(pygame.K_RETURN)])  # "Settings"
    frames(app, 0.1, [key(pygame.K_DOWN), key(pygame.K_RIGHT), key(pygame.K_ESCAPE)])  # arm: left
    assert isinstance(app.screen, Menu)
    saved = json.loads((tmp_path / "settings.json").read_text())
    assert saved["side"] == "left" and app.game.avatar.body.side == "left"


def test_quit_from_the_menu(app):
    frames(app, 0.1, [key(pygame.K_ESCAPE)])
    assert not app.running


def test_a_pulled_cable_pauses_with_a_message_and_play_resumes_when_it_is_back(app):
    import time

    from tracker.board import VirtualBoard

    with VirtualBoard() as board:
        app.game.use_board(board.port)
        app.game.calibrated = True
        app.screen = Play(app.game)
        deadline = time.monotonic() + 5
        while not app.game.tracker.connected and time.monotonic() < deadline:
            app.frame([], DT)
            time.sleep(0.01)
        assert app.game.tracker.connected
        board.pull_cable()
        deadline = time.monotonic() + 5
        while not isinstance(app.screen, Pause) and time.monotonic() < deadline:
            app.frame([], DT)
            time.sleep(0.01)
        assert isinstance(app.screen, Pause) and "cable" in app.screen.reason
        board.plug_in()
        deadline = time.monotonic() + 8
        while not isinstance(app.screen, Play) and time.monotonic() < deadline:
            app.frame([], DT)
            time.sleep(0.02)
        assert isinstance(app.screen, Play)


def test_without_a_display_the_game_says_how_to_run_headless():
    import subprocess
    import sys
    from pathlib import Path

    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "SDL_VIDEODRIVER")}
    r = subprocess.run([sys.executable, "-m", "game"], capture_output=True, text=True, env=env, timeout=60,
                       cwd=Path(__file__).resolve().parents[3])
    assert r.returncode != 0 and "Traceback" not in r.stderr
    assert "no display found" in r.stderr and "energyball shots" in r.stderr


def test_a_window_sdl_cannot_open_is_one_line_naming_sdls_reason():
    import subprocess
    import sys
    from pathlib import Path

    env = {**os.environ, "SDL_VIDEODRIVER": "no_such_driver", "SDL_AUDIODRIVER": "dummy"}
    r = subprocess.run([sys.executable, "-m", "game", "--keyboard"], capture_output=True, text=True, env=env,
                       timeout=60, cwd=Path(__file__).resolve().parents[3])
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert "energyball: cannot open the game window (no_such_driver not available)" in r.stderr


def test_virtual_input_plays_from_a_simulated_board_and_stops_it_on_close(tmp_path):
    import time

    a = App(Preferences(input="virtual"), config_dir=tmp_path, seed=2)
    try:
        board = a.game.virtual_board
        assert board is not None and a.game.tracker is not None
        assert a.game.tracker.opened.wait(5.0) and a.game.tracker.error is None
        time.sleep(0.3)
        assert a.game.pose(DT).flex_deg >= 0  # poses come from the board
    finally:
        a.close()
    assert a.game.virtual_board is None and not os.path.exists(board.port)


def test_the_menu_says_the_virtual_player_needs_no_calibration_and_stays(tmp_path):
    a = App(Preferences(input="virtual"), config_dir=tmp_path, seed=2)
    try:
        menu = Menu(a.game)
        assert "Calibrate  (not needed: virtual player)" in menu.labels()
        assert menu.choose("Calibrate") is menu
        assert "does not follow prompts" in a.game.notices[-1]
        assert isinstance(menu.choose("Play"), Play)  # and play starts at once
    finally:
        a.close()


def turning_arm(rate_hz: float):
    """A worn board whose arm never holds still: raised 30 degrees, it circles the vertical (a cone)
    once in 6 s, so the arm's direction turns some 30 degrees in every second of any hold and the
    accelerometer sees it. (A steady turn about the vertical alone would read as a gyroscope bias, and
    the virtual board's default arm swings back and forth: where its swings turn back together a
    second of it moves less than sway may, and a hold passed there once on a loaded machine.)"""
    import numpy as np

    from tracker import quat
    from tracker.sim import Motion, SimulatedSource, Simulator, arm_chain, realistic_errors

    def root(t):
        around = np.radians(60.0) * t
        raised = quat.multiply(quat.from_axis_angle((0, 0, 1), around),
                               quat.from_axis_angle((0, 1, 0), np.full_like(t, np.radians(30.0))))
        return quat.multiply(raised, quat.from_axis_angle((0, 0, 1), -around))

    motion = Motion(root, lambda t: np.zeros((len(t), 1)))
    return SimulatedSource(Simulator(arm_chain(), motion, realistic_errors(), seed=0), rate_hz)


def test_calibrating_a_board_that_keeps_moving_fails_with_the_reason(app):
    import time

    from tracker.board import BoardSettings, VirtualBoard

    settings = BoardSettings()
    with VirtualBoard(turning_arm(settings.rate_hz), settings) as board:
        app.game.use_board(board.port)
        assert app.game.tracker.opened.wait(5.0)
        app.screen = Calibration(app.game, then_play=False)
        # in real time (the hold is timed in the board's samples too): get ready, the hold and, when what
        # moved might be a slow tremor, the longer hold
        for _ in range(int(9.0 / DT)):
            app.frame([], DT)
            time.sleep(DT)
            if app.screen.step == "failed":
                break
        assert app.screen.step == "failed" and "moved" in app.screen.message, app.screen.message
        assert "R: try again" in app.screen.message


def test_a_signal_while_the_window_opens_is_not_lost(tmp_path, monkeypatch):
    """pygame's set_mode loads the window's icon through Python (``pygame.pkgdata.getResource``) and
    drops whatever that raises: a SIGTERM handled just then was lost, and a headless run of a thousand
    matches played on (the hosted CI, 2026-12-06). Here the signal arrives inside that very call."""
    import signal

    import pygame.pkgdata

    from tracker import signals

    real, calls = pygame.pkgdata.getResource, []

    def icon_with_a_signal(*args, **kwargs):
        calls.append(args)
        if len(calls) == 1:  # one signal, in the first resource pygame loads
            signal.raise_signal(signal.SIGTERM)
        return real(*args, **kwargs)

    pygame.quit()  # a fresh display, which loads its icon again
    monkeypatch.setattr(pygame.pkgdata, "getResource", icon_with_a_signal)
    try:
        with pytest.raises(KeyboardInterrupt) as stop:
            with signals.interrupts():
                App(Preferences(input="keyboard"), config_dir=tmp_path)
    finally:
        pygame.quit()
    assert calls and calls[0][0].endswith("icon.bmp")  # the signal did arrive inside the icon's loading
    assert signals.signum_of(stop.value) == signal.SIGTERM


def test_a_port_that_cannot_be_opened_falls_back_to_the_keyboard_with_a_notice(tmp_path):
    a = App(Preferences(input="/dev/ttyNOPE"), config_dir=tmp_path, seed=1)
    try:
        assert a.game.tracker is not None and a.game.tracker.opened.wait(5.0)
        frames(a, 0.1)
        assert a.game.tracker is None and a.game.source == "keyboard"
        assert any("no such port" in n and "keyboard" in n for n in a.game.notices)
    finally:
        a.close()


def test_shots_into_a_folder_that_cannot_be_made_is_one_clear_line():
    import subprocess
    import sys
    from pathlib import Path

    r = subprocess.run([sys.executable, "-m", "game", "shots", "--out", "/proc/no/such/folder"],
                       capture_output=True, text=True, timeout=120, cwd=Path(__file__).resolve().parents[3])
    assert r.returncode != 0 and "Traceback" not in r.stderr
    assert r.stderr.strip().splitlines() == [r.stderr.strip().splitlines()[-1]]
    assert "cannot write the screenshots" in r.stderr


def test_shots_onto_a_file_is_refused_and_the_file_kept(tmp_path):
    import subprocess
    import sys

    kept = tmp_path / "notes.txt"
    kept.write_text("mine")
    r = subprocess.run([sys.executable, "-m", "game", "shots", "--out", str(kept)],
                       capture_output=True, text=True, timeout=120, env={**os.environ, "SDL_VIDEODRIVER": "dummy"})
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and f"{kept} is not a folder" in r.stderr
    assert kept.read_text() == "mine" and sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


class _ShakyHoldTracker:
    """A board whose arm hangs still, but whose hold the bias estimate refuses (say, a turn about the vertical)."""

    def __init__(self):
        from types import SimpleNamespace

        import numpy as np

        from game.body.pose import ArmPose
        from tracker import protocol as P
        from tracker.calibration import BiasResult

        hanging = ArmPose((1.0, 0.0, 0.0, 0.0), 0.0, 0.0)
        self.recent = [P.RawSample(0.0, 0, 0, (0, 0, 2048), (0, 0, 0), None, 390, 16, 2000)]
        refused = BiasResult(False, "the arm turned about the vertical", np.zeros(3), np.zeros(3), 2.0)
        self.anchored = 0  # wearings put on (each keeps its "forward" as the field settles)
        self.tracking = SimpleNamespace(hold_still=lambda hold, params=None: (refused, [hanging] * 50),
                                        anchor_heading=lambda: setattr(self, "anchored", self.anchored + 1))
        self.forward = False
        self._hanging = hanging
        self.error, self.connected, self.status = None, True, "streaming"

    def poll(self):
        from game.body.pose import ArmPose
        from tracker import quat as Q

        if not self.forward:
            return self._hanging
        return ArmPose(tuple(Q.from_axis_angle((1.0, 0.0, 0.0), 1.5708)), 0.0, 0.0)

    def state(self):
        from game.body.controls import SourceState

        return SourceState(opened=True, connected=True)

    def close(self):
        pass


class _SlowTremorTracker(_ShakyHoldTracker):
    """A board whose first hold looks like a turn (a slow tremor) and whose longer hold is still."""

    def __init__(self):
        import numpy as np

        from tracker import protocol as P
        from tracker.calibration import BiasResult

        super().__init__()
        self.recent = [P.RawSample(i * 0.01, 0, i, (0, 0, 2048), (0, 0, 0), None, 390, 16, 2000) for i in range(600)]
        self.holds = []  # (seconds the hold spans, the judgement's settings)
        asks = BiasResult(False, "the arm turned about the vertical", np.zeros(3), np.zeros(3), 2.5, True)
        still = BiasResult(True, "gyroscope bias", np.ones(3) * 0.01, np.ones(3) * 0.001, 5.0)

        def hold_still(hold, params=None):
            self.holds.append((hold[-1].t - hold[0].t, params))
            return (asks if params is None else still), [self._hanging] * 50

        self.tracking.hold_still = hold_still


def test_a_hold_that_may_be_a_slow_tremor_goes_on_and_the_longer_hold_is_judged(app):
    from tracker.calibration import LONGER_HOLD, LONGER_HOLD_S

    tracker = _SlowTremorTracker()
    app.game.tracker = tracker
    screen = Calibration(app.game, then_play=False)
    app.screen = screen
    frames(app, 2.0 + 2.6)  # get ready, then hold the arm down: the judgement asks for more
    assert screen.step == "longer" and "a little longer" in screen.instruction()
    frames(app, 2.6)
    assert screen.step == "forward" and screen.bias_learned
    assert [p for _, p in tracker.holds] == [None, LONGER_HOLD]
    assert tracker.holds[0][0] == pytest.approx(2.5, abs=0.011)
    assert tracker.holds[1][0] == pytest.approx(LONGER_HOLD_S, abs=0.011)  # the whole hold, both parts
    tracker.forward = True
    frames(app, 2.0 + 2.1)
    assert screen.step == "done" and "learned as you play" not in screen.message


def test_a_hold_too_shaky_for_the_bias_still_calibrates_and_says_the_bias_is_learned_in_play(app):
    tracker = _ShakyHoldTracker()
    app.game.tracker = tracker
    screen = Calibration(app.game, then_play=False)
    app.screen = screen
    frames(app, 2.0 + 2.6)  # get ready, then hold the arm down
    assert screen.step == "forward" and not screen.bias_learned
    tracker.forward = True
    frames(app, 2.0 + 2.1)
    assert screen.step == "done", screen.message
    assert "learned as you play" in screen.message
    assert tracker.anchored == 1  # "forward" was taken once (the arm-down step sets the arm's axis only)
