"""Run a fusion filter over a recording or a ground-truth trial file (``armtracker fuse``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import protocol as P
from .atomic import AtomicFile
from .evaluate import DatasetError, load_trial
from .fusion import FILTERS, make
from .recording import RecordingError, decode_file


def sensor_arrays(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, float]:
    """gyr, acc, mag (None without a magnetometer) and the sample rate of a file."""
    path = Path(path)
    if path.suffix.lower() == ".npz":
        t = load_trial(path)
        return t.gyr, t.acc, t.mag, t.rate
    samples, _ = decode_file(path)
    raw = [s for s in samples if isinstance(s, P.RawSample)]
    if not raw:
        raise RecordingError(f"{path} holds fused samples only; fusing needs raw sensor samples")
    times = np.array([s.t for s in raw])
    steps = np.diff(times)
    rate = 1.0 / float(np.median(steps)) if len(steps) else 200.0
    gyr = np.array([s.gyr for s in raw])
    acc = np.array([s.acc for s in raw])
    mag = np.array([s.mag for s in raw]) if all(s.mag is not None for s in raw) else None
    return gyr, acc, mag, rate


def fuse_file(path: str | Path, name: str, dof: int, out: str | Path) -> int:
    """Write ``quat`` (N, 4), scalar first, sensor to earth, to ``out``; return N."""
    if name not in FILTERS:
        raise DatasetError(f"unknown filter {name!r}; choose from {', '.join(FILTERS)}")
    gyr, acc, mag, rate = sensor_arrays(path)
    if dof == 9 and mag is None:
        raise DatasetError(f"{path} has no magnetometer readings: use --dof 6")
    quat = make(name).run(gyr, acc, mag if dof == 9 else None, rate)
    with AtomicFile(out, "wb") as f:
        np.savez(f.file, quat=quat, rate=rate, filter=name, dof=dof)
    return len(quat)
