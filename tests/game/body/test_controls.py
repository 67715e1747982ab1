"""Input sources make the same ArmPose: keyboard and mouse, and a board over a pty."""

import math

import numpy as np
import pytest

from game.body.avatar import Avatar
from game.body.controls import KeyboardMouse, TrackerInput
from tracker.board import VirtualBoard
from tracker.link import LinkSettings


def settle(kb: KeyboardMouse, seconds: float = 1.0):
    pose = None
    for _ in range(int(seconds * 100)):
        pose = kb.update(0.01)
    return pose


def test_keyboard_arm_hangs_until_raised():
    kb = KeyboardMouse()
    state = Avatar().update(settle(kb))
    assert state.elevation_deg == pytest.approx(0, abs=0.5)


@pytest.mark.parametrize("aim_x, aim_y, azimuth, elevation", [(0, 0, 0, 90), (1, 0, 60, 90), (-0.5, 0.5, -30, 105)])
def test_keyboard_aim_points_the_avatar_arm(aim_x, aim_y, azimuth, elevation):
    kb = KeyboardMouse(raised=True, aim_x=aim_x, aim_y=aim_y)
    state = Avatar().update(settle(kb))
    el, az = math.radians(elevation), math.radians(azimuth)
    expected = (math.sin(el) * math.sin(az), math.sin(el) * math.cos(az), -math.cos(el))
    assert state.pointing == pytest.approx(expected, abs=1e-3)


def test_keyboard_flex_bends_the_elbow_smoothly():
    kb = KeyboardMouse(raised=True, flexed=True)
    first = kb.update(0.01).flex_deg
    assert 0 < first < 50  # not a jump: the gesture dwell times see real motion
    assert settle(kb).flex_deg == pytest.approx(100, abs=0.5)


def test_a_board_on_a_pty_gives_poses_and_plots():
    with VirtualBoard() as board:
        tracker = TrackerInput(LinkSettings(board.port))
        assert tracker.opened.wait(5.0) and tracker.error is None
        poses = []
        for _ in range(50):
            pose = tracker.poll()
            if pose is not None:
                poses.append(pose)
            import time
            time.sleep(0.01)
        tracker.close()
    assert poses and np.isclose(np.linalg.norm(poses[-1].q_upper), 1.0)
    series = tracker.plot_series()
    assert series["gyroscope (rad/s)"].shape[1] == 3 and len(series["flex (ADC)"]) > 50


def test_a_missing_port_is_a_status_not_a_crash():
    tracker = TrackerInput(LinkSettings("/dev/ttyNOPE"))
    assert tracker.opened.wait(5.0)
    assert tracker.error and "no such port" in tracker.status
    assert tracker.poll() is None and not tracker.connected
