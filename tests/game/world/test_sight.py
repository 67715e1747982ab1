"""Line of sight: buildings block it, lamp posts do not, and an eye sees over a low wall; the start faces
where the view is open."""

import math

import numpy as np
import pytest

from game.world.collision import segment_box
from game.world.sight import clear_distance, line_of_sight, line_of_sight_3d, open_yaw, sees
from game.world.town import Obstacle, Town, make_town


def town_of(*obstacles):
    return Town(half_size_m=20.0, obstacles=tuple(obstacles))


def test_a_building_between_blocks_sight_and_one_beside_the_line_does_not():
    between = town_of(Obstacle("building", 4.0, -2.0, 8.0, 2.0, 6.0))
    beside = town_of(Obstacle("building", 4.0, 1.0, 8.0, 5.0, 6.0))
    assert not line_of_sight(between, (0.0, 0.0), (12.0, 0.0))
    assert line_of_sight(beside, (0.0, 0.0), (12.0, 0.0))
    assert line_of_sight(between, (0.0, 0.0), (3.0, 0.0))  # stops short of it
    assert not sees(between, (0.0, 0.0), (12.0, 0.0))


def test_a_lamp_post_beside_the_line_or_on_it_hides_nothing_where_a_car_the_same_place_would():
    beside = Obstacle("lamp_post", 5.0, 0.1, 5.25, 0.35, 4.5)
    on = Obstacle("lamp_post", 5.0, -0.1, 5.25, 0.15, 4.5)
    assert line_of_sight(town_of(beside), (0.0, 0.0), (12.0, 0.0))
    assert line_of_sight(town_of(on), (0.0, 0.0), (12.0, 0.0))
    assert not line_of_sight(town_of(Obstacle("car", 5.0, -0.1, 5.25, 0.15, 1.4)), (0.0, 0.0), (12.0, 0.0))


def test_an_eye_sees_a_chest_over_a_low_wall_that_the_ground_plan_calls_blocked():
    """Eye at 1.6 m at x = 0, chest at 1.2 m at x = 10: the line is at 1.6 - 0.04 x. A wall at x 5..5.3
    (line at 1.40..1.388) of 1.0 m is below it; one of 2.0 m is not."""
    low = town_of(Obstacle("wall", 5.0, -3.0, 5.3, 3.0, 1.0))
    high = town_of(Obstacle("wall", 5.0, -3.0, 5.3, 3.0, 2.0))
    assert not line_of_sight(low, (0.0, 0.0), (10.0, 0.0))
    assert line_of_sight_3d(low, (0.0, 0.0, 1.6), (10.0, 0.0, 1.2))
    assert sees(low, (0.0, 0.0), (10.0, 0.0))
    assert not line_of_sight_3d(high, (0.0, 0.0, 1.6), (10.0, 0.0, 1.2))


def test_a_low_wall_right_in_front_of_the_target_hides_its_chest():
    """A wall at x 9.5..9.7: the line is at 1.22..1.212 there. 1.25 m hides the chest; 1.2 m does not."""
    assert not sees(town_of(Obstacle("wall", 9.5, -3.0, 9.7, 3.0, 1.25)), (0.0, 0.0), (10.0, 0.0))
    assert sees(town_of(Obstacle("wall", 9.5, -3.0, 9.7, 3.0, 1.2)), (0.0, 0.0), (10.0, 0.0))


def test_the_cells_walked_along_the_line_find_every_obstacle_that_blocks_it():
    """Oracle: every obstacle of the town tried, for random lines across a generated town."""
    town = make_town(6, "ring")
    rng = np.random.default_rng(6)
    inf = float("inf")
    blocked = 0
    for _ in range(300):
        (ax, ay), (bx, by) = rng.uniform(-town.half_size_m, town.half_size_m, (2, 2))
        brute = all(not o.hides or segment_box(ax, ay, 0.0, bx - ax, by - ay, 0.0, o.x0, o.y0, -inf, o.x1, o.y1, inf)
                    == inf for o in town.obstacles)
        assert line_of_sight(town, (ax, ay), (bx, by)) == brute
        eye, chest = (ax, ay, 1.6), (bx, by, 1.2)
        brute_3d = all(not o.hides or segment_box(*eye, bx - ax, by - ay, -0.4, o.x0, o.y0, 0.0, o.x1, o.y1,
                                                  o.height) == inf for o in town.obstacles)
        assert line_of_sight_3d(town, eye, chest) == brute_3d
        blocked += not brute
    assert 50 < blocked < 290


def test_the_start_faces_the_one_open_way_out_of_a_walled_yard():
    # Walls 3 m north, south and west of the origin; east is open to the town's edge (20 m).
    # Worked by hand: north 3 m, north-east meets the north wall at (3, 3), 3 sqrt(2) m away;
    # yaw -90 deg faces +x (yaw 0 faces +y, positive turns left).
    yard = town_of(Obstacle("wall", -20.0, 3.0, 20.0, 4.0, 3.0), Obstacle("wall", -20.0, -4.0, 20.0, -3.0, 3.0),
                   Obstacle("wall", -4.0, -3.0, -3.0, 3.0, 3.0))
    assert clear_distance(yard, (0.0, 0.0), 0.0, 20.0) == pytest.approx(3.0)
    assert clear_distance(yard, (0.0, 0.0), -math.pi / 4, 20.0) == pytest.approx(3.0 * math.sqrt(2.0))
    assert clear_distance(yard, (0.0, 0.0), -math.pi / 2, 20.0) == pytest.approx(20.0)
    assert open_yaw(yard, (0.0, 0.0)) == pytest.approx(-math.pi / 2)


def test_of_equal_views_the_start_faces_along_the_axes_and_north_first():
    assert open_yaw(town_of(), (0.0, 0.0)) == 0.0  # open every way: north
    # A building north-west to north-east (and a lamp post, which hides nothing, due south):
    # north and the diagonals beside it are blocked; west, east and south see 20 m, as do the
    # south diagonals: west (the first axis from north, turning left) wins.
    blocked = town_of(Obstacle("building", -8.0, 5.0, 8.0, 9.0, 6.0), Obstacle("lamp_post", -0.1, -6.0, 0.1, -5.8, 4.5))
    assert open_yaw(blocked, (0.0, 0.0)) == pytest.approx(math.pi / 2)


def test_every_generated_town_starts_facing_down_a_street_clear_to_its_edge():
    for seed in range(12):
        town = make_town(seed)
        yaw = open_yaw(town, town.start)
        assert clear_distance(town, town.start, yaw, town.half_size_m) == pytest.approx(town.half_size_m), seed
        assert yaw % (math.pi / 2) == pytest.approx(0.0), seed  # along the streets, not across a corner
