"""The simulated maker: its board's truth, its obedience to prompts, its clock, and the figures command."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from tracker import quat as Q
from tracker.accel_procedure import AccelProcedure, AccelStatus
from tracker.board import BoardSettings, quantise
from tracker.calibration import BoardCalibration, pose_label
from tracker.mag_procedure import MagProcedure
from tracker.maker_sim import SimulatedMaker, calibration_errors, extreme_errors, run_maker
from tracker.motion import EARTH_FIELD_UT, GRAVITY
from tracker.sim import SCALE_TOLERANCE, realistic_errors

ROOT = Path(__file__).resolve().parents[2]
G = 9.80665  # m/s^2 per g, as the figures count mg


def test_calibration_errors_are_the_issues_four_figures_worked_by_hand():
    truth = BoardCalibration(acc_offset=[0.1, -0.2, 0.3], acc_scale=[1.0, 1.02, 0.98],
                             mag_hard_iron=[10.0, 20.0, 30.0],
                             mag_soft_iron=[[1.0, 0.05, 0.0], [0.05, 0.9, 0.0], [0.0, 0.0, 1.1]],
                             gyro_scale=np.diag([1.0, 0.98, 1.03]))
    fitted = BoardCalibration(acc_offset=[0.1, -0.2 + 5e-3 * G, 0.3 - 2e-3 * G], acc_scale=[1.0, 1.02 * 1.003, 0.98],
                              mag_hard_iron=[13.0, 24.0, 30.0],
                              mag_soft_iron=[[1.0, 0.07, 0.0], [0.05, 0.9, 0.0], [0.0, 0.0, 1.1 - 0.01]],
                              gyro_scale=np.diag([1.0, 0.98, 1.03 * 0.999]))
    errors = calibration_errors(fitted, truth)
    assert errors["acc_offset_error_mg"] == pytest.approx(5.0)  # the worst axis, y
    assert errors["acc_scale_error_pct"] == pytest.approx(0.3)
    assert errors["mag_hard_iron_error_ut"] == pytest.approx(5.0)  # |(3, 4, 0)|
    assert errors["mag_soft_iron_error_pct"] == pytest.approx(2.0)  # the (0, 1) element
    assert errors["gyro_scale_error_pct"] == pytest.approx(0.1)  # z
    # F T^-1 = diag(1, 1.003, 1): the scale's 0.3 % is all that no rotation explains; the gyroscope's
    # diag(1, 1, 0.999) against it leaves 0.3 % on y (the accelerometer's frame stretched, not the gyroscope's)
    assert errors["acc_skew_error_pct"] == pytest.approx(0.3)
    assert errors["gyro_matrix_error_pct"] == pytest.approx(0.3)
    skewed = replace(fitted, acc_misalignment=np.array([[1.0, 0.01, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
                     acc_scale=truth.acc_scale, gyro_scale=truth.gyro_scale)
    turned = replace(skewed, acc_misalignment=np.array([[1.0, 0.01, 0.0], [-0.01, 1.0, 0.0], [0.0, 0.0, 1.0]]))
    # F T^-1 = M, the misalignment, with the true scales: a 1 % shear is half symmetric (0.5 %) and leaves
    # the gyroscope's frame 1 % off the accelerometer's; a skew-symmetric M (a turn of the frame) is no skew
    assert calibration_errors(skewed, truth)["acc_skew_error_pct"] == pytest.approx(0.5)
    assert calibration_errors(skewed, truth)["gyro_matrix_error_pct"] == pytest.approx(1.0)
    assert calibration_errors(turned, truth)["acc_skew_error_pct"] < 1e-9


def _noise_free(**kw: float):
    """A board with offsets, scales, hard and soft iron but no noise, no room disturbance and no
    low-pass delay (a tumbling board's specific force read 4.88 ms late is no calibration error:
    tests/tracker/test_mpu_dlpf.py)."""
    e = realistic_errors(noise_scale=0.0, mag_disturbance_ut=0.0, **kw)
    return replace(e, acc=replace(e.acc, scale_max=SCALE_TOLERANCE), dlpf=False)


@pytest.mark.parametrize("seed", [0, 3])
def test_the_true_calibration_undoes_the_boards_errors(seed):
    """Independent of any fit: applied to the board's readings as it tumbles, the true calibration
    gives back the true specific force R^T g, and a field along R^T h whose strength is the same
    in every orientation (the soft iron's det-1 convention scales it)."""
    maker = SimulatedMaker(_noise_free(mag_hard_iron_ut=150.0, mag_soft_iron_pct=15.0), seed=seed)
    truth = maker.true_calibration()
    assert abs(np.linalg.det(truth.mag_soft_iron) - 1.0) < 1e-9
    assert np.allclose(truth.mag_soft_iron, truth.mag_soft_iron.T)
    maker.reading(0.0)
    maker.follow(MagProcedure().status)
    strengths, ups = [], []
    for t in np.arange(0.5, 30.0, 0.5):
        r = maker.reading(float(t))
        cal = truth.apply_arrays(r.acc, r.gyr, r.mag, r.die_c)  # the zero-g level warms with the die
        q = np.array(r.q)
        assert np.allclose(cal.acc, Q.rotate(Q.conjugate(q), [0.0, 0.0, GRAVITY]), atol=0.01)  # 16 g counts
        field = Q.rotate(Q.conjugate(q), EARTH_FIELD_UT)
        cos = cal.mag @ field / (np.linalg.norm(cal.mag) * np.linalg.norm(field))
        assert math.degrees(math.acos(min(1.0, cos))) < 0.5  # 0.15 uT counts of a 45 uT field
        strengths.append(np.linalg.norm(cal.mag))
        ups.append(Q.rotate(q, [0.0, 0.0, 1.0])[2])
    assert np.ptp(strengths) < 0.02 * np.mean(strengths)
    assert min(ups) < -0.5 < 0.5 < max(ups)  # the tumble turned the board over and back


def test_following_a_prompt_lays_the_asked_face_up_and_lets_it_lie_still():
    maker = SimulatedMaker(seed=2)
    maker.reading(0.0)
    for face in ("-x", "+y", "-z"):
        start = maker.now
        maker.follow(AccelStatus(face, "+z", 0.0, (), f"put {face} up", False))
        t = start
        while t < start + 3.0:
            t += 0.005
            r = maker.reading(t)
        axis = {"-x": (-1.0, 0.0, 0.0), "+y": (0.0, 1.0, 0.0), "-z": (0.0, 0.0, -1.0)}[face]
        assert Q.rotate(np.array(r.q), axis)[2] > math.cos(math.radians(2.01))  # up, leaning 2 deg at most
        assert pose_label(np.array(r.acc))[0] == face  # and the accelerometer says so
        gyr = np.array([maker.reading(t + k * 0.005).gyr for k in range(200)])
        bias = maker.true_calibration().gyro_bias  # at power-on; it warms by 0.1 deg/s in the first 20 s
        assert np.abs(gyr.mean(axis=0) - bias).max() < math.radians(0.15)  # lying still: it reads its bias
        assert gyr.std(axis=0).max() < math.radians(0.2)  # and its noise, 0.14 deg/s at 200 Hz


def test_a_restarted_board_clock_does_not_restart_the_makers_world():
    maker = SimulatedMaker(seed=1)
    for k in range(1, 1001):
        maker.reading(k / 200.0)
    assert maker.now == pytest.approx(5.0)
    maker.reading(0.0)  # the hello's probe, or the power-up's first sample: now, unchanged
    assert maker.now == pytest.approx(5.0)
    maker.reading(0.005)  # the board's clock runs again from zero
    assert maker.now == pytest.approx(5.01)


def test_its_raw_samples_are_the_boards_quantisation_of_its_readings():
    maker = SimulatedMaker(seed=4)
    s = BoardSettings()
    for k in (0, 1, 57, 200):
        t = k / 200.0
        raw = maker.raw_sample(t, seq=k)
        assert raw == quantise(maker.reading(t), t, round(t * 1e6), k, s.acc_fs_g, s.gyr_fs_dps)


def test_the_six_pose_run_does_not_depend_on_how_many_samples_are_simulated_at_once():
    """A prompt changes the motion inside a block already simulated (it is simulated again): a
    maker simulating 37 samples, or 10 s, at a time gives the same samples, prompts and result."""
    runs = []
    for block_n in (None, 37, 2000):
        maker = SimulatedMaker(seed=6)
        if block_n:
            maker._block_n = block_n
        run = run_maker(AccelProcedure(), maker)
        runs.append((run.history, run.result.offset.tolist(), run.result.scale.tolist()))
    assert runs[0] == runs[1] == runs[2]


def test_the_extremes_are_the_catalogues_worst_board():
    from game.sim.motion_model import catalogue

    worst, ours = catalogue()["worst_plausible"].sensor_errors(), extreme_errors()
    assert ours.acc == replace(worst.acc, scale_max=SCALE_TOLERANCE)
    assert (ours.gyr, ours.mag, ours.magnetic) == (worst.gyr, worst.mag, worst.magnetic)  # the flex is not used


SIMULATED = (sys.executable, "-m", "tracker", "calibrate", "simulated")  # the figures' command (README)


def test_the_figures_command_prints_json(tmp_path):
    r = subprocess.run([*SIMULATED, "--json", "--seeds", "1"], cwd=ROOT, capture_output=True, text=True,
                       timeout=300, env={"HOME": str(tmp_path), "PATH": ""})
    assert r.returncode == 0, r.stderr
    report = json.loads(r.stdout)
    for kind in ("typical", "extreme"):
        figures = report[kind]
        assert figures["failures"] == []
        assert figures["acc_offset_error_mg"] < 5.0 and figures["acc_scale_error_pct"] < 0.3
        assert figures["mag_hard_iron_error_ut"] < 2.0 and figures["mag_soft_iron_error_pct"] < 2.0


def test_the_figures_command_refuses_a_bad_seed_count_in_one_line(tmp_path):
    r = subprocess.run([*SIMULATED, "--seeds", "0"], cwd=ROOT, capture_output=True, text=True, timeout=60,
                       env={"HOME": str(tmp_path), "PATH": ""})
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "--seeds" in r.stderr
