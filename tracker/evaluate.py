"""Ground-truth evaluation of the fusion filters (the BROAD metric).

Trials are ``.npz`` files in the format of the converted BROAD dataset (D.
Laidig, M. Caruso, A. Cereatti, T. Seel, "BROAD - A Benchmark for Robust
Inertial Orientation Estimation", Data 6(7):72, 2021): ``gyr`` (N, 3) rad/s,
``acc`` (N, 3) m/s^2, ``mag`` (N, 3) uT, ``quat`` (N, 4) sensor-to-ENU truth,
scalar first, NaN where the optical system saw nothing, ``rate`` Hz and
``movement`` (N,) bool marking the evaluated samples.

The metric is BROAD's: the error quaternion in earth coordinates
``q_err = q_est * q_ref^-1``; total error ``2 acos|w|``; heading error
``2 atan|z / w|``; inclination error ``2 acos sqrt(w^2 + z^2)``; RMSE over the
movement samples, NaN truth skipped, in degrees. For 6D estimates (no
magnetometer, heading arbitrary) one constant heading offset per trial, the
circular mean of the signed heading error, is removed before the heading and
total errors; the inclination error does not depend on it.

Peers (``vqf``, ``imufusion``) are run here, never inside the filters, when
the optional ``compare`` extra is installed.
"""

from __future__ import annotations

import math
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

from . import quat as Q
from .atomic import atomic_write
from .fusion import FILTERS, make

REQUIRED = {"gyr": 3, "acc": 3, "mag": 3, "quat": 4}
PEERS = ("vqf", "imufusion")


class DatasetError(Exception):
    """A trial file or dataset directory that cannot be used, worded for the user."""


@dataclass(frozen=True)
class Trial:
    """One recording with ground truth."""

    name: str
    gyr: np.ndarray
    acc: np.ndarray
    mag: np.ndarray
    quat: np.ndarray
    rate: float
    movement: np.ndarray


def load_trial(path: str | Path) -> Trial:
    """Read and check one trial file."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as e:
        raise DatasetError(f"{path}: not a readable .npz trial ({e})") from None
    missing = [k for k in (*REQUIRED, "rate") if k not in data]
    if missing:
        raise DatasetError(f"{path}: missing key(s) {', '.join(missing)}")
    n = len(data["gyr"])
    for key, width in REQUIRED.items():
        if data[key].shape != (n, width):
            raise DatasetError(f"{path}: '{key}' has shape {data[key].shape}, expected ({n}, {width})")
    movement = data.get("movement", np.ones(n, bool)).astype(bool).reshape(-1)
    if movement.shape != (n,):
        raise DatasetError(f"{path}: 'movement' has {movement.size} entries, expected {n}")
    rate = float(data["rate"])
    if not rate > 0:
        raise DatasetError(f"{path}: 'rate' must be positive, not {rate}")
    name = str(data["name"]) if "name" in data else path.stem
    return Trial(name, *(data[k].astype(float) for k in REQUIRED), rate, movement)


def find_trials(directory: str | Path) -> list[Path]:
    """The trial files in a dataset directory, sorted; an error if there are none."""
    d = Path(directory)
    if not d.is_dir():
        raise DatasetError(f"no such dataset directory: {d}")
    trials = sorted(d.glob("*.npz"))
    if not trials:
        raise DatasetError(f"{d} holds no trials (*.npz files in the BROAD format)")
    return trials


# ----------------------------------------------------------------- metric


def error_angles(q_est: np.ndarray, q_ref: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-sample total, heading and inclination error in radians (BROAD, steps 1-4)."""
    e = Q.multiply(Q.normalize(q_est), Q.conjugate(q_ref / np.linalg.norm(q_ref, axis=-1, keepdims=True)))
    e = e / np.linalg.norm(e, axis=-1, keepdims=True)
    w, z = np.abs(e[..., 0]), e[..., 3]
    total = 2 * np.arccos(np.clip(w, 0, 1))
    with np.errstate(divide="ignore", invalid="ignore"):
        heading = 2 * np.arctan(np.abs(z / w))
    inclination = 2 * np.arccos(np.clip(np.sqrt(w * w + z * z), 0, 1))
    return total, heading, inclination


def remove_heading_offset(q_est: np.ndarray, q_ref: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``q_est`` turned about world z by minus the circular mean heading error over ``mask``."""
    e = Q.multiply(q_est, Q.conjugate(q_ref))
    signed = 2 * np.arctan2(e[..., 3], e[..., 0])
    ok = mask & np.isfinite(signed)
    offset = math.atan2(np.sin(signed[ok]).mean(), np.cos(signed[ok]).mean()) if ok.any() else 0.0
    return Q.multiply(Q.from_axis_angle([0, 0, 1], -offset), q_est)


def rmse(q_est: np.ndarray, trial: Trial, dof: int) -> dict[str, float]:
    """RMSE in degrees of total, heading and inclination error over the movement samples."""
    valid = trial.movement & np.all(np.isfinite(trial.quat), axis=1)
    est, ref = q_est[valid], trial.quat[valid]
    if dof == 6:
        est = remove_heading_offset(est, ref, np.ones(len(est), bool))
    total, heading, inclination = error_angles(est, ref)

    def deg(x: np.ndarray) -> float:
        return math.degrees(math.sqrt(np.nanmean(x * x)))

    return {"total": deg(total), "heading": deg(heading), "inclination": deg(inclination)}


# ----------------------------------------------------------------- running


def run_filter(name: str, trial: Trial, dof: int) -> np.ndarray:
    """One of our filters, or a peer, over a trial: (N, 4) q_WS in ENU."""
    mag = trial.mag if dof == 9 else None
    if name in PEERS:
        return _PEER_RUNNERS[name](trial, mag)
    return make(name).run(trial.gyr, trial.acc, mag, trial.rate)


def uses_magnetometer(name: str) -> bool:
    """Whether a 9D run means anything for this filter (peers all use the magnetometer)."""
    return name in PEERS or make(name).uses_magnetometer


def available_peers() -> list[str]:
    """The peers whose packages are installed (the optional ``compare`` extra)."""
    found = []
    for name in PEERS:
        try:
            __import__(name)
            found.append(name)
        except ImportError:
            pass
    return found


def _run_vqf(trial: Trial, mag: np.ndarray | None) -> np.ndarray:
    """VQF (Laidig & Seel 2023), its own streaming C++ implementation, default parameters."""
    import vqf

    f = vqf.VQF(1.0 / trial.rate)
    c = np.ascontiguousarray
    out = f.updateBatch(c(trial.gyr), c(trial.acc), c(mag)) if mag is not None \
        else f.updateBatch(c(trial.gyr), c(trial.acc))
    return out["quat9D"] if mag is not None else out["quat6D"]


def _run_imufusion(trial: Trial, mag: np.ndarray | None) -> np.ndarray:
    """x-io Fusion (imufusion), ENU convention, its documented example settings."""
    import imufusion

    settings = imufusion.AhrsSettings()
    settings.convention = imufusion.CONVENTION_ENU
    settings.gain = 0.5
    settings.gyroscope_range = 2000.0
    settings.acceleration_rejection = 10.0
    settings.magnetic_rejection = 10.0
    settings.rejection_timeout = 5.0 * trial.rate  # in samples: five seconds, as x-io's example
    settings.sample_rate = trial.rate
    ahrs = imufusion.Ahrs()
    ahrs.set_settings(settings)
    gyr_dps = np.ascontiguousarray(np.degrees(trial.gyr))
    acc_g = np.ascontiguousarray(trial.acc / 9.81)
    out = np.empty((len(trial.gyr), 4))
    if mag is None:
        for i in range(len(out)):
            ahrs.update_no_magnetometer(gyr_dps[i], acc_g[i])
            out[i] = ahrs.get_quaternion()
    else:
        mag = np.ascontiguousarray(mag)
        for i in range(len(out)):
            ahrs.update(gyr_dps[i], acc_g[i], mag[i])
            out[i] = ahrs.get_quaternion()
    return out


_PEER_RUNNERS: dict[str, Callable[[Trial, np.ndarray | None], np.ndarray]] = {
    "vqf": _run_vqf, "imufusion": _run_imufusion}


def filter_names(choice: str) -> list[str]:
    """``all`` means every filter of ours and every installed peer."""
    if choice == "all":
        return [*FILTERS, *available_peers()]
    if choice not in FILTERS and choice not in PEERS:
        raise DatasetError(f"unknown filter {choice!r}; choose from {', '.join((*FILTERS, *PEERS))} or all")
    if choice in PEERS and choice not in available_peers():
        raise DatasetError(f"{choice} is not installed: pip install '.[compare]'")
    return [choice]


def evaluate(paths: list[Path], names: list[str], dofs: list[int]) -> Iterator[dict]:
    """One result per trial, filter and DoF: RMSE of total, heading and inclination.

    Filters that ignore the magnetometer by design are scored in 6D only.
    """
    for path in paths:
        trial = load_trial(path)
        for dof in dofs:
            for name in (n for n in names if dof == 6 or uses_magnetometer(n)):
                errors = rmse(run_filter(name, trial, dof), trial, dof)
                yield {"trial": trial.name, "filter": name, "dof": dof,
                       **{k: round(v, 4) for k, v in errors.items()}}


# ----------------------------------------------------------------- reporting

TABLE_BEGIN = "<!-- evaluate-table:begin -->"
TABLE_END = "<!-- evaluate-table:end -->"


def markdown_table(results: list[dict]) -> str:
    """RMSE tables in degrees: 6D inclination and 9D total, a row per filter, a column per trial."""
    trials = list(dict.fromkeys(r["trial"] for r in results))
    short = [t.split("_")[0] for t in trials]
    tables = []
    for dof, metric in ((6, "inclination"), (9, "total")):
        rows = [r for r in results if r["dof"] == dof]
        if not rows:
            continue
        cell = {(r["filter"], r["trial"]): r[metric] for r in rows}
        lines = [f"{dof}D {metric} RMSE (deg) | " + " | ".join(short) + " | mean",
                 "|".join(["---"] * (len(trials) + 2))]
        for name in dict.fromkeys(r["filter"] for r in rows):
            values = [cell.get((name, t)) for t in trials]
            mean = np.mean([v for v in values if v is not None])
            lines.append(f"{name} | " + " | ".join("" if v is None else f"{v:.2f}" for v in values)
                         + f" | **{mean:.3f}**")
        tables.append("\n".join(f"| {line} |" for line in lines))
    return "\n\n".join(tables)


def write_readme_table(readme: str | Path, results: list[dict]) -> None:
    """Replace the table between the markers in ``readme`` (atomically)."""
    path = Path(readme)
    text = path.read_text()
    if TABLE_BEGIN not in text or TABLE_END not in text:
        raise DatasetError(f"{path} has no {TABLE_BEGIN} ... {TABLE_END} markers to put the table between")
    before, rest = text.split(TABLE_BEGIN, 1)
    after = rest.split(TABLE_END, 1)[1]
    atomic_write(path, f"{before}{TABLE_BEGIN}\n{markdown_table(results)}\n{TABLE_END}{after}")
