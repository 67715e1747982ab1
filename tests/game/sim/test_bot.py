"""The bot's judgement: aim worked by hand, fleeing, facing, fatigue, and the calibration it follows."""

import math
from dataclasses import replace

import numpy as np
import pytest

from game.sim.bot import DIFFICULTIES, Bot, Screen
from game.sim.motion_model import SPEED_RANGE, PlayerProfile, direction
from game.world.arena import Arena
from game.world.arena_model import Controls
from game.world.town import Obstacle, Town

from ..world.test_arena import OPEN

SHOULDER = (0.2, 0.0, 1.4)


def _bot(difficulty: str = "normal", **changes) -> Bot:
    skill = DIFFICULTIES[difficulty]
    return Bot(replace(skill, **changes), seed=3)


def test_aim_at_a_zombie_ahead_worked_by_hand():
    # A zombie 10 m straight north of the shoulder; the chest (1.2 m) is 0.2 m below the shoulder (1.4 m):
    # azimuth 0, elevation 90 - atan(0.2 / 10) = 88.854 deg.
    arena = Arena(seed=1, town=OPEN)
    z = arena.add_zombie(0.2, 10.0, speed=1.0)
    az, el = _bot(leads_targets=False)._aim(z, arena, SHOULDER, 0.0)
    assert az == pytest.approx(0.0, abs=1e-9)
    assert el == pytest.approx(90.0 - math.degrees(math.atan2(0.2, 10.0)), abs=1e-9)


def test_aim_turns_with_the_body_and_leads_a_walking_zombie():
    arena = Arena(seed=1, town=OPEN)
    arena.player.yaw = math.pi / 2  # facing west (-x): a zombie to the north is on the right
    z = arena.add_zombie(0.0, 10.0, speed=1.0)
    az, _ = _bot(leads_targets=False)._aim(z, arena, (0.0, 0.0, 1.4), 0.0)
    assert az == pytest.approx(90.0, abs=1e-9)
    # Leading by 2 s: it walks 2 m straight at the player, so it is aimed at 8 m, lower down.
    _, el_now = _bot(leads_targets=True)._aim(z, arena, (0.0, 0.0, 1.4), 0.0)
    _, el_ahead = _bot(leads_targets=True)._aim(z, arena, (0.0, 0.0, 1.4), 2.0)
    assert el_ahead == pytest.approx(90.0 - math.degrees(math.atan2(0.2, 8.0)), abs=1e-9)
    assert el_ahead < el_now


def test_a_close_zombie_makes_it_walk_away_until_well_clear_and_not_mid_throw():
    arena = Arena(seed=1, town=OPEN)
    bot = _bot()
    bot.play_started = 0.0
    arena.add_zombie(0.0, 15.0, speed=1.0)
    assert bot.act(1.0, Screen("play"), arena, SHOULDER).controls.forward == 0.0  # far: it throws
    assert bot.launches and bot.script.now > 2.0
    near = arena.add_zombie(0.0, 2.0, speed=1.0)  # straight ahead, 1.1 s from contact
    assert bot.act(1.1, Screen("play"), arena, SHOULDER).controls == Controls()  # mid-throw: stays
    near.y = 1.4  # 0.5 s from contact: about to strike, so it walks even mid-throw
    c = bot.act(1.2, Screen("play"), arena, SHOULDER).controls
    assert c.forward == pytest.approx(-1.0) and c.strafe == pytest.approx(0.0, abs=1e-12)  # backs off south
    near.y = 4.0  # 3.1 s away: under 1.3 FLEE_S (3.25 s), so it keeps walking once the arm is free
    assert bot.act(bot.script.now + 0.1, Screen("play"), arena, SHOULDER).controls.forward < 0.0
    near.y = 7.0  # 6.1 s: clear
    assert bot.act(bot.script.now + 0.2, Screen("play"), arena, SHOULDER).controls.forward == 0.0


def test_a_target_behind_is_turned_to_before_any_throw():
    arena = Arena(seed=1, town=OPEN)
    arena.add_zombie(3.0, -12.0, speed=0.5)  # behind, to the right (east)
    bot = _bot()
    bot.play_started = 0.0
    action = bot.act(1.0, Screen("play"), arena, SHOULDER)
    assert action.controls.turn == -1.0  # a right turn is negative
    assert bot.launches == []


def test_a_target_ahead_gets_a_throw_after_the_reaction_time_toward_it():
    arena = Arena(seed=1, town=OPEN)
    arena.add_zombie(0.2, 15.0, speed=0.5)
    bot = _bot("hard", aim_noise_deg=0.0)
    bot.act(1.0, Screen("play"), arena, SHOULDER)
    launch = bot.launches[0]
    assert launch.t_straight_start > 1.0 + DIFFICULTIES["hard"].reaction_s
    aim = np.asarray(launch.direction_body)
    assert math.degrees(math.acos(np.clip(aim @ direction(0.0, 90.0), -1, 1))) < 1.5  # about level, ahead


def test_fatigue_slows_the_movements():
    bot = _bot(fatigue_per_min=0.1)
    bot._tire(10.0)
    assert bot.script.profile.speed == pytest.approx(bot.profile.speed / 2.0)


def test_calibration_raises_forward_when_asked_then_lowers_and_presses_enter():
    bot = _bot()
    arena = Arena(seed=1, town=OPEN)
    assert bot.act(0.1, Screen("menu"), arena, SHOULDER).keys == ("return",)
    bot.act(1.0, Screen("calibration", "down"), arena, SHOULDER)
    assert bot.script.now == 0.0  # still: nothing planned
    bot.act(5.0, Screen("calibration", "forward"), arena, SHOULDER)
    assert bot.script.pointing_at(7.0) == pytest.approx([0.0, 1.0, 0.0], abs=1e-12)  # level, forward
    keys = [bot.act(t, Screen("calibration", "done"), arena, SHOULDER).keys for t in np.arange(8.0, 11.0, 0.1)]
    assert keys.count(("return",)) == 1
    assert bot.script.pointing_at(11.0) == pytest.approx([0.0, 0.0, -1.0], abs=1e-12)  # down


def test_a_bot_keeps_a_slow_player_within_the_speeds_a_profile_allows():
    """The easy bot moves at 0.8 times the player's speed, but never below the slowest profile."""
    slowest, fastest = SPEED_RANGE
    assert Bot(DIFFICULTIES["easy"], PlayerProfile(speed=slowest)).profile.speed == slowest
    assert Bot(DIFFICULTIES["hard"], PlayerProfile(speed=fastest)).profile.speed == fastest
    assert Bot(DIFFICULTIES["easy"], PlayerProfile(speed=2.0)).profile.speed == 1.6


def _behind(*obstacles: Obstacle) -> Arena:
    arena = Arena(seed=1, town=Town(half_size_m=18.0, obstacles=obstacles, spawn_points=OPEN.spawn_points))
    arena.player.yaw = 0.0  # the cases are drawn facing north (a match would start facing its open view)
    return arena


def test_a_zombie_behind_a_building_is_not_thrown_at_but_one_in_sight_is():
    arena = _behind(Obstacle("building", -3.0, 6.0, 3.0, 10.0, 8.0))
    arena.add_zombie(0.2, 12.0, speed=0.5)  # straight ahead, hidden by the building
    bot = _bot("hard", aim_noise_deg=0.0)
    bot.play_started = 0.0
    bot.act(1.0, Screen("play"), arena, SHOULDER)
    assert bot.launches == []
    arena.add_zombie(-8.0, 12.0, speed=0.5)  # off to the side, in sight past the corner
    bot.act(bot.script.now + 0.1, Screen("play"), arena, SHOULDER)  # after the idle it fell into
    assert len(bot.launches) == 1
    az = math.degrees(math.atan2(bot.launches[0].direction_body[0], bot.launches[0].direction_body[1]))
    assert az == pytest.approx(math.degrees(math.atan2(-8.0 - SHOULDER[0], 12.0)), abs=3.0)


def test_a_fleeing_bot_turns_aside_where_a_wall_blocks_its_way():
    arena = _behind(Obstacle("wall", -5.0, -1.2, 5.0, -0.9, 2.5))  # just south of the player
    near = arena.add_zombie(0.0, 1.4, speed=1.0)  # north, about to strike: it walks away south...
    bot = _bot()
    bot.play_started = 0.0
    c = bot.act(1.0, Screen("play"), arena, SHOULDER).controls
    assert near.state.value == "walking"
    assert abs(c.strafe) > 0.5  # ...but the wall is there: it goes east or west along it
    assert c.forward >= -0.75


def test_a_cornered_bot_stands_and_throws():
    """Walls west, east and south within a step; the zombie comes from the open north: no way
    out but past it, so the bot throws at it instead of pressing into a wall."""
    arena = _behind(Obstacle("wall", -1.1, -1.0, -0.8, 3.0, 2.5), Obstacle("wall", 0.8, -1.0, 1.1, 3.0, 2.5),
                    Obstacle("wall", -1.1, -1.1, 1.1, -0.8, 2.5))
    arena.add_zombie(0.0, 3.0, speed=1.0)  # 1.9 s from contact: the bot would flee
    bot = _bot(aim_noise_deg=0.0, leads_targets=False)
    bot.play_started = 0.0
    assert bot.act(1.0, Screen("play"), arena, SHOULDER).controls == Controls()
    assert len(bot.launches) == 1
    x, y, _ = bot.launches[0].direction_body  # at the zombie from the shoulder (0.2 m east of it)
    assert math.degrees(math.atan2(x, y)) == pytest.approx(math.degrees(math.atan2(-SHOULDER[0], 3.0)), abs=1.0)


def test_a_fleeing_bot_held_in_place_by_bodies_stands_and_throws():
    """Open ground, but the walking does not move the player (bodies in the way): after STUCK_S
    of fleeing without moving it throws."""
    arena = Arena(seed=1, town=OPEN)
    arena.add_zombie(0.0, 3.0, speed=1.0)
    bot = _bot(aim_noise_deg=0.0)
    bot.play_started = 0.0
    walked = [bot.act(t, Screen("play"), arena, SHOULDER) for t in np.arange(1.0, 1.95, 1 / 60)]
    assert all(a.controls.forward == pytest.approx(-1.0) for a in walked) and bot.launches == []
    bot.act(2.05, Screen("play"), arena, SHOULDER)  # a second on, the player has not moved
    assert len(bot.launches) == 1


def test_with_zombies_about_but_none_in_sight_it_walks_back_to_the_open_square():
    arena = _behind(Obstacle("building", 6.0, 12.0, 12.0, 18.0, 8.0))
    arena.player.x, arena.player.y = 0.0, 10.0  # north of the start square, facing north
    arena.add_zombie(14.0, 15.0, speed=0.5)  # behind the building: heard, not seen
    bot = _bot()
    bot.play_started = 0.0
    c = bot.act(1.0, Screen("play"), arena, SHOULDER).controls
    assert c.forward == pytest.approx(-1.0, abs=0.05) and bot.launches == []  # south, toward (0, 0)
    arena.player.x, arena.player.y = 0.5, 0.0  # on the square: it waits for them there
    assert bot.act(2.0, Screen("play"), arena, SHOULDER).controls == Controls()
