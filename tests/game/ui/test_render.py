"""The renderer: pinhole projection worked by hand, near-plane clipping, depth order, and frames that paint."""

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
from game.ui.render.camera import Camera, CameraRig, clip_near, depth_order  # noqa: E402
from game.ui.render.effects import Effects, Particles  # noqa: E402
from game.world.arena_model import ArenaEvent, Ball, BallState, HeldBall, Player, Zombie, ZombieState  # noqa: E402

IDENTITY = (1.0, 0.0, 0.0, 0.0)


def raised_avatar(player: Player, elevation_deg: float = 100.0, flex_deg: float = 40.0) -> Avatar:
    """An avatar standing where the player is, the tracked arm raised forward (board frame = bone frame)."""
    avatar = Avatar(BodySettings(), Wearing(IDENTITY, IDENTITY), body_yaw=player.yaw, position=(player.x, player.y))
    half = math.radians(elevation_deg) / 2
    avatar.update(ArmPose((math.cos(half), math.sin(half), 0.0, 0.0), flex_deg, 0.0))
    return avatar


def busy_scene(n_zombies: int = 60, seed: int = 1):
    """A duck-typed arena: walking zombies around the player, two flying, three balls with full trails."""
    rng = np.random.default_rng(seed)
    player = Player(x=0.0, y=0.0, yaw=0.0, health=72.0)
    zombies = []
    for i in range(n_zombies):
        ang, r = rng.uniform(0, 2 * math.pi), rng.uniform(3.0, 17.0)
        x, y = r * math.cos(ang), r * math.sin(ang)
        zombies.append(Zombie(id=i, x=x, y=y, speed=1.0, health=1, phase=rng.uniform(0, 2 * math.pi),
                              heading=math.atan2(-y, -x)))
    for z, height in zip(zombies[:2], (4.0, 9.0)):  # two blown into the sky, in front of the player
        z.x, z.y = z.x * 0.3, abs(z.y) * 0.5 + 6.0
        z.state, z.z, z.spin, z.age = ZombieState.FLYING, height, 1.3 + height, 0.4
    balls = []
    for k in range(3):
        start = np.array([0.25, 0.5, 1.5])
        v = np.array([math.sin(0.3 * (k - 1)), math.cos(0.3 * (k - 1)), 0.05]) * 18.0
        ball = Ball(position=tuple(start + v * (0.25 + 0.1 * k)), velocity=tuple(v), charge=0.3 * k + 0.2)
        for j in range(24):
            ball.trail.append(tuple(start + v * (0.25 + 0.1 * k) * j / 24))
        balls.append(ball)
    settings = SimpleNamespace(zombie_height_m=1.8, zombie_radius_m=0.35, hurt_flash_s=0.3,
                               ball_radius_m=0.22, ball_radius_per_charge_m=0.1)
    held = HeldBall(position=(0.3, 0.55, 1.7), state="spinning", charge=0.7, spin=1.0)
    arena = SimpleNamespace(player=player, zombies=zombies, balls=balls, held=held, score=1200, wave=3,
                            settings=settings)
    return arena, raised_avatar(player)


def hud_dict():
    return {"score": 1200, "wave": 3, "health": 72.0, "ball": "spinning", "charge": 0.7,
            "source": "tracker /dev/ttyUSB0", "rate_hz": 200.0, "loss_pct": 0.4, "calibrated": True, "fps": 60.0}


def plot_series(n: int = 600):
    t = np.arange(n) / 100.0
    return {"gyroscope (rad/s)": np.column_stack([np.sin(t), np.cos(2 * t), 0.1 * t]),
            "accelerometer (m/s2)": np.column_stack([0.2 * np.sin(5 * t), np.zeros(n), 9.81 + 0.1 * np.cos(t)]),
            "flex (ADC)": (390 - 60 * np.sin(t) ** 2)[:, None], "t": t}


# ------------------------------------------------------------------ camera


def straight_camera() -> Camera:
    cam = Camera(CameraRig(fov_y_deg=90.0), (1280, 720))
    cam.look_at((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))  # looking north, level
    return cam


def test_pinhole_focal_length_from_fov():
    cam = straight_camera()
    assert cam.f == pytest.approx(360.0)  # (720 / 2) / tan(45 deg)


def test_point_straight_ahead_lands_at_centre():
    xy, depth, vis = straight_camera().project(np.array([[0.0, 7.0, 0.0]]))
    assert xy[0] == pytest.approx([640.0, 360.0]) and depth[0] == pytest.approx(7.0) and vis[0]


def test_point_one_metre_right_and_up():
    cam = straight_camera()
    # 1 m right at a depth of 360 / 100 = 3.6 m: f * x / z = 100 px right of the centre
    xy, _, _ = cam.project(np.array([[1.0, 3.6, 0.0], [0.0, 3.6, 1.0], [-2.0, 7.2, -1.0]]))
    assert xy[0] == pytest.approx([740.0, 360.0])
    assert xy[1] == pytest.approx([640.0, 260.0])  # up is toward the top of the screen
    assert xy[2] == pytest.approx([540.0, 410.0])


def test_points_behind_the_camera_are_not_visible():
    _, depth, vis = straight_camera().project(np.array([[0.0, -3.0, 0.0], [1.0, 0.05, 0.0], [0.0, 2.0, 0.0]]))
    assert depth[0] == pytest.approx(-3.0)
    assert vis.tolist() == [False, False, True]  # behind, inside the near plane, in front


def test_follow_sits_behind_and_above_the_player():
    cam = Camera(CameraRig(back=4.5, up=2.6), (1280, 720))
    cam.follow(10.0, 5.0, math.pi / 2, 0.016)  # first call snaps; facing west (-x)
    assert cam.eye == pytest.approx([14.5, 5.0, 2.6])
    xy, _, vis = cam.project(np.array([[10.0 - 6.0, 5.0, 1.3]]))  # the look-at point: screen centre
    assert vis[0] and xy[0] == pytest.approx([640.0, 360.0])


def test_follow_is_smooth():
    cam = Camera()
    cam.follow(0.0, 0.0, 0.0, 0.016)
    cam.follow(1.0, 0.0, 0.0, 0.016)
    x = cam.state[0]
    assert 0.0 < x < 1.0
    for _ in range(200):
        cam.follow(1.0, 0.0, 0.0, 0.016)
    assert cam.state[0] == pytest.approx(1.0)


def test_yaw_follow_takes_the_short_way_round():
    cam = Camera()
    cam.snap(0.0, 0.0, math.radians(179))
    cam.follow(0.0, 0.0, math.radians(-179), 0.05)
    assert math.degrees(cam.state[2]) > 179  # through 180, not back through 0


def test_near_plane_clipping_of_a_crossing_segment():
    near = 0.5
    a = np.array([[0.0, 0.0, -2.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])  # camera space: x, y, depth
    b = np.array([[4.0, 2.0, 2.0], [1.0, 0.0, 3.0], [0.0, 0.0, 0.2]])
    ca, cb, keep = clip_near(a, b, near)
    assert keep.tolist() == [True, True, False]
    # crossing: depth -2 -> 2, the plane 0.5 is at t = 2.5 / 4
    assert ca[0] == pytest.approx([2.5, 1.25, 0.5]) and cb[0] == pytest.approx(b[0])
    assert ca[1] == pytest.approx(a[1]) and cb[1] == pytest.approx(b[1])  # wholly in front: untouched


def test_project_segments_gives_finite_pixels_for_a_segment_through_the_camera():
    cam = straight_camera()
    pa, pb, keep = cam.project_segments(np.array([[1.0, -5.0, -1.0]]), np.array([[1.0, 5.0, -1.0]]))
    assert keep[0] and np.isfinite(pa).all() and np.isfinite(pb).all()
    assert pb[0] == pytest.approx([640 + 360 / 5, 360 + 360 / 5])
    assert pa[0][0] > pb[0][0]  # the clipped end lies far out toward the lower right


def test_depth_order_far_first():
    order = depth_order(np.array([3.0, 12.0, 0.5, 7.0, 12.0]))
    assert order.tolist() == [1, 4, 3, 0, 2]


def test_horizon_row_matches_a_far_ground_point():
    cam = Camera()
    cam.snap(0.0, 0.0, 0.0)
    xy, _, _ = cam.project(np.array([[0.0, 1e6, 0.0]]))
    assert cam.horizon_y() == pytest.approx(xy[0, 1], abs=0.5)


# ------------------------------------------------------------------ world frames


def test_draw_world_paints_the_scene(screen):
    arena, avatar = busy_scene(12)
    r = Renderer((1280, 720), seed=3)
    r.draw_world(screen, arena, avatar, 1 / 60)
    painted = screen.copy()
    empty = SimpleNamespace(**{**vars(arena), "zombies": [], "balls": [],
                               "held": HeldBall(state="idle", visible=False)})
    Renderer((1280, 720), seed=3).draw_world(screen, empty, avatar, 1 / 60)
    bare = screen.copy()
    # every walking zombie in view shows its green body where its torso projects
    checked = 0
    for z in arena.zombies[2:]:
        xy, depth, vis = r.camera.project(np.array([[z.x, z.y, 1.2]]))
        x, y = (int(v) for v in xy[0])
        if not (vis[0] and 5 < depth[0] < 12 and 0 <= x < 1280 and 0 <= y < 720):
            continue
        if abs(z.x) < 1.5 and 0 < z.y < 3:  # could be hidden behind the avatar
            continue
        c = painted.get_at((x, y))
        assert tuple(c) != tuple(bare.get_at((x, y)))
        assert c.g > c.r and c.g > c.b, (z, tuple(c))
        checked += 1
    assert checked >= 2
    # the avatar's chest is painted in its own colour, distinct from zombies
    xy, _, _ = r.camera.project(np.array([avatar.world_pos["spine"]]))
    c = painted.get_at(tuple(int(v) for v in xy[0]))
    assert c.b > c.g > c.r


def test_flying_zombie_and_balls_are_drawn(screen):
    arena, avatar = busy_scene(4)
    r = Renderer((1280, 720), seed=1)
    r.draw_world(screen, arena, avatar, 1 / 60)
    for ball in arena.balls:  # glow centres are bright
        xy, _, vis = r.camera.project(np.array([ball.position]))
        assert vis[0]
        c = screen.get_at(tuple(int(v) for v in xy[0]))
        assert min(c.r, c.g, c.b) > 180
    z = arena.zombies[0]
    xy, _, vis = r.camera.project(np.array([[z.x, z.y, z.z + 0.95]]))
    c = screen.get_at(tuple(int(v) for v in xy[0]))
    assert c.g > 120  # the flying zombie's hips, tinted


def test_draw_world_into_a_resized_surface():
    arena, avatar = busy_scene(20)
    r = Renderer((1280, 720))
    big = pygame.Surface((1280, 720))
    r.draw_world(big, arena, avatar, 1 / 60)
    small = pygame.Surface((800, 600))
    r.draw_world(small, arena, avatar, 1 / 60)
    assert (r.camera.width, r.camera.height) == (800, 600)
    assert r.camera.horizon_y() < 300  # above the centre (the camera looks slightly down)
    xy, _, _ = r.camera.project(np.array([[0.0, 6.0, 1.3]]))
    assert xy[0] == pytest.approx([400.0, 300.0], abs=1.0)
    arr = pygame.surfarray.array3d(small)
    assert arr.std() > 10  # not a blank fill


def test_hurt_vignette_reddens_the_edges(screen):
    arena, avatar = busy_scene(0)
    r = Renderer((1280, 720))
    r.draw_world(screen, arena, avatar, 0.0)
    before, centre = screen.get_at((2, 360)), screen.get_at((640, 250))
    arena.player.hurt = 0.3
    r.draw_world(screen, arena, avatar, 0.0)
    after = screen.get_at((2, 360))
    assert after.r > before.r + 60 and after.g <= before.g + 12
    assert screen.get_at((640, 250)) == centre  # the middle of the view stays clear


def test_gone_zombies_and_fading_balls_and_no_held_ball(screen):
    arena, avatar = busy_scene(5)
    arena.zombies[3].state = ZombieState.GONE
    arena.balls[0].state, arena.balls[0].fade = BallState.FADING, 0.3
    arena.held = None
    Renderer((1280, 720)).draw_world(screen, arena, avatar, 1 / 60)


# ------------------------------------------------------------------ effects


def test_hit_makes_a_burst_that_dies_out():
    r = Renderer((1280, 720), seed=5)
    r.react([ArenaEvent("hit", (1.0, 8.0, 1.2), 0.5), ArenaEvent("spawn", (5.0, 5.0, 0.0))])
    assert r.effects.particles.count > 40 and len(r.effects.flashes) == 1
    for _ in range(150):  # 2.5 s
        r.update_effects(1 / 60)
    assert r.effects.particles.count == 0 and not r.effects.flashes


def test_particle_cap_is_respected():
    p = Particles(cap=400, rng=np.random.default_rng(0))
    for _ in range(30):
        p.emit((0.0, 0.0, 1.0), 50, 3.0)
    assert p.count == 400
    r = Renderer((1280, 720), seed=2)
    r.react([ArenaEvent("hit", (0.0, 5.0, 1.0))] * 40)
    assert r.effects.particles.count <= Effects.MAX_PARTICLES


def test_effects_are_deterministic(screen):
    frames = []
    for _ in range(2):
        arena, avatar = busy_scene(10)
        r = Renderer((1280, 720), seed=9)
        r.react([ArenaEvent("hit", (0.0, 6.0, 1.0))])
        for _ in range(3):
            r.draw_world(screen, arena, avatar, 1 / 60)
        frames.append(pygame.image.tobytes(screen, "RGB"))
    assert frames[0] == frames[1]


# ------------------------------------------------------------------ HUD, plots, screens


def test_hud_and_plots_draw(screen):
    r = Renderer((1280, 720))
    screen.fill((0, 0, 0))
    r.draw_hud(screen, hud_dict())
    assert screen.get_at((30, 30)) != pygame.Color(0, 0, 0) or screen.get_bounding_rect().width > 0
    health_bar = pygame.Rect(22, 16 + 720 // 18, 1280 // 5, 720 // 50)
    c = screen.get_at((health_bar.left + 5, health_bar.centery))
    assert c.g > 100  # 72 % health: mostly green
    before = pygame.image.tobytes(screen, "RGB")
    rect = pygame.Rect(860, 390, 400, 300)
    r.draw_plots(screen, plot_series(), rect)
    assert pygame.image.tobytes(screen, "RGB") != before
    arr = pygame.surfarray.array3d(screen)[rect.left:rect.right, rect.top:rect.bottom]
    assert (arr[..., 0] > 200).any() and (arr[..., 2] > 200).any()  # red x and blue z traces
    r.draw_hud(screen, {"score": 0, "wave": 1, "health": 100, "ball": "idle", "charge": 0.0,
                        "input": "keyboard + mouse", "calibrated": False, "fps": 59.7, "notice": "board found"})
    r.draw_hud(screen, {})  # every key optional


def test_plots_cope_with_empty_flat_and_nan_series(screen):
    r = Renderer((1280, 720))
    r.draw_plots(screen, {"gyroscope (rad/s)": np.zeros((0, 3)), "flex (ADC)": np.full((50, 1), 390.0),
                          "acc": np.array([[np.nan, 1.0, 2.0], [0.0, np.nan, 2.5]])}, pygame.Rect(10, 10, 300, 200))
    r.draw_plots(screen, {}, pygame.Rect(10, 10, 300, 200))


def test_screen_helpers_draw(screen):
    r = Renderer((1280, 720))
    screen.fill((0, 0, 0))
    r.draw_title(screen, "ENERGYBALL", "raise your arm, flex, snap it straight")
    r.draw_menu(screen, ["Play", "Calibrate", "Settings", "Quit"], 1, 360)
    r.draw_panel(screen, ["HIGH SCORES", "1. ann 1200", "", "Enter: menu"], pygame.Rect(20, 600, 500, 100))
    r.draw_banner(screen, "WAVE 3", (250, 210, 80))
    r.draw_countdown(screen, 2.4, "Hold your arm down")
    arm = pygame.Rect(940, 80, 320, 240)
    before = pygame.surfarray.array3d(screen)[arm.left:arm.right, arm.top:arm.bottom].copy()
    _, avatar = busy_scene(0)
    r.draw_arm_view(screen, avatar, arm)
    after = pygame.surfarray.array3d(screen)[arm.left:arm.right, arm.top:arm.bottom]
    orange = (after[..., 0] > 200) & (after[..., 1] > 120) & (after[..., 2] < 100)
    assert (after != before).any() and orange.sum() > 50  # the tracked arm, in its colour
    assert screen.get_bounding_rect().width > 600


# ------------------------------------------------------------------ geometry helpers


def test_walking_zombie_reaches_forward_along_its_heading():
    from game.ui.render.actors import Z_FOOTL, Z_HANDL, Z_HANDR, Z_HEAD, Z_HIP, zombie_joints
    for heading, forward in ((0.0, (1.0, 0.0)), (math.pi / 2, (0.0, 1.0))):
        j = zombie_joints([2.0], [3.0], [0.0], [math.pi / 2], [heading], [0.0], [False], [0.0])[0]  # mid-stride
        reach = (j[Z_HANDL, :2] + j[Z_HANDR, :2]) / 2 - j[Z_HIP, :2]
        assert reach @ np.array(forward) > 0.5  # the arms stretch out ahead
        assert j[Z_HEAD, 2] == pytest.approx(1.66, abs=0.05) and j[Z_FOOTL, 2] == pytest.approx(0.0, abs=0.01)
        assert j[Z_HIP, :2] == pytest.approx([2.0, 3.0])


def test_flying_zombie_tumbles_with_spin_and_scales_with_height():
    from game.ui.render.actors import Z_HEAD, Z_HIP, zombie_joints
    upright, flipped = zombie_joints([0, 0], [0, 0], [5.0, 5.0], [0, 0], [0, 0], [0.0, math.pi], [True, True],
                                     [0.3, 0.3])
    assert upright[Z_HEAD, 2] > upright[Z_HIP, 2] > 5.0
    assert flipped[Z_HEAD, 2] < flipped[Z_HIP, 2]  # upside down
    tall = zombie_joints([0], [0], [0], [0], [0], [0], [False], [0], height=3.6)[0]
    assert tall[Z_HEAD, 2] == pytest.approx(2 * 1.66, abs=0.1)


def test_ground_grid_lines_every_two_metres_on_a_disc():
    from game.ui.render.world import grid_segments
    a, b = grid_segments(10.0, -4.0, 2.0, 56.0)
    xs = np.unique(a[: len(a) // 2, 0])
    assert np.diff(xs) == pytest.approx(2.0) and xs.min() > 10 - 56 and xs.max() < 10 + 56
    assert np.all(np.hypot(a[:, 0] - 10.0, a[:, 1] + 4.0) == pytest.approx(56.0))  # ends on the rim
    assert (a[:, 2] == 0).all() and (b[:, 2] == 0).all()


def test_title_glow_leaves_no_box(screen):
    r = Renderer((1280, 720))
    screen.fill((20, 20, 40))
    r.draw_title(screen, "ENERGYBALL", "sub")
    rect = r.text.render("ENERGYBALL", 720 // 7).get_rect(midtop=(640, 720 // 6))
    assert tuple(screen.get_at((rect.left + 2, rect.top + 1)))[:3] == (20, 20, 40)  # a corner between letters


def test_calls_painted_again_unchanged_come_from_one_picture_with_the_same_pixels(screen):
    from game.ui.render.actors import RepeatedCalls, paint_calls

    drawn = []

    def line(surface, *args):  # pygame.draw.line, counted
        drawn.append(args)
        return pygame.draw.line(surface, *args)

    glow = pygame.Surface((30, 30))
    glow.fill((60, 40, 20))
    calls = [(line, ((8, 10, 22), (300, 200), (340, 420), 14)), (pygame.draw.circle, ((70, 130, 240), (320, 200), 9)),
             (pygame.Surface.blit, (glow, (310, 300), None, pygame.BLEND_RGB_ADD)),  # adds: painted as it comes
             (line, ((255, 160, 50), (330, 300), (-5, 330), 6))]  # off the screen's left edge
    background = pygame.Surface(screen.get_size())
    background.fill((90, 100, 110))
    pygame.draw.line(background, (200, 30, 30), (0, 310), (1279, 330), 9)

    def frame(paint) -> tuple[bytes, list]:
        screen.blit(background, (0, 0))
        rects = paint(screen, calls)
        return pygame.image.tobytes(screen, "RGB"), rects

    direct = frame(paint_calls)
    repeated = RepeatedCalls()
    drawn.clear()
    frames = [frame(repeated.paint) for _ in range(3)]
    assert all(f == direct for f in frames)
    assert len(drawn) == 4  # two runs drawn at the first frame and again for their pictures, then blitted
    calls[3] = (line, ((255, 160, 50), (330, 300), (20, 360), 6))  # the second run moves: drawn as it comes
    assert frame(repeated.paint) == frame(paint_calls)


def test_panel_text_is_wrapped_at_spaces_to_the_panels_width():
    r = Renderer((1280, 720))
    notice = ("board calibration /root/.config/energyball/boards/virtual-imu-71.json: no calibration saved "
              "for this board yet (armtracker calibrate accel, then calibrate mag); using the default")
    lines = r.panel_lines(["input: board 200 Hz, loss 0.0%", notice], 600, 720)
    font = r.text.font(max(16, min(28, 720 // 28)))
    assert lines[0] == "input: board 200 Hz, loss 0.0%"
    assert len(lines) >= 3 and all(font.size(line)[0] <= 600 for line in lines)
    assert " ".join(lines[1:]) == notice  # every word kept, in order
    surface = pygame.Surface((1280, 720))
    r.draw_panel(surface, [notice], pygame.Rect(20, 500, 640, 200))  # drawn inside the panel
    pixels = pygame.surfarray.array3d(surface)  # [x, y, rgb]
    assert pixels[20:660, 500:700].any() and not pixels[660:, 500:700].any()
