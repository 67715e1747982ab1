"""The town on screen: what hides what (worked by hand), the fade of a building in front of the player and
the paint order through the real renderer, the street lines, the minimap's dots, a ball bursting on a wall."""

import math
import os

os.environ["SDL_VIDEODRIVER"] = "dummy"
os.environ["SDL_AUDIODRIVER"] = "dummy"

from types import SimpleNamespace  # noqa: E402

import numpy as np  # noqa: E402
import pygame  # noqa: E402
import pytest  # noqa: E402

from game.body.avatar import Avatar, BodySettings, Wearing  # noqa: E402
from game.body.pose import ArmPose  # noqa: E402
from game.ui.render import Renderer  # noqa: E402
from game.ui.render.occlusion import FADE_S, FADED_ALPHA, covers, ease, occluders  # noqa: E402
from game.ui.render import town as town_module  # noqa: E402
from game.ui.render.town import centre_dashes, hidden_boxes, open_outline  # noqa: E402
from game.world.arena_model import ArenaEvent, HeldBall, Player, Zombie  # noqa: E402
from game.world.town import Obstacle, Street, Town  # noqa: E402

IDENTITY = (1.0, 0.0, 0.0, 0.0)
AVATAR_BLUE = (70, 130, 240)  # the avatar's body (palette.AVATAR_BODY)


# ------------------------------------------------------------------ what hides what, by hand


def test_a_box_on_the_sight_line_covers_and_one_beside_or_behind_does_not():
    eye, chest = (0.0, 0.0, 2.0), (0.0, 10.0, 1.2)
    # the sight line falls 0.08 m a metre: over y 4..6 it runs from z 1.68 down to 1.52
    lo = np.array([[-3.0, 4.0, 0.0], [5.0, 4.0, 0.0], [-3.0, 12.0, 0.0], [-3.0, 4.0, 0.0], [-3.0, 4.0, 0.0]])
    hi = np.array([[3.0, 6.0, 8.0], [8.0, 6.0, 8.0], [3.0, 14.0, 8.0], [3.0, 6.0, 1.5], [3.0, 6.0, 1.6]])
    # in the way; beside it; behind the player; a wall 1.5 m high (the line passes over); 1.6 m (it clips the top)
    assert occluders(eye, [chest], lo, hi).tolist() == [True, False, False, False, True]


def test_a_sight_line_along_a_face_or_ending_on_it_is_not_covered():
    lo, hi = np.array([[1.0, 1.0, 0.0]]), np.array([[2.0, 2.0, 3.0]])
    along = covers((0.0, 1.0, 1.0), np.array([[3.0, 1.0, 1.0]])[:, None], lo[None], hi[None])  # on the y = 1 face
    ends = covers((0.0, 1.5, 1.0), np.array([[1.0, 1.5, 1.0]])[:, None], lo[None], hi[None])  # stops at x = 1
    inside = covers((0.0, 1.5, 1.0), np.array([[1.5, 1.5, 1.0]])[:, None], lo[None], hi[None])
    assert along.tolist() == [[False]] and ends.tolist() == [[False]] and inside.tolist() == [[True]]


def test_covers_pairs_points_with_boxes_by_broadcasting():
    lo, hi = np.array([[4.0, -1.0, 0.0], [9.0, -1.0, 0.0]]), np.array([[5.0, 1.0, 2.0], [10.0, 1.0, 2.0]])
    points = np.array([[7.0, 0.0, 1.0], [12.0, 0.0, 1.0]])
    # each point against each box: the first point is behind the first box only, the second behind both
    assert covers((0.0, 0.0, 1.0), points[:, None], lo[None], hi[None]).tolist() == [[True, False], [True, True]]
    assert covers((0.0, 0.0, 1.0), points, lo, hi).tolist() == [True, True]  # pairwise: point k with box k


def test_the_fade_eases_over_its_time_and_back():
    alpha = np.ones(2)
    faded = np.array([True, False])
    half = ease(alpha, faded, FADE_S / 2)
    assert half.tolist() == pytest.approx([1.0 - (1.0 - FADED_ALPHA) / 2, 1.0])  # half way after half the time
    full = ease(half, faded, FADE_S / 2)
    assert full.tolist() == pytest.approx([FADED_ALPHA, 1.0])
    assert ease(full, faded, 1.0).tolist() == pytest.approx([FADED_ALPHA, 1.0])  # it stays there
    assert ease(full, np.array([False, False]), FADE_S).tolist() == pytest.approx([1.0, 1.0])


def test_a_box_inside_a_nearer_opaque_wall_needs_no_painting():
    screen = np.array([[100.0, 100.0, 300.0, 400.0], [150.0, 200.0, 200.0, 260.0], [250.0, 200.0, 350.0, 260.0],
                       [150.0, 200.0, 200.0, 260.0]])  # x0, y0, x1, y1 pixels
    nearest = np.array([5.0, 20.0, 20.0, 6.0])  # depth of each box's nearest corner (m)
    rects = np.array([[110.0, 120.0, 290.0, 390.0]])  # box 0's wall: inside its face on screen
    far = np.array([8.0])  # the wall's farthest corner
    hidden = hidden_boxes(screen, nearest, rects, far, np.array([0]), np.ones(4, dtype=bool))
    # box 1 lies inside the wall and behind it; box 2 sticks out to the right; box 3 is within 8 m;
    # box 0 is the wall's own
    assert hidden.tolist() == [False, True, False, False]
    faded = np.array([False, True, True, True])
    assert not hidden_boxes(screen, nearest, rects, far, np.array([0]), faded).any()  # a faded wall hides nothing


# ------------------------------------------------------------------ through the real renderer


def town_arena(obstacles, zombies=(), yaw=0.0):
    """A duck-typed arena in a hand-built town: the player at the origin facing ``yaw``, arm raised."""
    town = Town(half_size_m=24.0, obstacles=tuple(obstacles),
                streets=(Street("street", -24.0, -3.0, 24.0, 3.0),))
    player = Player(x=0.0, y=0.0, yaw=yaw, health=100.0)
    arena = SimpleNamespace(player=player, zombies=list(zombies), balls=[], town=town,
                            held=HeldBall(state="idle", visible=False), settings=SimpleNamespace())
    avatar = Avatar(BodySettings(), Wearing(IDENTITY, IDENTITY), body_yaw=yaw, position=(0.0, 0.0))
    half = math.radians(100.0) / 2
    avatar.update(ArmPose((math.cos(half), math.sin(half), 0.0, 0.0), 40.0, 0.0))
    return arena, avatar


def pixel(r: Renderer, surface, point) -> tuple[int, int, int]:
    xy, _, vis = r.camera.project(np.array([point]))
    assert vis[0]
    return tuple(surface.get_at(tuple(int(v) for v in xy[0])))[:3]


def draw(arena, avatar, surface, frames=1, dt=1 / 60):
    r = Renderer((1280, 720), seed=1)
    for _ in range(frames):
        r.draw_world(surface, arena, avatar, dt)
    return r


def test_a_building_between_camera_and_player_fades_and_the_player_shows_through(screen):
    # the camera stands 4.5 m behind the player (y = -4.5), 2.6 m up; the building stands in between, 6 m high
    between = Obstacle("building", -2.0, -3.4, 2.0, -2.4, 6.0)
    arena, avatar = town_arena([between])
    chest = avatar.world_pos["spine"]
    r = draw(arena, avatar, screen, frames=int(FADE_S * 60) + 2)  # past the fade's time
    faded = pixel(r, screen, chest)
    assert r.town.alpha.tolist() == pytest.approx([FADED_ALPHA])
    bare, _ = town_arena([])
    plain = pixel(draw(bare, avatar, screen), screen, chest)
    assert plain == pytest.approx(AVATAR_BLUE, abs=3)  # the chest, with nothing in the way
    assert faded != plain  # the building is drawn over it ...
    assert faded[2] > 150 and faded[2] > faded[0] + 80  # ... and the player's blue shows through
    assert all(f >= 0.6 * p for f, p in zip(faded, plain))  # more than 60 % of it in each channel


def test_the_fade_takes_its_time_and_goes_back_when_the_building_is_no_longer_between(screen):
    arena, avatar = town_arena([Obstacle("building", -2.0, -3.4, 2.0, -2.4, 6.0)])
    r = Renderer((1280, 720), seed=1)
    r.draw_world(screen, arena, avatar, FADE_S / 2)
    assert r.town.alpha.tolist() == pytest.approx([1.0 - (1.0 - FADED_ALPHA) / 2])
    r.draw_world(screen, arena, avatar, FADE_S)
    assert r.town.alpha.tolist() == pytest.approx([FADED_ALPHA])
    arena.player.yaw = avatar.body_yaw = math.pi  # he turns round: the building is before him now
    for _ in range(3):
        r.draw_world(screen, arena, avatar, FADE_S)
    assert r.town.alpha.tolist() == pytest.approx([1.0])


def test_a_building_not_between_is_opaque_and_hides_a_zombie_behind_it(screen):
    # ahead of the player a building from y 8 to 12; a zombie behind it at y 16 and one beside it at x 6
    building = Obstacle("building", -3.0, 8.0, 3.0, 12.0, 8.0)
    hidden = Zombie(id=1, x=0.0, y=16.0, speed=1.0, health=1, phase=0.0, heading=-math.pi / 2)
    beside = Zombie(id=2, x=6.0, y=10.0, speed=1.0, health=1, phase=0.0, heading=-math.pi / 2)
    arena, avatar = town_arena([building], [hidden, beside])
    r = draw(arena, avatar, screen, frames=3, dt=FADE_S)
    assert r.town.alpha.tolist() == pytest.approx([1.0])
    with_zombies = (pixel(r, screen, (0.0, 16.0, 1.2)), pixel(r, screen, (6.0, 10.0, 1.2)))
    empty, _ = town_arena([building])
    r2 = draw(empty, avatar, screen, frames=3, dt=FADE_S)
    without = (pixel(r2, screen, (0.0, 16.0, 1.2)), pixel(r2, screen, (6.0, 10.0, 1.2)))
    assert with_zombies[0] == without[0]  # the building is opaque: nothing of the zombie behind it shows
    assert with_zombies[1] != without[1] and with_zombies[1][1] > with_zombies[1][0]  # the one beside it: green


def test_a_zombie_in_the_street_beside_a_long_building_is_painted_over_it(screen):
    # a long building down the left of the street (x -6..-3, y 2..30): its nearest corner is much nearer the
    # camera than the zombie at its far end, but the zombie stands in the street in front of its side
    building = Obstacle("building", -6.0, 2.0, -3.0, 30.0, 9.0)
    zombie = Zombie(id=1, x=-2.2, y=18.0, speed=1.0, health=1, phase=0.0, heading=-math.pi / 2)
    arena, avatar = town_arena([building], [zombie])
    r = draw(arena, avatar, screen, frames=1)
    torso = pixel(r, screen, (-2.2, 18.0, 1.2))
    assert torso[1] > torso[0] and torso[1] > torso[2]  # green: the zombie, not the building's dark side


def test_the_town_is_drawn_over_the_ground_and_draws_the_same_twice(screen):
    arena, avatar = town_arena([Obstacle("building", -3.0, 8.0, 3.0, 12.0, 8.0),
                                Obstacle("car", 4.0, 5.0, 8.5, 6.8, 1.4), Obstacle("ruin", -9.0, 6.0, -5.0, 10.0, 3.0),
                                Obstacle("lamp_post", 2.6, 3.2, 2.9, 3.5, 5.0)])
    frames = []
    for _ in range(2):
        draw(arena, avatar, screen, frames=2)
        frames.append(pygame.image.tobytes(screen, "RGB"))
    assert frames[0] == frames[1]
    bare, _ = town_arena([])
    draw(bare, avatar, screen, frames=2)
    assert pygame.image.tobytes(screen, "RGB") != frames[0]


# ------------------------------------------------------------------ the street lines


def test_the_kerbs_leave_the_crossing_and_an_alley_mouth_open():
    east_west = Street("street", -24.0, -3.0, 24.0, 3.0)
    north_south = Street("street", -3.0, -24.0, 3.0, 24.0)
    alley = Street("alley", 10.0, 3.0, 13.0, 10.0)  # off the north side of the east-west street
    pieces = {(kind, tuple(round(v, 6) for v in seg)) for kind, seg, _ in
              open_outline([east_west, north_south, alley], 24.0)}
    assert pieces == {
        ("street", (-24.0, -3.0, -3.0, -3.0)), ("street", (3.0, -3.0, 24.0, -3.0)),  # the south kerb, less the crossing
        ("street", (-24.0, 3.0, -3.0, 3.0)), ("street", (3.0, 3.0, 10.0, 3.0)), ("street", (13.0, 3.0, 24.0, 3.0)),
        ("street", (-3.0, -24.0, -3.0, -3.0)), ("street", (-3.0, 3.0, -3.0, 24.0)),
        ("street", (3.0, -24.0, 3.0, -3.0)), ("street", (3.0, 3.0, 3.0, 24.0)),
        ("alley", (10.0, 3.0, 10.0, 10.0)), ("alley", (13.0, 3.0, 13.0, 10.0)), ("alley", (10.0, 10.0, 13.0, 10.0)),
    }  # no kerb on the town's edge, none across the crossing or the alley's mouth


def test_centre_dashes_stop_at_a_crossing():
    dashes = centre_dashes([Street("street", -10.0, -3.0, 10.0, 3.0), Street("street", -3.0, -10.0, 3.0, 10.0),
                            Street("alley", 5.0, 3.0, 8.0, 10.0)])
    # 7 m each side of the crossing; from each piece's start a 1 m margin, 2 m dashes, 2 m gaps, the last
    # dash ending at least 1 m before the piece's end: one dash a piece (none in the alley)
    assert sorted(dashes) == [(-9.0, 0.0, -7.0, 0.0), (0.0, -9.0, 0.0, -7.0), (0.0, 4.0, 0.0, 6.0),
                              (4.0, 0.0, 6.0, 0.0)]


# ------------------------------------------------------------------ the minimap


def test_the_minimap_puts_the_player_and_a_zombie_where_they_are(screen):
    zombie = Zombie(id=1, x=12.0, y=-12.0, speed=1.0, health=1, phase=0.0)
    arena, _ = town_arena([Obstacle("building", -20.0, 10.0, -12.0, 20.0, 8.0)], [zombie], yaw=math.pi / 2)
    r = Renderer((1280, 720))
    screen.fill((0, 0, 0))
    r.draw_minimap(screen, arena)
    # worked by hand: a square 720 / 4 = 180 px, 16 px in from the right (left edge 1280 - 16 - 180 = 1084),
    # its top 16 + 720 // 34 = 37 px down; 180 px for 48 m is 3.75 px/m, north up
    centre = (1084 + 90, 37 + 90)  # the player at the town's centre
    zombie_px = (1084 + int(36 * 3.75), 37 + int(36 * 3.75))  # 24 + 12 m from the west and from the north edge
    z = screen.get_at(zombie_px)
    assert z.r > 200 and z.g < 100 and z.b < 100  # a red dot
    p = screen.get_at(centre)
    assert p.r > 200 and p.g > 200 and p.b < 160  # the player's arrow, yellow
    # he faces west (yaw 90 degrees): the arrow's tip to the left of him, its notch to the right
    tip, notch = screen.get_at((centre[0] - 5, centre[1])), screen.get_at((centre[0] + 6, centre[1]))
    assert tip.r > 200 and tip.g > 200 and not (notch.r > 200 and notch.g > 200)
    building = screen.get_at((1084 + int(8 * 3.75), 37 + int(9 * 3.75)))  # (-16, 15): inside the building
    street = screen.get_at((1084 + int(4 * 3.75), 37 + 90))  # (-20, 0): on the street
    assert sum(building[:3]) < 40 and sum(street[:3]) > sum(building[:3]) + 100  # dark shapes on lighter streets


def test_the_minimaps_dots_are_the_circles_drawn_at_each_zombie_even_at_its_edge(screen):
    from game.ui.render.minimap import Minimap, map_rect, to_map
    from game.ui.render.palette import MAP_ZOMBIE

    rng = np.random.default_rng(5)
    xy = [tuple(p) for p in rng.uniform(-24.5, 24.5, (40, 2))] + [(-24.0, 0.3), (23.9, 23.9), (0.01, -24.0)]
    rect = map_rect(screen.get_size())
    by_hand = pygame.Surface(screen.get_size())
    by_hand.set_clip(rect)
    for x, y in xy:
        pygame.draw.circle(by_hand, MAP_ZOMBIE, to_map(rect, 24.0, x, y), 3)
    screen.fill((0, 0, 0))
    screen.set_clip(rect)
    Minimap()._dots(screen, rect, 24.0, xy, MAP_ZOMBIE, 3)
    screen.set_clip(None)
    assert pygame.image.tobytes(screen, "RGB") == pygame.image.tobytes(by_hand, "RGB")


def test_no_minimap_without_a_town(screen):
    arena, _ = town_arena([])
    del arena.town
    screen.fill((0, 0, 0))
    Renderer((1280, 720)).draw_minimap(screen, arena)
    assert not pygame.surfarray.array3d(screen).any()


# ------------------------------------------------------------------ a ball on a wall


def test_a_ball_on_a_wall_bursts():
    r = Renderer((1280, 720), seed=3)
    r.react([ArenaEvent("wall", (1.0, 6.0, 1.4), 0.5)])
    assert r.effects.particles.count >= 30 and len(r.effects.flashes) == 1
    assert np.allclose(r.effects.particles.pos.mean(axis=0), (1.0, 6.0, 1.4))  # all born where the ball struck
    for _ in range(90):
        r.update_effects(1 / 60)
    assert r.effects.particles.count == 0 and not r.effects.flashes


def test_the_backdrop_behind_panels_shows_the_town_without_its_actors(screen):
    building = Obstacle("building", -3.0, 8.0, 3.0, 12.0, 8.0)
    zombie = Zombie(id=1, x=4.0, y=6.0, speed=1.0, health=1, phase=0.0, heading=-math.pi / 2)
    arena, _ = town_arena([building], [zombie])
    r = Renderer((1280, 720), seed=1)
    r.draw_backdrop(screen)
    bare = (pixel(r, screen, (0.0, 8.0, 5.0)), pixel(r, screen, (4.0, 6.0, 1.2)))
    r.draw_backdrop(screen, arena)
    town = (pixel(r, screen, (0.0, 8.0, 5.0)), pixel(r, screen, (4.0, 6.0, 1.2)))
    assert town[0] != bare[0]  # the building's face
    assert not (town[1][1] > town[1][0] + 30)  # no green zombie where the zombie stands


def test_leaving_out_the_hidden_boxes_changes_no_pixel(screen, monkeypatch):
    # a car and a low ruin behind a wide building ahead, a lamp post beside; the building hides the first two
    obstacles = [Obstacle("building", -8.0, 8.0, 8.0, 10.0, 9.0), Obstacle("car", -1.0, 14.0, 3.5, 15.8, 1.4),
                 Obstacle("ruin", -5.0, 13.0, -2.0, 16.0, 2.5), Obstacle("lamp_post", 9.0, 6.0, 9.3, 6.3, 5.0)]
    arena, avatar = town_arena(obstacles)
    culled = []
    real = town_module.hidden_boxes
    monkeypatch.setattr(town_module, "hidden_boxes", lambda *a: culled.append(real(*a)) or culled[-1])
    draw(arena, avatar, screen, frames=2)
    with_culling = pygame.image.tobytes(screen, "RGB")
    assert sum(culled[-1]) == 2  # the car and the ruin are left out
    monkeypatch.setattr(town_module, "hidden_boxes", lambda screen, *a: np.zeros(len(screen), dtype=bool))
    draw(arena, avatar, screen, frames=2)
    assert pygame.image.tobytes(screen, "RGB") == with_culling


def test_a_zombie_wholly_behind_a_wall_is_left_out_and_leaving_it_out_changes_no_pixel(screen, monkeypatch):
    # ahead a building from y 8 to 12, 8 m high; one zombie behind it, one beside it
    building = Obstacle("building", -3.0, 8.0, 3.0, 12.0, 8.0)
    behind = Zombie(id=1, x=0.0, y=16.0, speed=1.0, health=1, phase=0.0, heading=-math.pi / 2)
    beside = Zombie(id=2, x=6.0, y=10.0, speed=1.0, health=1, phase=0.0, heading=-math.pi / 2)
    arena, avatar = town_arena([building], [behind, beside])
    left_out = []
    real = Renderer._walled_in
    monkeypatch.setattr(Renderer, "_walled_in", staticmethod(lambda *a: left_out.append(real(*a)) or left_out[-1]))
    draw(arena, avatar, screen, frames=2)
    with_culling = pygame.image.tobytes(screen, "RGB")
    assert sum(left_out[-1]) == 1  # the zombie behind the building, not the one beside it nor the avatar
    monkeypatch.setattr(Renderer, "_walled_in", staticmethod(lambda boxes, things, slots: [False] * len(things)))
    draw(arena, avatar, screen, frames=2)
    assert pygame.image.tobytes(screen, "RGB") == with_culling
