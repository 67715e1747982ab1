"""The town generator: deterministic per seed, distinct layouts, and its promises checked by sampling."""

import dataclasses
import math

import numpy as np
import pytest

from game.world.navigation import Navigator
from game.world.town import KINDS, LAYOUTS, Obstacle, Town, TownSettings, make_town

TOWNS = [(seed, layout) for layout in LAYOUTS for seed in (0, 1, 2, 3)]


def footprint_distance(o, x, y):
    """Distance from a point to an obstacle's footprint, worked out here from the corners' coordinates."""
    dx = max(o.x0 - x, 0.0, x - o.x1)
    dy = max(o.y0 - y, 0.0, y - o.y1)
    return math.hypot(dx, dy)


def test_the_same_seed_gives_the_same_town_and_other_seeds_other_towns():
    assert make_town(11) == make_town(11)
    assert make_town(11, "ring") == make_town(11, "ring")
    obstacle_sets = {make_town(seed, "grid").obstacles for seed in range(5)}
    assert len(obstacle_sets) == 5


def test_an_unnamed_layout_is_the_seeds_choice_and_every_layout_gets_chosen():
    chosen = {make_town(seed).layout for seed in range(30)}
    assert chosen == set(LAYOUTS)
    for seed in range(5):
        town = make_town(seed)
        assert make_town(seed, town.layout) == town


def test_the_three_layouts_differ_in_their_open_ground():
    towns = {layout: make_town(4, layout) for layout in LAYOUTS}
    squares = {layout: [s for s in t.streets if s.kind == "square"] for layout, t in towns.items()}
    streets = {layout: [s for s in t.streets if s.kind == "street"] for layout, t in towns.items()}
    half = towns["grid"].half_size_m
    # grid: no square; three streets east-west and two north-south, each edge to edge
    assert squares["grid"] == [] and sorted(s.along_x for s in streets["grid"]) == [False, False, True, True, True]
    assert all(min(s.x0, s.y0) == -half and max(s.x1, s.y1) == half for s in streets["grid"])
    # crossroads: a square at the origin; two 8 m main streets through it
    assert len(squares["crossroads"]) == 1
    mains = [s for s in streets["crossroads"]
             if math.isclose(s.width, 8.0) and s.x0 <= 0.0 <= s.x1 and s.y0 <= 0.0 <= s.y1]
    assert len(mains) == 2 and {s.along_x for s in mains} == {True, False}
    # ring: a square, and no street reaches the origin (the ring goes round the square)
    assert len(squares["ring"]) == 1
    assert not any(s.x0 <= 0.0 <= s.x1 and s.y0 <= 0.0 <= s.y1 for s in streets["ring"])
    assert len({t.obstacles for t in towns.values()}) == 3


@pytest.mark.parametrize("seed,layout", TOWNS)
def test_every_obstacle_is_inside_the_town_and_clear_of_the_start_and_of_its_kinds_size(seed, layout):
    town = make_town(seed, layout)
    h = town.half_size_m
    assert len(town.obstacles) > 20
    for o in town.obstacles:
        assert -h <= o.x0 < o.x1 <= h and -h <= o.y0 < o.y1 <= h
        assert footprint_distance(o, *town.start) > town.start_radius_m
        spec = KINDS[o.kind]
        short, long = sorted((o.x1 - o.x0, o.y1 - o.y0))
        assert spec.width_m[0] - 1e-9 <= short <= spec.width_m[1] + 1e-9, o
        assert spec.length_m[0] - 1e-9 <= long <= spec.length_m[1] + 1e-9, o
        assert spec.height_m[0] <= o.height <= spec.height_m[1], o


@pytest.mark.parametrize("seed,layout", TOWNS)
def test_every_street_and_alley_keeps_the_passage_across_every_cross_section(seed, layout):
    """Sampled: across each street, every 0.1 m along it, the longest run of 2 cm samples outside every
    footprint (all of the town's obstacles, not only those the generator put in the street)."""
    town = make_town(seed, layout)
    step = 0.02
    for street in (s for s in town.streets if s.kind != "square"):
        a0, a1 = (street.x0, street.x1) if street.along_x else (street.y0, street.y1)
        c0, c1 = (street.y0, street.y1) if street.along_x else (street.x0, street.x1)
        across = np.arange(c0 + step / 2, c1, step)
        for a in np.arange(a0 + 0.05, a1, 0.1):
            blocked = np.zeros(across.size, bool)
            for o in town.obstacles:
                lo_a, hi_a, lo_c, hi_c = (o.x0, o.x1, o.y0, o.y1) if street.along_x else (o.y0, o.y1, o.x0, o.x1)
                if lo_a <= a <= hi_a:
                    blocked |= (across >= lo_c) & (across <= hi_c)
            runs = np.diff(np.flatnonzero(np.concatenate(([True], blocked, [True])))) - 1
            assert runs.max() * step >= town.min_passage_m - step, (street, a)


@pytest.mark.parametrize("seed,layout", TOWNS)
def test_every_spawn_point_is_clear_inside_the_town_and_has_a_way_to_the_start(seed, layout):
    town = make_town(seed, layout)
    nav = Navigator(town)  # its goal is the start
    h = town.half_size_m
    assert len(town.spawn_points) >= 4
    for x, y in town.spawn_points:
        assert -h + 0.35 <= x <= h - 0.35 and -h + 0.35 <= y <= h - 0.35
        assert all(footprint_distance(o, x, y) >= 1.0 for o in town.obstacles)
        assert nav.path_length(x, y) < math.inf


def test_spawn_points_lie_in_alleys_or_at_the_edge_on_a_street():
    in_alleys = 0
    for seed, layout in TOWNS:
        town = make_town(seed, layout)
        alleys = [s for s in town.streets if s.kind == "alley"]
        streets = [s for s in town.streets if s.kind == "street"]
        h = town.half_size_m
        for x, y in town.spawn_points:
            alley = any(a.x0 < x < a.x1 and a.y0 < y < a.y1 for a in alleys)
            edge = math.isclose(max(abs(x), abs(y)), h - 1.0) and any(
                s.x0 < x < s.x1 and s.y0 < y < s.y1 for s in streets)
            assert alley or edge, (seed, layout, x, y)
            in_alleys += alley
    assert in_alleys >= 3


def test_bad_names_and_settings_are_refused_in_one_line():
    with pytest.raises(ValueError) as caught:
        make_town(1, "maze")
    assert str(caught.value) == "layout must be one of grid, crossroads, ring, not 'maze'"
    with pytest.raises(ValueError, match="seed must be a whole number"):
        make_town(-1)
    with pytest.raises(ValueError, match="at least min_passage_m"):
        TownSettings(street_width_m=(2.0, 3.0))
    with pytest.raises(ValueError, match="low <= high"):
        TownSettings(setback_m=(1.5, 0.8))
    with pytest.raises(ValueError, match="half_size_m must be a finite number"):
        TownSettings(half_size_m=float("nan"))
    with pytest.raises(ValueError, match="kind must be one of"):
        Obstacle("tree", 0.0, 0.0, 1.0, 1.0, 3.0)
    with pytest.raises(ValueError, match="x0 < x1"):
        Obstacle("wall", 1.0, 0.0, 1.0, 1.0, 3.0)


def test_settings_change_the_town_as_documented():
    wide = make_town(3, "grid", TownSettings(street_width_m=(7.0, 7.0), lamp_spacing_m=6.0))
    assert all(math.isclose(s.width, 7.0) for s in wide.streets if s.kind == "street")
    lamps = sum(o.kind == "lamp_post" for o in wide.obstacles)
    assert lamps > sum(o.kind == "lamp_post" for o in make_town(3, "grid").obstacles)


def test_a_hand_built_town_needs_only_its_size_and_obstacles():
    town = Town(half_size_m=10.0, obstacles=(Obstacle("wall", 0.0, -2.0, 0.3, 2.0, 2.0),))
    assert town.layout == "custom" and town.spawn_points == () and town.grid.near(0.1, 0.0)


def test_the_grid_is_built_once_and_follows_a_replaced_town():
    # Every near() of every body reads it: it must not be built again at each use (as a cached_property
    # was in the compiled build), and a town made from another with new obstacles gets its own.
    town = make_town(3)
    assert town.grid is town.grid and town.grid.obstacles == town.obstacles
    wall = Obstacle("wall", 0.0, -2.0, 0.3, 2.0, 2.0)
    moved = dataclasses.replace(town, obstacles=(wall,))
    assert moved.grid.obstacles == (wall,) and moved == dataclasses.replace(town, obstacles=(wall,))
