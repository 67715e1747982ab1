"""The HUD says when the board's filter has switched its magnetometer off or found it weak (issue 12)."""

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

import math  # noqa: E402

import numpy as np  # noqa: E402
import pygame  # noqa: E402
import pytest  # noqa: E402

from game.body.controls import SampleInput  # noqa: E402
from game.ui.app import App  # noqa: E402
from game.ui.preferences import Preferences  # noqa: E402
from tracker.fusion.default import MAG_WEAK  # noqa: E402

WARNING = (255, 150, 120)
RATE = 200.0


@pytest.fixture
def app(tmp_path):
    a = App(Preferences(input="keyboard"), config_dir=tmp_path, seed=3)
    yield a
    a.close()


def turn_the_board(source: SampleInput, hard_iron: tuple[float, float, float], seconds: float = 20.0) -> None:
    """A level board turning about its x axis at 0.5 rad/s, its field (0, 20, -40) uT seen with a
    hard-iron offset, fed to the source's filter."""
    f = source.tracking.filter
    for k in range(int(seconds * RATE)):
        a = 0.5 * k / RATE
        c, s = math.cos(a), math.sin(a)
        mag = (hard_iron[0], 20 * c - 40 * s + hard_iron[1], -20 * s - 40 * c + hard_iron[2])
        f.update((0.5, 0.0, 0.0), (0.0, 9.81 * s, 9.81 * c), mag, 1 / RATE)


def warning_pixels(surface: pygame.Surface) -> int:
    """Pixels near the warning colour in the HUD's bottom-left corner (its text is antialiased)."""
    w, h = surface.get_size()
    rgb = pygame.surfarray.array3d(surface)[: w // 2, h - 120:].astype(int)
    return int(np.sum(np.abs(rgb - np.array(WARNING)).sum(axis=-1) < 40))


def test_the_hud_warns_of_a_switched_off_magnetometer(app):
    source = SampleInput()
    app.game.use_source(source)
    turn_the_board(source, (0.0, 0.0, 0.0))
    assert app.game.hud()["magnetometer"] == ""  # a consistent field: nothing to say
    turn_the_board(source, (60.0, 30.0, 0.0))
    line = app.game.hud()["magnetometer"]
    assert line.startswith("magnetometer off: field strength changes as the board moves")


def test_the_hud_says_a_field_that_turns_with_the_board_is_weak(app):
    # Strength and dip stay the same, so the field is in use, but its heading swings +-20 deg as the
    # board turns: weighed down, and the player is told.
    from tests.tracker.test_fusion_default_robust import swinging
    source = SampleInput()
    app.game.use_source(source)
    gyr, acc, mag = swinging(30.0, 20.0)
    f = source.tracking.filter
    for i in range(len(gyr)):
        f.update(gyr[i], acc[i], mag[i], 1 / RATE)
    assert app.game.hud()["magnetometer"] == MAG_WEAK


def test_keyboard_play_has_no_magnetometer_line(app):
    app.game.use_keyboard()
    assert app.game.hud()["magnetometer"] == ""


def test_the_warning_is_drawn_in_the_warning_colour():
    pygame.display.init()
    pygame.font.init()
    try:
        from game.ui.render import Renderer
        surface = pygame.Surface((1280, 720))
        r = Renderer((1280, 720))
        hud = {"input": "board 200 Hz, loss 0.0%", "calibrated": True}
        r.draw_hud(surface, hud)
        before = warning_pixels(surface)
        surface.fill((0, 0, 0))
        r.draw_hud(surface, {**hud, "magnetometer": "magnetometer off: field strength changes as the board moves"})
        assert before == 0 and warning_pixels(surface) > 100
    finally:
        pygame.display.quit()
