"""The gyroscope's sensitivity matrix from the turns between the accelerometer calibration's poses."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tracker import protocol as P
from tracker.accel_procedure import AccelProcedure
from tracker.calibration import BoardCalibration
from tracker.gyro_scale import Turn, fit_sensitivity, integrate_turn, rotate_back
from tracker.maker_sim import SimulatedMaker, calibrate, calibration_errors, extreme_errors, run_maker
from tracker.sim import realistic_errors

DEG = math.pi / 180.0


def test_rotate_back_is_the_transposed_rotation_of_scipy():
    rng = np.random.default_rng(1)
    theta, u = rng.normal(size=(20, 3)) * 1.5, rng.normal(size=(20, 3))
    expected = Rotation.from_rotvec(theta).inv().apply(u)
    np.testing.assert_allclose(rotate_back(theta, u), expected, atol=1e-12)


def test_a_turn_is_its_steps_composed_and_its_jacobian_the_turns_sensitivity_to_the_matrix():
    """R0 is the steps' exact rotations composed in order (scipy's product of the trapezoidal steps), and
    E is how the turn moves when the rates are multiplied by I + D: R0^T R(D) = exp(E(D)) to first order
    (central differences of scipy's rotations: R(I - h e_i e_j^T)^T R(I + h e_i e_j^T) = exp(2 h E[:, i, j]),
    for all nine entries, the diagonal's the sensitivities' and the others the cross-axis terms');
    one sample is no turn."""
    rng = np.random.default_rng(4)
    t = np.cumsum(rng.uniform(0.004, 0.006, 300))  # a tip of 180 deg over x in 1 s, a turn on the table
    gyr = np.where((t < t[0] + 1.0)[:, None], [np.pi, 0.0, 0.0], [0.0, 0.0, 0.6]) + rng.normal(0.0, 0.02, (300, 3))
    bias0, bias1 = np.array([0.01, -0.02, 0.0]), np.array([0.03, 0.0, -0.01])

    def composed(matrix: np.ndarray) -> Rotation:
        rates = (gyr - (bias0 + ((t - t[0]) / (t[-1] - t[0]))[:, None] * (bias1 - bias0))) @ matrix.T
        steps = 0.5 * (rates[1:] + rates[:-1]) * np.diff(t)[:, None]
        turn = Rotation.identity()
        for step in Rotation.from_rotvec(steps):
            turn = turn * step
        return turn

    rotation, jacobian = integrate_turn(t, gyr, bias0, bias1)
    assert jacobian.shape == (3, 3, 3)
    np.testing.assert_allclose(rotation, composed(np.eye(3)).as_matrix(), atol=1e-12)
    h = 1e-6
    for i in range(3):
        for j in range(3):
            d = np.zeros((3, 3))
            d[i, j] = h
            column = ((composed(np.eye(3) - d).inv() * composed(np.eye(3) + d)).as_rotvec()) / (2.0 * h)
            np.testing.assert_allclose(jacobian[:, i, j], column, atol=1e-4)  # (E is pi-sized; the
            # right Jacobian to first order in a step of 0.016 rad leaves ~1e-5)
    assert integrate_turn(t[:1], gyr[:1], bias0, bias1)[0] == pytest.approx(np.eye(3))


RATE = 200.0


FACE_TURNS = (((1, 0, 0), 180, 30), ((0, 1, 0), 90, -20), ((1, 0, 0), 180, 10), ((0, 0, 1), 90, 15),
              ((1, 0, 0), -180, -5))  # +z, -z, +x, -x, +y, -y
LEAN_TURNS = ((0, 0, 1), 45, 20), ((1, 0, 0), -60, -10), ((0, 1, 0), 70, 25), ((1, 0, 0), 90, 5)  # four leans


def _turns(matrix: np.ndarray, pieces=FACE_TURNS) -> list[Turn]:
    """The procedure's turns as a maker makes them: tip the board over an edge (``pieces``: an axis of the
    board and an angle, in a second), then turn it on the table to a new heading (about the axis now
    up, half a second), read by a gyroscope whose true rates are ``matrix`` times its readings; bias 0.
    Gravity before and after each from the true rotations (each piece turns about one fixed axis, so
    the true turn is the product of the pieces' rotations)."""
    g = np.array([0.0, 0.0, 1.0])
    out = []
    for axis, angle, heading in pieces:
        tip = np.radians(angle) * np.array(axis, float)
        up_after = Rotation.from_rotvec(tip).inv().apply(g)  # the axis up once tipped, in the board
        head = np.radians(heading) * up_after / np.linalg.norm(up_after)
        rates = np.concatenate([np.tile(tip, (int(RATE), 1)), np.tile(head / 0.5, (int(RATE / 2), 1))])
        rates = np.concatenate([np.zeros((5, 3)), rates, np.zeros((5, 3))])  # still before and after
        t = np.arange(len(rates)) / RATE
        rotation, jacobian = integrate_turn(t, rates @ np.linalg.inv(matrix).T, np.zeros(3), np.zeros(3))
        after = (Rotation.from_rotvec(tip) * Rotation.from_rotvec(head)).inv().apply(g)
        out.append(Turn(rotation, jacobian, g, after))
        g = after
    return out


def test_the_sensitivities_of_turns_worked_by_hand():
    """A gyroscope reading 3 % low on x, 2 % high on y and 1 % low on z (true rates 1.03, 0.98 and 1.01
    times its readings): the fit finds those factors, the turn on the table composed after the tip
    (not summed with it), and the heading turns that gravity does not see change nothing."""
    scale = np.array([1.03, 0.98, 1.01])
    fit = fit_sensitivity(_turns(np.diag(scale)))
    assert fit.ok and fit.turns == 5 and fit.residual_deg < 0.01
    np.testing.assert_allclose(np.diag(fit.matrix), scale, atol=2e-4)
    assert np.max(np.abs(fit.matrix - np.diag(np.diag(fit.matrix)))) < 5e-4  # no cross-axis term made up (of 2 %)


def test_the_cross_axis_terms_of_the_faces_and_the_leaning_poses_turns():
    """A gyroscope whose every axis also reads 2 % or less of the rates about the others (the data
    sheet's bound, PS-MPU-9250A-01 table 1) and whose sensitivities are off by up to 3 %: the nine
    turns of the six faces and four leaning poses give the whole matrix, every entry within 0.05 %,
    where the five face turns alone leave some of it (the prior holds what they do not see)."""
    matrix = np.array([[1.03, 0.02, -0.015], [-0.02, 0.98, 0.01], [0.018, -0.012, 1.01]])
    fit = fit_sensitivity(_turns(matrix, FACE_TURNS + LEAN_TURNS))
    assert fit.ok and fit.turns == 9 and fit.residual_deg < 0.05  # the first-order model's own misfit
    np.testing.assert_allclose(fit.matrix, matrix, atol=1e-3)
    faces_alone = fit_sensitivity(_turns(matrix))
    assert np.max(np.abs(faces_alone.matrix - matrix)) > 2e-3


def test_too_few_turns_or_a_bumped_one_is_refused_and_the_sensitivities_stay_one():
    turns = _turns(np.eye(3))
    short = fit_sensitivity(turns[:2])
    assert not short.ok and "only 2 turns" in short.problem and np.all(short.matrix == np.eye(3))
    tr = turns[1]
    knock = np.cross(tr.after, np.cross(tr.before, tr.after))  # out of the turn's plane: no sensitivity explains it
    turns[1] = Turn(tr.rotation, tr.jacobian, tr.before,
                    Rotation.from_rotvec(np.radians(5.0) * knock / np.linalg.norm(knock)).apply(tr.after))
    bumped = fit_sensitivity(turns)
    assert not bumped.ok and "bumped" in bumped.problem and np.all(bumped.matrix == np.eye(3))


@pytest.mark.parametrize("errors", [realistic_errors(), extreme_errors()], ids=["typical", "extreme"])
def test_the_six_pose_procedure_measures_the_boards_sensitivities(errors):
    """On simulated boards drawn within the data sheet's +-3 % and +-2 % cross-axis: the simulator's own
    sensitivity matrix is the truth (the fit is against the accelerometer's calibrated frame, so the
    matrix is judged there: :func:`tracker.maker_sim.calibration_errors`)."""
    for seed in range(3):
        maker = SimulatedMaker(errors, seed)
        six = AccelProcedure()
        run = run_maker(six, maker)
        cal, fit = six.calibration(run.result)
        data = maker._simulator.stream(200.0).block(0, 1)
        truth, cross = data.scale["gyr"][0], data.cross["gyr"][0]
        assert fit.ok and fit.turns >= 9, fit.problem
        assert np.max(np.abs(np.diag(cal.gyro_scale) * truth - 1)) < 0.002  # of up to 3 %
        assert np.max(np.abs(truth - 1)) > 0.005  # there was something to find
        assert calibration_errors(cal, maker.true_calibration())["gyro_matrix_error_pct"] < 1.0
        assert np.max(np.abs(cross)) > 0.01  # of up to 2 %


def test_the_calibration_applies_the_sensitivities_alike_one_sample_or_many():
    cal = BoardCalibration(gyro_bias=[0.01, 0.0, -0.02], gyro_scale=np.diag([0.97, 1.02, 1.0]),
                           gyro_thermal=[0.001, 0, 0], gyro_thermal_ref_c=25.0)
    s = P.RawSample(0.0, 0, 0, (10, 20, 2048), (1000, -500, 250), None, 0, temp_counts=P.temp_counts(30.0))
    one = cal.apply(s).gyr
    many = cal.apply_arrays(np.array([s.acc]), np.array([s.gyr]), None, [s.die_c]).gyr[0]
    np.testing.assert_allclose(one, many, rtol=1e-12)
    by_hand = np.diag([0.97, 1.02, 1.0]) @ (np.array(s.gyr) - [0.01, 0.0, -0.02]
                                            - np.array([0.001, 0, 0]) * (s.die_c - 25.0))
    np.testing.assert_allclose(one, by_hand, rtol=1e-12)


def test_the_simulated_maker_calibrates_the_sensitivities_with_the_accelerometer():
    maker = SimulatedMaker(realistic_errors(), 5)
    cal, problems = calibrate(maker, thermal=False)
    assert problems == [] and not np.array_equal(cal.gyro_scale, np.eye(3))
    errors = calibration_errors(cal, maker.true_calibration())
    left = calibration_errors(BoardCalibration(), maker.true_calibration())  # nothing calibrated
    assert errors["gyro_matrix_error_pct"] < 0.3 < 1.0 < left["gyro_matrix_error_pct"]
    assert errors["acc_skew_error_pct"] < 0.2 < 0.5 < left["acc_skew_error_pct"]


def test_calibrate_show_says_whether_the_sensitivities_were_measured():
    from tracker.calibrate_cli import show_board
    from tracker.calibration import ProcedureRecord
    record = ProcedureRecord.now("accel", {"residual_m_s2": 0.01})
    refused = BoardCalibration("imu-71", acc_offset=[0.1, 0.0, 0.0], procedures=(record,))
    assert any(line.endswith("gyroscope sensitivities not measured") for line in show_board(refused))
    measured = BoardCalibration("imu-71", gyro_scale=np.diag([1.02, 0.99, 1.0]), procedures=(record,))
    assert any(line.endswith("gyroscope sensitivities (1.0200 0.9900 1.0000), cross-axis not measured")
               for line in show_board(measured))  # a file from before the cross-axis terms were fitted
    matrix = np.array([[1.02, 0.013, 0.0], [-0.004, 0.99, 0.0], [0.0, 0.0, 1.0]])
    full = BoardCalibration("imu-71", gyro_scale=matrix, procedures=(record,))
    assert any(line.endswith("gyroscope sensitivities (1.0200 0.9900 1.0000), cross-axis up to 1.30 %")
               for line in show_board(full))
