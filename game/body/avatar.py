"""The avatar: a skeleton posed by forward kinematics, its arm driven by the tracker.

Frames. The body frame is x right, y forward, z up; the world frame of the
game is the same at body yaw 0. Every bone has its own frame, equal to the
body frame in the rest pose (standing, arms hanging), and hangs along its
-z axis: a bone's child joint sits at ``rotate(world_rot, (0, 0, -length))``
from its own joint (torso bones point up, along +z, by negative offsets).
The elbow hinge is the upper arm's x axis: a positive flex turns the
forearm about +x, bringing the hand forward.

Forward kinematics (Zhu & Shi, sec. 4, Unity's transform hierarchy): a bone's
world rotation is its parent's world rotation times its local rotation, and
its joint sits at the parent's joint plus the parent's world rotation applied
to the bone's rest offset.

The tracked arm follows Zhu & Shi, sec. 4 exactly::

    upper arm world = initRotation * parent.rotation * inertialRotation
    forearm world   = parent.rotation * Euler(flex, -flex, 0)    (paper's 45 deg mounting)
    forearm world   = parent.rotation * hinge(flex)              (board aligned with the arm)

where ``inertialRotation`` is the tracker's q_WS turned into the bone frame
by the board's mounting (``q_WS * q_SB``), and ``initRotation`` is what the
wearing calibration (:mod:`game.body.wearing`) found when the player held the
arm down.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from mypy_extensions import mypyc_attr

from tracker import quat as Q
from tracker.fusion import qmath as q

from .pose import ArmPose, Quat

Vec = tuple[float, float, float]

Side = Literal["right", "left"]
Mounting = Literal["aligned", "paper45"]
IDENTITY: Quat = (1.0, 0.0, 0.0, 0.0)
REFERENCE_HEIGHT_M = 1.75  # the torso offsets below are for this height


@dataclass(frozen=True)
class Bone:
    """A bone: its parent, where its joint sits in the parent's frame at rest, its length."""

    name: str
    parent: str | None
    offset: tuple[float, float, float]
    length: float = 0.0


@mypyc_attr(native_class=False)  # a plain class even when compiled (README, "The compiled build")
@dataclass(frozen=True)
class BodySettings:
    """The player's body; arm lengths default to ARCHITECTURE.md's arm model."""

    height_m: float = REFERENCE_HEIGHT_M
    upper_arm_m: float = 0.30
    forearm_m: float = 0.27
    hand_m: float = 0.08
    side: Side = "right"  # the arm that wears the board
    mounting: Mounting = "aligned"  # how the forearm follows the flex angle (Zhu & Shi, sec. 4)

    def __post_init__(self) -> None:
        if self.side not in ("right", "left"):
            raise ValueError(f"side must be 'right' or 'left', not {self.side!r}")
        if self.mounting not in ("aligned", "paper45"):
            raise ValueError(f"mounting must be 'aligned' or 'paper45', not {self.mounting!r}")
        for name in ("height_m", "upper_arm_m", "forearm_m", "hand_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and 0 < value < 3):
                raise ValueError(f"{name} must be a length in metres between 0 and 3, not {value!r}")


def skeleton(body: BodySettings) -> tuple[Bone, ...]:
    """The bone hierarchy: hips, spine, chest, neck, head; per side shoulder, upper arm, forearm, hand.

    Torso offsets scale with height; the arms take the player's own lengths.
    """
    k = body.height_m / REFERENCE_HEIGHT_M
    bones = [
        Bone("hips", None, (0.0, 0.0, 1.00 * k)),
        Bone("spine", "hips", (0.0, 0.0, 0.12 * k)),
        Bone("chest", "spine", (0.0, 0.0, 0.22 * k)),
        Bone("neck", "chest", (0.0, 0.0, 0.18 * k)),
        Bone("head", "neck", (0.0, 0.0, 0.10 * k), 0.0),
    ]
    for side, sign in (("right", 1.0), ("left", -1.0)):
        bones += [
            Bone(f"{side}_shoulder", "chest", (sign * 0.04 * k, 0.0, 0.15 * k)),
            Bone(f"{side}_upper_arm", f"{side}_shoulder", (sign * 0.15 * k, 0.0, 0.0), body.upper_arm_m),
            Bone(f"{side}_forearm", f"{side}_upper_arm", (0.0, 0.0, -body.upper_arm_m), body.forearm_m),
            Bone(f"{side}_hand", f"{side}_forearm", (0.0, 0.0, -body.forearm_m), body.hand_m),
        ]
    return tuple(bones)


@dataclass(frozen=True)
class Wearing:
    """How the board sits on the arm and how the tracker's world meets the avatar's.

    ``mount`` is q_SB, the bone frame seen from the sensor (the ideal board has
    its y axis along the elbow hinge and -x forward: a quarter turn about z);
    ``init`` is Zhu & Shi's initRotation.
    """

    mount: Quat = (math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))
    init: Quat = IDENTITY


@dataclass(frozen=True)
class ArmState:
    """What one update of the avatar gives the game (world frame, metres)."""

    t: float
    shoulder: np.ndarray
    elbow: np.ndarray
    wrist: np.ndarray
    hand: np.ndarray  # the fingertips
    pointing: np.ndarray  # unit vector along the upper arm, shoulder to elbow
    elevation_deg: float  # angle of the upper arm from hanging straight down
    flex_deg: float


def hinge(flex_deg: float, mounting: Mounting) -> Quat:
    """The forearm's rotation in the upper arm's frame (Zhu & Shi, sec. 4).

    ``aligned``: a single rotation about the hinge (the bone's x axis).
    ``paper45``: the paper's Unity call ``Quaternion.Euler(flex, -flex, 0)``
    (z, then x, then y, about fixed axes), which counteracts its board's
    45 degree offset about the arm.
    """
    if mounting == "paper45":
        return tuple(float(c) for c in Q.unity_euler(flex_deg, -flex_deg, 0.0))  # type: ignore[return-value]
    half = 0.5 * math.radians(flex_deg)
    return (math.cos(half), math.sin(half), 0.0, 0.0)


@dataclass
class Avatar:
    """A posed skeleton; :meth:`update` poses the tracked arm and returns its joints."""

    body: BodySettings = field(default_factory=BodySettings)
    wearing: Wearing = field(default_factory=Wearing)
    body_yaw: float = 0.0  # radians, the avatar turned about the vertical (walking)
    position: tuple[float, float] = (0.0, 0.0)  # where the avatar stands on the ground
    bones: tuple[Bone, ...] = field(init=False)
    local: dict[str, Quat] = field(init=False)
    world_rot: dict[str, Quat] = field(init=False)
    world_pos: dict[str, Vec] = field(init=False)

    def __post_init__(self) -> None:
        self.bones = skeleton(self.body)
        self._by_name = {b.name: b for b in self.bones}
        self.local = {b.name: IDENTITY for b in self.bones}
        self.world_rot, self.world_pos = {}, {}
        self._arm_bones = _subtree(self.bones, f"{self.body.side}_upper_arm")
        self._body_key: tuple | None = None
        self.forward_kinematics()

    # ------------------------------------------------------------ kinematics

    def forward_kinematics(self, arm: ArmPose | None = None) -> None:
        """World rotations and joint positions of every bone, parents first.

        With an ``arm`` pose the tracked arm takes Zhu & Shi's chain (see
        :meth:`_tracked`) instead of parent * local. Scalar quaternion math
        (:mod:`tracker.fusion.qmath`): this runs once per frame. While the body
        stands as before (position, yaw and local rotations unchanged) only the
        tracked arm's bones are posed again.
        """
        root = (math.cos(0.5 * self.body_yaw), 0.0, 0.0, math.sin(0.5 * self.body_yaw))
        key = (self.body_yaw, self.position, tuple(self.local.values()))
        bones = self._arm_bones if key == self._body_key else self.bones
        self._body_key = key
        for bone in bones:
            if bone.parent is None:
                parent_rot, parent_pos = root, (self.position[0], self.position[1], 0.0)
            else:
                parent_rot, parent_pos = self.world_rot[bone.parent], self.world_pos[bone.parent]
            self.world_pos[bone.name] = _add(parent_pos, q.rotate(parent_rot, bone.offset))
            tracked = self._tracked(bone.name, parent_rot, arm) if arm else None
            self.world_rot[bone.name] = tracked or q.mul(parent_rot, self.local[bone.name])

    def _tracked(self, name: str, parent_rot: Quat, arm: ArmPose) -> Quat | None:
        """The tracked arm's world rotations (Zhu & Shi, sec. 4); None for any other bone.

        The hand follows the forearm rigidly (parent * identity), so it needs no case.
        """
        side = self.body.side
        if name == f"{side}_upper_arm":
            return self._chain(parent_rot, arm.q_upper)
        if name == f"{side}_forearm":
            return q.mul(parent_rot, hinge(arm.flex_deg, self.body.mounting))
        return None

    def _chain(self, parent_rot: Quat, q_upper: Quat) -> Quat:
        """initRotation * parent.rotation * inertialRotation, inertialRotation = q_WS * q_SB."""
        inertial = q.mul(q_upper, self.wearing.mount)
        return q.normalize(q.mul(q.mul(self.wearing.init, parent_rot), inertial))

    def end_of(self, name: str) -> Vec:
        """Where a bone ends: its joint plus its length along its own -z."""
        bone = self._by_name[name]
        return _add(self.world_pos[name], q.rotate(self.world_rot[name], (0.0, 0.0, -bone.length)))

    def upper_arm_rotation(self, q_upper: Quat) -> Quat:
        """The tracked upper arm's world rotation for a reading, with the body as it stands."""
        self.forward_kinematics()  # the parent (shoulder) follows the body
        return self._chain(self.world_rot[f"{self.body.side}_shoulder"], q_upper)

    def update(self, arm: ArmPose) -> ArmState:
        """Pose the tracked arm from one ArmPose and return its joints."""
        side = self.body.side
        self.forward_kinematics(arm)
        pointing = q.rotate(self.world_rot[f"{side}_upper_arm"], (0.0, 0.0, -1.0))
        elevation = math.degrees(math.acos(max(-1.0, min(1.0, -pointing[2]))))
        return ArmState(arm.t, np.array(self.world_pos[f"{side}_upper_arm"]),
                        np.array(self.world_pos[f"{side}_forearm"]), np.array(self.world_pos[f"{side}_hand"]),
                        np.array(self.end_of(f"{side}_hand")), np.array(pointing), elevation, arm.flex_deg)


def _add(a: Vec, b: Vec) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _subtree(bones: tuple[Bone, ...], name: str) -> tuple[Bone, ...]:
    """The bone called ``name`` and every bone below it, parents first."""
    names = {name}
    for bone in bones:
        if bone.parent in names:
            names.add(bone.name)
    return tuple(b for b in bones if b.name in names)
