"""Player profiles: the issue's keys and ranges, clear errors, and the catalogue that ships."""

import json
import os
import tomllib
from dataclasses import fields
from pathlib import Path

import pytest

from game.sim.motion_model import PROFILES_DIR, PlayerProfile, catalogue, catalogue_descriptions

# The issue's table ("Player profile keys"), written out here as the independent truth.
NEW_KEYS = {
    "tremor_deg": (0, 2), "tremor_hz": (3, 12), "sway_deg": (0, 4), "wobble_deg": (0, 6),
    "wobble_hz": (5, 25), "twist_follow": (0.4, 1.0), "slip_deg_per_min": (0, 4),
    "flex_hysteresis_pct": (0, 12), "flex_creep_pct": (0, 12), "gyro_warmup_dps": (0, 4),
    "mag_hard_iron_ut": (0, 200), "mag_soft_iron_pct": (0, 20), "mag_disturbance_ut": (0, 40),
}
OLD_KEYS = ("upper_arm_m", "forearm_m", "mount_roll_deg", "mount_pitch_deg", "flex_straight_ohm",
            "flex_bent_ohm", "gyro_bias_dps", "noise_scale", "speed")


def test_the_profile_has_exactly_the_issues_keys():
    assert {f.name for f in fields(PlayerProfile)} == set(NEW_KEYS) | set(OLD_KEYS)


@pytest.mark.parametrize("key", sorted(NEW_KEYS))
def test_each_new_key_takes_its_range_and_refuses_outside_it_in_one_line(key):
    low, high = NEW_KEYS[key]
    for value in (low, high, (low + high) / 2):
        assert getattr(PlayerProfile.from_json({key: value}), key) == value
    for bad in (low - 0.01, high + 0.01, float("nan"), "1", None, True):
        with pytest.raises(ValueError) as e:
            PlayerProfile.from_json({key: bad})
        message = str(e.value)
        assert key in message and f"{low:g}" in message and f"{high:g}" in message
        assert "\n" not in message


def test_missing_keys_are_the_typical_player():
    assert PlayerProfile.from_json({}) == PlayerProfile()
    p = PlayerProfile.from_json({"tremor_hz": 5.0})
    assert p.tremor_hz == 5.0
    assert all(getattr(p, k) == getattr(PlayerProfile(), k) for k in NEW_KEYS if k != "tremor_hz")
    typical = PlayerProfile()
    for key, (low, high) in NEW_KEYS.items():
        assert low <= getattr(typical, key) <= high


def test_every_catalogue_file_loads_and_has_a_description():
    players = catalogue()
    files = sorted(f[:-5] for f in os.listdir(PROFILES_DIR) if f.endswith(".json"))
    assert list(players) == files and len(players) >= 9
    descriptions = catalogue_descriptions()
    assert list(descriptions) == files
    assert all(d and "|" not in d for d in descriptions.values())
    for name in files:
        with open(os.path.join(PROFILES_DIR, name + ".json"), encoding="utf-8") as f:
            data = json.load(f)
        assert set(data) <= set(NEW_KEYS) | set(OLD_KEYS)  # profile keys only, no description
        assert PlayerProfile.load(os.path.join(PROFILES_DIR, name + ".json")) == players[name]


def test_the_catalogue_holds_the_issues_players_and_spans_the_ranges():
    players = catalogue()
    assert players["typical"] == PlayerProfile()
    assert (players["essential_tremor"].tremor_deg, players["essential_tremor"].tremor_hz) == (1.0, 5.0)
    assert 8 <= players["physiological_tremor"].tremor_hz <= 12
    assert players["slow_elderly"].speed < 1 < players["fast"].speed
    loose = players["loose_strap"]
    typical = players["typical"]
    assert loose.wobble_deg > typical.wobble_deg and loose.twist_follow < typical.twist_follow
    assert loose.slip_deg_per_min > typical.slip_deg_per_min
    warm = players["warming_board"]
    assert warm.gyro_warmup_dps > typical.gyro_warmup_dps and warm.gyro_bias_dps > typical.gyro_bias_dps
    room = players["magnetic_room"]
    assert room.mag_disturbance_ut > typical.mag_disturbance_ut and room.mag_hard_iron_ut > typical.mag_hard_iron_ut
    for key, (low, high) in NEW_KEYS.items():  # from the low quarter to the high one of every range
        values = [getattr(p, key) for p in players.values()]
        assert min(values) <= low + 0.25 * (high - low) and max(values) >= high - 0.25 * (high - low), key


def test_the_catalogue_ships_with_the_package():
    # The project's own pyproject.toml (beside tests/), wherever the package under test is installed.
    with open(Path(__file__).resolve().parents[3] / "pyproject.toml", "rb") as f:
        data = tomllib.load(f)["tool"]["setuptools"]["package-data"]["game"]
    assert "profiles/*.json" in data and "profiles/README.md" in data
