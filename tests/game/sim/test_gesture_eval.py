"""The gesture evaluation: matching worked by hand, and a short run of the real pipeline."""

import functools
import json
import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.linalg import polar
import pytest

from game.body.gestures import GestureEvent
from game.body.tracking import Tracking
from game.sim.gesture_eval import (TrialResult, aim_split_deg, board_stream, maker_calibration, run_trial,
                                     score_launches, summarise)
from game.sim.motion_model import PlayerProfile, Segment, Session, TrueLaunch, catalogue, session
from tracker.calibration import LONGER_HOLD_S

ROOT = Path(__file__).resolve().parents[3]


def fake_session() -> Session:
    launches = [TrueLaunch(10.0, 10.2, (0.0, 1.0, 0.0), 1.0), TrueLaunch(20.0, 20.15, (1.0, 0.0, 0.0), 1.0)]
    return Session(None, 60.0, launches, [(30.0, 60.0)], None, [Segment("idle", 30.0, 60.0)])


def launch(t, direction):
    return GestureEvent("launch", t, direction, 1.0)


def test_matching_worked_by_hand():
    result = TrialResult(true_launches=2)
    c, s = np.cos(np.radians(3)), np.sin(np.radians(3))
    events = [launch(10.25, (s, c, 0.0)),   # 50 ms after the crossing, 3 deg off: a hit
              launch(12.0, (0.0, 1.0, 0.0)),  # long after any launch, not idle: false
              launch(40.0, (0.0, 1.0, 0.0))]  # in the idle stretch: false, and idle
    truth = fake_session()
    unmatched = score_launches(truth.launches, truth.idle_intervals, events, result)
    assert unmatched == [truth.launches[1]]
    assert (result.matched, result.false_launches, result.idle_false_launches) == (1, 2, 1)
    assert result.latencies_ms == pytest.approx([50.0])
    assert result.aim_errors_deg == pytest.approx([3.0])
    assert result.idle_minutes == pytest.approx(0.5)
    report = summarise([result])
    assert report["launch_precision"] == pytest.approx(1 / 3, abs=1e-4)
    assert report["launch_recall"] == 0.5
    assert report["false_launches_per_min"] == 2.0
    assert report["aim_error_deg_median_late"] is None  # no launch counted as late
    assert report["calibration_ok_rate"] == 0.0  # the result never said its calibration worked


def test_late_launches_are_those_made_in_the_last_quarter():
    truth = fake_session()  # true launches cross at 10.2 s and 20.15 s
    c, s = np.cos(np.radians(3)), np.sin(np.radians(3))
    events = [launch(10.25, (s, c, 0.0)), launch(20.2, (1.0, 0.0, 0.0))]
    result = TrialResult(true_launches=2, calibration_ok=True)
    score_launches(truth.launches, truth.idle_intervals, events, result, late_from=15.0)
    assert result.aim_errors_deg == pytest.approx([3.0, 0.0], abs=1e-6)
    assert result.late_aim_errors_deg == pytest.approx([0.0], abs=1e-6)  # only the second
    report = summarise([result, TrialResult(calibration_ok=False)])
    assert report["aim_error_deg_median_late"] == 0.0
    assert report["calibration_ok_rate"] == 0.5


def _direction(azimuth_deg, elevation_deg):
    """A unit vector (x right, y forward, z up) from its azimuth and elevation, worked by hand."""
    az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
    return (math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), math.sin(el))


def test_an_aim_error_splits_into_azimuth_and_elevation():
    assert aim_split_deg(_direction(3.0, 0.0), (0.0, 1.0, 0.0)) == pytest.approx((3.0, 0.0))
    assert aim_split_deg(_direction(0.0, 2.0), (0.0, 1.0, 0.0)) == pytest.approx((0.0, 2.0))
    wrapped = 2.0 * math.cos(math.radians(15.0))  # 2 deg of azimuth across the back, at 15 deg up
    assert aim_split_deg(_direction(-179.0, 10.0), _direction(179.0, 15.0)) == pytest.approx((wrapped, -5.0))
    # 10 deg of azimuth at 60 deg of elevation is a smaller angle: cos a = cos^2 60 cos 10 + sin^2 60,
    # about 5 deg, what the split gives across: 10 cos 60
    reported, true = _direction(10.0, 60.0), _direction(0.0, 60.0)
    assert aim_split_deg(reported, true) == pytest.approx((5.0, 0.0))
    angle = math.degrees(math.acos(0.25 * math.cos(math.radians(10.0)) + 0.75))
    result = TrialResult(true_launches=1)
    truth = [TrueLaunch(10.0, 10.2, true, 1.0)]
    score_launches(truth, [], [launch(10.25, reported)], result, late_from=5.0)
    assert result.aim_errors_deg == pytest.approx([angle]) and angle == pytest.approx(5.0, abs=0.05)
    assert result.aim_split_deg == result.late_aim_split_deg == [pytest.approx((5.0, 0.0))]


def test_the_report_gives_the_median_size_of_each_part():
    early, late = TrialResult(aim_split_deg=[(-3.0, 1.0), (2.0, -4.0)]), TrialResult()
    late.aim_split_deg = late.late_aim_split_deg = [(0.5, -6.0), (-7.0, 0.25), (1.0, 1.0)]
    report = summarise([early, late])
    assert report["aim_azimuth_error_deg_median"] == 2.0  # of 3, 2, 0.5, 7, 1
    assert report["aim_elevation_error_deg_median"] == 1.0  # of 1, 4, 6, 0.25, 1
    assert report["aim_azimuth_error_deg_median_late"] == 1.0  # of 0.5, 7, 1
    assert report["aim_elevation_error_deg_median_late"] == 1.0  # of 6, 0.25, 1
    assert summarise([TrialResult()])["aim_azimuth_error_deg_median_late"] is None


def test_a_failed_maker_calibration_is_a_reported_figure(monkeypatch):
    from tracker import accel_procedure
    from tracker.calibration import SixPoseResult

    def refuse(poses, extra=(), misalignment=False, params=None):
        return SixPoseResult(False, "pose +x moved", np.zeros(3), np.ones(3), np.eye(3), math.nan)

    monkeypatch.setattr(accel_procedure, "six_pose_calibration", refuse)
    result = run_trial(PlayerProfile(), 5, gestures=1)
    assert not result.calibration_ok
    assert result.calibration.startswith("accelerometer calibration failed: pose +x moved")


def test_the_board_stream_arrives_whole():
    profile = PlayerProfile()
    script = session(profile, seed=3, gestures=1, idle_s=1.0)
    samples = board_stream(script, profile, 3)
    assert len(samples) == round(script.duration_s * 200)
    assert [s.seq for s in samples[:3]] == [0, 1, 2]
    # hanging still at the start: the accelerometer feels about 1 g
    assert 9.0 < np.linalg.norm(samples[10].acc) < 10.6


def test_a_short_run_of_the_whole_pipeline_meets_the_targets():
    results = [run_trial(PlayerProfile(), seed, gestures=4) for seed in (0, 1)]
    assert all("calibrated" in r.calibration for r in results)
    report = summarise(results)
    assert report["launch_precision"] >= 0.99 and report["launch_recall"] >= 0.98
    assert report["false_launches"] == 0
    assert report["aim_error_deg_median"] <= 3.0
    assert report["latency_ms_median"] <= 60.0
    # each launch's split: the two parts make up the whole, as the sides of a right triangle do for
    # errors of a few degrees
    for r in results:
        assert len(r.aim_split_deg) == len(r.aim_errors_deg) == r.matched
        for (across, up), total in zip(r.aim_split_deg, r.aim_errors_deg):
            assert math.hypot(across, up) == pytest.approx(total, rel=0.02, abs=0.01)


# A corner of the ranges: a 2 deg tremor at 10 Hz, next to the strap's 9.3 Hz resonance, rolls the
# board by the whole 6 deg of wobble about the arm's axis at rest (motion_model.tissue_response).
RESONANT_STRAP = PlayerProfile(tremor_deg=2.0, tremor_hz=10.0, wobble_deg=6.0, wobble_hz=9.3, sway_deg=2.5,
                               gyro_bias_dps=15.0)


@pytest.mark.parametrize("name", ["worst_plausible", "resonant_strap"])
def test_the_hardest_players_start_up_holds_are_all_still(name):
    """The catalogue's worst player (2 deg tremor at 4 Hz, a strap rocking 6 deg at 5 Hz, 4 deg
    sway, twice the noise) and a strap driven at its resonance (RESONANT_STRAP) holding still,
    through the game's own hold on the maker-calibrated board: every hold of 20 is judged
    still. The board's rocking about the humerus, which hangs vertically, is a turn the
    accelerometer cannot see; a low-pass that let the tremor band through made 7 of the worst
    player's 20 holds look like a turn. The resonant roll's rate times the swing's rectifies
    into a slow specific force (calibration._roll_columns); without it in the fit, hold 7 of
    the resonant strap's looked like a move (1.2 deg/s)."""
    profile = catalogue()["worst_plausible"] if name == "worst_plausible" else RESONANT_STRAP
    refused = []
    for seed in range(20):
        script = session(profile, seed, gestures=1, idle_s=1.0)
        down, _ = script.calibration
        board, problem = maker_calibration(profile, seed)
        assert problem is None
        hold = [s for s in board_stream(script, profile, seed) if down[0] <= s.t < down[1]]
        result, _ = Tracking(board=board).hold_still(hold)
        if not result.ok:
            refused.append((seed, result.message))
    assert not refused


def test_a_slow_tremor_is_held_longer_and_every_session_calibrates_at_the_first_attempt():
    """The worst plausible player with the slowest tremor a profile allows (3 Hz): its tremor's
    beating components reach 2 Hz, which the hold's 1 s low-pass lets through as a turn (1 hold
    in 20 was refused). The game then asks the player to hold on, and judges the whole longer
    hold (tracker.calibration.LONGER_HOLD): 20 sessions through the whole pipeline, every one
    calibrated at the first attempt, at least one by the longer hold."""
    profile = replace(catalogue()["worst_plausible"], tremor_hz=3.0)
    results = [run_trial(profile, seed, gestures=1) for seed in range(20)]
    assert not [(seed, r.calibration) for seed, r in enumerate(results) if not r.calibration_ok]
    assert any(f"from {LONGER_HOLD_S:.1f} s still" in r.calibration for r in results)


def test_a_player_who_lets_go_of_the_longer_hold_a_moment_early_calibrates():
    """A corner of issue 12's ranges (every key at its harshest, a 2 deg tremor at 12 Hz, the strap
    rocking at 5 Hz; speed and noise the typical player's), session 11: its first hold asks for the
    longer one, and the player, who let go of the first 2.5 s after 2.45 s, holds the 5 s hold for
    4.96 s (motion_model: the first hold lasts 2.4-2.7 s). Judged on needing all 5 s, the hold was
    refused ("only 4.96 s of samples"); the longer hold needs 4.5 s (tracker.calibration.HOLD_SLACK_S)."""
    profile = PlayerProfile(tremor_deg=2.0, tremor_hz=12.0, sway_deg=4.0, wobble_deg=6.0, wobble_hz=5.0,
                            twist_follow=0.4, slip_deg_per_min=4.0, flex_hysteresis_pct=12.0, flex_creep_pct=12.0,
                            gyro_warmup_dps=4.0, mag_hard_iron_ut=200.0, mag_soft_iron_pct=20.0,
                            mag_disturbance_ut=40.0)
    result = run_trial(profile, 11, gestures=1)
    assert result.calibration_ok, result.calibration
    assert f"from {LONGER_HOLD_S:.1f} s still" in result.calibration  # judged on the longer hold (4.96 s: "5.0")


def energyball(*args):
    return subprocess.run([sys.executable, "-m", "game", *args], capture_output=True, text=True,
                          cwd=ROOT, timeout=300)


@pytest.mark.parametrize("content, words", [('{"mount_roll": 3}', "unknown key 'mount_roll'"),
                                            ('{"speed": -1}', "speed must be"),
                                            ("{not json", "not valid JSON")])
def test_a_bad_profile_is_one_clear_line(tmp_path, content, words):
    path = tmp_path / "p.json"
    path.write_text(content)
    r = energyball("gestures-eval", "--profile", str(path))
    assert r.returncode != 0 and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and words in r.stderr


def test_gestures_eval_json_shape():
    r = energyball("gestures-eval", "--trials", "1", "--gestures", "2", "--json")
    assert r.returncode == 0, r.stderr
    report = json.loads(r.stdout)
    assert {"launch_precision", "launch_recall", "false_launches_per_min", "latency_ms_median",
            "latency_ms_p95", "aim_error_deg_median", "aim_error_deg_p95", "aim_error_deg_median_late",
            "aim_azimuth_error_deg_median", "aim_elevation_error_deg_median", "aim_azimuth_error_deg_median_late",
            "aim_elevation_error_deg_median_late", "calibration_ok_rate", "trials", "aim_error_deg_median_ci95",
            "aim_error_deg_p95_ci95", "aim_error_deg_median_late_ci95"} <= set(report)
    assert report["aim_error_deg_median_late_ci95"] is None  # one session says nothing of the next


def test_envelope_and_profile_do_not_go_together(tmp_path):
    path = tmp_path / "p.json"
    path.write_text("{}")
    r = energyball("gestures-eval", "--envelope", "--profile", str(path))
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert "--envelope" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_drawn_players_span_the_ranges_and_come_back_from_their_seed():
    from game.sim.motion_model import _RANGES, DRAWN_SPANS, drawn_players

    players = drawn_players(200, seed=5)
    assert drawn_players(200, seed=5) == players and drawn_players(200, seed=6) != players
    for key, (lo, hi) in DRAWN_SPANS.items():
        values = np.array([getattr(p, key) for p in players.values()])
        assert _RANGES[key][0] <= lo and hi <= _RANGES[key][1]  # every drawn profile is a valid one
        assert values.min() >= lo and values.max() <= hi
        assert np.ptp(values) > 0.9 * (hi - lo)  # 200 uniform draws reach both ends of the span


def test_a_drawn_player_runs_again_from_its_own_profile(tmp_path):
    r = energyball("gestures-eval", "--drawn", "2", "--trials", "1", "--gestures", "3", "--seed", "4", "--json")
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)["players"]
    assert list(rows) == ["drawn-4-0", "drawn-4-1"]
    row = rows["drawn-4-1"]
    path = tmp_path / "drawn.json"
    path.write_text(json.dumps(row.pop("profile")))
    again = energyball("gestures-eval", "--profile", str(path), "--trials", "1", "--gestures", "3", "--seed", "4",
                       "--json")
    assert again.returncode == 0, again.stderr
    assert json.loads(again.stdout) == row


def test_drawn_players_and_the_envelope_do_not_go_together():
    r = energyball("gestures-eval", "--drawn", "3", "--envelope")
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert "--drawn" in r.stderr and len(r.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("name", ["typical", "magnetic_room"])
def test_the_simulated_maker_recovers_the_boards_own_errors(name):
    from game.sim.gesture_eval import maker_calibration
    from game.sim.motion_model import catalogue
    from tracker.sim import Chain, LinkSpec, Motion, SensorSpec, Simulator

    profile = catalogue()[name]
    cal, problem = maker_calibration(profile, seed=9)
    assert problem is None
    board = Chain((LinkSpec("board", 0.0),), (SensorSpec("imu", 0, (0.0, 0.0, 0.0)),))
    still = Motion(lambda t: np.tile([1.0, 0.0, 0.0, 0.0], (len(t), 1)), lambda t: np.zeros((len(t), 0)))
    truth = Simulator(board, still, profile.sensor_errors(), seed=9).simulate(0.1, 200.0)  # the errors it drew
    assert np.linalg.norm(cal.mag_hard_iron - truth.hard_iron[0]) < 0.5  # uT, of 30-150 uT
    inverse = np.linalg.inv(truth.soft_iron[0])
    w_true = inverse / np.linalg.det(inverse) ** (1 / 3)  # the fit's scale: det W = 1
    # saved turned onto the accelerometer's calibrated frame (tracker.mag_alignment): the accelerometer's
    # fitted matrix times its true sensitivities is that frame's turn, scipy's polar rotation of it
    sensitivity = np.diag(truth.scale["acc"][0]) + truth.cross["acc"][0]
    turn, _ = polar((cal.acc_misalignment * cal.acc_scale[None, :]) @ sensitivity)
    assert np.abs(cal.mag_soft_iron - turn @ w_true).max() < 0.01
    g = 9.80665
    acc_offset = truth.offset["acc"][0]
    assert np.abs(cal.acc_offset - acc_offset).max() < 0.005 * g  # 5 mg, of up to 60 mg


def test_without_the_magnetometer_the_drift_state_holds_the_aim_better(monkeypatch):
    """6D fusion has no heading reference: the gyro's bias about the vertical, followed only as
    well as gravity sees it while the board warms, turns the aim for good. The bias's drift state
    (a type-2 loop), unknown from the board's power-up on, follows the warm-up's ramp from its
    steepest start, so without a magnetometer the late aim meets the target as 9D's does and is
    far better than the filter's without the drift state (same player, same seed: 11.1 deg
    without it, 4.3 with the drift known to be zero at power-up, 1.0 then). The board has no
    warm-up calibration here (a firmware before the TEMP frame): with one, most of the warm-up is
    predicted from the die's temperature (tests/tracker/test_thermal.py) and the loop has less to follow."""
    import game.sim.gesture_eval as ge
    import tracker.maker_sim as maker_sim
    from game.body.tracking import Tracking
    from tracker.fusion.default import DefaultFilter, DefaultParams

    monkeypatch.setattr(ge, "calibrate", functools.partial(maker_sim.calibrate, thermal=False))

    nine = run_trial(PlayerProfile(), 0, gestures=20)
    six = run_trial(PlayerProfile(), 0, gestures=20, magnetometer=False)
    before_filter = DefaultFilter(DefaultParams(drift_t=1e9, drift_max=0.0))  # no drift: the filter before
    monkeypatch.setattr(ge, "Tracking", functools.partial(Tracking, filter=before_filter))
    before = run_trial(PlayerProfile(), 0, gestures=20, magnetometer=False)
    assert (nine.matched, six.matched) == (nine.true_launches, six.true_launches)
    late = {name: float(np.median(r.late_aim_errors_deg)) for name, r in (("9D", nine), ("6D", six),
                                                                          ("6D before", before))}
    assert late["9D"] <= 3.0 and late["6D"] <= 3.0, late
    assert late["6D"] < 0.5 * late["6D before"], late
