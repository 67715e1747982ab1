"""The magnetometer's frame turned onto the accelerometer's, from the dip being the same in every pose."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tracker.accel_procedure import AccelProcedure
from tracker.mag_alignment import AlignmentParams, fit_alignment
from tracker.mag_procedure import MagProcedure
from tracker.maker_sim import SimulatedMaker, calibration_errors, run_maker
from tracker.sim import realistic_errors

DIP = math.radians(60.0)
FIELD = 50.0 * np.array([math.cos(DIP), 0.0, -math.sin(DIP)])  # north and down, uT
UP = np.array([0.0, 0.0, 1.0])  # what the accelerometer reads at rest, in the room, over g


def _poses(turns: Rotation, misaligned: Rotation) -> tuple[np.ndarray, np.ndarray]:
    """The field and gravity's direction seen from a board in the orientations ``turns``, the field in
    a magnetometer frame that ``misaligned`` turns onto the accelerometer's (h_acc = R h_mag)."""
    up = turns.inv().apply(UP)
    field = misaligned.inv().apply(turns.inv().apply(FIELD))
    return field, up


def test_a_known_turn_between_the_frames_is_found_worked_by_hand():
    """Ten poses in drawn orientations, the magnetometer's frame 1.5 deg off the accelerometer's about
    a slanted axis: without a prior the fit finds that rotation (scipy's, as the oracle) and the dip
    exactly; with the default prior, within 0.02 deg (the prior's pull on exact data)."""
    turns = Rotation.random(10, random_state=3)
    misaligned = Rotation.from_rotvec(np.radians(1.5) * np.array([0.6, -0.8, 0.0]))
    field, up = _poses(turns, misaligned)
    exact = fit_alignment(field, up, AlignmentParams(prior_deg=1e9))
    assert exact.ok and exact.residual_deg < 1e-6 and abs(exact.dip_deg - 60.0) < 1e-6
    assert np.degrees((Rotation.from_matrix(exact.rotation) * misaligned.inv()).magnitude()) < 1e-4
    assert abs(exact.turn_deg - 1.5) < 1e-4
    found = fit_alignment(field, up)
    assert found.ok and np.degrees((Rotation.from_matrix(found.rotation) * misaligned.inv()).magnitude()) < 0.02


def test_an_unseen_direction_is_held_by_the_prior_and_poses_alike_or_too_large_a_turn_are_refused():
    """A board only turned about the vertical, the same face up, never sees a turn about its z axis
    (the room's east stays in its x-y plane): the x and y parts are found, z held at 0 by the prior.
    Ten poses all alike see too little, and frames 8 deg apart are more than the data sheets allow:
    both keep the identity."""
    flat = Rotation.from_euler("z", np.linspace(0.0, 300.0, 8)[:, None], degrees=True)
    field, up = _poses(flat, Rotation.from_rotvec(np.radians([1.0, -0.5, 1.0])))
    held = fit_alignment(field, up)
    assert held.ok and np.degrees(Rotation.from_matrix(held.rotation).as_rotvec()) == pytest.approx(
        [1.0, -0.5, 0.0], abs=0.02)
    field, up = _poses(Rotation.from_euler("z", np.full((10, 1), 30.0), degrees=True), Rotation.identity())
    refused = fit_alignment(field, up)
    assert not refused.ok and "not turned through enough orientations" in refused.problem
    assert np.array_equal(refused.rotation, np.eye(3))
    field, up = _poses(Rotation.random(10, random_state=4), Rotation.from_rotvec(np.radians([8.0, 0.0, 0.0])))
    far = fit_alignment(field, up)
    assert not far.ok and np.array_equal(far.rotation, np.eye(3))
    assert "would turn 7.9 deg" in far.problem  # (the prior's pull)


@pytest.mark.parametrize("dot_noise, ok", [(0.014, True), (0.016, False)])
def test_a_second_direction_is_seen_well_enough_once_it_carries_three_priors_worth(dot_noise, ok):
    """Eight poses flat, 45 deg of heading apart: the room's east seen from the board is cos(dip) (cos k 45,
    sin k 45, 0), whose covariance has cos^2(dip) / 2 = 0.125 along x and y (dip 60 deg) and 0 along z. The
    second best seen direction then carries 8 x 0.125 (prior / dot_noise)^2 = (prior / dot_noise)^2 priors'
    worth: at least 3 while dot_noise <= prior / sqrt(3) = 0.0151 rad for the prior of 1.5 deg."""
    flat = Rotation.from_euler("z", 45.0 * np.arange(8)[:, None], degrees=True)
    field, up = _poses(flat, Rotation.from_rotvec(np.radians([0.5, -0.5, 0.0])))
    found = fit_alignment(field, up, AlignmentParams(dot_noise=dot_noise))
    information = (math.radians(1.5) / dot_noise) ** 2
    assert found.ok == ok and (information >= 3.0) == ok
    if not ok:
        assert f"a second direction {information:.1f} times as well as the prior, 3 needed" in found.problem


def test_the_procedures_align_the_magnetometer_with_the_accelerometers_frame():
    """On simulated boards whose accelerometer's cross-axis terms turn its calibrated frame: the soft iron
    saved, in the accelerometer's frame (calibration_errors), is closer to the truth aligned than not."""
    for seed in (0, 2):
        maker = SimulatedMaker(realistic_errors(), seed)
        six = AccelProcedure()
        cal, _ = six.calibration(run_maker(six, maker).result)
        assert np.count_nonzero(cal.pose_fields[:, 6]) == 10  # every pose kept its field
        result = run_maker(MagProcedure(accel=cal), maker).result
        truth = maker.true_calibration()
        aligned = replace(cal, mag_hard_iron=np.array(result.fit.offset), mag_soft_iron=result.soft_iron)
        unaligned = replace(aligned, mag_soft_iron=np.array(result.fit.soft_iron))
        assert result.alignment.ok and 0.1 < result.alignment.turn_deg < 2.0
        assert calibration_errors(aligned, truth)["mag_soft_iron_error_pct"] < 0.5 \
            < 1.0 < calibration_errors(unaligned, truth)["mag_soft_iron_error_pct"]


def test_without_the_accelerometers_poses_the_turn_is_the_identity_and_says_so():
    maker = SimulatedMaker(realistic_errors(), 1)
    result = run_maker(MagProcedure(), maker).result
    assert not result.alignment.ok and "run calibrate accel first" in result.alignment.problem
    assert np.array_equal(result.soft_iron, np.array(result.fit.soft_iron))
