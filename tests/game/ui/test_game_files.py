"""The game's own files never kill it: a bad value means its default and a notice naming file, key and range.

The real app under the dummy video driver, with a throwaway HOME (the app finds
``~/.config/energyball`` through it), the real command in a subprocess, and
property tests that feed random JSON and random bytes to every loader.
"""

import dataclasses
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

import pygame  # noqa: E402
import pytest  # noqa: E402
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from game.body import players  # noqa: E402
from game.body.players import Player, ProfileError  # noqa: E402
from game.sim.motion_model import PlayerProfile  # noqa: E402
from game.ui import preferences as P  # noqa: E402
from game.ui.app import App, GameOver, Menu, Play, Settings  # noqa: E402
from game.ui.preferences import FLEX_GAP_DEG, Preferences, Score, load_preferences, load_scores  # noqa: E402
from game.world.arena_model import Zombie  # noqa: E402
from tracker.flex import FlexCalibration  # noqa: E402

from ...json_text import ANY, dumps  # noqa: E402
from ...unavailable import unavailable  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]
DT = 1 / 60
SHOWN = "~/.config/energyball"
KNOWN = [f.name for f in dataclasses.fields(Preferences)]


def key(k):
    return pygame.event.Event(pygame.KEYDOWN, key=k, mod=0, unicode="")


def snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


@pytest.fixture
def config(tmp_path, monkeypatch):
    """~/.config/energyball under a throwaway HOME."""
    home = tmp_path / "home"
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.delenv("XDG_CONFIG_HOME", raising=False)
    folder = home / ".config" / "energyball"
    folder.mkdir(parents=True)
    assert P.config_dir() == folder
    return folder


@pytest.fixture
def start(capsys):
    """Start the real app as ``energyball --keyboard`` does (its files from HOME); closed afterwards."""
    apps = []

    def _start() -> tuple[App, list[str]]:
        app = App(input_choice="keyboard", seed=1)
        apps.append(app)
        app.frame([], DT)  # the menu is drawn, notices and all
        lines = capsys.readouterr().err.splitlines()
        return app, lines

    yield _start
    for app in apps:
        app.close()


def game_over(app: App) -> None:
    """Lose the round now: the game-over screen saves the score and draws the table."""
    app.game.new_round()
    arena = app.game.arena
    arena.player.health = 0.5
    arena.zombies.append(Zombie(999, arena.player.x + 0.3, arena.player.y, speed=0.5, health=3, phase=0.0))
    app.screen = Play(app.game)
    for _ in range(600):
        app.frame([], DT)
        if isinstance(app.screen, GameOver):
            return
    raise AssertionError("the round did not end")


# ----------------------------------------------------------------- settings.json


@pytest.mark.parametrize("bad", ['"high"', "null", "200", "5", "NaN", "Infinity", "-Infinity", "1e400",
                                 "true", "[55]", "9" * 400])
def test_a_bad_raise_deg_falls_back_alone_with_a_notice(config, start, bad):
    text = f'{{"side": "left", "raise_deg": {bad}, "volume": 0.3}}'
    (config / "settings.json").write_text(text)
    app, err = start()
    assert (app.game.prefs.raise_deg, app.game.prefs.side, app.game.prefs.volume) == (55.0, "left", 0.3)
    assert app.game.gestures.settings.raise_deg == 55.0
    notice = f"{SHOWN}/settings.json: raise_deg must be a number from 20 to 120"
    assert [n for n in app.game.notices if n.startswith(notice)] and len(err) == 1 and notice in err[0]
    assert err[0].endswith("; using 55.0 (a copy is kept as settings.json.damaged before the game saves over it)")
    assert snapshot(config) == {"settings.json": text.encode()}  # loading wrote nothing


def test_true_is_not_a_number_and_every_bad_key_is_named(config, start):
    text = '{"flex_off_deg": true, "fullscreen": 1, "side": "up", "player": "", "input": "a\\u0000b", "x": 1}'
    (config / "settings.json").write_text(text)
    app, err = start()
    assert app.game.prefs == Preferences(input="keyboard")  # --keyboard; every other value its default
    named = [line.split(": ")[2].split(" ")[0] for line in err]
    assert named == ["input", "side", "fullscreen", "flex_off_deg", "player", "unknown"]
    assert "flex_off_deg must be a number from 5 to 110 (elbow flex in degrees), not True" in err[3]
    assert "fullscreen must be true or false, not 1" in err[2]


def test_a_player_name_that_is_not_text_does_not_kill_the_game_over_screen(config, start):
    (config / "settings.json").write_text('{"player": 5}')
    app, err = start()
    assert app.game.prefs.player == "Player" and "player must be text of 1 to 40" in err[0]
    game_over(app)
    app.frame([], DT)  # draws the table
    saved = json.loads((config / "scores.json").read_text())
    assert [s["name"] for s in saved] == ["Player"]


@pytest.mark.parametrize("on, off, notice", [
    (170, 160, "flex_on_deg must be a number from 15 to 120"),
    (60, 55, "flex_off_deg (55) must be at least 10 below flex_on_deg (60); using 55 and 25"),
    (20, 25, "flex_off_deg (25) must be at least 10 below flex_on_deg (20)"),
])
def test_a_bad_flex_pair_is_not_accepted_and_the_menu_never_makes_one(config, start, on, off, notice):
    text = json.dumps({"flex_on_deg": on, "flex_off_deg": off, "side": "left"})
    (config / "settings.json").write_text(text)
    app, err = start()
    p = app.game.prefs
    assert (p.flex_on_deg, p.flex_off_deg, p.side) == (55.0, 25.0, "left") and any(notice in e for e in err)
    app.frame([key(pygame.K_DOWN), key(pygame.K_DOWN), key(pygame.K_RETURN)], DT)  # Settings
    assert isinstance(app.screen, Settings)
    app.frame([key(pygame.K_DOWN), key(pygame.K_DOWN)], DT)  # "Launch flex"
    seen = set()
    for k in [pygame.K_RIGHT] * 20 + [pygame.K_LEFT] * 30 + [pygame.K_d] * 3:
        app.frame([key(k)], DT)
        p = app.game.prefs
        assert 15.0 <= p.flex_on_deg <= 120.0 and p.flex_off_deg + FLEX_GAP_DEG <= p.flex_on_deg
        seen.add(p.flex_on_deg)
    assert min(seen) == 35.0 and max(seen) == 120.0  # flex-off 25 + the 10-degree gap; the top of the range
    app.frame([key(pygame.K_ESCAPE)], DT)  # save and back
    assert isinstance(app.screen, Menu)
    assert (config / "settings.json.damaged").read_text() == text  # what the user wrote is kept
    assert load_preferences(config) == (app.game.prefs, [])


@settings(derandomize=True, max_examples=300)
@given(st.floats(5.0, 110.0), st.floats(0.0, 100.0), st.lists(st.sampled_from([-1, 1]), max_size=60))
def test_stepping_flex_on_from_any_valid_pair_stays_valid(off, gap, steps):
    p = Preferences(flex_off_deg=off, flex_on_deg=min(120.0, off + FLEX_GAP_DEG + gap))
    for step in steps:
        p = P.step_flex_on(p, step)  # Preferences() checks the pair on construction
        assert p.flex_off_deg == off and p.flex_off_deg + FLEX_GAP_DEG <= p.flex_on_deg <= 120.0


def test_an_input_choice_no_setting_can_hold_is_a_notice_not_a_crash(config, capsys):
    app = App(input_choice="x" * 300, seed=1)
    try:
        assert app.game.prefs.input == "auto" and app.game.source == "keyboard"
        assert any(n.startswith("input must be text of 1 to 200 printable characters") and n.endswith(
            "; using 'auto'") for n in app.game.notices)
    finally:
        app.close()


# ----------------------------------------------------------------- scores.json

GOOD = [{"name": "Ada", "score": 900, "wave": 4, "date": "2024-05-01"},
        {"name": "Bo", "score": 300, "wave": 2, "date": "2024-05-02"}]


def test_a_score_of_infinity_is_dropped_alone_and_the_file_kept_before_it_is_replaced(config, start):
    text = json.dumps(GOOD[:1])[:-1] + ', {"name": "Cy", "score": Infinity, "wave": 3, "date": "x"}, ' \
        + json.dumps(GOOD[1]) + "]"
    (config / "scores.json").write_text(text)
    app, err = start()
    assert [s.name for s in app.game.scores] == ["Ada", "Bo"]
    assert err == [f"energyball: {SHOWN}/scores.json: 1 of 3 entries damaged and dropped (entry 2: score must "
                   f"be a whole number from 0 to 1000000000000 (points), not Infinity) (a copy is kept as "
                   f"scores.json.damaged before the game saves over it)"]
    assert snapshot(config) == {"scores.json": text.encode()}
    game_over(app)
    assert (config / "scores.json.damaged").read_text() == text
    saved = json.loads((config / "scores.json").read_text())
    assert [s["name"] for s in saved] == ["Ada", "Bo", "Player"]
    assert load_scores(config)[1] == []  # the new table is clean: the next save keeps no copy


def test_copies_of_damaged_files_never_overwrite_each_other(config):
    (config / "scores.json.damaged").write_text("an older copy")
    (config / "scores.json").write_text("{oops")
    scores, notices = load_scores(config)
    assert scores == [] and "not valid JSON" in notices[0]
    P.add_score(scores, Score("Ada", 5, 1), config)
    P.add_score([], Score("Bo", 6, 1), config)  # the file is clean now: no third copy
    assert snapshot(config) == {"scores.json": (config / "scores.json").read_bytes(),
                                "scores.json.damaged": b"an older copy", "scores.json.damaged.2": b"{oops"}


def test_a_scores_path_that_is_not_a_file_is_never_replaced(config, start):
    (config / "scores.json").mkdir()
    app, err = start()
    assert app.game.scores == [] and "scores.json: not a regular file" in err[0]
    game_over(app)
    assert (config / "scores.json").is_dir()
    assert any(n.startswith("could not save the high scores: ~/.config/energyball/scores.json is not a regular")
               for n in app.game.notices)


# ----------------------------------------------------------------- the folder itself


def test_a_config_folder_that_is_a_file_means_defaults_and_nothing_saved(config, start):
    config.rmdir()
    config.write_text("not a folder")
    app, err = start()
    assert app.game.prefs == Preferences(input="keyboard") and app.game.scores == []
    assert f"{SHOWN} is not a folder: settings and high scores will not be saved" in err[-1]
    assert "cannot be read (Not a directory)" in err[0]
    app.frame([key(pygame.K_DOWN), key(pygame.K_DOWN), key(pygame.K_RETURN)], DT)  # Settings
    app.frame([key(pygame.K_ESCAPE)], DT)  # save and back: refused
    game_over(app)
    assert [n.split(":")[0] for n in app.game.notices[-2:]] == ["could not save the settings",
                                                                "could not save the high scores"]
    assert config.read_text() == "not a folder"


def test_permission_denied_is_a_notice_also_where_root_would_not_get_it(config, start, monkeypatch):
    """Root bypasses chmod 000: the errors a user would get are given to the app instead."""
    (config / "settings.json").write_text('{"side": "left"}')

    def denied(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(P, "read_json", denied)
    monkeypatch.setattr(P, "atomic_write", denied)
    monkeypatch.setattr(P.os, "access", lambda *args, **kwargs: False)
    app, err = start()
    assert app.game.prefs == Preferences(input="keyboard")
    assert err == [f"energyball: {SHOWN}/settings.json cannot be read (Permission denied); using the default "
                   f"settings",
                   f"energyball: {SHOWN}/scores.json cannot be read (Permission denied); starting a new "
                   f"high-score table",
                   f"energyball: {SHOWN} cannot be written: settings and high scores will not be saved"]
    game_over(app)
    assert app.game.notices[-1] == "could not save the high scores: [Errno 13] Permission denied"
    assert (config / "settings.json").read_text() == '{"side": "left"}'


# ----------------------------------------------------------------- the real command

QUIT_AT_ONCE = """
import sys
import pygame
import game.ui.app
run = game.ui.app.App.run
def quit_at_once(self):  # as if the window were closed at the first frame
    pygame.event.post(pygame.event.Event(pygame.QUIT))
    return run(self)
game.ui.app.App.run = quit_at_once
from game.__main__ import main
sys.exit(main(sys.argv[1:]))
"""


def test_energyball_starts_on_damaged_files_and_says_so(tmp_path):
    folder = tmp_path / ".config" / "energyball"
    folder.mkdir(parents=True)
    (folder / "settings.json").write_text('{"raise_deg": NaN, "flex_on_deg": 170, "flex_off_deg": 160}')
    (folder / "scores.json").write_text('[{"name": "Ada", "score": 1e999, "wave": 1, "date": "x"}]')
    before = snapshot(folder)
    env = {**os.environ, "HOME": str(tmp_path), "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy"}
    env.pop("XDG_CONFIG_HOME", None)
    r = subprocess.run([sys.executable, "-c", QUIT_AT_ONCE, "--keyboard"], capture_output=True, text=True,
                       env=env, cwd=ROOT, timeout=120)
    assert r.returncode == 0 and "Traceback" not in r.stderr
    lines = [line for line in r.stderr.splitlines() if line.startswith("energyball: ")]
    assert [line.split(": ")[2].split(" ")[0] for line in lines] == [
        "raise_deg", "flex_on_deg", "flex_off_deg", "1"]
    assert "not 1e999" in lines[3]
    assert snapshot(folder) == before


def test_an_unreadable_config_folder_means_defaults_and_nothing_saved(tmp_path):
    """``chmod 000 ~/.config/energyball``, through the real command. Root's capabilities to read
    and write past permissions (CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH) are dropped for the game
    (setpriv), so root meets the folder as its owner would."""
    as_owner = []
    if os.geteuid() == 0:
        if not shutil.which("setpriv"):
            unavailable("setpriv (util-linux) is needed to drop root's file capabilities", "util-linux is required")
        caps = "-dac_override,-dac_read_search"
        as_owner = ["setpriv", f"--bounding-set={caps}", f"--inh-caps={caps}"]
    folder = tmp_path / ".config" / "energyball"
    folder.mkdir(parents=True)
    (folder / "settings.json").write_text('{"side": "left"}')
    folder.chmod(0)
    try:
        env = {**os.environ, "HOME": str(tmp_path), "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy"}
        env.pop("XDG_CONFIG_HOME", None)
        r = subprocess.run([*as_owner, sys.executable, "-c", QUIT_AT_ONCE, "--keyboard"], capture_output=True,
                           text=True, env=env, cwd=ROOT, timeout=120)
    finally:
        folder.chmod(0o755)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    lines = [line for line in r.stderr.splitlines() if line.startswith("energyball: ")]
    assert "settings.json cannot be read (Permission denied); using the default settings" in lines[0]
    assert lines[-1].endswith("cannot be written: settings and high scores will not be saved")
    assert sorted(p.name for p in folder.iterdir()) == ["settings.json"]
    assert (folder / "settings.json").read_text() == '{"side": "left"}'


# ----------------------------------------------------------------- random files




SETTINGS = st.dictionaries(st.sampled_from(KNOWN) | st.text(max_size=6),
                           ANY | st.floats(0, 130) | st.sampled_from(["left", "right", "auto"]), max_size=9)
SCORE = st.fixed_dictionaries({"name": st.text(max_size=45) | ANY, "score": st.integers(-5, 10**13) | ANY,
                               "wave": st.integers(-1, 10) | ANY, "date": st.text(max_size=8) | ANY})
SCORES = st.lists(SCORE | ANY, max_size=6)
TEXTS = (st.one_of(SETTINGS, SCORES, ANY).map(dumps)
         | st.binary(max_size=80) | st.text(st.sampled_from('[]{}":,0123456789NaI -e'), max_size=60))


def load_quietly(loader, name: str, content) -> tuple[object, list[str], dict[str, bytes], dict[str, bytes]]:
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        (folder / name).write_bytes(content if isinstance(content, bytes) else content.encode())
        before = snapshot(folder)
        value, notices = loader(folder)
        return value, notices, before, snapshot(folder)


@settings(derandomize=True, max_examples=300)
@given(TEXTS)
def test_any_settings_file_loads_as_valid_settings_and_changes_nothing(content):
    prefs, notices, before, after = load_quietly(load_preferences, "settings.json", content)
    assert after == before and isinstance(prefs, Preferences) and Preferences(**dataclasses.asdict(prefs)) == prefs
    assert all("settings.json" in n and "\n" not in n for n in notices)
    data = json.loads(content) if isinstance(content, str) and not notices else None
    if data is not None:  # loaded cleanly: every known key holds the file's value
        assert all(getattr(prefs, k) == data[k] for k in KNOWN if k in data)


@settings(derandomize=True, max_examples=300)
@given(TEXTS)
def test_any_scores_file_loads_as_a_valid_table_and_changes_nothing(content):
    scores, notices, before, after = load_quietly(load_scores, "scores.json", content)
    assert after == before and len(notices) <= 1 and all("\n" not in n for n in notices)
    assert len(scores) <= P.MAX_SCORES and [s.score for s in scores] == sorted((s.score for s in scores),
                                                                                reverse=True)
    assert all(Score(**dataclasses.asdict(s)) == s for s in scores)
    if not notices and isinstance(content, str) and content.strip():  # clean: every entry kept (best ten)
        assert len(scores) == min(P.MAX_SCORES, len(json.loads(content)))


# ----------------------------------------------------------------- simulated players' profiles (case 10)

BAD_PROFILES = {
    "400 digits": '{"speed": ' + "9" * 400 + "}",
    "nested 100000 deep": '{"speed":' * 100_000 + "1" + "}" * 100_000,
    "NaN": '{"speed": NaN}',
    "true": '{"speed": true}',
    "not UTF-8": b'{"speed": "\xff"}',
    "a list": "[1, 2]",
}


@pytest.mark.parametrize("command", [["--headless"], ["gestures-eval"]])
@pytest.mark.parametrize("name", list(BAD_PROFILES))
def test_a_bad_profile_is_one_line_and_exit_1(tmp_path, command, name):
    path = tmp_path / "bad.json"
    content = BAD_PROFILES[name]
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    r = subprocess.run([sys.executable, "-m", "game", *command, "--profile", str(path)], capture_output=True,
                       text=True, cwd=ROOT, timeout=120, env={**os.environ, "HOME": str(tmp_path)})
    assert r.returncode == 1 and r.stdout == ""
    assert len(r.stderr.splitlines()) == 1 and r.stderr.startswith(f"energyball: {path}: ")
    assert path.read_bytes() == (content if isinstance(content, bytes) else content.encode())


def test_a_profile_that_is_a_fifo_or_a_folder_is_refused_without_waiting(tmp_path):
    os.mkfifo(tmp_path / "fifo.json")  # no writer: reading it would block forever
    for path in (tmp_path / "fifo.json", tmp_path):
        r = subprocess.run([sys.executable, "-m", "game", "gestures-eval", "--profile", str(path)],
                           capture_output=True, text=True, cwd=ROOT, timeout=120)
        assert r.returncode == 1 and r.stderr == f"energyball: {path}: not a regular file\n"


PROFILE_KEYS = [f.name for f in dataclasses.fields(PlayerProfile)]
PROFILES = st.dictionaries(st.sampled_from(PROFILE_KEYS) | st.text(max_size=6),
                           ANY | st.floats(-1e3, 1e7), max_size=6)


@settings(derandomize=True, max_examples=300)
@given(st.one_of(PROFILES.map(dumps), TEXTS))
def test_any_profile_file_is_a_profile_or_one_value_error_and_is_not_changed(content):
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "p.json"
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
        try:
            profile = PlayerProfile.load(path)
        except ValueError as e:
            assert str(e).startswith(f"{path}: ") and "\n" not in str(e)
        else:
            assert PlayerProfile.from_json(profile.to_json()) == profile
        assert snapshot(Path(d)) == {"p.json": path.read_bytes()} and path.read_bytes() == (
            content if isinstance(content, bytes) else content.encode())


def player_file(changes: dict) -> str:
    """Ada's profile with some fields replaced (by random values), as JSON text."""
    data = Player("Ada", flex=FlexCalibration.paper()).to_json()
    for dotted, value in changes.items():
        owner, _, leaf = dotted.rpartition(".")
        target = data
        for part in filter(None, owner.split(".")):
            if not isinstance(target.get(part), dict):
                target[part] = {}
            target = target[part]
        target[leaf] = value
    return dumps(data)


PLAYER_FIELDS = ["name", "format", "version", "body", "wearing", "flex", "body.side", "body.height_m",
                 "body.upper_arm_m", "body.extra", "wearing.mount", "wearing.init", "flex.adc_straight",
                 "flex.bent_deg", "flex.curve"]
PLAYERS = st.dictionaries(st.sampled_from(PLAYER_FIELDS), ANY | st.lists(st.floats(-2, 2), max_size=5),
                          max_size=3).map(player_file)


@settings(derandomize=True, max_examples=300)
@given(st.one_of(PLAYERS, TEXTS))
def test_any_player_file_is_a_player_or_one_profile_error_and_is_not_changed(content):
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "Ada.json"
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
        try:
            player = players.load("Ada", Path(d))
        except ProfileError as e:
            assert str(e).startswith(f"{path}") and "\n" not in str(e)
        else:
            assert Player.from_json(json.loads(json.dumps(player.to_json()))) == player
        assert snapshot(Path(d)) == {"Ada.json": content if isinstance(content, bytes) else content.encode()}


def test_player_profiles_refuse_what_numpy_or_float_would_take_by_hand(tmp_path):
    good = Player("Ada").to_json()
    for change, words in [({"body": {**good["body"], "upper_arm_m": True}}, "body.upper_arm_m must be a number"),
                          ({"wearing": {"mount": ["1", 0, 0, 0], "init": [1, 0, 0, 0]}}, "unit quaternion"),
                          ({"wearing": [1, 0, 0, 0]}, "wearing must be an object"),
                          ({"name": 5}, "player name")]:
        (tmp_path / "Ada.json").write_text(json.dumps({**good, **change}))
        with pytest.raises(ProfileError, match=words):
            players.load("Ada", tmp_path)
    with pytest.raises(ProfileError, match="is not a player name"):
        players.load("../Ada", tmp_path)
