"""The wearing calibration's "forward" kept while the magnetometer's heading settles
(game/body/heading_anchor.py, issue 12: a disturbed magnetometer never makes the pose worse than none)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from game.body.heading_anchor import GYRO_HEADING_SD, HeadingAnchor
from game.body.tracking import Tracking
from game.sim.gesture_eval import run_trial
from game.sim.motion_model import PlayerProfile

DEG = math.pi / 180


def test_each_turn_moves_forward_by_the_fixed_point_smoothers_share():
    # Worked by hand: the heading was taken from a field spreading by 5 deg (p0 = 25 deg^2) and the
    # gyroscope strays by s = 0.4 deg/s, so a turn t seconds later counts 25 / (25 + (0.4 t)^2).
    assert GYRO_HEADING_SD == pytest.approx(0.4 * DEG)
    anchor = HeadingAnchor()
    assert anchor.follow(1.0, 0.3) == 0.0  # no calibration yet: nothing is taken off
    anchor.set(10.0, 0.3, 5 * DEG)
    assert anchor.follow(10.0, 0.3 + 10 * DEG) == pytest.approx(10 * DEG)  # at once: all of it
    assert anchor.follow(22.5, 0.3 + 14 * DEG) == pytest.approx(12 * DEG)  # s t = 5 deg: half of 4
    far = anchor.follow(135.0, 0.3 + 24 * DEG)  # s t = 50 deg: 25 / 2525 of 10
    assert far == pytest.approx(12 * DEG + 10 * DEG * 25 / 2525)
    # Turns wrap: from +179 deg to -179 deg is a turn of 2 deg, not -358.
    anchor.set(0.0, math.radians(179.0), 5 * DEG)
    assert anchor.follow(0.0, math.radians(-179.0)) - far == pytest.approx(2 * DEG)


def test_turns_given_back_by_the_filter_are_given_back_by_forward_too():
    # Worked by hand with the shares above (5 deg spread, s = 0.4 deg/s). "Forward" is taken at 10 s
    # from a heading holding 1 deg a field not yet trusted turned: forward followed all of it. At
    # once the field turns 2 deg more (share 1), at 22.5 s 4 deg more (share a half): the offset is
    # 2 + 2 = 4 deg, and forward has followed 1 + 2 + 2 = 5 deg of the 7 provisional. Found bad, the
    # filter gives back all 7: the heading ends 1 deg below where forward was taken, the offset
    # -1 deg, so the pose is where the calibration saw it, as if the field had never turned it.
    anchor = HeadingAnchor()
    anchor.set(10.0, 0.3, 5 * DEG, 1 * DEG, 0)
    assert anchor.follow(10.0, 0.3 + 2 * DEG, 3 * DEG, 0) == pytest.approx(2 * DEG)
    assert anchor.follow(22.5, 0.3 + 6 * DEG, 7 * DEG, 0) == pytest.approx(4 * DEG)
    offset = anchor.follow(23.0, 0.3 - 1 * DEG, 0.0, 1)
    assert offset == pytest.approx(-1 * DEG) and (0.3 - 1 * DEG) - offset == pytest.approx(0.3)
    # A field that is trusted keeps what it turned: its provisional share becomes 0, nothing moves.
    anchor.set(30.0, 0.3, 5 * DEG, 0.0, 1)
    anchor.follow(30.0, 0.3 + 2 * DEG, 2 * DEG, 1)
    kept = anchor.follow(31.0, 0.3 + 2 * DEG, 0.0, 1)
    assert kept == pytest.approx(offset + 2 * DEG) and anchor.held == 0.0
    assert anchor.follow(32.0, 0.3 + 2 * DEG, 0.0, 2) == kept  # a give-back with nothing provisional


def test_a_calibration_from_a_clean_field_lets_every_turn_through():
    anchor = HeadingAnchor()
    anchor.set(0.0, 0.0, 0.0)  # a field that did not spread: its heading was right
    assert anchor.follow(1.0, 5 * DEG) == 0.0


def test_a_restart_forgets_forward():
    tracking = Tracking()
    tracking.anchor.set(1.0, 0.0, 5 * DEG)
    tracking.reset()
    assert tracking.anchor.t0 is None


# A player drawn within the ranges whose 9D aim was off by up to 6.8 deg in a session
# (sessions 0-7): a 2 deg tremor at 5.9 Hz, 3 deg sway, a 7.75 uT disturbance turning the
# heading the calibration took by up to 12 deg; 6D loses it to the vertical bias (8.7 deg).
DRAWN = PlayerProfile(gyro_bias_dps=9.81, tremor_deg=1.97, tremor_hz=5.87, sway_deg=3.15, wobble_deg=5.22,
                      wobble_hz=12.82, twist_follow=0.66, slip_deg_per_min=1.49, flex_hysteresis_pct=1.28,
                      flex_creep_pct=5.75, gyro_warmup_dps=0.97, mag_hard_iron_ut=51.43, mag_soft_iron_pct=3.69,
                      mag_disturbance_ut=7.75, speed=2.53, noise_scale=1.13)


class _ForwardNotKept:
    """The game's tracking, but "forward" follows every turn of the heading (as before the anchor).
    A wrapper, not a patch: the compiled build's Tracking takes no new attributes."""

    def __init__(self, **kwargs) -> None:
        self._tracking = Tracking(**kwargs)

    def anchor_heading(self) -> None:
        pass

    def __getattr__(self, name: str):
        return getattr(self._tracking, name)


def session_errors(anchored: bool, monkeypatch) -> list[list[float]]:
    if not anchored:
        monkeypatch.setattr("game.sim.gesture_eval.Tracking", _ForwardNotKept)
    errors = [run_trial(DRAWN, seed, 10, True).aim_errors_deg for seed in range(8)]
    monkeypatch.undo()
    return errors


def test_forward_stays_where_the_calibration_saw_it_while_the_field_settles(monkeypatch):
    kept_errors = session_errors(True, monkeypatch)
    kept = [float(np.median(e)) for e in kept_errors]
    free = [float(np.median(e)) for e in session_errors(False, monkeypatch)]
    assert max(free) > 4.5, free  # the premise: the settling heading moved forward (session 5: 6.5 deg)
    assert kept[free.index(max(free))] <= 3.0, kept  # ... and kept, that session meets the target
    assert np.median(np.concatenate(kept_errors)) <= 3.0, kept  # as the player's launches do together
    # One session's median of 11-16 launches of this shaky, fast player moves by half a degree between
    # pipelines that agree on the player (with the drift's settling, session 3 went 2.49 -> 3.17 deg,
    # all launches 2.10 -> 2.24): every session stays well below the field's unanchored 4.5 deg.
    assert max(kept) <= 3.5, kept


def test_a_field_found_bad_while_still_being_checked_leaves_the_aim_near_no_magnetometers():
    # The magnetic room's session 5 (traced, docs/gesture-accuracy-log.md): its field was still being
    # checked at the wearing calibration, settled the heading -2.3 deg over the next 30 s and was then
    # found bad. Kept, those turns left 9D's median aim 1.9 deg worse than 6D's over these 30 gestures
    # (2.23 against 0.35 deg); given back with what "forward" followed of them, 9D is within a degree.
    from game.sim.motion_model import catalogue

    room = catalogue()["magnetic_room"]
    nine, six = (float(np.median(run_trial(room, 5, 30, mag).aim_errors_deg)) for mag in (True, False))
    assert nine <= six + 1.0, (nine, six)
