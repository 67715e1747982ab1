"""Trial files (.npz) and evaluate's README a user can throw at fuse and evaluate (issue 13, cases 8 and 11).

Through the real command: a refused file is a non-zero exit and one line
naming the file, the key and what was expected; nothing of the user's changes.
A property test feeds random arrays to the trial loader.
"""

import io
import json
import os
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st
from scipy.spatial.transform import Rotation

from tracker.evaluate import TABLE_BEGIN, TABLE_END, DatasetError, check_readme, load_trial

from .test_bad_recordings import armtracker, assert_refused, snapshot

N = 60


def good_arrays(n: int = N) -> dict[str, np.ndarray]:
    """A small trial at rest: gravity up, a field north and down, truth = identity (scipy's, scalar first)."""
    truth = np.roll(Rotation.identity(n).as_quat(), 1, axis=1)
    return {"gyr": np.zeros((n, 3)), "acc": np.tile([0.0, 0.0, 9.81], (n, 1)),
            "mag": np.tile([0.0, 20.0, -40.0], (n, 1)), "quat": truth, "rate": np.array(100.0),
            "movement": np.ones(n, bool), "name": np.array("rest")}


def trial(folder: Path, file: str = "t.npz", **changes) -> Path:
    arrays = {**good_arrays(), **changes}
    arrays = {k: v for k, v in arrays.items() if v is not None}
    path = folder / file
    with open(path, "wb") as f:
        np.savez(f, **arrays)
    return path


BAD = [
    ({"rate": np.array([100.0, 200.0])}, "'rate' is", "shape (2,); expected one number"),
    ({"rate": np.array([])}, "'rate' is", "shape (0,); expected one number"),
    ({"rate": np.array("fast")}, "'rate' is text", "expected one number"),
    ({"rate": np.array(-5.0)}, "'rate' is -5", "from 1 to 100000 Hz"),
    ({"rate": np.array(np.nan)}, "'rate' is nan", "from 1 to 100000 Hz"),
    ({"gyr": np.array(1.0)}, "'gyr' has shape ()", "expected (N, 3)"),
    ({"gyr": np.full((N, 3), "x")}, "'gyr' holds text", "expected numbers"),
    ({"gyr": np.zeros((0, 3)), "acc": np.zeros((0, 3)), "mag": np.zeros((0, 3)), "quat": np.zeros((0, 4)),
      "movement": np.zeros(0, bool)}, "'gyr' has shape (0, 3)", "N >= 1"),
    ({"acc": np.zeros((N - 1, 3))}, "'acc' has shape (59, 3)", "= 60 (the length of 'gyr')"),
    ({"mag": np.zeros((N, 3), complex)}, "'mag' holds complex numbers", "expected numbers"),
    ({"quat": np.zeros((N, 4))}, "'quat' row 0", "expected a unit quaternion, or NaN"),
    ({"quat": np.full((N, 4), np.inf)}, "'quat' row 0", "expected a unit quaternion"),
    ({"movement": np.full(N, 2)}, "'movement' is", f"expected ({N},) booleans"),
    ({"name": np.array([1, 2])}, "'name' holds", "expected one string"),
    ({"quat": None}, "missing key(s) quat", ""),
]


@pytest.mark.parametrize("changes, key_words, expected", BAD)
def test_a_bad_trial_is_one_line_in_fuse_and_evaluate(tmp_path, changes, key_words, expected):
    data = tmp_path / "data"
    data.mkdir()
    path = trial(data, **changes)
    out = tmp_path / "q.npz"
    out.write_bytes(b"an earlier result")
    before = snapshot(tmp_path)
    for args in (["fuse", str(path), "--out", str(out)],
                 ["evaluate", "--dataset", str(data), "--filter", "default", "--dof", "6"]):
        assert_refused(armtracker(tmp_path, *args), str(path), key_words, expected)
    assert snapshot(tmp_path) == before


def test_the_good_trial_of_these_tests_is_accepted(tmp_path):
    """The cases above differ from an accepted trial by the one change each makes."""
    t = load_trial(trial(tmp_path))
    assert t.name == "rest" and t.rate == 100.0 and t.gyr.shape == (N, 3)
    r = armtracker(tmp_path, "evaluate", "--dataset", str(tmp_path), "--filter", "default", "--dof", "6", "--json")
    assert r.returncode == 0, r.stderr
    (result,) = json.loads(r.stdout)["results"]
    assert result["inclination"] < 1.0  # at rest and level, the default filter is level


def test_a_npy_renamed_npz_a_pickle_and_a_zip_bomb_header_are_refused(tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    npy = data / "array.npz"
    np.save(npy.with_suffix(".tmp"), np.zeros((5, 3)))
    npy.with_suffix(".tmp.npy").rename(npy)
    pickled = trial(data, "pickled.npz", gyr=np.array([{"a": 1}] * N, dtype=object))
    # A member whose header claims 10^12 floats in a few bytes: refused before anything is allocated.
    liar = data / "liar.npz"
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": (10**12, 3)})
    with zipfile.ZipFile(liar, "w") as z:
        for key, value in good_arrays().items():
            member = io.BytesIO()
            np.save(member, value)
            z.writestr(f"{key}.npy", buf.getvalue() + b"\0" * 64 if key == "gyr" else member.getvalue())
    out = tmp_path / "q.npz"
    for path, words in ((npy, "not a zip archive: a single .npy array, renamed?"),
                        (pickled, "'gyr' holds Python objects (pickled data), which are not read"),
                        (liar, "'gyr' claims more data than it holds")):
        assert_refused(armtracker(tmp_path, "fuse", str(path), "--out", str(out)), str(path), words)
        alone = tmp_path / path.stem
        alone.mkdir()
        (alone / path.name).write_bytes(path.read_bytes())
        assert_refused(armtracker(tmp_path, "evaluate", "--dataset", str(alone), "--filter", "default"),
                       str(alone / path.name), words)
    assert not out.exists()


def test_a_fifo_named_like_a_trial_is_refused_at_once(tmp_path):
    fifo = tmp_path / "t.npz"
    os.mkfifo(fifo)
    assert_refused(armtracker(tmp_path, "fuse", str(fifo), "--out", str(tmp_path / "q.npz"), timeout=60),
                   str(fifo), "FIFO")
    assert_refused(armtracker(tmp_path, "evaluate", "--dataset", str(tmp_path), timeout=60), str(fifo), "FIFO")


# ----------------------------------------------------------------- case 11: evaluate


def strict_json(text: str):
    """JSON as RFC 8259 has it: NaN and Infinity are not numbers."""
    def refuse(name):
        raise ValueError(f"{name} in JSON output")
    return json.loads(text, parse_constant=refuse)


def test_a_trial_without_movement_is_not_scorable_and_the_json_stays_json(tmp_path):
    trial(tmp_path, "still.npz", movement=np.zeros(N, bool), name=None)
    trial(tmp_path, "unseen.npz", quat=np.full((N, 4), np.nan), name=None)
    trial(tmp_path, "moving.npz", name=None)
    r = armtracker(tmp_path, "evaluate", "--dataset", str(tmp_path), "--filter", "default", "--json")
    assert r.returncode == 0, r.stderr
    assert "Warning" not in r.stderr and "Traceback" not in r.stderr
    results = {(x["trial"], x["dof"]): x for x in strict_json(r.stdout)["results"]}
    assert set(results) == {(t, d) for t in ("moving", "still", "unseen") for d in (6, 9)}
    for (name, _), x in results.items():
        if name == "moving":
            assert x["inclination"] < 1.0 and "note" not in x
        else:
            assert x["total"] is None and x["heading"] is None and x["inclination"] is None
            assert x["note"].startswith("not scorable")
    table = armtracker(tmp_path, "evaluate", "--dataset", str(tmp_path), "--filter", "default")
    assert table.returncode == 0 and "nan" not in table.stdout.lower(), table.stderr
    assert "still default 6D: not scorable" in table.stderr


def readme(folder: Path, content: bytes) -> Path:
    path = folder / "README.md"
    path.write_bytes(content)
    return path


@pytest.mark.parametrize("content, words", [
    (b"caf\xe9 " + TABLE_BEGIN.encode() + b"\n" + TABLE_END.encode(), "is not UTF-8 text (byte 3)"),
    (b"# results\nno markers here\n", f"has no {TABLE_BEGIN} ... {TABLE_END} markers"),
    (TABLE_END.encode() + b"\n" + TABLE_BEGIN.encode(), "markers"),
])
def test_a_bad_readme_is_said_before_the_evaluation_runs(tmp_path, content, words):
    """A broken trial in the dataset would fail the evaluation: the README's message comes first."""
    data = tmp_path / "data"
    data.mkdir()
    trial(data, gyr=np.array(1.0))
    path = readme(tmp_path, content)
    before = snapshot(tmp_path)
    r = armtracker(tmp_path, "evaluate", "--dataset", str(data), "--readme", str(path))
    assert_refused(r, str(path), words)
    assert snapshot(tmp_path) == before


def test_a_readme_that_is_a_fifo_or_a_folder_is_refused_at_once(tmp_path):
    fifo = tmp_path / "README.md"
    os.mkfifo(fifo)
    with pytest.raises(DatasetError, match="FIFO"):
        check_readme(fifo)
    with pytest.raises(DatasetError, match="directory"):
        check_readme(tmp_path)


def test_the_readme_table_is_rewritten_between_its_markers(tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    trial(data)
    path = readme(tmp_path, f"before\n{TABLE_BEGIN}\nold\n{TABLE_END}\nafter\n".encode())
    r = armtracker(tmp_path, "evaluate", "--dataset", str(data), "--filter", "default",
                   "--dof", "6", "--readme", str(path))
    assert r.returncode == 0, r.stderr
    text = path.read_text()
    assert text.startswith(f"before\n{TABLE_BEGIN}\n| 6D inclination") and text.endswith(f"{TABLE_END}\nafter\n")
    assert "old" not in text


# ----------------------------------------------------------------- properties

arrays = st.one_of(
    st.sampled_from([np.array(1.0), np.array([]), np.array("fast"), np.array([1, 2]), np.array(True),
                     np.zeros((N, 3)), np.ones((N, 4)), np.full((N, 3), np.nan), np.zeros((N, 3), np.int8),
                     np.zeros((N, 3), bool), np.zeros((N, 3), "U2"), np.zeros((N, 3), complex),
                     np.zeros((N, 3, 1)), np.zeros(N), np.ones(N, bool), np.array(1e308), np.array(100)]),
    st.builds(lambda shape, seed: np.random.default_rng(seed).normal(size=shape) * 10.0 ** seed,
              st.sampled_from([(N, 3), (N, 4), (N,), (), (1,), (N - 1, 3), (3, N)]), st.integers(-3, 300)))


@settings(derandomize=True, max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(st.dictionaries(st.sampled_from(["gyr", "acc", "mag", "quat", "rate", "movement", "name"]), arrays,
                       max_size=7))
def test_random_arrays_never_crash_the_trial_loader(tmp_path_factory, changes):
    folder = tmp_path_factory.mktemp("npz")
    path = trial(folder, **changes)
    before = snapshot(folder)
    try:
        t = load_trial(path)
    except DatasetError as e:
        assert "\n" not in str(e) and str(path) in str(e)
    else:  # what was accepted is what the evaluation relies on
        n = len(t.gyr)
        assert t.gyr.shape == t.acc.shape == t.mag.shape == (n, 3) and t.quat.shape == (n, 4) and n >= 1
        assert 1 <= t.rate <= 100_000 and t.movement.shape == (n,) and t.movement.dtype == bool
    assert snapshot(folder) == before


@settings(derandomize=True, max_examples=100, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(st.binary(max_size=400), st.integers(0, 2000))
def test_random_bytes_in_or_after_a_trial_never_crash_the_loader(tmp_path_factory, junk, at):
    folder = tmp_path_factory.mktemp("bytes")
    path = trial(folder)
    good = path.read_bytes()
    path.write_bytes(good[:at] + junk + good[at + len(junk):])
    try:
        load_trial(path)
    except DatasetError as e:
        assert "\n" not in str(e) and str(path) in str(e)
