"""Bodies against obstacles: push_out (circles slide along walls) and sweep_sphere (no ball tunnels)."""

import math

import numpy as np
import pytest

from game.world.collision import push_out, segment_box, sweep_sphere
from game.world.town import Obstacle, Town, make_town

R = 0.35  # a zombie's (and the player's) radius
DT = 1.0 / 120.0


def town_of(*obstacles, half=10.0):
    return Town(half_size_m=half, obstacles=tuple(obstacles))


_RADII, _ANGLES = np.meshgrid(np.linspace(0.0, 1.0 - 1e-6, 12), np.linspace(0.0, 2 * math.pi, 72, endpoint=False))
DISC = np.stack([(_RADII * np.cos(_ANGLES)).ravel(), (_RADII * np.sin(_ANGLES)).ravel()], axis=1)


def overlap(o, x, y, radius):
    """Whether a circle overlaps a footprint: by sampling the circle's disc on a fine polar grid."""
    px, py = x + radius * DISC[:, 0], y + radius * DISC[:, 1]
    return bool(np.any((o.x0 < px) & (px < o.x1) & (o.y0 < py) & (py < o.y1)))


def gap(o, x, y):
    """The distance from (x, y) outside a footprint to it: to the nearest face, or corner."""
    return math.hypot(max(o.x0 - x, 0.0, x - o.x1), max(o.y0 - y, 0.0, y - o.y1))


# ---------------------------------------------------------------- push_out

def test_a_circle_pressed_diagonally_into_a_wall_slides_and_ends_a_radius_from_the_face():
    wall = Obstacle("wall", 0.0, -5.0, 0.3, 5.0, 2.0)
    town = town_of(wall)
    # from (-0.5, 0) a step of (+0.3, +0.3) ends at (-0.2, 0.3): 0.15 m into the wall's margin
    x, y = push_out(town, -0.5 + 0.3, 0.0 + 0.3, R)
    assert x == pytest.approx(-R, abs=1e-12)  # the face is at x = 0: exactly a radius from it
    assert y == pytest.approx(0.3, abs=1e-12)  # the motion along the face is kept


def test_a_circle_in_an_inside_corner_is_pushed_out_of_both_walls():
    west = Obstacle("wall", 0.0, 0.0, 0.3, 5.0, 2.0)
    south = Obstacle("wall", 0.0, 0.0, 5.0, 0.3, 2.0)
    x, y = push_out(town_of(west, south), 0.5, 0.5, R)
    assert (x, y) == pytest.approx((0.3 + R, 0.3 + R), abs=1e-12)


def test_a_body_walking_into_a_notch_rests_there_and_never_overlaps():
    """A building's corner 0.47 m from a ruin's face, narrower than a body (seed 106's town had
    one): a zombie walking into it every step comes to rest touching both, never inside either.
    The rest point, worked by hand: x = 0.47 - R against the face; then the corner (0, 0) is R away
    at y = sqrt(R^2 - x^2)."""
    building, ruin = Obstacle("building", -4.0, -4.0, 0.0, 0.0, 7.0), Obstacle("ruin", 0.47, -4.0, 4.0, 4.0, 3.0)
    town = town_of(building, ruin)
    x, y = 0.0, 1.0
    for _ in range(400):  # 1 cm steps toward a point deep in the notch
        d = math.hypot(0.2 - x, -3.0 - y)
        x, y = push_out(town, x + 0.01 * (0.2 - x) / d, y + 0.01 * (-3.0 - y) / d, R)
        assert gap(building, x, y) >= R - 1e-6 and gap(ruin, x, y) >= R - 1e-6
    rest_x = 0.47 - R
    assert (x, y) == pytest.approx((rest_x, math.sqrt(R * R - rest_x * rest_x)), abs=1e-3)


def test_a_circle_at_an_outside_corner_is_pushed_away_from_the_corner():
    box = Obstacle("building", 0.0, 0.0, 1.0, 1.0, 5.0)
    x, y = push_out(town_of(box), 1.1, 1.1, R)  # 0.1 * sqrt(2) from the corner, along the diagonal
    assert (x, y) == pytest.approx((1.0 + R / math.sqrt(2), 1.0 + R / math.sqrt(2)), abs=1e-12)


def test_a_centre_inside_a_box_leaves_it_across_the_nearest_face():
    wall = Obstacle("wall", 0.0, -5.0, 0.3, 5.0, 2.0)
    assert push_out(town_of(wall), 0.1, 1.0, R) == pytest.approx((-R, 1.0), abs=1e-12)
    assert push_out(town_of(wall), 0.25, 1.0, R) == pytest.approx((0.3 + R, 1.0), abs=1e-12)


def test_a_circle_clear_of_everything_stays_put_and_the_town_edge_holds_it_in():
    wall = Obstacle("wall", 0.0, -5.0, 0.3, 5.0, 2.0)
    town = town_of(wall)
    assert push_out(town, -1.0, 2.0, R) == (-1.0, 2.0)
    assert push_out(town, 9.9, -12.0, R) == pytest.approx((10.0 - R, -10.0 + R), abs=1e-12)


def test_in_a_generated_town_no_pushed_circle_overlaps_any_obstacle():
    """Oracle: every obstacle of the town (not only the spatial hash's), the disc sampled."""
    town = make_town(5, "crossroads")
    rng = np.random.default_rng(5)
    moved = 0
    for x, y in rng.uniform(-town.half_size_m, town.half_size_m, (300, 2)):
        nx, ny = push_out(town, float(x), float(y), R)
        if any(o.x0 <= x <= o.x1 and o.y0 <= y <= o.y1 for o in town.obstacles):
            continue  # a walking body's centre never gets inside a box (see push_out)
        assert math.hypot(nx - x, ny - y) <= R + 1e-9  # a push only takes back the penetration
        assert not any(overlap(o, nx, ny, R) for o in town.obstacles), (x, y)
        moved += (nx, ny) != (x, y)
    assert moved > 20


# ---------------------------------------------------------------- sweep_sphere

def test_a_fast_ball_stops_at_the_face_of_a_thin_wall():
    """A 0.3 m ball at 30 m/s (0.25 m a step) against a 0.2 m fence-thin wall whose face is at x = 5: the
    grown face is at x = 5 - 0.3 = 4.7. Launched from x = 0, step 18 starts at 4.5 and meets it at
    t = (4.7 - 4.5) / 0.25 = 0.8."""
    wall = Obstacle("wall", 5.0, -5.0, 5.2, 5.0, 2.0)
    town = town_of(wall)
    step = 30.0 * DT
    x = 0.0
    for k in range(18):
        assert sweep_sphere(town, (x, 0.0, 1.0), (x + step, 0.0, 1.0), 0.3) is None, k
        x += step
    hit = sweep_sphere(town, (x, 0.0, 1.0), (x + step, 0.0, 1.0), 0.3)
    assert hit is not None and hit[1] is wall
    assert hit[0] == pytest.approx(0.8, abs=1e-12)
    assert x + hit[0] * step == pytest.approx(4.7, abs=1e-12)


def test_a_ball_that_would_jump_the_whole_wall_in_one_step_still_hits_it():
    wall = Obstacle("fence", 5.0, -5.0, 5.12, 5.0, 1.2)
    hit = sweep_sphere(town_of(wall), (4.6, 0.0, 1.0), (5.9, 0.0, 1.0), 0.22)  # grown: 4.78..5.34
    assert hit is not None and hit[0] == pytest.approx((4.78 - 4.6) / 1.3, abs=1e-12)


def test_a_ball_over_a_low_car_misses_and_one_a_little_lower_hits():
    car = Obstacle("car", 4.0, -1.0, 8.0, 1.0, 1.4)
    town = town_of(car)
    radius = 0.25  # the grown top is at 1.4 + 0.25 = 1.65
    assert sweep_sphere(town, (0.0, 0.0, 1.7), (12.0, 0.0, 1.7), radius) is None
    assert sweep_sphere(town, (0.0, 0.0, 1.65), (12.0, 0.0, 1.65), radius) is None  # grazing the top
    hit = sweep_sphere(town, (0.0, 0.0, 1.6), (12.0, 0.0, 1.6), radius)
    assert hit is not None and hit[0] == pytest.approx((4.0 - radius) / 12.0, abs=1e-12)


def test_grazing_along_a_face_is_no_hit_and_a_hair_closer_is():
    wall = Obstacle("wall", -5.0, 0.0, 5.0, 0.4, 2.0)
    town = town_of(wall)
    radius = 0.3
    assert sweep_sphere(town, (-8.0, -radius, 1.0), (8.0, -radius, 1.0), radius) is None
    hit = sweep_sphere(town, (-8.0, -radius + 1e-6, 1.0), (8.0, -radius + 1e-6, 1.0), radius)
    assert hit is not None and hit[0] == pytest.approx((8.0 - 5.0 - radius) / 16.0, abs=1e-12)


def test_a_ball_that_starts_inside_the_grown_box_hits_at_once_and_one_going_away_too():
    wall = Obstacle("wall", 0.0, -5.0, 0.3, 5.0, 2.0)
    hit = sweep_sphere(town_of(wall), (-0.1, 0.0, 1.0), (-1.0, 0.0, 1.0), 0.3)
    assert hit is not None and hit[0] == 0.0


def test_the_spatial_hash_finds_the_same_first_hit_as_every_obstacle_tried():
    town = make_town(8, "grid")
    rng = np.random.default_rng(8)
    hits = 0
    for _ in range(400):
        p0 = (*rng.uniform(-town.half_size_m, town.half_size_m, 2), float(rng.uniform(0.3, 3.0)))
        v = rng.normal(size=3)
        p1 = tuple(np.array(p0) + v / np.linalg.norm(v) * rng.uniform(0.05, 1.0))
        radius = float(rng.uniform(0.22, 0.32))
        ts = [segment_box(*p0, *(np.array(p1) - p0), o.x0 - radius, o.y0 - radius, -radius,
                          o.x1 + radius, o.y1 + radius, o.height + radius) for o in town.obstacles]
        best = min(ts)
        hit = sweep_sphere(town, p0, p1, radius)
        if best < 1.0:
            hits += 1
            assert hit is not None and hit[0] == best and hit[1] is town.obstacles[ts.index(best)]
        else:
            assert hit is None
    assert hits > 20


def test_segment_box_in_two_dimensions_with_infinite_heights():
    inf = math.inf
    # a segment from (-1, 0.5) to (3, 0.5) enters the unit square at x = 0: t = 1 / 4
    assert segment_box(-1.0, 0.5, 0.0, 4.0, 0.0, 0.0, 0.0, 0.0, -inf, 1.0, 1.0, inf) == 0.25
    assert segment_box(-1.0, 1.0, 0.0, 4.0, 0.0, 0.0, 0.0, 0.0, -inf, 1.0, 1.0, inf) == inf  # along an edge
    assert segment_box(-1.0, 0.5, 0.0, 0.9, 0.0, 0.0, 0.0, 0.0, -inf, 1.0, 1.0, inf) == inf  # stops short


def test_the_spatial_hash_in_a_box_holds_every_obstacle_near_it_once_in_the_towns_order_kept_or_not(monkeypatch):
    town = make_town(8, "grid")
    grid = town.grid
    monkeypatch.setattr(type(grid), "BLOCKS_KEPT", 16)  # the kept blocks are dropped again and again
    rank = {id(o): k for k, o in enumerate(town.obstacles)}
    rng = np.random.default_rng(3)
    for _ in range(300):
        x0, y0 = rng.uniform(-town.half_size_m - 2, town.half_size_m, 2)
        x1, y1 = x0 + rng.uniform(0.0, 8.0), y0 + rng.uniform(0.0, 8.0)
        found = grid.in_box(x0, y0, x1, y1)
        order = [rank[id(o)] for o in found]
        assert order == sorted(set(order))  # each once, in the town's order
        r = grid.reach_m
        near = {rank[id(o)] for o in town.obstacles
                if o.x0 - r < x1 and o.x1 + r > x0 and o.y0 - r < y1 and o.y1 + r > y0}
        assert near <= set(order)
        assert grid.in_box(x0, y0, x1, y1) == found  # asked again: the same
