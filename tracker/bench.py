"""Benchmarks of the tracker's hot paths; ``armtracker bench --json`` prints them.

Figures are medians over repeats of wall-clock time on this machine; they
belong here, never in unit tests.
"""

from __future__ import annotations

import random
import statistics
import time
from typing import Callable

import numpy as np

from . import protocol as P
from .evaluate import available_peers
from .fusion import FILTERS, make

FRAMES = 20_000
REPEATS = 5
CHUNK = 256  # bytes per feed: about what one serial read returns while streaming


def _frames(n: int, seed: int = 0) -> list[P.RawSample]:
    rng = random.Random(seed)

    def axis() -> tuple[int, int, int]:
        return tuple(rng.randint(-32768, 32767) for _ in range(3))  # type: ignore[return-value]

    return [P.RawSample(0.0, i * 5000, i & 0xFFFF, axis(), axis(), axis(), rng.randrange(1024))
            for i in range(n)]


def _median_rate(n: int, run: Callable[[], None]) -> float:
    times = []
    for _ in range(REPEATS):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return n / statistics.median(times)


def decode_rate(n: int = FRAMES) -> float:
    """Raw frames per second the incremental decoder takes, fed in serial-sized chunks."""
    blob = b"".join(P.encode_raw(s) for s in _frames(n))

    def run() -> None:
        d = P.FrameDecoder()
        for i in range(0, len(blob), CHUNK):
            d.feed(blob[i:i + CHUNK])
        assert d.stats.frames == n

    return _median_rate(n, run)


def encode_rate(n: int = FRAMES) -> float:
    """Raw frames per second the encoder produces (the virtual board's cost)."""
    samples = _frames(n)
    return _median_rate(n, lambda: [P.encode_raw(s) for s in samples])


FILTER_UPDATES = 5_000


def _motion(n: int, seed: int = 0) -> tuple[list, list, list]:
    """Plausible IMU rows: a slow rotation with noise (values do not affect the cost much)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 200.0
    gyr = np.stack([np.sin(t), np.cos(0.7 * t), 0.3 * np.sin(0.2 * t)], axis=1) + rng.normal(0, 0.01, (n, 3))
    acc = np.array([0.0, 0.0, 9.81]) + rng.normal(0, 0.05, (n, 3))
    mag = np.array([0.0, 20.0, -40.0]) + rng.normal(0, 0.3, (n, 3))
    return gyr.tolist(), acc.tolist(), mag.tolist()


def filter_rates(n: int = FILTER_UPDATES) -> dict[str, float]:
    """Updates per second of each filter (and installed peer) called from a Python loop, 9D."""
    gyr, acc, mag = _motion(n)
    rates = {}
    for name in FILTERS:
        f = make(name)

        def run(f=f) -> None:
            f.reset()
            for i in range(n):
                f.update(gyr[i], acc[i], mag[i], 0.005)

        rates[name] = round(_median_rate(n, run))
    for name, step in _peer_steppers().items():
        rates[name] = round(_median_rate(n, lambda step=step: step(gyr, acc, mag)))
    return rates


def _vqf_loop(gyr: list, acc: list, mag: list) -> None:
    import vqf

    f = vqf.VQF(0.005)
    g, a, m = (np.asarray(x) for x in (gyr, acc, mag))
    for i in range(len(g)):
        f.update(g[i], a[i], m[i])
        f.getQuat9D()


def _imufusion_loop(gyr: list, acc: list, mag: list) -> None:
    import imufusion

    ahrs = imufusion.Ahrs()
    g, a, m = np.degrees(gyr), np.asarray(acc) / 9.81, np.asarray(mag)
    for i in range(len(g)):
        ahrs.update(g[i], a[i], m[i])
        ahrs.get_quaternion()


_PEER_LOOPS: dict[str, Callable[[list, list, list], None]] = {"vqf": _vqf_loop, "imufusion": _imufusion_loop}


def _peer_steppers() -> dict[str, Callable[[list, list, list], None]]:
    """Per-sample update loops of the installed peers, as a Python program would call them."""
    return {name: _PEER_LOOPS[name] for name in available_peers()}


def run_all() -> dict:
    """Every benchmark, as one JSON-ready object."""
    return {
        "decode_frames_per_s": round(decode_rate()),
        "encode_frames_per_s": round(encode_rate()),
        "raw_frame_bytes": P.RAW_FRAME_SIZE,
        "link_utilisation_200hz": round(P.link_utilisation(200), 4),  # at P.DEFAULT_BAUD
        "filters": filter_rates(),
    }
