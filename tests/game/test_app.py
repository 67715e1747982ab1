"""The real app under the dummy video driver, driven by injected keyboard events."""

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

import json  # noqa: E402

import pygame  # noqa: E402
import pytest  # noqa: E402

from game.app import App, Calibration, GameOver, Menu, Pause, Play  # noqa: E402
from game.arena_model import Zombie  # noqa: E402
from game.preferences import Preferences  # noqa: E402

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
