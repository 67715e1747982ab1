"""The guided magnetometer procedure: on the simulated board with a simulated maker, and on hand-made streams."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tracker import magfit
from tracker import quat as Q
from tracker.calibration import BoardCalibration
from tracker.mag_procedure import MagProcedure, MagProcedureParams, bin_directions
from tracker.magfit import MagFitError, OnlineParams
from tracker.maker_sim import (Magnet, SimulatedMaker, calibration_errors, extreme_errors, maker_errors,
                               run_maker)
from tracker.motion import EARTH_FIELD_UT
from tracker.protocol import MAG_UT_PER_COUNT, RawSample
from tracker.sim import MAG_NOISE_RMS_UT, MAG_RATE_HZ, Chain, LinkSpec, Motion, SensorSpec, Simulator, realistic_errors

RATE = 200.0


def _fitted(result) -> BoardCalibration:
    return BoardCalibration(mag_hard_iron=np.array(result.fit.offset), mag_soft_iron=result.soft_iron)


@pytest.mark.parametrize("errors, seed", [(maker_errors(), s) for s in (0, 1, 2)]
                         + [(extreme_errors(), s) for s in (0, 3, 4)])
def test_the_procedure_recovers_hard_and_soft_iron(errors, seed):
    maker = SimulatedMaker(errors, seed=seed)
    run = run_maker(MagProcedure(), maker)
    assert run.error == "", run.error
    err = calibration_errors(_fitted(run.result), maker.true_calibration())
    assert err["mag_hard_iron_error_ut"] < 2.0  # of 30 to 200 uT
    assert err["mag_soft_iron_error_pct"] < 2.0  # of 5 to 20 %
    assert run.result.residual_ut < 1.0 and run.result.fit.model == magfit.ELLIPSOID
    assert run.result.fit.coverage >= 0.7


@pytest.mark.parametrize("errors, rms_ut",
                         [(maker_errors(), MAG_NOISE_RMS_UT), (extreme_errors(), 2 * MAG_NOISE_RMS_UT)],
                         ids=["typical", "extreme"])
def test_the_noise_measured_is_the_magnetometers_its_held_readings_counted_once(errors, rms_ut):
    # The AK8963 measures at 100 Hz (tracker.sim.MAG_RATE_HZ) and the board samples at 200: each measurement comes
    # twice. A kept reading, the mean of 10 samples, holds 5 measurements: its noise is rms / sqrt(5) per axis.
    maker = SimulatedMaker(errors, seed=3)
    run = run_maker(MagProcedure(), maker)
    assert maker.rate_hz == 2 * MAG_RATE_HZ and run.error == ""
    assert run.result.noise_ut == pytest.approx(rms_ut / math.sqrt(5.0), rel=0.05)
    assert run.result.residual_ut < 1.5 * run.result.noise_ut + 0.3  # judged no change of the field


def test_strength_and_dip_are_the_fields():
    """No room disturbance and the accelerometer calibrated: the dip is the earth field's own,
    atan(40 / 20) = 63.4 deg below the horizontal, and the strength |h| through the det-1 soft iron."""
    errors = realistic_errors(mag_disturbance_ut=0.0, mag_hard_iron_ut=120.0, mag_soft_iron_pct=10.0)
    maker = SimulatedMaker(errors, seed=6)
    run = run_maker(MagProcedure(accel=maker.true_calibration()), maker)
    assert run.result.dip_deg == pytest.approx(math.degrees(math.atan2(40.0, 20.0)), abs=0.5)
    board = Chain((LinkSpec("board", 0.0),), (SensorSpec("imu", 0, (0.0, 0.0, 0.0)),))
    still = Motion(lambda t: np.tile([1.0, 0.0, 0.0, 0.0], (len(t), 1)), lambda t: np.zeros((len(t), 0)))
    drawn = Simulator(board, still, errors, seed=6).simulate(0.01, RATE).soft_iron[0]  # the board's S
    expected = np.linalg.norm(EARTH_FIELD_UT) * np.linalg.det(drawn) ** (1 / 3)  # W = det(S)^(1/3) S^-1
    assert run.result.strength_ut == pytest.approx(expected, rel=0.01)


def test_a_magnet_near_the_board_is_refused_in_one_line():
    maker = SimulatedMaker(seed=1, magnet=Magnet(8.0, 14.0))  # 200 uT: a neodymium cube 10 cm away
    run = run_maker(MagProcedure(), maker)
    assert run.result is None
    assert run.error.startswith("a magnet or iron near the board: its readings span")
    assert "22-67 uT" in run.error and "\n" not in run.error
    assert run.seconds < 10.0  # refused as it came near, not at the end


def test_a_magnet_there_all_along_is_refused():
    """A steady 100 uT added: the readings lie on one ellipsoid (nothing changes), but of 110 uT."""
    maker = SimulatedMaker(seed=2, magnet=Magnet(-10.0, 1e9, (100.0, 0.0, 0.0)))
    run = run_maker(MagProcedure(), maker)
    assert run.error.startswith("a magnet or iron near the board: ")
    assert "22-67 uT" in run.error


def test_a_field_that_changes_during_the_procedure_is_refused():
    maker = SimulatedMaker(seed=1, magnet=Magnet(8.0, 14.0, (25.0, 0.0, 0.0)))  # steel moved near, for 6 s
    run = run_maker(MagProcedure(), maker)
    assert run.error.startswith("the field changed during the procedure: the readings leave a residual of")
    assert "\n" not in run.error


def test_too_little_coverage_is_refused():
    """A board turned about one axis only: its field traces a circle, a fraction of the directions."""
    procedure = MagProcedure()
    hard = np.array([40.0, -25.0, 60.0])
    for k in range(round(20 * RATE)):
        t = k / RATE
        q = Q.from_axis_angle((0.0, 0.0, 1.0), 2.0 * math.pi * t / 5.0)
        m = Q.rotate(Q.conjugate(q), EARTH_FIELD_UT) + hard
        status = procedure.feed(_sample(t, m, Q.rotate(Q.conjugate(q), (0.0, 0.0, 9.81))))
    assert not status.ready and status.coverage < 0.4
    with pytest.raises(MagFitError, match="^too little coverage"):
        procedure.finish()


def test_a_still_board_covers_nothing():
    procedure = MagProcedure()
    for k in range(round(5 * RATE)):
        status = procedure.feed(_sample(k / RATE, np.array(EARTH_FIELD_UT) + [30.0, 0.0, 0.0] +
                                        np.random.default_rng(k).normal(0.0, 0.6, 3), (0.0, 0.0, 9.81)))
    assert status.coverage == 0.0 and not any(status.covered)
    with pytest.raises(MagFitError, match="^too little coverage"):
        procedure.finish()


def test_a_pulled_cable_keeps_the_readings_and_the_procedure_resumes():
    maker = SimulatedMaker(seed=1)
    procedure = MagProcedure()
    seen = []
    run = run_maker(procedure, maker, pull_cable=(9.0, 3.0), watch=lambda t, s: seen.append((procedure.readings, s)))
    pulled = [m for _, m in run.history if "disconnected" in m]
    kept, before = seen[round(9.0 * RATE) - 1]
    assert pulled == [f"the board was disconnected: the {kept} readings so far are kept; turn it on through "
                      f"the directions not yet covered"]
    after = seen[round(9.0 * RATE) + 20][1]  # the first kept reading after the board came back
    assert kept > 20 and after.coverage >= before.coverage > 0.2
    assert run.error == ""
    err = calibration_errors(_fitted(run.result), maker.true_calibration())
    assert err["mag_hard_iron_error_ut"] < 2.0 and err["mag_soft_iron_error_pct"] < 2.0


def test_memory_stays_bounded():
    procedure = MagProcedure(MagProcedureParams(store=OnlineParams(capacity=64)))
    maker = SimulatedMaker(seed=3)
    run_maker(procedure, maker, limit_s=20.0)
    assert procedure.readings <= 64


def test_the_status_lists_the_bins_in_the_order_of_their_directions():
    d = bin_directions()
    assert d.shape == (magfit.BINS, 3) and np.allclose(np.linalg.norm(d, axis=1), 1.0)
    assert list(magfit.bin_index(d)) == list(range(magfit.BINS))
    maker = SimulatedMaker(seed=0)
    procedure = MagProcedure()
    run_maker(procedure, maker)
    status = procedure.status
    assert len(status.covered) == magfit.BINS and status.coverage == sum(status.covered) / magfit.BINS
    assert status.ready and status.coverage >= procedure.params.target_coverage


def _sample(t: float, mag, acc) -> RawSample:
    m = tuple(int(round(x / MAG_UT_PER_COUNT)) for x in mag)
    a = tuple(int(round(x / (16 * 9.80665 / 32768))) for x in acc)
    return RawSample(t, round(t * 1e6), 0, a, (0, 0, 0), m, 0)
