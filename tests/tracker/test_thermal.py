"""The gyroscope's warm-up: the die's temperature on the wire, in the simulator, in the calibration and in play."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from game.body.tracking import Tracking
from game.replay import samples as S
from tracker import protocol as P
from tracker.calibrate_cli import finish_thermal, show_board
from tracker.calibration import MG, BoardCalibration
from tracker.maker_sim import THERMAL_POWER_ON, SimulatedMaker, calibration_errors, run_maker, warm_up
from tracker.sim import (ROOM_C, ErrorModel, LinkSpec, Motion, SensorSpec, Chain, Simulator, die_rise_c,
                         realistic_errors)
from tracker.thermal import ThermalParams, ThermalProcedure, fit_thermal

DEG = math.pi / 180.0


def _still_board(errors, seed: int, power_on: int) -> Simulator:
    """A board lying flat and still: what it measures is its errors alone."""
    chain = Chain((LinkSpec("board", 0.0),), (SensorSpec("imu", 0, (0.0, 0.0, 0.0)),))
    still = Motion(lambda t: np.tile([1.0, 0.0, 0.0, 0.0], (len(t), 1)), lambda t: np.zeros((len(t), 0)))
    return Simulator(chain, still, errors, seed=seed, power_on=power_on)


# ----------------------------------------------------------------- the wire


def test_temp_counts_convert_as_the_register_map_says():
    # RM-MPU-9250A-00: TEMP_degC = TEMP_OUT / 333.87 + 21
    assert P.temp_c(0) == 21.0
    assert P.temp_c(334) == pytest.approx(21.0 + 334 / 333.87)
    assert P.temp_counts(31.0) == 3339  # 10 degC above 21: 3338.7 counts, rounded
    assert P.temp_c(P.temp_counts(27.35)) == pytest.approx(27.35, abs=0.5 / 333.87)


def test_a_temp_frame_stamps_the_samples_after_it_until_the_board_says_hello_again():
    raw = P.RawSample(0.0, 0, 0, (1, 2, 3), (4, 5, 6), None, 7)
    nxt = raw._replace(t=0.005, t_us=5000, seq=1)
    frame = P.encode_temp(0, 1335)
    assert len(frame) == 12 and frame[2:4] == bytes([6, 0x05])  # len 6, type TEMP (PROTOCOL.md sec. 3)
    dec = P.FrameDecoder()
    out = dec.feed(P.encode(raw) + frame + P.encode(nxt))
    assert out == [raw, nxt._replace(temp_counts=1335)]
    assert out[1].die_c == pytest.approx(1335 / 333.87 + 21.0)
    hello = P.Hello(1, "1.0.0", 0x71, 0x48, 200, P.Mode.RAW, True, 16, 2000, P.BoardError.NONE)
    after = dec.feed(P.encode_hello(hello) + P.encode(raw))
    assert after[-1].temp_counts is None  # a new power-up: no temperature known until its first TEMP frame


def test_session_logs_keep_the_temperature_bit_for_bit_and_old_records_still_read():
    with_temp = P.RawSample(1.5, 1500000, 300, (1, 2, 3), (4, 5, 6), (7, 8, 9), 10, host_t=2.25, temp_counts=-120)
    without = with_temp._replace(temp_counts=None)
    assert S.unpack(S.pack([with_temp, without])) == [with_temp, without]
    assert S.pack([without])[:1] == b"R"  # what logs before the TEMP frame hold


# ----------------------------------------------------------------- the simulated die


def test_the_die_warms_along_the_warm_up_and_the_bias_follows_it():
    errors = realistic_errors(gyro_warmup_dps=1.2, gyro_bias_dps=0.0, noise_scale=0.0)
    errors = replace(errors, gyr=replace(errors.gyr, warmup_unexplained=0.0, resolution=0.0))
    data = _still_board(errors, 5, 0).simulate(600.0, 10.0)
    rise = data.die_c[-1] - data.die_c[0]
    assert data.die_c[0] == ROOM_C
    assert rise == pytest.approx(1.2 / 0.24, rel=1e-3)  # the data sheet's steepest 0.24 deg/s per degC: 5 degC
    drift = data.gyr[-1, 0] - data.gyr[0, 0]
    assert np.linalg.norm(drift) / DEG == pytest.approx(1.2, rel=1e-3)
    # the bias is a line in the temperature: every sample on it
    slope = drift / rise
    np.testing.assert_allclose(data.gyr[:, 0] - data.gyr[0, 0], np.outer(data.die_c - ROOM_C, slope), atol=1e-9)


def test_a_share_of_the_warm_up_is_drawn_anew_at_each_power_on():
    gyr = ErrorModel(warmup=2.0 * DEG, warmup_unexplained=0.2)
    errors = replace(realistic_errors(), gyr=gyr)

    def warm(power_on: int, r: float) -> np.ndarray:
        e = replace(errors, gyr=replace(gyr, warmup_unexplained=r))
        return _still_board(e, 9, power_on).stream(10.0).block(0, 1).warmup["gyr"][0]

    np.testing.assert_array_equal(warm(0, 0.0), warm(1, 0.0))  # all of it the board's own
    a, b = warm(0, 1.0), warm(1, 1.0)  # all of it drawn per power-on: two directions, each the whole warm-up
    assert np.linalg.norm(a) == pytest.approx(2.0 * DEG) and np.linalg.norm(b) == pytest.approx(2.0 * DEG)
    assert np.linalg.norm(a - b) > 0.1 * DEG
    # r = 0.2: u = 0.8 u_board + 0.2 u_power_on, so two power-ons differ by 0.2 (u_a - u_b), at most 0.4 of it
    a, b = warm(0, 0.2), warm(1, 0.2)
    np.testing.assert_allclose(a - b, 0.2 * (warm(0, 1.0) - warm(1, 1.0)), atol=1e-15)


# ----------------------------------------------------------------- the fit and the procedure


def test_the_fit_recovers_a_line_worked_by_hand_and_refuses_what_it_cannot_fit():
    die = np.linspace(22.0, 30.0, 200)
    slope = np.array([0.1, -0.05, 0.2]) * DEG  # per degC
    gyr = np.array([1.0, 2.0, -3.0]) * DEG + np.outer(die - 22.0, slope)
    acc_slope = np.array([1.5, -0.5, 0.8]) * MG  # the zero-g level's, per degC
    acc = np.array([0.1, -0.2, 9.8]) + np.outer(die - 22.0, acc_slope)
    fit = fit_thermal(die, gyr, acc)
    assert fit.ok and fit.ref_c == pytest.approx(26.0) and fit.rise_c == pytest.approx(8.0)
    np.testing.assert_allclose(fit.slope, slope, atol=1e-12)
    np.testing.assert_allclose(fit.acc_slope, acc_slope, atol=1e-12)
    assert fit.residual_dps == pytest.approx(0.0, abs=1e-9)
    short = fit_thermal(die[:100], gyr[:100], acc[:100])
    assert not short.ok and "only 100 s" in short.problem and short.warmed
    flat_die = np.full(200, 25.0) + np.linspace(0, 0.5, 200)
    flat = fit_thermal(flat_die, gyr, acc)
    assert not flat.ok and not flat.warmed and "warmed by only 0.50 degC" in flat.problem
    assert "not seen powering up" in flat.problem
    # The same rise from a board seen powering up: a negligible warm-up, kept with zero slopes.
    negligible = fit_thermal(flat_die, gyr, acc, seen_powering_up=True)
    assert negligible.ok and negligible.negligible and negligible.rise_c == pytest.approx(0.5)
    assert not negligible.slope.any() and not negligible.acc_slope.any()
    assert negligible.ref_c == pytest.approx(25.25)  # the mean of a linear ramp 25 .. 25.5
    # about its zero-slope lines, the gyroscope's spread: the RMS over the axes of each one's deviation
    assert negligible.residual_dps == pytest.approx(math.sqrt(np.mean(np.var(gyr, axis=0))) / DEG)
    assert fit.ok and not fit.negligible


def test_the_procedure_finds_the_boards_slope_from_cold_and_leaves_out_a_bump():
    errors = realistic_errors(gyro_warmup_dps=3.0, gyro_bias_dps=5.0)
    board = SimulatedMaker(errors, 4, rate_hz=50, nudges=(200.0,), power_on=THERMAL_POWER_ON)
    seen: list[str] = []
    run = run_maker(ThermalProcedure(), board, limit_s=601.0, watch=lambda t, st: seen.append(st.moved))
    assert run.error == "" and run.result is not None
    assert any("gyroscope strayed" in m for m in seen)  # the bumped seconds were left out, and said so
    truth = board.true_calibration()  # this power-on's warm-up over the die's rise
    assert np.linalg.norm(run.result.slope - truth.gyro_thermal) / DEG < 0.002  # of 0.2 deg/s per degC
    assert np.linalg.norm(run.result.acc_slope - truth.acc_thermal) / MG < 0.02  # of 1.5 mg per degC
    assert run.result.rise_c == pytest.approx(3.0 / 0.24, rel=0.01)  # the whole warm-up: 12.5 degC
    assert 597 <= run.result.seconds <= 599  # the bumped second or two of 600 left out


def test_a_board_that_barely_warms_from_power_up_is_kept_as_negligible_and_a_warm_one_refused():
    """0.1 deg/s of warm-up warms the die by 0.42 degC (0.24 deg/s per degC): below the 1 degC a slope
    needs. Seen powering up, that is the board's warm-up, saved; its clock already at 300 s, it is not."""
    board = SimulatedMaker(realistic_errors(gyro_warmup_dps=0.1), 3, rate_hz=10, power_on=THERMAL_POWER_ON)
    proc = ThermalProcedure()
    run_maker(proc, board, limit_s=601.0)
    assert proc.result().negligible and proc.result().rise_c == pytest.approx(0.1 / 0.24, rel=0.05)
    fitted, record, values, lines = finish_thermal("imu-72", proc, proc.status, 600.0)
    assert "negligible" in lines[0] and not fitted.gyro_thermal.any() and values["rise_c"] < 1.0
    saved = BoardCalibration("imu-72").with_procedure(fitted, record)
    assert saved.gyro_thermal_known and not saved.acc_thermal_known
    assert any("a negligible warm-up" in line for line in show_board(saved))
    late = ThermalProcedure()
    for k in range(6010):
        late.feed(board.raw_sample(k / 10, k)._replace(t=300.0 + k / 10))
    assert not late.result().ok and "not seen powering up" in late.result().problem


def test_a_firmware_without_temp_frames_is_told_to_flash_the_current_one():
    proc = ThermalProcedure()
    st = proc.feed(P.RawSample(0.0, 0, 0, (0, 0, 2048), (0, 0, 0), None, 0))
    assert st.done and "flash the current firmware" in st.problem
    assert not proc.result().ok


def test_a_finished_warm_up_is_saved_with_its_figures_and_shown():
    board = SimulatedMaker(realistic_errors(gyro_warmup_dps=2.0), 6, rate_hz=10, power_on=THERMAL_POWER_ON)
    proc = ThermalProcedure()
    run_maker(proc, board, limit_s=601.0)
    fitted, record, values, lines = finish_thermal("imu-71", proc, proc.status, 600.0)
    assert record.name == "thermal" and dict(record.figures)["rise_c"] == pytest.approx(values["rise_c"])
    assert values["still_s"] >= 598 and "bias slope (" in lines[0]
    errors = calibration_errors(fitted, board.true_calibration())
    assert errors["gyro_thermal_error_dps_per_c"] < 0.002 and errors["acc_thermal_error_mg_per_c"] < 0.02
    assert "accelerometer zero-g slope (" in lines[1] and values["acc_thermal"] == pytest.approx(fitted.acc_thermal)
    shown = show_board(BoardCalibration("imu-71", procedures=(record,)).with_procedure(fitted, record))
    assert any(line.strip().startswith("warm-up drift") for line in shown)
    assert any("deg/s per degC about" in line and "zero-g slope (" in line for line in shown)


# ----------------------------------------------------------------- in play


def test_the_calibration_leaves_only_the_power_ons_own_share_of_the_warm_up():
    """The warm-up calibrated at one power-on, applied at another: what is left of the bias's change
    over ten minutes is r (u_play - u_calibration) of the warm-up (tracker.sim.ErrorModel), no more."""
    errors = realistic_errors(gyro_warmup_dps=4.0, gyro_bias_dps=10.0)
    run = warm_up(SimulatedMaker(errors, 11))
    assert run.error == ""
    quiet = replace(errors, gyr=replace(errors.gyr, noise_density=0.0, resolution=0.0),
                    acc=replace(errors.acc, noise_density=0.0, resolution=0.0))  # the same board, no noise
    play = _still_board(quiet, 11, 1).simulate(600.0, 10.0)
    # The accelerometer's offsets as if the six-pose procedure had measured them at power-on.
    cal = BoardCalibration(gyro_thermal=run.result.slope, gyro_thermal_ref_c=run.result.ref_c,
                           acc_thermal=run.result.acc_slope, acc_offset_ref_c=play.die_c[0])
    corrected = cal.apply_arrays(play.acc[:, 0], play.gyr[:, 0], None, play.die_c)
    left, raw = corrected.gyr[-1] - corrected.gyr[0], play.gyr[-1, 0] - play.gyr[0, 0]
    calibration_run = _still_board(errors, 11, THERMAL_POWER_ON).stream(10.0).block(0, 1).warmup
    share = (play.die_c[-1] - play.die_c[0]) / die_rise_c(errors.gyr)
    expected = (play.warmup["gyr"][0] - calibration_run["gyr"][0]) * share  # = 0.2 W (u_play - u_cal)
    np.testing.assert_allclose(left, expected, atol=0.05 * DEG)  # the fit's own error: 0.002 deg/s/degC x 16.7
    # The zero-g level alike: of its 25 mg of warming, the power-on's own share is left.
    acc_left = corrected.acc[-1] - corrected.acc[0]
    acc_expected = (play.warmup["acc"][0] - calibration_run["acc"][0]) * share
    assert np.linalg.norm(play.acc[-1, 0] - play.acc[0, 0]) / MG > 20.0  # what it would be without
    np.testing.assert_allclose(acc_left, acc_expected, atol=0.5 * MG)  # the fit's error: 0.02 mg/degC x 16.7
    assert np.linalg.norm(left) <= 2 * 0.2 * 4.0 * DEG + 0.05 * DEG < np.linalg.norm(raw)  # at most 2 r of it


def test_the_start_up_hold_learns_the_bias_of_the_compensated_rate():
    """A cold board whose calibration's reference is warm: the hold's bias is the rate after the warm-up's
    correction, so the filter starts with what it will be fed (the bug: the raw rate's bias, 2.9 deg/s off)."""
    slope = np.array([0.0, 0.0, 0.2]) * DEG
    cal = BoardCalibration(gyro_thermal=slope, gyro_thermal_ref_c=35.0)
    counts = round(1.0 / 2000 * 32768)  # 1 deg/s on z, 16.4 counts per deg/s
    temp = P.temp_counts(22.0)
    samples = [P.RawSample(k / 200, k * 5000, k, (0, 0, 2048), (0, 0, counts), None, 0, temp_counts=temp)
               for k in range(600)]
    tracking = Tracking(board=cal)
    result, _ = tracking.hold_still(samples)
    assert result.ok
    raw_z = counts * 2000 / 32768  # deg/s
    assert result.bias[2] / DEG == pytest.approx(raw_z - 0.2 * (P.temp_c(temp) - 35.0), abs=1e-6)
