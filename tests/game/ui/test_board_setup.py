"""The game's "Board setup" and the board's saved calibration, through the real app (dummy video driver).

Two ways of feeding the screen: the simulated maker in simulated time
(:class:`game.ui.board_setup.MakerInput`: quick, the same every run) and, as
``energyball --virtual`` does, the virtual board on a pty served in real time,
handed to the simulated maker while the screen is up. Every test has a
throwaway HOME and XDG_CONFIG_HOME: no user's file is touched.
"""

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

import json  # noqa: E402
import time  # noqa: E402
from collections import deque  # noqa: E402

import numpy as np  # noqa: E402
import pygame  # noqa: E402
import pytest  # noqa: E402
from hypothesis import given, settings, strategies as st  # noqa: E402

from game.ui.app import App, BoardSetupScreen, Menu, Play  # noqa: E402
from game.ui.board_setup import (ACCEL, ACCEL_DONE, FAILED, MAG, MAG_DONE, WARM, WARM_DONE,  # noqa: E402
                                 WARM_WAIT, BoardSetup, MakerInput, fresh_samples)
from game.ui.preferences import Preferences  # noqa: E402
from game.ui.render.board import (BOARD_FACES, face_normal, globe_cells, globe_image, rotation_to_up,  # noqa: E402
                                  view_rotation, visible_faces)
from tracker.calibration import BoardCalibration, ProcedureRecord, load, save_procedure  # noqa: E402
from tracker.maker_sim import SimulatedMaker, calibration_errors  # noqa: E402
from tracker import protocol as P  # noqa: E402
from tracker.motion import EARTH_FIELD_UT  # noqa: E402
from tracker.thermal import ThermalParams, ThermalProcedure  # noqa: E402

DT = 1 / 60
SETUP_ITEM = Menu(None).items.index("Board setup")  # type: ignore[arg-type]


def key(k, down=True):
    return pygame.event.Event(pygame.KEYDOWN if down else pygame.KEYUP, key=k, mod=0, unicode="")


@pytest.fixture
def home(tmp_path, monkeypatch):
    """A throwaway HOME and XDG_CONFIG_HOME; the board files go to <it>/config/energyball/boards."""
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    return tmp_path / "config" / "energyball"


def open_board_setup(app):
    """From the menu, with the keys a player presses."""
    assert isinstance(app.screen, Menu)
    app.frame([key(pygame.K_DOWN)] * SETUP_ITEM + [key(pygame.K_RETURN)], DT)
    assert isinstance(app.screen, BoardSetupScreen)
    return app.screen


def run_until(app, done, limit_frames, real_time=False):
    """Frames until ``done()`` (every tenth drawn); in real time (a pty board) each frame waits a frame's time."""
    for i in range(limit_frames):
        app.frame([], DT, draw=i % 10 == 0)
        if done():
            return
        if real_time:
            time.sleep(DT)
    raise AssertionError(f"not reached in {limit_frames} frames; screen {type(app.screen).__name__}, "
                         f"{getattr(getattr(app.screen, 'setup', None), 'message', lambda: '')()}")


def phase_of(app):
    setup = getattr(app.screen, "setup", None)
    return setup.phase if setup else None


# ----------------------------------------------------------------- simulated time


@pytest.fixture
def maker_app(home):
    app = App(Preferences(input="keyboard"), seed=5)
    maker = SimulatedMaker(seed=11)
    app.game.use_source(MakerInput(maker, DT))
    yield app, maker
    app.close()


def test_board_setup_runs_both_procedures_with_the_simulated_maker_and_saves_the_board_file(maker_app, home):
    app, maker = maker_app
    app.frame([], DT)  # the board says who it is: nothing saved yet
    assert app.game.board_id == "imu-71" and app.game.board_uncalibrated
    screen = open_board_setup(app)
    run_until(app, lambda: phase_of(app) == ACCEL_DONE, 60 * 240)  # ~100 s waiting for the die
    path = home / "boards" / "imu-71.json"
    saved = json.loads(path.read_text())
    assert set(saved["procedures"]) == {"accel"} and saved["procedures"]["accel"]["residual_m_s2"] >= 0.0
    assert str(path) in screen.setup.saved
    truth = maker.true_calibration()
    errors = calibration_errors(load("imu-71", home / "boards"), truth)
    assert errors["acc_offset_error_mg"] < 5.0 and errors["acc_scale_error_pct"] < 0.3, errors
    assert errors["gyro_scale_error_pct"] < 0.2, errors  # the turns between the poses, of up to 3 %
    # what was saved is what the game now applies
    np.testing.assert_array_equal(app.game.tracker.tracking.board.acc_offset, saved["acc_offset"])
    assert not app.game.board_uncalibrated

    app.frame([key(pygame.K_RETURN)], DT)  # on to the magnetometer
    assert phase_of(app) == MAG
    run_until(app, lambda: phase_of(app) == MAG_DONE, 60 * 180)
    saved = json.loads(path.read_text())
    assert set(saved["procedures"]) == {"accel", "mag"}
    figures = saved["procedures"]["mag"]
    # The simulated room's field: the earth's (tracker.motion.EARTH_FIELD_UT) plus the room's disturbance
    # at the table, at most disturbance_ut, which can turn it by up to asin(disturbance / |earth|).
    earth = np.array(EARTH_FIELD_UT)
    strength, room = float(np.linalg.norm(earth)), maker.errors.magnetic.disturbance_ut
    dip = np.degrees(np.arctan2(-earth[2], np.hypot(earth[0], earth[1])))
    assert abs(figures["strength_ut"] - strength) <= room + 1.0, figures
    assert abs(figures["dip_deg"] - dip) <= np.degrees(np.arcsin((room + 1.0) / strength)), figures
    assert 0.0 <= figures["residual_ut"] < 0.05 * figures["strength_ut"]
    fitted = load("imu-71", home / "boards")
    errors = calibration_errors(fitted, truth)
    assert errors["mag_hard_iron_error_ut"] < 2.0 and errors["mag_soft_iron_error_pct"] < 2.0, errors
    np.testing.assert_array_equal(fitted.acc_offset, app.game.tracker.tracking.board.acc_offset)  # kept
    np.testing.assert_array_equal(fitted.mag_hard_iron, app.game.tracker.tracking.board.mag_hard_iron)
    lines = " ".join(screen.setup.figures)
    assert f"{figures['strength_ut']:.1f} uT" in lines and f"dip {figures['dip_deg']:.1f} deg" in lines

    app.frame([key(pygame.K_RETURN)], DT)  # on to the warm-up, which waits for a board powered up cold
    assert phase_of(app) == WARM_WAIT and "S: start now" in screen.setup.keys()
    app.frame([key(pygame.K_RETURN)], DT)  # done without it: back to the menu
    assert isinstance(app.screen, Menu)


def test_the_warm_up_starts_when_the_board_powers_up_and_saves_its_slope(maker_app, home):
    """The third step: the simulated maker unplugs the board until it is cold and plugs it back in (a
    board whose clock starts again), the screen watches it warm, fits the bias's slope and saves it."""
    app, _ = maker_app
    screen = open_board_setup(app)
    app.frame([], DT)
    setup = screen.setup
    setup.warm = ThermalProcedure(ThermalParams(duration_s=150.0))  # a quarter of the ten minutes: quick
    setup.start(WARM_WAIT)
    app.frame([], DT)
    assert phase_of(app) == WARM and app.game.tracker.t < 0.1  # plugged in cold: its clock starts again
    run_until(app, lambda: phase_of(app) == WARM_DONE, 60 * 160)
    saved = json.loads((home / "boards" / "imu-71.json").read_text())
    figures = saved["procedures"]["thermal"]
    assert figures["rise_c"] >= 1.0 and "warmed" in " ".join(setup.figures)
    truth = app.game.tracker.maker.true_calibration()  # this power-on's warm-up over the die's rise
    error = calibration_errors(load("imu-71", home / "boards"), truth)["gyro_thermal_error_dps_per_c"]
    assert error < 0.02, error  # of the data sheet's 0.24 deg/s per degC
    np.testing.assert_array_equal(app.game.tracker.tracking.board.gyro_thermal, saved["gyro_thermal"])  # applied
    app.frame([key(pygame.K_RETURN)], DT)
    assert isinstance(app.screen, Menu)


def test_the_warm_up_waits_for_a_board_that_just_powered_up():
    setup = BoardSetup("imu-71")
    setup.start(WARM_WAIT)
    still = [P.RawSample(t, 0, 0, (0, 0, 2048), (0, 0, 0), None, 400, temp_counts=P.temp_counts(30.0))
             for t in (500.0, 500.005)]
    setup.feed(still)  # a board powered up long ago: already warm, nothing to watch
    assert setup.phase == WARM_WAIT and setup.warm_status.die_c is None
    setup.feed([s._replace(t=s.t - 500.0) for s in still])  # unplugged and plugged back in: its clock restarts
    assert setup.phase == WARM and setup.warm_status.die_c == pytest.approx(30.0, abs=0.01)
    setup.redo()  # R while it warms: wait for the board again
    assert setup.phase == WARM_WAIT


@pytest.mark.parametrize("clock_s", [0.0, 500.0])
def test_a_board_that_barely_warms_is_saved_as_negligible_only_when_seen_powering_up(tmp_path, clock_s):
    """0.15 degC in 150 s (under the 1 degC a slope needs): from a board just plugged in, its warm-up,
    kept with zero slopes; from one on for 500 s (S: start now), a warm board, refused."""
    setup = BoardSetup("imu-71", directory=tmp_path)
    setup.warm = ThermalProcedure(ThermalParams(duration_s=150.0))
    setup.start(WARM)
    setup.feed([P.RawSample(clock_s + k / 10, 0, k, (0, 0, 2048), (3, -2, 1), None, 400,
                            temp_counts=P.temp_counts(30.0 + 0.001 * k / 10)) for k in range(1510)])
    if clock_s:
        assert setup.phase == FAILED and "not seen powering up" in setup.message()
        assert list(tmp_path.iterdir()) == []
        return
    assert setup.phase == WARM_DONE and any("negligible" in line for line in setup.figures)
    saved = load("imu-71", tmp_path)
    assert saved.gyro_thermal_known and not saved.gyro_thermal.any() and not saved.acc_thermal.any()
    assert dict(saved.record("thermal").figures)["rise_c"] == pytest.approx(0.15, abs=0.01)


def test_a_board_without_temperatures_fails_the_warm_up_with_its_reason_and_saves_nothing(tmp_path):
    setup = BoardSetup("imu-71", directory=tmp_path)
    setup.start(WARM)  # S: on the board as it is
    setup.feed([P.RawSample(1.0, 0, 0, (0, 0, 2048), (0, 0, 0), None, 400)])  # a firmware before the TEMP frame
    assert setup.phase == FAILED and "flash the current firmware" in setup.message()
    assert list(tmp_path.iterdir()) == []
    setup.redo()  # R: wait for the board again
    assert setup.phase == WARM_WAIT


def test_keys_skip_redo_and_leave(maker_app):
    app, _ = maker_app
    open_board_setup(app)
    run_until(app, lambda: len(app.screen.setup.accel_status.captured) == 1, 60 * 150)
    app.frame([key(pygame.K_r)], DT)  # start the accelerometer again: nothing captured
    assert phase_of(app) == ACCEL and app.screen.setup.accel_status.captured == ()
    app.frame([key(pygame.K_m)], DT)  # straight to the magnetometer
    assert phase_of(app) == MAG
    app.frame([key(pygame.K_ESCAPE)], DT)
    assert isinstance(app.screen, Menu)


def test_a_damaged_board_file_is_named_before_and_kept_beside_the_new_one(maker_app, home):
    app, _ = maker_app
    path = home / "boards" / "imu-71.json"
    path.parent.mkdir(parents=True)
    path.write_text("{ not json")
    app.frame([], DT)
    assert any("damaged" in n for n in app.game.notices) and app.game.board_uncalibrated
    screen = open_board_setup(app)
    app.frame([], DT)
    assert "damaged" in screen.setup.notice
    run_until(app, lambda: phase_of(app) == ACCEL_DONE, 60 * 240)  # ~100 s waiting for the die
    assert (path.parent / "imu-71.json.damaged").read_text() == "{ not json"
    assert "damaged" in screen.setup.saved and json.loads(path.read_text())["procedures"]["accel"]


def test_without_a_board_the_screen_says_what_to_do(home):
    app = App(Preferences(input="keyboard"), seed=1)
    try:
        screen = open_board_setup(app)
        app.frame([], DT)
        assert screen.setup is None and "No board connected" in screen.waiting()
        app.frame([key(pygame.K_ESCAPE)], DT)
        assert isinstance(app.screen, Menu)
    finally:
        app.close()


# ----------------------------------------------------------------- the virtual board on a pty, real time


def wait_for_board(app, seconds=10.0):
    deadline = time.monotonic() + seconds
    while app.game.board_id is None and time.monotonic() < deadline:
        app.frame([], DT)
        time.sleep(DT)
    # the virtual board sends the real firmware's HELLO; its file never is a real board's
    assert app.game.board_id == "virtual-imu-71", app.game.notices


def test_virtual_board_setup_end_to_end_with_a_pulled_cable(home):
    """``--virtual``: the simulated maker follows the prompts on the virtual board; a cable pulled
    mid-procedure forgets only the pose being held, and the procedure resumes."""
    app = App(input_choice="virtual", seed=0)
    try:
        wait_for_board(app)
        board = app.game.virtual_board
        player = board.motion
        screen = open_board_setup(app)
        # the board just powered up: the poses wait some 100 s for its die to settle (tracker.warming)
        run_until(app, lambda: screen.setup.accel_status.waiting and screen.setup.accel_status.warming is not None,
                  60 * 30, real_time=True)
        assert "the board is warming" in screen.setup.message()
        run_until(app, lambda: len(screen.setup.accel_status.captured) == 2, 60 * 180, real_time=True)
        assert board.motion is not player  # the maker has the board
        board.pull_cable()
        run_until(app, lambda: screen.setup.disconnected, 60 * 10, real_time=True)
        assert "disconnected" in screen.setup.message() and screen.setup.accel_status.captured[:2]
        board.plug_in()
        run_until(app, lambda: phase_of(app) == ACCEL_DONE, 60 * 90, real_time=True)
        app.frame([key(pygame.K_RETURN)], DT)
        run_until(app, lambda: phase_of(app) == MAG_DONE, 60 * 150, real_time=True)
        saved = json.loads((home / "boards" / "virtual-imu-71.json").read_text())
        assert set(saved["procedures"]) == {"accel", "mag"}
        assert not (home / "boards" / "imu-71.json").exists()
        assert saved["mag_hard_iron"] != [0.0, 0.0, 0.0] and saved["acc_offset"] != [0.0, 0.0, 0.0]
        plugs = board.counters.plugs
        app.frame([key(pygame.K_RETURN)], DT)  # on to the warm-up: the maker unplugs the board until it is cold
        run_until(app, lambda: phase_of(app) == WARM, 60 * 10, real_time=True)
        assert board.counters.plugs == plugs + 1 and screen.setup.warm_status.die_c is not None
        assert screen.setup.warm_status.elapsed_s < 5.0  # watched from its power-up
        app.frame([key(pygame.K_ESCAPE)], DT)
        assert isinstance(app.screen, Menu) and board.motion is player  # the player has it back
    finally:
        app.close()


def test_no_saved_calibration_is_said_once_and_the_game_plays_without_it(home, capsys):
    app = App(input_choice="virtual", seed=0)
    try:
        wait_for_board(app)
        said = [n for n in app.game.notices if "no calibration saved" in n]
        assert len(said) == 1 and "Board setup" in said[0]
        assert app.game.board_uncalibrated and app.game.tracker.tracking.board.procedures == ()
        assert "Board setup  (not done for this board)" in app.screen.labels()  # the menu offers it
        board = app.game.virtual_board
        board.pull_cable()  # the same board again, after a replug: not said twice
        deadline = time.monotonic() + 5
        while app.game.tracker.connected and time.monotonic() < deadline:
            app.frame([], DT)
            time.sleep(DT)
        board.plug_in()
        deadline = time.monotonic() + 8
        while not app.game.tracker.connected and time.monotonic() < deadline:
            app.frame([], DT)
            time.sleep(DT)
        for _ in range(30):
            app.frame([], DT)
        assert len([n for n in app.game.notices if "no calibration saved" in n]) == 1
        assert capsys.readouterr().err.count("no calibration saved") == 1
        app.frame([key(pygame.K_RETURN)], DT)  # "Play": the virtual player needs no wearing calibration
        assert isinstance(app.screen, Play)
        start = app.game.arena.time
        for _ in range(60):
            app.frame([], DT)
            time.sleep(DT / 2)
        assert isinstance(app.screen, Play) and app.game.arena.time > start
        assert app.game.tracker.last_pose is not None  # the board's samples drive the arm
    finally:
        app.close()


def test_a_saved_calibration_is_loaded_by_the_boards_identity_and_applied(home):
    """The virtual board's file (``virtual-imu-71``: its HELLO is a real MPU-9250 board's)."""
    fitted = BoardCalibration("virtual-imu-71", acc_offset=np.array([0.3, -0.2, 0.1]),
                              acc_scale=np.array([1.01, 0.99, 1.02]),
                              mag_hard_iron=np.array([12.0, -30.0, 4.0]),
                              mag_soft_iron=np.array([[1.02, 0.01, 0.0], [0.01, 0.98, 0.0], [0.0, 0.0, 1.0]]))
    save_procedure("virtual-imu-71", fitted, ProcedureRecord.now("accel", {"residual_m_s2": 0.0}), home / "boards")
    save_procedure("virtual-imu-71", fitted, ProcedureRecord.now("mag", {"residual_ut": 0.5, "strength_ut": 48.0,
                                                                 "dip_deg": 60.0}), home / "boards")
    app = App(input_choice="virtual", seed=0)
    try:
        wait_for_board(app)
        applied = app.game.tracker.tracking.board
        for name in ("acc_offset", "acc_scale", "mag_hard_iron", "mag_soft_iron"):
            np.testing.assert_array_equal(getattr(applied, name), getattr(fitted, name))
        assert not app.game.board_uncalibrated and "Board setup" in app.screen.labels()
        assert any("loaded from" in n for n in app.game.notices)
        assert not any("no calibration saved" in n for n in app.game.notices)
        # the samples are corrected with it: acc_cal = scale * (acc - offset) (BoardCalibration's doc)
        deadline = time.monotonic() + 5
        while not app.game.tracker.recent and time.monotonic() < deadline:
            app.game.tracker.poll()  # the menu does not read the board; play would
            time.sleep(DT)
        sample = app.game.tracker.recent[-1]
        corrected = applied.apply(sample)
        np.testing.assert_allclose(corrected.acc, (np.array(sample.acc) - [0.3, -0.2, 0.1]) * [1.01, 0.99, 1.02])
    finally:
        app.close()


# ----------------------------------------------------------------- pieces


@settings(derandomize=True, max_examples=200)
@given(st.integers(1, 30), st.integers(0, 60), st.integers(1, 30))
def test_fresh_samples_are_exactly_those_after_the_last_seen(maxlen, before, after):
    recent: deque = deque(maxlen=maxlen)
    items = [object() for _ in range(before + after)]
    recent.extend(items[:before])
    last = recent[-1] if recent else None
    recent.extend(items[before:])
    got = fresh_samples(recent, last)
    if last is not None and after < maxlen:
        assert got == items[before:]
    else:  # the last seen is gone: all that is kept
        assert got == list(recent)


@settings(derandomize=True, max_examples=200)
@given(st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda v: np.linalg.norm(v) > 1e-3))
def test_rotation_to_up_turns_the_vector_up(v):
    r = rotation_to_up(np.array(v))
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-9)
    assert np.linalg.det(r) == pytest.approx(1.0)
    np.testing.assert_allclose(r @ np.array(v), [0.0, 0.0, np.linalg.norm(v)], atol=1e-9)


@settings(derandomize=True, max_examples=100)
@given(st.floats(-np.pi, np.pi), st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda v: np.linalg.norm(v) > 1e-3))
def test_a_box_shows_at_most_three_faces_never_two_opposite(turn, up):
    view = view_rotation(turn, 0.5) @ rotation_to_up(np.array(up))
    faces = visible_faces(view)
    assert 1 <= len(faces) <= 3
    for f in faces:
        assert (("-" if f[0] == "+" else "+") + f[1]) not in faces
        assert (view @ face_normal(f))[2] > 0
    assert set(faces) <= set(BOARD_FACES)


def test_the_globe_shows_each_point_in_the_colour_of_its_nearest_direction():
    """Two bins, up (+z) and down: seen from the side (no pitch, screen y = world z), the upper half
    of the disc is the first bin's colour and the lower half the second's."""
    colours = np.array([[0.0, 200.0, 0.0], [0.0, 0.0, 200.0]])
    cells = globe_cells(20, view_rotation(0.0, 0.0), np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]))
    image = globe_image(20, cells, colours)
    top, bottom = image[20 - 10, 20], image[20 + 10, 20]  # rows run downwards
    assert top[1] > 50 and top[2] <= 1 and bottom[2] > 50 and bottom[1] <= 1  # 1: never the colour key
    assert image[0, 0].tolist() == [0, 0, 0]  # outside the disc: the colour key

