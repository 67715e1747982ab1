"""Headless matches end to end: bot -> simulator -> frames -> decoder -> filter -> game -> arena."""

import gc
import json
import subprocess
import sys

import pytest

from game.sim.headless import MatchConfig, run_match, run_matches
from game.sim.motion_model import catalogue
from tracker.board import Faults

SHORT = 40.0  # seconds of play: two waves


def _outcome(report: dict) -> dict:
    return {k: v for k, v in report.items() if k != "timing"}


@pytest.fixture(scope="module")
def normal_matches() -> list[dict]:
    return [run_match(MatchConfig(seed=seed, duration_s=SHORT)) for seed in (1, 2)]


def test_the_bot_kills_zombies_and_every_launch_is_seen_and_none_is_false(normal_matches):
    for r in normal_matches:
        assert r["kills"] >= 3 and r["hits"] >= r["kills"] and r["shots"] >= r["hits"]
        assert r["intended_launches"] >= 5
        assert r["launch_precision"] >= 0.98 and r["launch_recall"] >= 0.98
        assert r["false_launches"] == 0
        assert r["aim_error_deg_median"] < 3.0
        # a clean link: every frame the board sent was decoded
        assert r["frames_decoded"] == r["frames_sent"] and r["crc_errors"] == r["dropped"] == 0
        # in the town: walls push bodies out, so no step has one inside an obstacle
        assert r["obstacle_violations"] == 0 and r["wall_hits"] >= 0


def test_the_worst_plausible_player_calibrates_in_the_app_at_the_first_attempt():
    """The game's own calibration screen, the bot following it with the catalogue's worst player
    (2 deg tremor, 4 deg sway, a strap rocking 6 deg): its arm-down pose is judged over the hold's
    last second, as gestures-eval judges it. Over the whole hold, the filter that "hold still" runs
    again from a fresh state was still settling in its first half second, and 11 of 20 matches
    (seeds 0-19) failed their first attempt with "the arm moved 9-15 degrees" (seeds 1-4 here: 3)."""
    worst = catalogue()["worst_plausible"]
    reports = [run_match(MatchConfig(seed=seed, duration_s=1.0, profile=worst)) for seed in range(1, 5)]
    assert [r["calibration_failures"] for r in reports] == [0, 0, 0, 0]
    assert not any(r["abandoned"] for r in reports)


def test_the_same_seed_gives_the_same_match_and_another_seed_another(normal_matches):
    again = run_match(MatchConfig(seed=1, duration_s=SHORT))
    assert _outcome(again) == _outcome(normal_matches[0])
    assert _outcome(normal_matches[1]) != _outcome(normal_matches[0])
    assert normal_matches[1]["score"] != normal_matches[0]["score"]


def test_link_faults_are_counted_as_injected_and_cause_no_false_launch():
    r = run_match(MatchConfig(seed=4, duration_s=SHORT, faults=Faults.parse("corrupt=0.01,drop=0.002")))
    injected = r["injected"]
    assert injected["bytes_corrupted"] > 100 and injected["bytes_dropped"] > 20
    # Every whole frame is decoded. A damaged frame passes CRC-16 with a chance of 2^-16 (one or
    # two flipped bits never do; a lost byte shifts the rest): 0.05 of the ~3,200 damaged here
    # are expected through, and 3 or more come with a chance of 2e-5.
    slipped = r["frames_decoded"] - (r["frames_sent"] - injected["frames_damaged"])
    assert 0 <= slipped <= 2
    assert r["dropped"] == injected["frames_damaged"] - slipped  # every damaged frame lost is a sequence gap
    # A damaged frame whose header arrived whole fails its CRC; one with a damaged header may be
    # skipped before the CRC (a broken sync or length) or fail it (an unknown type).
    assert injected["damaged_header_intact"] - slipped <= r["crc_errors"] <= injected["frames_damaged"]
    assert r["false_launches"] == 0 and r["launch_recall"] >= 0.9
    assert r["survived_s"] > 0


def test_a_stall_skips_samples_without_a_sequence_gap():
    r = run_match(MatchConfig(seed=5, duration_s=10.0, faults=Faults.parse("stall=0.5@12")))
    assert r["injected"]["samples_stalled"] == 100  # 0.5 s at 200 Hz
    assert r["dropped"] == 0 and r["frames_decoded"] == r["frames_sent"]


def test_through_a_real_pty_and_with_drawing_the_match_is_the_same():
    quick = MatchConfig(seed=6, duration_s=8.0)
    plain = run_match(quick)
    assert _outcome(run_match(MatchConfig(seed=6, duration_s=8.0, pty=True))) == _outcome(plain)
    assert _outcome(run_match(MatchConfig(seed=6, duration_s=8.0, render=True))) == _outcome(plain)


def test_workers_give_the_same_results_in_the_same_order():
    configs = [MatchConfig(seed=s, duration_s=6.0) for s in (7, 8)]
    one, two = run_matches(configs, workers=1), run_matches(configs, workers=2)
    assert [_outcome(r) for r in one["matches"]] == [_outcome(r) for r in two["matches"]]
    assert {k: v for k, v in one["summary"].items() if k != "timing"} == \
        {k: v for k, v in two["summary"].items() if k != "timing"}


def test_command_line_prints_json_and_progress(tmp_path):
    out = subprocess.run([sys.executable, "-m", "game", "--headless", "--matches", "2", "--duration", "3",
                          "--seed", "3", "--json"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    report = json.loads(out.stdout)
    assert [m["seed"] for m in report["matches"]] == [3, 4]
    assert report["summary"]["matches"] == 2 and report["summary"]["timing"]["sim_speed"] > 0
    # A match's speed is its play's; its preparation (the maker's calibrations, the app) is timed apart,
    # and the run's wall clock holds both.
    for match in report["matches"]:
        timing = match["timing"]
        assert timing["prepare_s"] > 0
        assert timing["sim_speed"] == pytest.approx(match["duration_s"] / timing["wall_s"], rel=0.05)
    whole = report["summary"]["timing"]
    assert whole["prepare_s"] == pytest.approx(sum(m["timing"]["prepare_s"] for m in report["matches"]), abs=0.002)
    assert whole["wall_s"] >= sum(m["timing"]["prepare_s"] + m["timing"]["wall_s"] for m in report["matches"]) - 0.01
    assert "match 2/2" in out.stderr


@pytest.mark.parametrize("args, message", [
    (["--faults", "corrupt=2"], "bad fault 'corrupt=2'"),
    (["--faults", "melt=1"], "unknown fault 'melt'"),
    (["--faults", "corrupt=0.1,corrupt=0.2"], "given twice"),
    (["--difficulty", "insane"], "invalid choice"),
    (["--duration", "nan"], "--duration: must be a number above 0"),
    (["--seed", "-1"], "--seed: must be a whole number of at least 0"),
    (["--port", "/dev/null"], "--port do not go with --headless"),
    (["gestures-eval"], "--headless do not go with the gestures-eval command"),
])
def test_bad_settings_are_one_clear_line(args, message):
    out = subprocess.run([sys.executable, "-m", "game", "--headless", *args], capture_output=True, text=True,
                         timeout=60)
    assert out.returncode != 0 and message in out.stderr and "Traceback" not in out.stderr


def test_headless_options_without_headless_are_refused():
    out = subprocess.run([sys.executable, "-m", "game", "--matches", "3"], capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 1 and "only go with --headless" in out.stderr


def test_headless_options_before_another_command_are_refused_not_ignored():
    out = subprocess.run([sys.executable, "-m", "game", "--matches", "3", "--faults", "x", "gestures-eval"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 1 and "--matches, --faults do not go with the gestures-eval command" in out.stderr


def test_a_match_that_never_gets_past_setup_says_it_was_abandoned():
    heard: list[str] = []
    report = run_matches([MatchConfig(seed=1, duration_s=5.0, faults=Faults(drop_rate=1.0))], progress=heard.append)
    assert report["matches"][0]["abandoned"] and report["summary"]["abandoned"] == 1
    assert report["matches"][0]["survived_s"] == 0.0
    assert any("abandoned" in line for line in heard)


def test_a_finished_match_leaves_nothing_frozen_from_the_garbage_collector():
    """The app freezes what it made (fewer full collections); closing it must thaw that, or every
    match of a run stays in memory. The match collects less often; after it, as often as before."""
    before = gc.get_threshold()
    run_match(MatchConfig(seed=2, duration_s=1.0))
    assert gc.get_freeze_count() == 0
    assert gc.get_threshold() == before


def test_a_broken_profile_file_is_one_clear_line(tmp_path):
    bad = tmp_path / "p.json"
    bad.write_text("{not json")
    out = subprocess.run([sys.executable, "-m", "game", "--headless", "--profile", str(bad)],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 1 and out.stderr.count("\n") == 1
    assert f"{bad}: not valid JSON" in out.stderr


def _board_bytes(edit_after: float | None, gesture: bool = True) -> bytes:
    """A board on a script that gets a gesture from 2.3 s: planned before the start, or only after
    ``edit_after`` seconds were sent (the samples to 4 s are computed ahead by then, so those the
    gesture touches must be computed again)."""
    from tracker.sim_board import SimBoard
    from game.sim.motion_model import PlayerProfile, Script
    from tracker.sim import Simulator
    profile = PlayerProfile()
    script = Script(profile, seed=9)
    sim = Simulator(profile.chain(), script.motion, profile.sensor_errors(),
                    profile.flex_sensor(), seed=9)
    board = SimBoard(sim, script.take_edits)

    def plan() -> None:
        if gesture:
            script.wait_until(2.3)
            script.gesture([(10.0, 95.0)])

    out = b""
    if edit_after is None:
        plan()
    else:
        out += board.run_until(edit_after)
        plan()
    return out + board.run_until(8.0)


def test_samples_computed_ahead_are_redone_when_the_motion_changes():
    assert _board_bytes(2.05) == _board_bytes(None)  # as if the gesture had been known all along
    assert _board_bytes(2.05) != _board_bytes(2.05, gesture=False)  # and the gesture did change them
    with pytest.raises(RuntimeError, match="before samples already sent"):
        _board_bytes(2.9)


def test_an_endless_match_lasts_its_duration_where_a_normal_one_ends():
    # The premise: a hard match that is lost. Which seed loses, and when, moves with every
    # improvement of the bot's aim, so the first of a few seeds lost within 15 minutes is taken
    # (when this was written seed 0 fell at 364 s, seed 2 at 218 s; seed 1 lasted 900 s).
    normal = next(r for r in (run_match(MatchConfig(seed=seed, difficulty="hard", duration_s=900.0))
                              for seed in (0, 2, 3, 4)) if r["game_over"])
    assert normal["survived_s"] < 900.0
    # The same match, endless, runs on past the moment the normal one was lost.
    duration = normal["survived_s"] + 10.0
    endless = run_match(MatchConfig(seed=normal["seed"], difficulty="hard", duration_s=duration, endless=True))
    assert not endless["game_over"] and endless["survived_s"] == pytest.approx(duration, abs=0.02)
