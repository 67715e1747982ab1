"""Player profiles: saved atomically, loaded by name, clear errors."""

import json

import pytest

from game.body.avatar import BodySettings, Wearing
from game.body.players import Player, ProfileError, load, load_or_new, names, save
from tracker.flex import FlexCalibration


def test_round_trip_keeps_everything(tmp_path):
    player = Player("Ada", BodySettings(side="left", upper_arm_m=0.33, mounting="paper45"),
                    Wearing((0.5, 0.5, 0.5, 0.5), (0.0, 0.0, 0.0, 1.0)),
                    FlexCalibration.paper())
    path = save(player, tmp_path)
    assert path.name == "Ada.json" and [p.name for p in tmp_path.iterdir()] == ["Ada.json"]
    assert load("Ada", tmp_path) == player
    assert names(tmp_path) == ["Ada"]


def test_missing_or_broken_profiles_are_clear(tmp_path):
    with pytest.raises(ProfileError, match="no profile named 'Bob'"):
        load("Bob", tmp_path)
    (tmp_path / "Bob.json").write_text("{not json")
    with pytest.raises(ProfileError, match="damaged"):
        load("Bob", tmp_path)
    good = Player("Bob").to_json()
    good["body"]["side"] = "middle"
    (tmp_path / "Bob.json").write_text(json.dumps(good))
    with pytest.raises(ProfileError, match="side must be"):
        load("Bob", tmp_path)
    player, notice = load_or_new("Bob", tmp_path)
    assert player == Player("Bob") and "starting with defaults" in notice


def test_bad_names_are_refused():
    for bad in ("", "../etc/passwd", "a" * 41, ".hidden"):
        with pytest.raises(ProfileError, match="player name"):
            Player(bad)


def test_a_non_unit_quaternion_is_refused(tmp_path):
    data = Player("Cy").to_json()
    data["wearing"]["init"] = [2, 0, 0, 0]
    (tmp_path / "Cy.json").write_text(json.dumps(data))
    with pytest.raises(ProfileError, match="unit quaternion"):
        load("Cy", tmp_path)
