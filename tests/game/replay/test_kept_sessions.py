"""The newest sessions kept as recordings (the ``keep_sessions`` setting)."""

import os
from types import SimpleNamespace

import pytest

from game.replay.log import SessionRecorder
from game.ui.preferences import Preferences
from game.ui.session_events import keep_session, recordings_dir


def game(keep, tmp_path):
    return SimpleNamespace(prefs=Preferences(keep_sessions=keep), notices=[], seed=1, window=(640, 360),
                           boards_folder=lambda: tmp_path / "boards")


@pytest.fixture
def data_home(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    return tmp_path / "data" / "energyball" / "recordings"


def test_the_newest_sessions_are_kept_and_the_oldest_go(tmp_path, data_home):
    assert recordings_dir() == data_home
    data_home.mkdir(parents=True)
    for k in range(12):  # sessions of earlier days, oldest first
        old = data_home / f"session-202611{k + 10:02d}-120000.ebs"
        old.write_bytes(b"old")
        os.utime(old, (1_700_000_000 + k, 1_700_000_000 + k))
    (data_home / "notes.txt").write_text("mine")
    log = keep_session(game(10, tmp_path))
    assert isinstance(log, SessionRecorder)
    log.close({})
    names = sorted(p.name for p in data_home.iterdir())
    assert "notes.txt" in names and len([n for n in names if n.startswith("session-")]) == 10
    assert "session-20261121-120000.ebs" in names and "session-20261112-120000.ebs" not in names  # newest 9 + this
    assert log.writer.path.name in names


def test_keeping_none_records_nothing(tmp_path, data_home):
    assert keep_session(game(0, tmp_path)) is None
    assert not data_home.exists()


def test_a_folder_that_cannot_be_made_is_a_notice_and_the_game_plays_on(tmp_path, monkeypatch):
    blocker = tmp_path / "data"
    blocker.write_text("a file where the folder should be")
    monkeypatch.setenv("XDG_DATA_HOME", str(blocker))
    g = game(10, tmp_path)
    assert keep_session(g) is None
    assert len(g.notices) == 1 and "not kept" in g.notices[0]


def test_keep_sessions_out_of_range_is_refused_in_one_line():
    with pytest.raises(ValueError) as e:
        Preferences(keep_sessions=-1)
    assert "keep_sessions must be a whole number from 0 to 1000" in str(e.value)
