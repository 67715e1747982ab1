"""The still camera's picture (game.ui.render.still): a frame painted from it equals the frame painted in full,
pixel for pixel, while the camera stands still, after it moves, and when the covers would not fit."""

import math
import os

os.environ["SDL_VIDEODRIVER"] = "dummy"
os.environ["SDL_AUDIODRIVER"] = "dummy"

import pygame  # noqa: E402
import pytest  # noqa: E402

from game.ui.render import Renderer  # noqa: E402
from game.ui.render.still import StillView  # noqa: E402
from game.world.arena_model import ArenaEvent, Zombie, ZombieState  # noqa: E402
from game.world.town import Obstacle  # noqa: E402

from .test_town_view import town_arena  # noqa: E402


def street_scene():
    """Boxes ahead with zombies behind, beside and between them (one near, drawn outlined, behind a low
    wall), one in the air, a lamp post, a hit's sparks."""
    obstacles = [Obstacle("building", -3.0, 8.0, 3.0, 12.0, 8.0), Obstacle("car", 3.5, 5.0, 8.0, 6.8, 1.4),
                 Obstacle("ruin", -9.0, 6.0, -5.0, 10.0, 3.0), Obstacle("lamp_post", 2.6, 3.2, 2.9, 3.5, 5.0),
                 Obstacle("wall", -4.0, 14.0, 4.0, 14.4, 2.2), Obstacle("wall", 0.8, 1.4, 2.6, 1.7, 1.0)]
    spots = [(0.5, 13.0), (2.8, 12.5), (5.0, 7.5), (-7.0, 11.0), (6.0, 4.0), (-1.5, 6.0), (0.0, 15.5), (-4.2, 9.0),
             (1.6, 2.4)]
    zombies = [Zombie(id=k, x=x, y=y, speed=1.0, health=1, phase=0.7 * k, heading=-math.pi / 2)
               for k, (x, y) in enumerate(spots)]
    zombies[3].state, zombies[3].z = ZombieState.FLYING, 3.0
    return town_arena(obstacles, zombies)


def frames(renderer, arena, avatar, moves) -> list[bytes]:
    """The frames drawn as the player moves: (x, y, yaw, dt) each; dt 0 leaves the camera where it was."""
    out = []
    for x, y, yaw, dt in moves:
        arena.player.x, arena.player.y, arena.player.yaw = x, y, yaw
        avatar.position, avatar.body_yaw = (x, y), yaw
        renderer.draw_world(pygame.display.get_surface(), arena, avatar, dt)
        out.append(pygame.image.tobytes(pygame.display.get_surface(), "RGB"))
    return out


def in_full(renderer: Renderer) -> Renderer:
    """The renderer with its still view switched off: every frame painted in full."""
    renderer.still.paint = lambda *args: False
    return renderer


@pytest.mark.parametrize("budget_bytes", [StillView().budget_bytes, 0])
def test_frames_from_the_still_picture_equal_frames_painted_in_full(screen, budget_bytes):
    standing = [(0.0, 0.0, 0.0, 0.0)] * 8  # the picture is built, then a cover a frame, then used alone
    moved = [(0.4, 0.6, 0.3, 0.05)]  # he steps and turns: the camera moves, the picture is dropped
    again = [(0.4, 0.6, 0.3, 0.0)] * 8  # standing again: a new picture
    shown, used = [], []
    for still in (True, False):
        arena, avatar = street_scene()
        r = Renderer((1280, 720), seed=4)
        r.still.budget_bytes = budget_bytes
        real = r.still.paint
        r.still.paint = lambda *args: used.append(real(*args)) or used[-1]
        r.react([ArenaEvent("hit", (1.5, 9.0, 1.2), 0.5)])  # sparks, some behind the building
        shown.append(frames(r if still else in_full(r), arena, avatar, standing + moved + again))
        if still and budget_bytes:  # the picture was used, and painted boxes back over what they hide
            assert used[7] and used[-1] and not used[8] and any(slot > 0 for slot in r.still.covers)
        elif still:
            assert not any(used) and not r.still.covers  # no cover fits: every frame was painted in full
    assert shown[0] == shown[1]
    assert shown[0][8] != shown[0][7]  # the camera moved


def test_a_moving_camera_keeps_no_picture(screen):
    arena, avatar = street_scene()
    r = Renderer((1280, 720), seed=4)
    frames(r, arena, avatar, [(0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0), (0.3, 0.0, 0.0, 0.05), (0.6, 0.0, 0.0, 0.05)])
    assert r.still.picture is None and not r.still.covers


def test_the_backdrop_from_the_still_picture_equals_the_backdrop_painted_in_full(screen):
    shown = []
    for still in (True, False):
        arena, _ = street_scene()
        r = Renderer((1280, 720), seed=4)
        r = r if still else in_full(r)
        for _ in range(3):  # no actors, no shadows: the picture alone from the second frame on
            r.draw_backdrop(screen, arena)
        shown.append(pygame.image.tobytes(screen, "RGB"))
        assert (r.still.picture is not None) == still
    assert shown[0] == shown[1]
