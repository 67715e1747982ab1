"""How fast the town's logic runs: ``python -m game.world.bench`` prints JSON.

On the densest of the towns of seeds 0-9 (the most portals: the dearest flow
field), with ``--zombies`` (60) zombies walking their waypoints to a player
who walks round the town: the microseconds per zombie step (waypoint and
push_out), per flow-field rebuild (every region as the goal), per ball step
(sweep_sphere) and per line of sight; the milliseconds to build the town
and its navigator; how many rebuilds a walking player causes. Wall-clock
figures, so they vary with the machine and its load; the inputs are seeded.
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

from .collision import push_out, sweep_sphere
from .navigation import Navigator
from .sight import sees
from .town import LAYOUTS, Town, make_town

DT = 1.0 / 120.0
ZOMBIE_RADIUS_M = 0.35
ZOMBIE_SPEED_M_S = 1.2
PLAYER_SPEED_M_S = 3.0
STOP_M = 0.81  # a zombie stops this near the player (the arena's 0.9 * contact distance)


def densest_town(seeds: range = range(10)) -> Town:
    """The town of those seeds and every layout whose navigator has the most portals."""
    towns = [make_town(seed, layout) for seed in seeds for layout in LAYOUTS]
    return max(towns, key=lambda t: len(Navigator(t).portals))


def _micro(total_s: float, count: int) -> float:
    return round(total_s / count * 1e6, 2)


def bench(zombies: int = 60, seconds: float = 20.0, seed: int = 0) -> dict:
    """The figures (see the module's docstring) as a dict."""
    town = densest_town()
    t0 = time.perf_counter()
    make_town(town.seed, town.layout)
    t1 = time.perf_counter()
    nav = Navigator(town)
    t2 = time.perf_counter()
    rebuild = time.perf_counter()
    for region in range(len(nav.regions)):
        nav._flow_field(region)
    rebuild = time.perf_counter() - rebuild

    rng = np.random.default_rng(seed)
    free = [k for k in range(nav.n * nav.n) if nav.free[k]]
    cells = rng.choice(free, zombies, replace=False)
    xs = [nav.origin + (k % nav.n + 0.5) * nav.settings.cell_m for k in cells]
    ys = [nav.origin + (k // nav.n + 0.5) * nav.settings.cell_m for k in cells]
    start = time.perf_counter()
    visible = sum(sees(town, town.start, (x, y)) for x, y in zip(xs, ys))  # from where they start
    sight_s = time.perf_counter() - start
    route = list(town.spawn_points) + [town.start]  # the player walks from spawn point to spawn point
    px, py = town.start
    target = 0
    steps = int(seconds / DT)
    builds_before = len(nav._fields)
    waypoint_s = push_s = 0.0
    walk, player_step = ZOMBIE_SPEED_M_S * DT, PLAYER_SPEED_M_S * DT
    for _ in range(steps):
        tx, ty = route[target]
        d = math.hypot(tx - px, ty - py)
        if d < player_step:
            target = (target + 1) % len(route)
        else:
            px, py = push_out(town, px + (tx - px) / d * player_step, py + (ty - py) / d * player_step,
                              ZOMBIE_RADIUS_M)
        nav.set_goal(px, py)
        start = time.perf_counter()
        for i in range(zombies):
            x, y = xs[i], ys[i]
            wx, wy, final = nav.waypoint(x, y)
            dx, dy = wx - x, wy - y
            d = math.sqrt(dx * dx + dy * dy)
            if d > (STOP_M if final else 1e-9):
                xs[i], ys[i] = x + dx / d * walk, y + dy / d * walk
        middle = time.perf_counter()
        for i in range(zombies):
            xs[i], ys[i] = push_out(town, xs[i], ys[i], ZOMBIE_RADIUS_M)
        end = time.perf_counter()
        waypoint_s += middle - start
        push_s += end - middle
    rebuilds = len(nav._fields) - builds_before

    balls = 2000
    origins = rng.uniform(-town.half_size_m, town.half_size_m, (balls, 2))
    angles = rng.uniform(0.0, 2.0 * math.pi, balls)
    step = 30.0 * DT
    paths = [((float(x), float(y), 1.2), (float(x + step * math.cos(a)), float(y + step * math.sin(a)), 1.2))
             for (x, y), a in zip(origins, angles)]
    start = time.perf_counter()
    hits = sum(sweep_sphere(town, p0, p1, 0.32) is not None for p0, p1 in paths)
    sweep_s = time.perf_counter() - start

    return {
        "town": {"layout": town.layout, "seed": town.seed, "obstacles": len(town.obstacles),
                 "regions": len(nav.regions), "portals": len(nav.portals)},
        "make_town_ms": round((t1 - t0) * 1e3, 2),
        "navigator_build_ms": round((t2 - t1) * 1e3, 2),
        "flow_field_rebuild_us": _micro(rebuild, len(nav.regions)),
        "zombies": zombies,
        "waypoint_us_per_zombie_step": _micro(waypoint_s, steps * zombies),
        "push_out_us_per_zombie_step": _micro(push_s, steps * zombies),
        "zombie_step_us": _micro(waypoint_s + push_s, steps * zombies),
        "player_walked_s": seconds,
        "flow_field_rebuilds": rebuilds,
        "rebuild_ms_per_game_s": round(rebuilds * rebuild / len(nav.regions) * 1e3 / seconds, 3),
        "sweep_sphere_us_per_ball_step": _micro(sweep_s, balls),
        "ball_steps_hitting": hits,
        "sight_us_per_zombie": _micro(sight_s, zombies),
        "zombies_seen_at_first_from_start": visible,
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m game.world.bench", description=__doc__.splitlines()[0])
    parser.add_argument("--zombies", type=int, default=60, help="walking zombies (default 60)")
    parser.add_argument("--seconds", type=float, default=20.0, help="game seconds the player walks (default 20)")
    parser.add_argument("--seed", type=int, default=0, help="where the zombies start (default 0)")
    args = parser.parse_args(argv)
    print(json.dumps(bench(args.zombies, args.seconds, args.seed)))


if __name__ == "__main__":
    main()
