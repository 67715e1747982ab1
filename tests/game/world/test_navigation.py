"""Navigation: free regions, the flow field over them, and zombies that walk their waypoints to the player."""

import math

import numpy as np
import pytest

from game.world.collision import push_out
from game.world.navigation import NavSettings, Navigator
from game.world.town import LAYOUTS, Obstacle, Town, make_town

R = 0.35
DT = 1.0 / 120.0
SPEED = 1.2  # m/s, a wave-1 zombie's fastest
WALL = Obstacle("wall", -0.2, -4.0, 0.2, 4.0, 2.0)  # across the way from (-5, 0) to (5, 0)


def walk(nav, x, y, seconds, town=None, each=None):
    """A zombie at (x, y) walking its waypoints at SPEED (stopping on the goal), optionally pushed out of
    obstacles each step; ``each(x, y)`` sees every position. Returns the end and the length walked."""
    walked = 0.0
    for _ in range(int(seconds / DT)):
        tx, ty, final = nav.waypoint(x, y)
        dx, dy = tx - x, ty - y
        d = math.hypot(dx, dy)
        if d > 1e-12:
            step = min(SPEED * DT, d) if final else SPEED * DT
            x, y = x + dx / d * step, y + dy / d * step
            walked += step
        if town is not None:
            x, y = push_out(town, x, y, R)
        if each is not None:
            each(x, y)
    return x, y, walked


def wall_gap(x, y):
    """A circle's centre's distance to WALL's footprint, worked out here."""
    return math.hypot(max(WALL.x0 - x, 0.0, x - WALL.x1), max(WALL.y0 - y, 0.0, y - WALL.y1))


def test_a_zombie_walks_round_a_single_wall_to_the_goal_without_touching_it():
    """The shortest way for a centre that stays 0.35 m off the wall passes its grown corners
    (+-0.55, 4.35): 2 * hypot(4.45, 4.35) + 1.1 = 13.55 m (rounding the corners saves under 0.1 m)."""
    town = Town(half_size_m=10.0, obstacles=(WALL,))
    nav = Navigator(town)
    nav.set_goal(5.0, 0.0)
    gaps = []
    x, y, walked = walk(nav, -5.0, 0.0, 20.0, each=lambda x, y: gaps.append(wall_gap(x, y)))
    assert math.hypot(x - 5.0, y) < 1e-9  # arrived, and stays
    assert min(gaps) >= R - 1e-9  # its body never entered the wall
    shortest = 2 * math.hypot(4.45, 4.35) + 1.1
    assert shortest - 0.1 < walked < 1.2 * shortest  # the regions' edges bend the way a little
    assert shortest - 0.1 < nav.path_length(-5.0, 0.0) < 1.25 * shortest


def test_in_an_empty_town_the_way_is_nearly_straight():
    town = Town(half_size_m=10.0, obstacles=())
    nav = Navigator(town)
    nav.set_goal(6.0, 5.0)
    straight = math.hypot(6.0 + 7.0, 5.0 + 6.0)
    x, y, walked = walk(nav, -7.0, -6.0, 30.0)
    assert math.hypot(x - 6.0, y - 5.0) < 1e-9
    assert straight <= walked < 1.05 * straight
    assert straight <= nav.path_length(-7.0, -6.0) < 1.15 * straight  # through the portals' midpoints


def test_regions_cover_exactly_the_free_cells_and_keep_a_body_clear_of_every_obstacle():
    """Oracle: every free cell's square, grown by the radius (a square margin), against every footprint."""
    town = make_town(3, "crossroads")
    nav = Navigator(town)
    c, n, o = nav.settings.cell_m, nav.n, nav.origin
    area = sum((r[2] - r[0]) * (r[3] - r[1]) for r in nav.regions)
    assert area == pytest.approx(sum(nav.free) * c * c)
    for k in range(n * n):
        x0, y0 = o + (k % n) * c, o + (k // n) * c
        clear = all(x0 - R >= ob.x1 or x0 + c + R <= ob.x0 or y0 - R >= ob.y1 or y0 + c + R <= ob.y0
                    for ob in town.obstacles)
        inside = -town.half_size_m + R <= x0 and x0 + c <= town.half_size_m - R and \
            -town.half_size_m + R <= y0 and y0 + c <= town.half_size_m - R
        assert bool(nav.free[k]) == (clear and inside), k
    for a, ra in enumerate(nav.regions):  # disjoint
        for rb in nav.regions[a + 1:]:
            assert not (ra[0] < rb[2] and rb[0] < ra[2] and ra[1] < rb[3] and rb[1] < ra[3])
    assert max(max(r[2] - r[0], r[3] - r[1]) for r in nav.regions) <= nav.settings.region_max_m


def test_a_straight_walk_to_any_waypoint_keeps_a_body_clear_of_every_obstacle():
    """From random points of free cells, to their waypoints: the segment sampled every 2 cm, each sample's
    distance to every footprint at least the radius."""
    town = make_town(9, "grid")
    nav = Navigator(town)
    nav.set_goal(*town.spawn_points[0])
    rng = np.random.default_rng(9)
    free = [k for k in range(nav.n * nav.n) if nav.free[k]]
    boxes = np.array([(o.x0, o.y0, o.x1, o.y1) for o in town.obstacles])
    for k in rng.choice(free, 400, replace=False):
        x = nav.origin + (k % nav.n + rng.random()) * nav.settings.cell_m
        y = nav.origin + (k // nav.n + rng.random()) * nav.settings.cell_m
        tx, ty, final = nav.waypoint(x, y)
        s = np.linspace(0.0, 1.0, max(2, int(math.hypot(tx - x, ty - y) / 0.02)))[:, None]
        px, py = x + (tx - x) * s, y + (ty - y) * s
        gx = np.maximum(np.maximum(boxes[:, 0] - px, 0.0), px - boxes[:, 2])
        gy = np.maximum(np.maximum(boxes[:, 1] - py, 0.0), py - boxes[:, 3])
        assert np.hypot(gx, gy).min() >= R - 1e-9, (x, y, tx, ty, final)


@pytest.mark.parametrize("layout", list(LAYOUTS))
def test_zombies_from_every_spawn_point_reach_the_player_at_the_start(layout):
    town = make_town(12, layout)
    nav = Navigator(town)
    for sx, sy in town.spawn_points:
        length = nav.path_length(sx, sy)
        assert length < math.inf
        x, y, walked = walk(nav, sx, sy, 1.2 * length / SPEED + 2.0, town=town)
        assert math.hypot(x - town.start[0], y - town.start[1]) < 1e-6, (sx, sy)
        assert walked < 1.2 * length


def test_the_flow_field_is_rebuilt_only_in_another_region_and_kept_for_a_return():
    nav = Navigator(make_town(4, "ring"))
    first = nav._exits
    region = nav.region_at(0.0, 0.0)
    x0, y0, x1, y1 = nav.regions[region]
    nav.set_goal(x0 + 0.01, y0 + 0.01)  # another point of the same region
    assert nav._exits is first
    nav.set_goal(10.0, -20.0)
    assert nav.region_at(10.0, -20.0) != region and nav._exits is not first
    nav.set_goal(0.0, 0.0)
    assert nav._exits is first


def test_a_walled_off_courtyard_has_no_way_and_its_zombie_heads_straight_for_the_goal():
    ring = (Obstacle("wall", -3.0, -3.0, 3.0, -2.7, 2.0), Obstacle("wall", -3.0, 2.7, 3.0, 3.0, 2.0),
            Obstacle("wall", -3.0, -2.7, -2.7, 2.7, 2.0), Obstacle("wall", 2.7, -2.7, 3.0, 2.7, 2.0))
    nav = Navigator(Town(half_size_m=10.0, obstacles=ring, start=(8.0, 8.0)))
    assert nav.path_length(0.0, 0.0) == math.inf
    assert nav.waypoint(0.0, 0.0) == (8.0, 8.0, True)
    assert nav.path_length(-8.0, -8.0) < math.inf


def test_bad_navigation_settings_are_refused():
    with pytest.raises(ValueError, match="cell_m must be a finite number more than 0"):
        NavSettings(cell_m=0.0)
    with pytest.raises(ValueError, match="region_max_m"):
        NavSettings(region_max_m=0.2)
