"""Wearing calibration: where the board sits on the arm, and where "forward" is.

Sec. 6 of Zhu & Shi names the weaknesses this answers: the board worn at an
unknown angle ("wearing offset") and the heading drifting away. The paper
only asks the player to hold the arm straight down and picks initRotation to
match (sec. 4); here that pose also finds the arm's long axis in the sensor
frame, an optional second pose (arm straight forward) finds the rotation
about it, and a recenter turns "where I point now" into forward.

The arm's long axis: held straight down, the upper arm lies along world -z,
so in the sensor frame it is ``conj(q_down) * (0, 0, -1) * q_down``. Raising
the straight arm forward turns it a quarter turn about the shoulder's
left-right axis, the bone's x axis; that rotation, seen in the sensor frame,
is ``conj(q_down) * q_forward``, and its axis is the bone's x axis in sensor
coordinates. The two axes give the bone frame in the sensor frame, q_SB.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from tracker import quat as Q
from tracker.calibration import HOLD_SLACK_S, LONGER_HOLD_S, TREMOR_MIN_HZ, StartupParams

from .avatar import Avatar, Wearing
from .pose import ArmPose, Quat

MOVE_DEG = math.degrees(StartupParams().max_tilt)  # a pose's smoothed orientations may lie this far
# apart (deg): a postural sway of up to 4 deg peak swings the arm up to 8 deg (the start-up hold's bound)
FORWARD_RANGE_DEG = (60.0, 120.0)  # how far "arm straight forward" may be from "arm down"
DOWN_S = StartupParams().duration + HOLD_SLACK_S  # the arm-down hold (s): 2.5
HOLD_S = {"down": DOWN_S, "longer": LONGER_HOLD_S - DOWN_S, "forward": 2.0}  # each step's hold (s);
# "longer" goes on from "down" when the hold's judgement asks for it (tracker.calibration.LONGER_HOLD)
POSE_WINDOW_S = 1.0  # a held pose is judged and taken over its hold's last second: the player has
# settled into it, and so has the filter that "hold still" runs again over the hold from a fresh state
# (over the whole hold the worst plausible player's arm-down poses moved 3.4-12.4 deg, its first half
# second's settling included; over the last second 1.3-4.1: seeds 0-11, a scratch run)


@dataclass(frozen=True)
class CalibrationResult:
    """The outcome of a calibration step: a new wearing, or why not."""

    ok: bool
    message: str
    wearing: Wearing


def mean_orientation(quats: Sequence[Quat]) -> np.ndarray:
    """The chordal mean of nearby orientations (signs aligned to the first)."""
    q = np.asarray(quats, dtype=float)
    q = q * np.where(q @ q[0] < 0, -1.0, 1.0)[:, None]
    return Q.normalize(q.mean(axis=0))


def _hann_mean(quats: np.ndarray, t: np.ndarray, t0: float, length: float) -> np.ndarray:
    """The chordal mean of the orientations in [t0, t0 + length], Hann-weighted: a low-pass
    whose first zero is at 2 / length (Harris 1978, sec. V.C), so tremor averages out."""
    x = np.clip((t - t0) / length, 0.0, 1.0)
    w = np.sin(np.pi * x) ** 2
    if not w.any():  # no sample inside: the one nearest the window's centre
        w[np.argmin(np.abs(t - (t0 + length / 2)))] = 1.0
    return Q.normalize(w @ quats)


def moved_deg(poses: Sequence[ArmPose]) -> float:
    """How far the arm turned (deg) during a held pose, tremor and sway aside.

    Tremor and sway oscillate about the pose, a move does not: the orientations are
    low-passed (Hann windows of 2 / TREMOR_MIN_HZ, whose first zero is the slowest tremor,
    or half the pose when it is shorter), which tremor at TREMOR_MIN_HZ and above hardly
    reaches, at the pose's start, its end and every quarter window between, and the move is
    the widest angle between two of them: an arm that went out and came back moved too, though
    its ends agree. Sway swings at most twice its peak.
    """
    q = np.asarray([p.q_upper for p in poses], dtype=float)
    q = q * np.where(q @ q[0] < 0, -1.0, 1.0)[:, None]
    t = np.asarray([p.t for p in poses], dtype=float)
    length = max(1e-9, min(2.0 / TREMOR_MIN_HZ, (t[-1] - t[0]) / 2))
    room = max(0.0, t[-1] - length - t[0])  # how far the window slides
    starts = np.linspace(t[0], t[0] + room, 2 + math.ceil(4.0 * room / length))
    means = np.array([_hann_mean(q, t, start, length) for start in starts])
    return math.degrees(float(np.max(Q.angle_between(means[:, None], means[None, :]))))


def _still(poses: Sequence[ArmPose], what: str) -> tuple[np.ndarray | None, str]:
    """The pose's mean orientation, or why the arm did not hold it."""
    if len(poses) < 2:
        return None, f"{what}: no samples arrived (is the board streaming?)"
    moved = moved_deg(poses)
    if moved > MOVE_DEG:
        return None, (f"{what}: the arm moved {moved:.1f} degrees during the pose; hold it still "
                      f"(a still arm drifts less than {MOVE_DEG:.1f}) and try again")
    return mean_orientation([p.q_upper for p in poses]), ""


def _mount_from_axes(long_axis_s: np.ndarray, x_hint_s: np.ndarray) -> np.ndarray:
    """q_SB from the arm's downward long axis and a hint for the bone's x axis (sensor frame)."""
    z = -long_axis_s / np.linalg.norm(long_axis_s)
    x = x_hint_s - np.dot(x_hint_s, z) * z
    if np.linalg.norm(x) < 1e-6:
        raise ValueError("the hint for the bone's x axis is parallel to the arm")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return Q.from_matrix(np.stack([x, y, z], axis=1))


def _init_for_rest(avatar: Avatar, q_down: np.ndarray, mount: np.ndarray) -> np.ndarray:
    """initRotation that makes the avatar's arm hang at rest for this reading (Zhu & Shi, sec. 4).

    Rest means the upper arm's world rotation equals its parent's (local
    identity): init * parent * q_down * mount = parent.
    """
    avatar.forward_kinematics()
    parent = avatar.world_rot[f"{avatar.body.side}_shoulder"]
    return Q.multiply(parent, Q.conjugate(Q.multiply(parent, Q.multiply(q_down, mount))))


def last_held(poses: Sequence[ArmPose]) -> list[ArmPose]:
    """The poses of a hold's last POSE_WINDOW_S seconds, which make the pose."""
    end = poses[-1].t if poses else 0.0
    return [p for p in poses if p.t > end - POSE_WINDOW_S]


def arm_down(avatar: Avatar, poses: Sequence[ArmPose]) -> CalibrationResult:
    """"Hold your arm straight down": the arm's long axis and initRotation.

    The rotation about the arm is kept from the current mounting (the ideal
    board's, or a previous two-pose calibration's).
    """
    q_down, problem = _still(poses, "arm down")
    if q_down is None:
        return CalibrationResult(False, problem, avatar.wearing)
    long_axis = Q.rotate(Q.conjugate(q_down), (0.0, 0.0, -1.0))
    x_hint = Q.rotate(avatar.wearing.mount, (1.0, 0.0, 0.0))
    try:
        mount = _mount_from_axes(long_axis, x_hint)
    except ValueError:  # the old mounting's x lies along the arm: start from the sensor's y
        mount = _mount_from_axes(long_axis, Q.rotate(Q.conjugate(q_down), (0.0, 1.0, 0.0)))
    init = _init_for_rest(avatar, q_down, mount)
    wearing = Wearing(tuple(mount), tuple(init))
    return CalibrationResult(True, "arm down: calibrated", wearing)


def arm_down_then_forward(avatar: Avatar, down: Sequence[ArmPose],
                          forward: Sequence[ArmPose]) -> CalibrationResult:
    """Two poses: the full mounting (about and across the arm), initRotation and forward."""
    q_down, problem = _still(down, "arm down")
    if q_down is None:
        return CalibrationResult(False, problem, avatar.wearing)
    q_fwd, problem = _still(forward, "arm forward")
    if q_fwd is None:
        return CalibrationResult(False, problem, avatar.wearing)
    turn = Q.multiply(Q.conjugate(q_down), q_fwd)  # the raise, in the sensor frame at "down"
    axis, angle = Q.to_axis_angle(turn)
    low, high = FORWARD_RANGE_DEG
    if not low <= math.degrees(angle) <= high:
        return CalibrationResult(False, (
            f"arm forward: the arm turned {math.degrees(angle):.0f} degrees from hanging down; raise "
            "it straight forward to shoulder height (90 degrees) and hold it there"), avatar.wearing)
    long_axis = Q.rotate(Q.conjugate(q_down), (0.0, 0.0, -1.0))
    mount = _mount_from_axes(long_axis, axis)
    wearing = Wearing(tuple(mount), tuple(_init_for_rest(avatar, q_down, mount)))
    # The raise was straight forward, so the forward pose defines "forward".
    centred = recenter(replace(avatar, wearing=wearing), ArmPose(tuple(q_fwd), 0.0, forward[-1].t))
    return CalibrationResult(True, "arm down and forward: calibrated", centred)


def recenter(avatar: Avatar, pose: ArmPose) -> Wearing:
    """"Forward is where I point now": turn initRotation about the vertical.

    The avatar's forward is its shoulder's +y. The arm's horizontal heading
    now is turned onto it; pointing straight up or down leaves heading as is.
    """
    upper = avatar.upper_arm_rotation(pose.q_upper)
    pointing = Q.rotate(upper, (0.0, 0.0, -1.0))
    forward = Q.rotate(avatar.world_rot[f"{avatar.body.side}_shoulder"], (0.0, 1.0, 0.0))
    if math.hypot(pointing[0], pointing[1]) < 0.2:
        return avatar.wearing
    turn = math.atan2(forward[1], forward[0]) - math.atan2(pointing[1], pointing[0])
    init = Q.multiply(Q.from_axis_angle((0.0, 0.0, 1.0), turn), avatar.wearing.init)
    return Wearing(avatar.wearing.mount, tuple(init))
