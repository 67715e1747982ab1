"""Benchmarks of the tracker's hot paths; ``armtracker bench --json`` prints them.

Figures are medians over repeats of wall-clock time on this machine; they
belong here, never in unit tests.
"""

from __future__ import annotations

import random
import statistics
import time
from typing import Callable

from . import protocol as P

FRAMES = 20_000
REPEATS = 5
CHUNK = 256  # bytes per feed: about what a serial read returns at 115200 baud


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


def run_all() -> dict:
    """Every benchmark, as one JSON-ready object."""
    return {
        "decode_frames_per_s": round(decode_rate()),
        "encode_frames_per_s": round(encode_rate()),
        "raw_frame_bytes": P.RAW_FRAME_SIZE,
        "link_utilisation_200hz_115200": round(P.link_utilisation(200), 4),
    }
