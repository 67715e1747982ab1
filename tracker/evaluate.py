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
import os
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Callable, Iterator

import numpy as np

from . import quat as Q
from .atomic import atomic_write
from .fusion import FILTERS, make
from .input_files import open_input

REQUIRED = {"gyr": 3, "acc": 3, "mag": 3, "quat": 4}
PEERS = ("vqf", "imufusion")
MAX_TRIAL_BYTES = 2**30  # a BROAD trial is about 3 MB (50 000 samples)
RATE_RANGE_HZ = (1.0, 100_000.0)  # IMUs sample at 10 Hz to 32 kHz
QUAT_NORM_TOLERANCE = 0.1  # a truth quaternion is unit; NaN where the optical system saw nothing
NOT_SCORABLE = "not scorable: no movement sample has ground truth"


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
    """Read and check one trial file: every array's shape, type and range, one clear error otherwise."""
    path = Path(path)
    data = read_npz(path)
    missing = [k for k in (*REQUIRED, "rate") if k not in data]
    if missing:
        raise DatasetError(f"{path}: missing key(s) {', '.join(missing)}")
    gyr = data["gyr"]
    n = len(gyr) if gyr.ndim == 2 else 0
    for key, width in REQUIRED.items():
        a = data[key]
        if a.dtype.kind not in "iuf":
            raise DatasetError(f"{path}: '{key}' holds {_dtype_words(a)}; expected numbers (floats)")
        if a.shape != (n, width) or n == 0:
            raise DatasetError(f"{path}: '{key}' has shape {a.shape}, expected (N, {width}) with N >= 1"
                               + (f" = {n} (the length of 'gyr')" if n and key != "gyr" else ""))
    quat = data["quat"].astype(float)
    _check_truth(path, quat)
    name = path.stem
    if "name" in data:
        if data["name"].dtype.kind != "U" or data["name"].shape != ():
            raise DatasetError(f"{path}: 'name' holds {_dtype_words(data['name'])} of shape "
                               f"{data['name'].shape}; expected one string")
        name = str(data["name"])
    return Trial(name, gyr.astype(float), data["acc"].astype(float), data["mag"].astype(float), quat,
                 _rate(path, data["rate"]), _movement(path, data.get("movement"), n))


def _dtype_words(a: np.ndarray) -> str:
    kinds = {"b": "booleans", "U": "text", "S": "bytes", "c": "complex numbers", "O": "Python objects",
             "V": "raw records", "M": "dates", "m": "time spans"}
    return kinds.get(a.dtype.kind, f"{a.dtype} values")


def _rate(path: Path, a: np.ndarray) -> float:
    """The sample rate: one number within :data:`RATE_RANGE_HZ`."""
    low, high = RATE_RANGE_HZ
    if a.dtype.kind not in "iuf" or a.size != 1 or a.ndim > 1:
        raise DatasetError(f"{path}: 'rate' is {_dtype_words(a)} of shape {a.shape}; "
                           f"expected one number, the sample rate in Hz ({low:g} to {high:g})")
    rate = float(a.reshape(()))
    if not low <= rate <= high:
        raise DatasetError(f"{path}: 'rate' is {rate:g}; expected a sample rate from {low:g} to {high:g} Hz")
    return rate


def _movement(path: Path, a: np.ndarray | None, n: int) -> np.ndarray:
    """The samples to evaluate: (N,) booleans (or 0/1); all of them when absent."""
    if a is None:
        return np.ones(n, bool)
    if a.dtype.kind not in "biu" or a.shape != (n,) or not np.isin(a, (0, 1)).all():
        raise DatasetError(f"{path}: 'movement' is {_dtype_words(a)} of shape {a.shape}; "
                           f"expected ({n},) booleans")
    return a.astype(bool)


def _check_truth(path: Path, quat: np.ndarray) -> None:
    """Truth rows are unit quaternions, or NaN where the reference system saw nothing (BROAD)."""
    seen = np.isfinite(quat).all(axis=1)
    broken = np.isinf(quat).any(axis=1) | (seen & (np.abs(np.linalg.norm(np.where(seen[:, None], quat, 1.0),
                                                                         axis=1) - 1) > QUAT_NORM_TOLERANCE))
    if broken.any():
        row = int(np.argmax(broken))
        raise DatasetError(f"{path}: 'quat' row {row} is {np.array2string(quat[row], precision=3)}; "
                           "expected a unit quaternion, or NaN where there is no truth")


def read_npz(path: str | Path, error: Callable[[str], Exception] = DatasetError) -> dict[str, np.ndarray]:
    """The arrays of a ``.npz`` file, read without pickles and without trusting its headers.

    A regular file of at most :data:`MAX_TRIAL_BYTES` (:func:`tracker.input_files.open_input`),
    a zip archive of ``.npy`` members (NumPy's format, ``numpy.lib.format``),
    each member's header checked before its data is read: no Python objects
    (they would need unpickling) and no more data claimed than the member holds.
    """
    with open_input(path, ".npz trial", error, MAX_TRIAL_BYTES) as f:
        head = f.read(6)
        f.seek(0)
        if not head.startswith(b"PK\x03\x04") and not head.startswith(b"PK\x05\x06"):
            hint = ": a single .npy array, renamed?" if head == b"\x93NUMPY" else ""
            raise error(f"{path}: not a readable .npz trial (not a zip archive{hint})")
        try:
            with zipfile.ZipFile(f) as z:
                total = sum(info.file_size for info in z.infolist())
                if total > MAX_TRIAL_BYTES:
                    raise error(f"{path}: its arrays take {total / 2**20:.0f} MB unpacked; a trial of at most "
                                f"{MAX_TRIAL_BYTES // 2**20} MB is read")
                return {info.filename[:-4]: _member(z, info, path, error)
                        for info in z.infolist() if info.filename.endswith(".npy")}
        # What a damaged archive or member raises inside zipfile, zlib and numpy.lib.format:
        except (OSError, EOFError, ValueError, zipfile.BadZipFile, zlib.error, NotImplementedError,
                RuntimeError) as e:
            raise error(f"{path}: not a readable .npz trial ({_one_line(e)})") from None


def _member(z: zipfile.ZipFile, info: zipfile.ZipInfo, path: str | Path,
            error: Callable[[str], Exception]) -> np.ndarray:
    key = info.filename[:-4]
    with z.open(info) as m:
        shape, dtype = _npy_header(m)
    if dtype.hasobject:
        raise error(f"{path}: '{key}' holds Python objects (pickled data), which are not read")
    if math.prod(shape) * dtype.itemsize > info.file_size:
        raise error(f"{path}: not a readable .npz trial ('{key}' claims more data than it holds)")
    with z.open(info) as m:
        return np.lib.format.read_array(m, allow_pickle=False)


def _npy_header(m: IO[bytes]) -> tuple[tuple[int, ...], np.dtype]:
    version = np.lib.format.read_magic(m)
    if version == (1, 0):
        shape, _, dtype = np.lib.format.read_array_header_1_0(m)
    elif version == (2, 0):
        shape, _, dtype = np.lib.format.read_array_header_2_0(m)
    else:
        raise ValueError(f".npy format version {version[0]}.{version[1]} is not read")
    return shape, dtype


def _one_line(e: BaseException) -> str:
    return " ".join(str(e).split()) or type(e).__name__


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


def rmse(q_est: np.ndarray, trial: Trial, dof: int) -> dict[str, float] | None:
    """RMSE in degrees of total, heading and inclination error over the movement samples;
    None when no movement sample has ground truth (nothing to score)."""
    valid = trial.movement & np.all(np.isfinite(trial.quat), axis=1) & np.all(np.isfinite(q_est), axis=1)
    if not valid.any():
        return None
    est, ref = q_est[valid], trial.quat[valid]
    if dof == 6:
        est = remove_heading_offset(est, ref, np.ones(len(est), bool))
    total, heading, inclination = error_angles(est, ref)

    def deg(x: np.ndarray) -> float:
        return math.degrees(math.sqrt(float(np.mean(x * x))))

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
                if errors is None:
                    yield {"trial": trial.name, "filter": name, "dof": dof,
                           "total": None, "heading": None, "inclination": None, "note": NOT_SCORABLE}
                else:
                    yield {"trial": trial.name, "filter": name, "dof": dof,
                           **{k: round(v, 4) for k, v in errors.items()}}


def result_line(r: dict) -> str:
    """One result for the progress display."""
    if r["total"] is None:
        return f"{r['trial']} {r['filter']} {r['dof']}D: {r.get('note', NOT_SCORABLE)}"
    return (f"{r['trial']} {r['filter']} {r['dof']}D: "
            f"total {r['total']:.2f}  inclination {r['inclination']:.2f} deg")


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
            scored = [v for v in values if v is not None]
            mean = f"**{sum(scored) / len(scored):.3f}**" if scored else ""
            lines.append(f"{name} | " + " | ".join("" if v is None else f"{v:.2f}" for v in values)
                         + f" | {mean}")
        tables.append("\n".join(f"| {line} |" for line in lines))
    return "\n\n".join(tables)


def check_readme(readme: str | Path) -> str:
    """The text of a README whose results table ``--readme`` will rewrite; call it before
    the evaluation runs, so a wrong file is said at once, not after the work.

    It must be a regular UTF-8 text file holding the table markers, in a folder
    where the rewritten file can be written.
    """
    path = Path(readme)
    with open_input(path, "README", DatasetError) as f:
        data = f.read()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise DatasetError(f"{path} is not UTF-8 text (byte {e.start}); --readme rewrites a Markdown file") from None
    if TABLE_BEGIN not in text or TABLE_END not in text or text.index(TABLE_BEGIN) > text.index(TABLE_END):
        raise DatasetError(f"{path} has no {TABLE_BEGIN} ... {TABLE_END} markers to put the table between")
    if not os.access(path.resolve().parent, os.W_OK) or not os.access(path, os.W_OK):
        raise DatasetError(f"{path} cannot be rewritten: no permission to write it or its folder")
    return text


def write_readme_table(readme: str | Path, results: list[dict]) -> None:
    """Replace the table between the markers in ``readme`` (atomically)."""
    text = check_readme(readme)
    before, rest = text.split(TABLE_BEGIN, 1)
    after = rest.split(TABLE_END, 1)[1]
    atomic_write(Path(readme), f"{before}{TABLE_BEGIN}\n{markdown_table(results)}\n{TABLE_END}{after}")
