"""Run a fusion filter over a recording or a ground-truth trial file (``armtracker fuse``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import protocol as P
from .atomic import AtomicFile
from .evaluate import DatasetError, load_trial
from .fusion import FILTERS, make
from .recording import RecordingError, Run, decode_file


@dataclass(frozen=True)
class SensorSeries:
    """What a filter runs on: (N, 3) gyr rad/s, acc m/s^2, mag uT (None without a magnetometer),
    the sample rate, and where each run of the board starts (a filter starts again there)."""

    gyr: np.ndarray
    acc: np.ndarray
    mag: np.ndarray | None
    rate: float
    run_starts: tuple[int, ...] = (0,)

    def run_index(self) -> np.ndarray:
        """The run of each sample, 0 first."""
        index = np.zeros(len(self.gyr), int)
        for start in self.run_starts[1:]:
            index[start:] += 1
        return index


def sensor_arrays(path: str | Path) -> SensorSeries:
    """The sensor readings of a trial file (.npz) or a recording (.bin, .csv), checked."""
    path = Path(path)
    if path.suffix.lower() == ".npz":
        t = load_trial(path)
        return SensorSeries(t.gyr, t.acc, t.mag, t.rate)
    samples, replay = decode_file(path)
    raw = [s for s in samples if isinstance(s, P.RawSample)]
    if len(raw) != len(samples):
        raise RecordingError(f"{path} holds fused samples; fusing needs raw sensor samples only")
    times = np.array([s.t for s in raw])
    steps = np.concatenate([np.diff(times[r.start:r.start + r.samples]) for r in replay.runs])
    _check_steps(path, replay.runs, times)
    if not len(steps):
        raise RecordingError(f"{path}: no two samples in one run of the board; the sample rate is not known")
    gyr = np.array([s.gyr for s in raw])
    acc = np.array([s.acc for s in raw])
    mag = np.array([s.mag for s in raw]) if all(s.mag is not None for s in raw) else None
    return SensorSeries(gyr, acc, mag, 1.0 / float(np.median(steps)), tuple(r.start for r in replay.runs))


def _check_steps(path: Path, runs: list[Run], times: np.ndarray) -> None:
    """Device time increases within each run, or the recording is refused naming the sample."""
    for r in runs:
        bad = np.flatnonzero(np.diff(times[r.start:r.start + r.samples]) <= 0)
        if len(bad):
            k = r.start + int(bad[0]) + 1
            raise RecordingError(f"{path}: sample {k + 1} (t {times[k]:.6f} s) is not after the one before it "
                                 f"(t {times[k - 1]:.6f} s); time must increase within a run")


def fuse_file(path: str | Path, name: str, dof: int, out: str | Path) -> int:
    """Write ``quat`` (N, 4), scalar first, sensor to earth, to ``out``; return N.

    Also written: ``rate``, ``filter``, ``dof`` and ``run`` (N,), the board's run
    of each sample (:mod:`tracker.recording`); the filter starts afresh at each run,
    since the time between runs is not known.
    """
    if name not in FILTERS:
        raise DatasetError(f"unknown filter {name!r}; choose from {', '.join(FILTERS)}")
    series = sensor_arrays(path)
    if dof == 9 and series.mag is None:
        raise DatasetError(f"{path} has no magnetometer readings: use --dof 6")
    mag = series.mag if dof == 9 else None
    bounds = [*series.run_starts, len(series.gyr)]
    quat = np.concatenate([make(name).run(series.gyr[a:b], series.acc[a:b], None if mag is None else mag[a:b],
                                          series.rate) for a, b in zip(bounds, bounds[1:])])
    with AtomicFile(out, "wb") as f:
        np.savez(f.file, quat=quat, rate=series.rate, filter=name, dof=dof, run=series.run_index())
    return len(quat)
