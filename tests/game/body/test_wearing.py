"""Wearing calibration: a badly worn board still gives the right avatar."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from game.body.avatar import Avatar, BodySettings
from game.body.pose import ArmPose
from game.body.wearing import (POSE_WINDOW_S, arm_down, arm_down_then_forward, last_held, mean_orientation,
                               moved_deg, recenter)
from tracker import quat as Q

HEADING = Rotation.from_euler("z", 40, degrees=True)  # the player faces 40 deg left of the tracker's y
IDEAL_BS = Rotation.from_euler("z", -90, degrees=True)  # sensor y along the hinge (bone x), -x forward


def wxyz(r: Rotation) -> tuple:
    x, y, z, w = r.as_quat()
    return (float(w), float(x), float(y), float(z))


def worn(roll_deg: float, pitch_deg: float) -> Rotation:
    """q_BS: the sensor frame in the bone frame, rolled about the arm and pitched across it."""
    return Rotation.from_euler("z", roll_deg, degrees=True) * Rotation.from_euler("x", pitch_deg, degrees=True) \
        * IDEAL_BS


def hold(bone_world: Rotation, q_bs: Rotation, seconds: float = 1.0, tremor_deg: float = 0.3,
         seed: int = 0) -> list[ArmPose]:
    """Sensor readings of a held pose with a little tremor (q_WS = q_WB q_BS)."""
    rng = np.random.default_rng(seed)
    n = int(seconds * 100)
    shake = Rotation.from_rotvec(rng.normal(0, math.radians(tremor_deg) / math.sqrt(3), (n, 3)))
    return [ArmPose(wxyz(HEADING * shake[i] * bone_world * q_bs), 0.0, i / 100) for i in range(n)]


def aimed(direction) -> Rotation:
    """The bone rotation pointing the hanging arm (-z) along ``direction`` (body frame)."""
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    rot, _ = Rotation.align_vectors([d], [[0, 0, -1]])
    return rot


def pointing_error_deg(avatar: Avatar, q_bs: Rotation, direction) -> float:
    state = avatar.update(ArmPose(wxyz(HEADING * aimed(direction) * q_bs), 0.0, 0.0))
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    return math.degrees(math.acos(np.clip(np.dot(state.pointing, d), -1, 1)))


TARGETS = [(0, 1, 0), (0.5, 1, 0.1), (-0.7, 1, -0.2), (1, 0.2, 0), (0.3, 1, 0.8), (-1, 0.5, 0.3)]


def test_a_board_worn_25_deg_rolled_and_10_deg_pitched_points_within_2_deg_after_two_poses():
    q_bs = worn(25, 10)
    avatar = Avatar(BodySettings())
    result = arm_down_then_forward(avatar, hold(Rotation.identity(), q_bs),
                                   hold(Rotation.from_euler("x", 90, degrees=True), q_bs, seed=1))
    assert result.ok, result.message
    avatar.wearing = result.wearing
    errors = [pointing_error_deg(avatar, q_bs, d) for d in TARGETS]
    assert max(errors) < 2.0, errors
    # And the arm hangs at rest when the player's arm hangs.
    assert avatar.update(hold(Rotation.identity(), q_bs, 0.02)[0]).elevation_deg < 1.0


def test_without_calibration_the_same_board_points_far_off():
    q_bs = worn(25, 10)
    avatar = Avatar(BodySettings())
    assert max(pointing_error_deg(avatar, q_bs, d) for d in TARGETS) > 20


def test_arm_down_alone_fixes_the_tilt_but_not_the_roll_about_the_arm():
    q_bs = worn(25, 10)
    avatar = Avatar(BodySettings())
    result = arm_down(avatar, hold(Rotation.identity(), q_bs))
    assert result.ok
    avatar.wearing = result.wearing
    # Hanging is right, but the rolled board turns every raise sideways by about the roll.
    assert avatar.update(hold(Rotation.identity(), q_bs, 0.02)[0]).elevation_deg < 1.0
    assert 15 < pointing_error_deg(avatar, q_bs, (0, 1, 0)) < 35


def shaky_hold(bone_world: Rotation, q_bs: Rotation, moves, seconds: float) -> list[ArmPose]:
    """A held pose whose bone turns by ``moves(t)`` (rotation vectors, body frame) on top of ``bone_world``."""
    t = np.arange(round(seconds * 100)) / 100
    turn = Rotation.from_rotvec(moves(t))
    return [ArmPose(wxyz(HEADING * turn[i] * bone_world * q_bs), 0.0, float(t[i])) for i in range(len(t))]


def tremor_and_sway(phase: float, sway_hz: float):
    """A 2 deg tremor at 3 Hz on both swing axes and a 4 deg sway about x: the issue's largest."""
    def moves(t):
        w = 2 * np.pi * t
        return np.radians(np.stack([2 * np.sin(3 * w) + 4 * np.sin(sway_hz * w + phase),
                                    2 * np.sin(3 * w + 1.0), 0.5 * np.sin(3 * w + 2.0)], axis=1))
    return moves


@pytest.mark.parametrize("seconds", [1.0, 2.0])
def test_tremor_and_sway_pass_and_their_mean_is_the_pose(seconds):
    """The old check (4 deg about the mean) refused these; the mean pose is what matters.

    Sway at the worst phase: a half period across the pose (its two ends 8 deg apart).
    The mean of a sway over the pose is off the pose by at most its peak, 4 deg."""
    q_bs = worn(25, 10)
    for phase in np.linspace(0, 2 * np.pi, 8, endpoint=False):
        poses = shaky_hold(Rotation.identity(), q_bs, tremor_and_sway(phase, 0.5 / seconds), seconds)
        result = arm_down(Avatar(BodySettings()), poses)
        assert result.ok, (phase, result.message)
        mean = mean_orientation([p.q_upper for p in poses])
        truth = wxyz(HEADING * q_bs)
        assert math.degrees(Q.angle_between(mean, truth)) < 4.0


def test_a_pose_is_its_holds_last_second_so_a_settling_start_is_left_out():
    """"Hold still" runs the filter again over the hold from a fresh state, and its first poses
    are still settling: here 20 deg off about the arm's swing axis for the first 0.4 s. Over the
    whole 2.5 s hold that reads as a move (the start's 0.67 s Hann window is mostly inside the
    settling); the hold's last second (POSE_WINDOW_S) is the pose: 100 poses, at 1.5-2.49 s,
    still, and their mean the truth within the 0.3 deg tremor."""
    q_bs = worn(25, 10)
    settled = hold(Rotation.identity(), q_bs, seconds=2.5)
    off = wxyz(HEADING * Rotation.from_euler("x", 20, degrees=True) * HEADING.inv())  # a world turn
    poses = [ArmPose(tuple(Q.multiply(off, p.q_upper)), p.flex_deg, p.t) if p.t < 0.4 else p for p in settled]
    assert not arm_down(Avatar(BodySettings()), poses).ok
    last = last_held(poses)
    assert len(last) == round(POSE_WINDOW_S * 100) and last[0].t == pytest.approx(1.5) and last[-1] is poses[-1]
    assert arm_down(Avatar(BodySettings()), last).ok
    mean = mean_orientation([p.q_upper for p in last])
    assert math.degrees(Q.angle_between(mean, wxyz(HEADING * q_bs))) < 0.3


@pytest.mark.parametrize("degrees, seconds, refused", [(20.0, 1.0, True), (12.0, 2.0, True), (5.0, 2.0, False)])
def test_a_real_move_during_a_pose_is_rejected_with_a_message(degrees, seconds, refused):
    """A raise that persists (minimum jerk over the middle half of the pose), with a 1 deg tremor."""
    def moves(t):
        x = np.clip((t - seconds / 4) / (seconds / 2), 0.0, 1.0)
        raised = degrees * (10 * x ** 3 - 15 * x ** 4 + 6 * x ** 5)
        return np.radians(np.stack([raised + np.sin(2 * np.pi * 5 * t), np.zeros_like(t), np.zeros_like(t)], axis=1))
    q_bs = worn(0, 0)
    avatar = Avatar(BodySettings())
    poses = shaky_hold(Rotation.identity(), q_bs, moves, seconds)
    result = arm_down(avatar, poses)
    assert result.ok != refused, result.message
    if refused:
        assert result.message.startswith("arm down: the arm moved") and result.wearing == avatar.wearing
        assert 0.7 * degrees < moved_deg(poses) <= degrees + 1.0


@pytest.mark.parametrize("seconds", [1.0, 2.0])
def test_an_arm_that_moves_out_and_back_during_a_pose_is_rejected(seconds):
    """A 20 deg raise and back (minimum jerk, out over the pose's second quarter, back over its
    third), with a 1 deg tremor at 5 Hz: the pose's two halves are mirror images, so their means
    agree (a judgement by the ends alone took it), but the arm moved and the pose's mean is off."""
    def rise(s):
        s = np.clip(s, 0.0, 1.0)
        return 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5

    def moves(t):
        raised = 20.0 * (rise((t - seconds / 4) / (seconds / 4)) - rise((t - seconds / 2) / (seconds / 4)))
        return np.radians(np.stack([raised + np.sin(2 * np.pi * 5 * t), np.zeros_like(t), np.zeros_like(t)], axis=1))
    q_bs = worn(0, 0)
    avatar = Avatar(BodySettings())
    poses = shaky_hold(Rotation.identity(), q_bs, moves, seconds)
    half = len(poses) // 2
    ends = [Rotation.from_quat([[*p.q_upper[1:], p.q_upper[0]] for p in part]).mean()
            for part in (poses[:half], poses[half:])]
    assert (ends[0].inv() * ends[1]).magnitude() < math.radians(1.0)  # scipy: the halves agree
    result = arm_down(avatar, poses)
    assert not result.ok and result.message.startswith("arm down: the arm moved"), result.message
    assert 8.5 < moved_deg(poses) <= 21.0


def test_a_forward_pose_that_is_not_forward_is_rejected():
    q_bs = worn(0, 0)
    avatar = Avatar(BodySettings())
    result = arm_down_then_forward(avatar, hold(Rotation.identity(), q_bs),
                                   hold(Rotation.from_euler("x", 30, degrees=True), q_bs))
    assert not result.ok and "shoulder height" in result.message


def test_recenter_makes_where_i_point_forward():
    q_bs = worn(0, 0)
    avatar = Avatar(BodySettings())
    avatar.wearing = arm_down_then_forward(avatar, hold(Rotation.identity(), q_bs, tremor_deg=0),
                                           hold(Rotation.from_euler("x", 90, degrees=True), q_bs,
                                                tremor_deg=0)).wearing
    # The player turns 70 deg to the right and points ahead: after recenter that is forward.
    turned = Rotation.from_euler("z", -70, degrees=True) * Rotation.from_euler("x", 90, degrees=True)
    pose = ArmPose(wxyz(HEADING * turned * q_bs), 0.0, 0.0)
    expected = [math.sin(math.radians(70)), math.cos(math.radians(70)), 0]
    assert avatar.update(pose).pointing == pytest.approx(expected, abs=1e-6)
    avatar.wearing = recenter(avatar, pose)
    assert avatar.update(pose).pointing == pytest.approx([0, 1, 0], abs=1e-6)
