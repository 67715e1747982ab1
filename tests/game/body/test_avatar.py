"""Forward kinematics against poses worked by hand, and against scipy as an oracle."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from game.body.avatar import Avatar, BodySettings, Wearing, hinge, skeleton
from game.body.pose import ArmPose
from tracker import quat as Q

IDENTITY = (1.0, 0.0, 0.0, 0.0)


def wxyz(r: Rotation) -> tuple:
    x, y, z, w = r.as_quat()
    return (w, x, y, z)


def posed(q_upper, flex=0.0, mounting="aligned", side="right", yaw=0.0):
    """An avatar whose board frame is the bone frame (mount and init identity)."""
    avatar = Avatar(BodySettings(side=side, mounting=mounting), Wearing(IDENTITY, IDENTITY), body_yaw=yaw)
    return avatar.update(ArmPose(wxyz(q_upper), flex, 0.0))


@pytest.mark.parametrize("mounting", ["aligned", "paper45"])
def test_arm_hanging_down(mounting):
    s = posed(Rotation.identity(), mounting=mounting)
    assert s.elbow - s.shoulder == pytest.approx([0, 0, -0.30])
    assert s.wrist - s.elbow == pytest.approx([0, 0, -0.27])
    assert s.hand - s.wrist == pytest.approx([0, 0, -0.08])
    assert s.pointing == pytest.approx([0, 0, -1]) and s.elevation_deg == pytest.approx(0)


@pytest.mark.parametrize("mounting", ["aligned", "paper45"])
def test_arm_forward_straight(mounting):
    s = posed(Rotation.from_euler("x", 90, degrees=True), mounting=mounting)
    assert s.elbow - s.shoulder == pytest.approx([0, 0.30, 0], abs=1e-12)
    assert s.hand - s.shoulder == pytest.approx([0, 0.65, 0], abs=1e-12)
    assert s.elevation_deg == pytest.approx(90)


def test_arm_forward_elbow_at_90_aligned_points_the_forearm_up():
    s = posed(Rotation.from_euler("x", 90, degrees=True), flex=90.0)
    assert s.wrist - s.elbow == pytest.approx([0, 0, 0.27], abs=1e-12)
    assert s.hand - s.elbow == pytest.approx([0, 0, 0.35], abs=1e-12)


def test_arm_forward_elbow_at_90_paper45_follows_unity_euler():
    # Unity's Euler(x, y, z) applies z, then x, then y about fixed axes: R = Ry Rx Rz,
    # which is scipy's intrinsic 'YXZ' with angles (y, x, z).
    s = posed(Rotation.from_euler("x", 90, degrees=True), flex=90.0, mounting="paper45")
    forearm = Rotation.from_euler("x", 90, degrees=True) * Rotation.from_euler("YXZ", [-90, 90, 0], degrees=True)
    assert s.wrist - s.elbow == pytest.approx(forearm.apply([0, 0, -0.27]), abs=1e-12)


@pytest.mark.parametrize("mounting", ["aligned", "paper45"])
def test_right_arm_raised_sideways(mounting):
    s = posed(Rotation.from_euler("y", -90, degrees=True), mounting=mounting)
    assert s.pointing == pytest.approx([1, 0, 0], abs=1e-12)
    assert s.elevation_deg == pytest.approx(90)
    left = posed(Rotation.from_euler("y", 90, degrees=True), side="left", mounting=mounting)
    assert left.pointing == pytest.approx([-1, 0, 0], abs=1e-12)
    assert left.shoulder[0] < 0 < s.shoulder[0]  # each arm on its own side


def test_the_arm_turns_with_the_body():
    s = posed(Rotation.from_euler("x", 90, degrees=True), yaw=math.pi / 2)
    assert s.pointing == pytest.approx([-1, 0, 0], abs=1e-12)  # facing -x after a left turn


@pytest.mark.parametrize("seed", range(5))
def test_random_poses_match_scipy_chain(seed):
    rng = np.random.default_rng(seed)
    q = Rotation.random(random_state=seed)
    mount = Rotation.random(random_state=seed + 100)
    init = Rotation.from_euler("z", rng.uniform(-180, 180), degrees=True)
    flex = rng.uniform(0, 140)
    avatar = Avatar(BodySettings(), Wearing(wxyz(mount), wxyz(init)), body_yaw=0.3)
    s = avatar.update(ArmPose(wxyz(q), flex, 0.0))
    parent = Rotation.from_euler("z", 0.3)
    upper = init * parent * q * mount  # Zhu & Shi, sec. 4
    forearm = upper * Rotation.from_euler("x", flex, degrees=True)
    assert s.elbow - s.shoulder == pytest.approx(upper.apply([0, 0, -0.30]), abs=1e-12)
    assert s.wrist - s.elbow == pytest.approx(forearm.apply([0, 0, -0.27]), abs=1e-12)


def test_skeleton_scales_with_height_and_has_every_bone():
    names = {b.name for b in skeleton(BodySettings())}
    for side in ("right", "left"):
        assert {f"{side}_shoulder", f"{side}_upper_arm", f"{side}_forearm", f"{side}_hand"} <= names
    assert {"hips", "spine", "chest", "neck", "head"} <= names
    tall, short = Avatar(BodySettings(height_m=2.0)), Avatar(BodySettings(height_m=1.5))
    assert tall.world_pos["head"][2] / short.world_pos["head"][2] == pytest.approx(2.0 / 1.5)


def test_bad_body_settings_are_clear_errors():
    with pytest.raises(ValueError, match="side must be"):
        BodySettings(side="middle")
    with pytest.raises(ValueError, match="upper_arm_m must be"):
        BodySettings(upper_arm_m=-1)


def test_hinge_is_a_rotation_about_x():
    assert hinge(90.0, "aligned") == pytest.approx(wxyz(Rotation.from_euler("x", 90, degrees=True)))


def test_a_walking_body_moves_every_bone_and_a_standing_one_keeps_the_arm_live():
    # Posing only the arm while the body stands must give what a fresh avatar computes in full.
    raised = ArmPose(tuple(Q.from_axis_angle((1, 0, 0), math.radians(80.0))), 40.0, 0.0)
    walker = Avatar()
    walker.update(ArmPose((1.0, 0.0, 0.0, 0.0), 0.0, 0.0))
    walker.position, walker.body_yaw = (1.0, 2.0), 0.3
    walker.update(raised)
    walker.update(ArmPose(raised.q_upper, 90.0, 0.1))  # the body stands still: only the arm is posed
    fresh = Avatar(position=(1.0, 2.0), body_yaw=0.3)
    fresh.update(ArmPose(raised.q_upper, 90.0, 0.1))
    for name in fresh.world_pos:
        assert walker.world_pos[name] == pytest.approx(fresh.world_pos[name], abs=1e-12), name
        assert walker.world_rot[name] == pytest.approx(fresh.world_rot[name], abs=1e-12), name
    assert walker.world_pos["hips"][:2] == pytest.approx((1.0, 2.0))
