"""Session recordings through the real app (dummy video driver): a played session replays to the same game."""

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pygame
import pytest

from game.replay.replay import replay
from game.replay.samples import SAMPLES, unpack
from game.ui.app import App
from game.ui.preferences import Preferences
from game.replay.log import SessionRecorder
from game.ui.session_events import session_header
from tracker.session_recording import BinaryRecord, SessionReader, SessionWriter

from ...commands import env_for

DT = 1 / 60


def key(k, down=True):
    return pygame.event.Event(pygame.KEYDOWN if down else pygame.KEYUP, key=k, mod=0, unicode="")


def mouse(x, y):
    return pygame.event.Event(pygame.MOUSEMOTION, pos=(x, y), rel=(0, 0), buttons=(0, 0, 0))


def player_script(seed: int, frames: int) -> dict[int, list]:
    """A keyboard player: Enter through the menu, then raise (R), aim (mouse), flex (F) and
    straighten at seeded moments, walking now and then (W, A)."""
    rng = np.random.default_rng(seed)
    script: dict[int, list] = {5: [key(pygame.K_RETURN)]}
    at = 60
    while at < frames - 120:
        x, y = int(rng.integers(100, 540)), int(rng.integers(60, 300))
        script.setdefault(at, []).extend([key(pygame.K_r), mouse(x, y)])
        script.setdefault(at + 30, []).append(key(pygame.K_f))
        script.setdefault(at + 30 + int(rng.integers(25, 60)), []).append(key(pygame.K_f, down=False))
        script.setdefault(at + 100, []).append(key(pygame.K_r, down=False))
        walk = pygame.K_w if rng.random() < 0.5 else pygame.K_a
        script.setdefault(at + 105, []).append(key(walk))
        script.setdefault(at + 125, []).append(key(walk, down=False))
        at += int(rng.integers(130, 200))
    return script


class Witness(SessionRecorder):
    """A recorder that also keeps what the live game did (the truth a replay is held to)."""

    def __init__(self, path, header):
        super().__init__(path, header)
        self.seen = []

    def _write(self, record):
        if record["type"] == "happened":
            self.seen.append(record)
        super()._write(record)


def play(path: Path, config: Path, source: str, frames: int, paced: bool = False) -> dict:
    """Play a scripted session in the real app, recording it; the live game's score and events."""
    witness: list[Witness] = []

    def session(game):
        witness.append(Witness(path, session_header(game, game.prefs.input)))
        return witness[0]

    app = App(Preferences(input=source, volume=0.0, music_volume=0.0), config_dir=config, seed=11,
              size=(640, 360), draws=False, session=session)
    script = player_script(4, frames)
    for i in range(frames):
        app.frame(script.get(i, []), DT, draw=False)
        if paced:  # a board in real time: samples arrive as the frames go
            time.sleep(DT)
    live = {"score": app.game.arena.score, "kills": app.game.arena.kills}
    app.close()
    return {**live, "events": witness[0].seen}


@pytest.fixture(scope="module")
def keyboard_session(tmp_path_factory):
    folder = tmp_path_factory.mktemp("kb")
    path = folder / "kb.ebs"
    live = play(path, folder, "keyboard", 2400)
    return path, live


def test_a_keyboard_session_replays_to_the_same_events_and_score(keyboard_session):
    path, live = keyboard_session
    report = replay(path)
    assert report.difference is None and report.stopped is None
    assert report.events == live["events"] and len(live["events"]) > 20
    assert any(g[0] == "launch" for e in live["events"] for g in e["gestures"])  # the player threw
    assert (report.summary["score"], report.summary["kills"]) == (live["score"], live["kills"])


def test_replaying_twice_gives_byte_identical_json(keyboard_session):
    path, _ = keyboard_session
    assert json.dumps(replay(path).to_json()) == json.dumps(replay(path).to_json())


@pytest.fixture(scope="module")
def virtual_session(tmp_path_factory):
    folder = tmp_path_factory.mktemp("virtual")
    path = folder / "virtual.ebs"
    return path, play(path, folder, "virtual", 600, paced=True)


def test_a_virtual_board_session_replays_to_the_same_events(virtual_session):
    path, live = virtual_session
    report = replay(path)
    assert report.difference is None
    assert report.events == live["events"]
    assert (report.summary["score"], report.summary["kills"]) == (live["score"], live["kills"])
    assert any(g[0] == "launch" for e in live["events"] for g in e["gestures"])  # the virtual player threw
    samples = sum(len(unpack(r.data)) for r in SessionReader(path).records()
                  if isinstance(r, BinaryRecord) and r.channel == SAMPLES)
    assert samples >= 1000  # some 10 s of the board at 200 Hz went into the game, and into the file


def test_a_changed_input_is_reported_as_a_difference(keyboard_session, tmp_path):
    """The comparison can fail: drop one F press from the recording and the replay says where it parts."""
    path, _ = keyboard_session
    source = SessionReader(path)
    changed = tmp_path / "changed.ebs"
    header = {k: v for k, v in source.header.items() if k not in ("format", "version", "records")}
    writer = SessionWriter(changed, header, source.header["records"])
    dropped = None
    for r in source.records():
        if isinstance(r, BinaryRecord):
            writer.binary(r.channel, r.t, r.data)
        elif r["type"] != "end":
            if r["type"] == "frame" and dropped is None and any(e.get("key") == pygame.K_f for e in r["events"]):
                dropped = r
                r = {**r, "events": [e for e in r["events"] if e.get("key") != pygame.K_f]}
            writer.json(r)
    writer.close()
    report = replay(changed)
    assert dropped is not None and report.difference is not None


def test_a_cut_off_recording_replays_its_complete_part_and_says_where_it_stopped(virtual_session, tmp_path):
    """A block a second: cut at 60% of the file, the replay plays the blocks before the cut, the same game."""
    path, live = virtual_session
    data = path.read_bytes()
    cut = tmp_path / "cut.ebs"
    cut.write_bytes(data[:int(len(data) * 0.6)])
    report = replay(cut)
    assert report.stopped and "complete before it" in report.stopped
    assert report.difference is None and 0 < len(report.events) < len(live["events"])
    assert report.events == live["events"][:len(report.events)]


def run_cli(*args, home):
    return subprocess.run([sys.executable, "-m", "game", *args], capture_output=True, text=True,
                          env=env_for(home), timeout=300)


def test_replay_on_the_command_line_prints_json(keyboard_session, tmp_path):
    path, live = keyboard_session
    r = run_cli("replay", str(path), "--headless", "--json", home=tmp_path)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["same_as_recorded"] and out["summary"]["score"] == live["score"]
    assert out["events"] == live["events"] and len(out["launches"]) >= 1


@pytest.mark.parametrize("content, words", [
    (b"", "not an EnergyBall session recording"),
    (b"EBRAW1\n{}\n", "not an EnergyBall session recording"),
    (b"EBSESSION1\n{\"format\": \"energyball-session\", \"version\": 9}\n", "version 9"),
])
def test_foreign_files_are_one_clear_line(tmp_path, content, words):
    path = tmp_path / "x.ebs"
    path.write_bytes(content)
    r = run_cli("replay", str(path), "--headless", home=tmp_path)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert words in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_a_headless_match_kept_with_record_dir_replays_to_its_own_report(tmp_path):
    from game.sim.headless import MatchConfig, run_match

    match = run_match(MatchConfig(seed=3, duration_s=40.0, record_dir=str(tmp_path)))
    report = replay(tmp_path / "match-3.ebs")
    assert report.difference is None and report.stopped is None
    assert (report.summary["score"], report.summary["kills"]) == (match["score"], match["kills"])
    out = report.to_json()
    assert len(out["launches"]) == match["detected_launches"] > 0
    assert [h["step"] for h in out["holds"]] == ["down", "forward"] and all(h["ok"] for h in out["holds"])
    assert out["holds"][0]["gyro_bias"]["ok"]  # the bot's hold gave the gyroscope's bias
    assert out["link"]["samples"] == match["frames_decoded"] and out["link"]["crc_errors"] == 0


def test_record_dir_on_the_command_line(tmp_path):
    r = run_cli("--headless", "--matches", "2", "--seed", "5", "--duration", "10", "--record-dir",
                str(tmp_path / "kept"), home=tmp_path)
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in (tmp_path / "kept").iterdir()) == ["match-5.ebs", "match-6.ebs"]
    bad = tmp_path / "a-file"
    bad.write_text("")
    r = run_cli("--headless", "--duration", "10", "--record-dir", str(bad), home=tmp_path)
    assert r.returncode == 1 and "--record-dir" in r.stderr and "Traceback" not in r.stderr


def pressing(window, monkeypatch, keys_at):
    """The window's keys posted as a player presses them: {game time: key}."""
    real_after = window.after

    def after(app, t):
        for at in sorted(a for a in keys_at if t >= a):
            pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=keys_at.pop(at), mod=0, unicode=""))
        return real_after(app, t)

    monkeypatch.setattr(window, "after", after)


def test_the_window_starts_where_asked_seeks_and_speeds_up_on_its_keys(keyboard_session, monkeypatch):
    """The viewer under the dummy driver: frames before --from are not drawn; Right skips 5 s
    undrawn; Up doubles the speed; Left asks to start again 5 s back (watch() then replays from there)."""
    from game.ui import replay_window as W

    path, _ = keyboard_session
    monkeypatch.setattr(W.time, "sleep", lambda s: None)  # no pacing: the test runs as fast as it can
    window = W.ReplayWindow(path, start_s=10.0)
    drawn = []
    real_show = window._show
    monkeypatch.setattr(window, "_show", lambda app, picture, t: (drawn.append(t), real_show(app, picture, t)))
    pressing(window, monkeypatch, {11.0: pygame.K_RIGHT, 17.0: pygame.K_UP, 18.0: pygame.K_LEFT})
    report = W.replay(path, window)
    assert min(drawn) >= 10.0 and not any(11.05 < t < 16.0 for t in drawn)  # 11 -> 16 skipped, undrawn
    assert window.speed == 2.0 and window.restart_at == pytest.approx(max(drawn) - 5.0, abs=0.05)
    assert report.difference is None


def test_esc_ends_the_window_early(keyboard_session, monkeypatch):
    from game.ui import replay_window as W

    path, _ = keyboard_session
    monkeypatch.setattr(W.time, "sleep", lambda s: None)
    window = W.ReplayWindow(path)
    pressing(window, monkeypatch, {3.0: pygame.K_ESCAPE})
    report = W.replay(path, window)
    assert window.quit and report.t == pytest.approx(3.0, abs=0.05)


def test_rescoring_with_the_games_own_settings_changes_no_launch(virtual_session, tmp_path):
    from game.body.gestures import GestureSettings
    from game.replay.rescore import Rescorer

    path, _ = virtual_session
    rescorer = Rescorer(None, GestureSettings())
    replay(path, rescorer=rescorer)
    out = rescorer.compare()
    assert out["launches"] == out["other_launches"] > 0
    assert out["appeared"] == out["disappeared"] == out["moved"] == []


def test_rescoring_with_a_flex_on_no_keyboard_bend_reaches_loses_every_launch(keyboard_session, tmp_path):
    """Worked by hand: the keyboard bends the elbow to 100 deg (game.body.controls), so with flex-on
    at 110 no spin starts and every launch of the game disappears."""
    path, live = keyboard_session
    settings = tmp_path / "g.json"
    settings.write_text(json.dumps({"flex_on_deg": 110.0, "flex_off_deg": 25.0}))
    r = run_cli("replay", str(path), "--gestures", str(settings), "--json", "--plot", str(tmp_path / "p.png"),
                home=tmp_path)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)["rescored"]
    launches = sum(1 for e in live["events"] for g in e["gestures"] if g[0] == "launch")
    assert out["launches"] == launches > 0 and out["other_launches"] == 0
    assert len(out["disappeared"]) == launches and out["appeared"] == out["moved"] == []
    assert (tmp_path / "p.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_another_filter_accounts_for_every_launch(virtual_session):
    from game.replay.rescore import Rescorer

    path, _ = virtual_session
    rescorer = Rescorer("madgwick", None)
    replay(path, rescorer=rescorer)
    out = rescorer.compare()
    assert out["samples"] > 1000
    kept = out["launches"] - len(out["disappeared"])  # matched: moved or the same
    assert kept + len(out["appeared"]) == out["other_launches"] and len(out["moved"]) <= kept


def test_rescoring_with_the_default_filter_runs_the_games_own(virtual_session):
    """``--filter default`` is the filter as the game fuses with it (its accelerometer at the shoulder,
    the residual sensitivity learned, the MPU-9250's low-pass lead), not a bare default; it starts with
    play, without the hold's bias, so its launches are the game's, their aims a little off."""
    from game.body.tracking import Tracking
    from game.replay.rescore import Rescorer

    path, _ = virtual_session
    rescorer = Rescorer("default", None)
    replay(path, rescorer=rescorer)
    assert rescorer.tracking is not None and rescorer.tracking.filter.params == Tracking().filter.params
    out = rescorer.compare()
    assert out["launches"] == out["other_launches"] > 0 and out["appeared"] == out["disappeared"] == []
    assert all(m["aim_turned_deg"] < 2.0 for m in out["moved"])  # its one launch moved by 0.77 deg when written


@pytest.mark.parametrize("args, words", [
    (["--filter", "default"], "holds no board samples"),
    (["--gestures", "{missing}"], "No such file"),
    (["--gestures", "{bad}"], "flex_on_deg"),
])
def test_rescoring_mistakes_are_one_clear_line(keyboard_session, tmp_path, args, words):
    path, _ = keyboard_session
    (tmp_path / "bad.json").write_text(json.dumps({"flex_on_deg": "high"}))
    args = [a.format(missing=tmp_path / "none.json", bad=tmp_path / "bad.json") for a in args]
    r = run_cli("replay", str(path), *args, home=tmp_path)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert words in r.stderr and len(r.stderr.strip().splitlines()) == 1
