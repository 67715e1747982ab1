"""Screenshots of every screen, and the game's benchmarks (frame time, input latency).

Both run the real app under SDL's dummy video driver (no window needed), with
a throwaway settings folder so the player's own files are never touched.
"""

from __future__ import annotations

import math
import os
import statistics
import tempfile
import time
from pathlib import Path
from typing import Callable, Sequence

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

import numpy as np  # noqa: E402
import pygame  # noqa: E402

from tracker.atomic import AtomicFile  # noqa: E402

from ..world.arena_model import Controls, Zombie, ZombieState  # noqa: E402
from ..world.collision import inside  # noqa: E402
from ..world.town import make_town  # noqa: E402
from .app import App, BoardSetupScreen, Calibration, GameOver, Menu, Pause, Play, Settings  # noqa: E402
from .board_setup import ACCEL_DONE, FAILED, MAG, MAG_DONE, WARM, WARM_DONE, MakerInput  # noqa: E402
from .preferences import Preferences  # noqa: E402

SIZE = (1280, 720)
SETUP_LIMIT_S = 1000.0  # the board setup's shots give up after this much simulated time
WARM_FRAME_S = 0.5  # the warm-up's ten minutes go by in frames this long (nothing on screen moves faster)


def _app(folder: str) -> App:
    return App(Preferences(input="keyboard"), config_dir=Path(folder), seed=7, size=SIZE)


def _key(key: int, down: bool = True) -> pygame.event.Event:
    return pygame.event.Event(pygame.KEYDOWN if down else pygame.KEYUP, key=key, mod=0, unicode="")


def densest_view(seeds: Sequence[int] = range(8), reach_m: float = 30.0, half_fov_deg: float = 45.0,
                 step_m: float = 2.0) -> tuple[int, float, float, float]:
    """The densest part of the towns of ``seeds``: (seed, x, y, yaw) of the player who sees the most obstacles.

    The player stands on open ground (clear of obstacles by a metre) every
    ``step_m`` across the town and faces each of eight ways; the camera
    behind him (:class:`~game.ui.render.camera.CameraRig`'s 4.5 m) must stand
    clear too. Counted: the obstacles whose centre lies within ``reach_m``
    of the camera and ``half_fov_deg`` of the way he faces (the view's half
    width at 16:9 and 60 degrees high is 46 degrees). Ties go to the first
    seed, place and way found.
    """
    best: tuple[int, int, float, float, float] | None = None
    yaws = np.arange(8) * (math.pi / 4)
    fx, fy = -np.sin(yaws), np.cos(yaws)  # yaw 0 faces +y
    cos_half = math.cos(math.radians(half_fov_deg))
    for seed in seeds:
        town = make_town(seed)
        centres = np.array([((o.x0 + o.x1) / 2, (o.y0 + o.y1) / 2) for o in town.obstacles]).reshape(-1, 2)
        h = town.half_size_m - step_m
        for x in np.arange(-h, h + 1e-9, step_m).tolist():
            for y in np.arange(-h, h + 1e-9, step_m).tolist():
                if inside(town, x, y, 1.0, 0.0):
                    continue
                cx, cy = x - 4.5 * fx, y - 4.5 * fy  # the camera, each way
                dx, dy = centres[None, :, 0] - cx[:, None], centres[None, :, 1] - cy[:, None]
                dist = np.hypot(dx, dy)
                ahead = (dx * fx[:, None] + dy * fy[:, None]) > cos_half * dist
                counts = ((dist < reach_m) & ahead).sum(axis=1)
                for k in np.argsort(-counts, kind="stable").tolist():
                    if best is not None and counts[k] <= best[0]:
                        break
                    if abs(cx[k]) < town.half_size_m and abs(cy[k]) < town.half_size_m \
                            and not inside(town, float(cx[k]), float(cy[k]), 0.3, 0.0):
                        best = (int(counts[k]), seed, x, y, float(yaws[k]))
                        break
    if best is None:
        raise ValueError("no place in these towns where the player and his camera stand clear")
    return best[1:]


def town_scene(app: App, seed: int, x: float, y: float, yaw: float) -> None:
    """A new round in the town of ``seed``, the player at (x, y) facing ``yaw``."""
    app.game.seed = seed
    app.game.new_round()
    player = app.game.arena.player
    player.x, player.y, player.yaw = x, y, yaw
    app.game.stand_avatar()


def busy_arena(app: App, zombies: int = 60, balls: int = 3, seed: int = 1, health: float = 1e9) -> None:
    """A mid-wave scene around the player: zombies on the open ground all round him (from 4 to 16 m
    away), some blown into the air, balls in flight.

    ``health``: the player's; a benchmark makes it endless so no game over ends the run.
    """
    arena = app.game.arena
    town, p = arena.town, arena.player
    rng = np.random.default_rng(seed)
    arena.wave, arena.score = max(arena.wave, 3), max(arena.score, 1200)
    p.health = health
    arena.zombies = []
    fx, fy = -math.sin(p.yaw), math.cos(p.yaw)
    while len(arena.zombies) < zombies:
        r, a = rng.uniform(4, 16), rng.uniform(0, 2 * math.pi)
        x, y = p.x + r * math.cos(a), p.y + r * math.sin(a)
        if abs(x) > town.half_size_m - 1 or abs(y) > town.half_size_m - 1 or inside(town, x, y, 0.4, 0.0):
            continue
        i = len(arena.zombies)
        z = Zombie(i, x, y, speed=rng.uniform(0.6, 1.1), health=1, phase=rng.uniform(0, 6.3), heading=a + math.pi)
        if i % 12 == 0:  # a few already blown into the sky
            z.state, z.z, z.velocity, z.spin_rate = ZombieState.FLYING, rng.uniform(2, 6), (0.0, 2.0, 6.0), 5.0
        arena.zombies.append(z)
    for k in range(balls):
        turn = 0.4 * (k - 1)
        direction = (-math.sin(p.yaw + turn), math.cos(p.yaw + turn), 0.05)
        along = 0.5 + 2.0 * k
        arena.launch((p.x + fx * along + 0.3 * fy, p.y + fy * along - 0.3 * fx, 1.4), direction, 0.4 + 0.3 * k)
    for _ in range(8):  # give the balls trails
        arena.step(Controls())


def _raise_and_spin(app: App) -> None:
    kb = app.game.keyboard
    kb.raised, kb.flexed, kb.aim_x = True, True, 0.15
    for _ in range(60):
        app.frame([], 1 / 60)


def shots(out: str | os.PathLike) -> list[Path]:
    """Render menu, calibration, play, pause, game over, settings and the board setup (its three procedures,
    a few moments each) to PNG files in ``out``."""
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    with tempfile.TemporaryDirectory() as config:
        app = _app(config)

        def save(name: str) -> None:
            app.screen.draw(app.surface)
            path = folder / f"{name}.png"
            with AtomicFile(path) as f:  # a shot cut off half-way never replaces a good one
                pygame.image.save(app.surface, f.file, path.name)
            written.append(path)

        app.frame([], 1 / 60)
        save("menu")
        app.screen = Calibration(app.game, then_play=False)
        app.game.keyboard.raised = False
        for _ in range(150):
            app.frame([], 1 / 60)
        save("calibration")
        town_scene(app, *densest_view())
        app.screen = Play(app.game)
        busy_arena(app, zombies=24, health=72.0)
        _raise_and_spin(app)
        save("play")
        app.screen = Pause(app.game, "Paused")
        save("pause")
        app.game.arena.score = 4200
        app.game.arena.player.health = 0.0
        app.screen = GameOver(app.game)
        save("game_over")
        app.screen = Settings(app.game)
        save("settings")
        board_setup_shots(app, save)
        app.screen = Menu(app.game)
        app.close()
    return written


def board_setup_shots(app: App, save: Callable[[str], None]) -> None:
    """The board setup with a simulated maker in simulated time, a few moments of each procedure:
    the board just plugged in, its poses waiting for it to warm, a face held still, the board turning to the
    next, a leaning pose held, the accelerometer's result; the sphere a third and two thirds covered, the
    magnetometer's result; the board warming, the warm-up's result."""
    from tracker.maker_sim import SimulatedMaker

    dt = 1 / 60
    board = MakerInput(SimulatedMaker(seed=7), dt)
    app.game.use_source(board)
    screen = BoardSetupScreen(app.game)
    app.screen = screen
    moments: list[tuple[str, Callable[[], bool]]] = [
        ("board_setup_accel_warming", lambda: accel().waiting and accel().warming is not None),
        ("board_setup_accel_hold", lambda: len(accel().captured) == 2 and accel().still_s > 1.2),
        ("board_setup_accel_turn", lambda: len(accel().captured) == 4 and accel().up is None),
        ("board_setup_accel_lean", lambda: len(accel().captured) == 7 and accel().still_s > 1.2),
        ("board_setup_accel_done", lambda: phase() == ACCEL_DONE),
        ("board_setup_mag_third", lambda: phase() == MAG and mag().coverage >= 0.33),
        ("board_setup_mag_two_thirds", lambda: phase() == MAG and mag().coverage >= 0.67),
        ("board_setup_mag_done", lambda: phase() == MAG_DONE),
        ("board_setup_warm", lambda: phase() == WARM and warm().elapsed_s >= 240.0),
        ("board_setup_warm_done", lambda: phase() == WARM_DONE)]

    def phase() -> str:
        return screen.setup.phase if screen.setup else ""

    def accel():
        assert screen.setup is not None
        return screen.setup.accel_status

    def mag():
        assert screen.setup is not None
        return screen.setup.mag_status

    def warm():
        assert screen.setup is not None
        return screen.setup.warm_status

    t = 0.0
    while moments and t < SETUP_LIMIT_S:
        app.frame([], dt, draw=False)
        t += dt
        if phase() == FAILED:
            raise RuntimeError(f"the board setup failed: {screen.setup.message() if screen.setup else ''}")
        name, reached = moments[0]
        if screen.setup is not None and reached():
            save(name)
            moments.pop(0)
            if phase() in (ACCEL_DONE, MAG_DONE):
                app.frame([_key(pygame.K_RETURN)], dt, draw=False)
            if name == "board_setup_mag_done":  # on to the warm-up: the board lies still for minutes
                board.frame_s = dt = WARM_FRAME_S
    if moments:
        raise RuntimeError(f"the board setup did not reach {moments[0][0]} in {SETUP_LIMIT_S:g} s")
    app.game.use_keyboard()


def bench(frames: int = 300, progress: Callable[[str], None] | None = None) -> dict:
    """Frame time with a busy arena in the densest part of the town (:func:`densest_view`), and input
    latency from a virtual board."""
    with tempfile.TemporaryDirectory() as config:
        app = _app(config)
        town_scene(app, *densest_view())
        app.screen = Play(app.game)
        busy_arena(app)
        _raise_and_spin(app)
        times = []
        for i in range(frames):
            start = time.perf_counter()
            app.frame([], 1 / 60)
            _still_playing(app)
            if i % 40 == 0:  # keep the scene busy: more balls, zombies back in
                busy_arena(app, seed=i)
            times.append(1000 * (time.perf_counter() - start))
        if progress:
            progress(f"frame time: {len(times)} frames measured")
        latency = input_latency(app, progress)
        app.close()
    return {"frame_ms_median": round(statistics.median(times), 3),
            "frame_ms_p95": round(float(np.percentile(times, 95)), 3), **latency}


def _board_process(link: str, seconds: float, ready, results) -> None:
    """A virtual board in its own process, as a real board is outside the game's."""
    from tracker.board import BoardSettings, VirtualBoard

    with VirtualBoard(settings=BoardSettings(rate_hz=200, keep_sent=100_000), link=link) as board:
        ready.set()
        time.sleep(seconds)
        results.put(list(board.sent_at))


def _still_playing(app: App) -> None:
    if not isinstance(app.screen, Play):
        raise RuntimeError(f"the benchmark left the play screen for {type(app.screen).__name__}")


def input_latency(app: App, progress: Callable[[str], None] | None, seconds: float = 5.0) -> dict:
    """From a sample's write on the virtual board's side of the pty to the first frame drawn with it.

    The board runs in another process (time.monotonic is system-wide, so its
    write times compare with ours); the game polls the link and draws frames
    as fast as it can, as it does when it is not waiting for the display.
    """
    import multiprocessing as mp

    from tracker.link import LinkSettings

    from ..body.controls import TrackerInput

    ctx = mp.get_context("spawn")
    ready, results = ctx.Event(), ctx.Queue()
    with tempfile.TemporaryDirectory() as folder:
        link = os.path.join(folder, "ttyBOARD")
        board = ctx.Process(target=_board_process, args=(link, seconds + 4.0, ready, results), daemon=True)
        board.start()
        ready.wait(20.0)
        busy_arena(app)
        tracker = TrackerInput(LinkSettings(link))
        tracker.opened.wait(5.0)
        app.game.tracker = tracker
        drawn: dict[int, float] = {}
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            app.frame([], 1 / 240)
            pygame.display.flip()
            _still_playing(app)
            if tracker.last_seq is not None:
                drawn.setdefault(tracker.last_seq, time.monotonic())
        tracker.close()
        app.game.tracker = None
        sent = dict(results.get(timeout=30.0))
        board.join(10.0)
    latencies = _latencies(drawn, sent)
    if progress:
        progress(f"input latency: {len(latencies)} samples measured")
    return {"input_latency_ms_median": round(statistics.median(latencies), 3) if latencies else None,
            "input_latency_ms_p99": round(float(np.percentile(latencies, 99)), 3) if latencies else None}


def _latencies(drawn: dict[int, float], sent: dict[int, float]) -> list[float]:
    """Each sample's latency: from its write to the first frame that used it or a later sample."""
    frames = sorted(drawn.items())
    first_frame = min(drawn.values(), default=math.inf)
    latencies = []
    for seq, t_write in sorted(sent.items()):
        if t_write < first_frame:  # written before the link was up (the handshake)
            continue
        shown = next((t for s, t in frames if s >= seq), None)
        if shown is not None:
            latencies.append(1000 * (shown - t_write))
    return latencies
