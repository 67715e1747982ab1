"""Recordings a user can throw at decode, fuse and replay (issue 13, cases 5, 7 and 12).

Through the real command (a separate process, a throwaway HOME): a refused
file is a non-zero exit and one line on stderr naming the file and what was
expected, never a traceback, and no file of the user's changes. Property
tests feed random contents to the readers themselves.
"""

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from tracker import protocol as P
from tracker.board import BoardSettings, VirtualBoard, hello as board_hello
from tracker.fuse import sensor_arrays
from tracker.link import Link, LinkSettings
from tracker.recording import (CSV_FORMAT, MAGIC, RAW_COLUMNS, CsvRecorder, RawRecorder, RecordingError,
                               decode_file, open_input, read_csv, summarize)

from .helpers import wait_until

ROOT = Path(__file__).resolve().parents[2]
HELLO = board_hello(200, P.Mode.RAW, True, 16, 2000, P.BoardError.NONE, True)
PERIOD_US = 5000  # 200 Hz


def armtracker(home: Path, *args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    env = {**os.environ, "HOME": str(home)}
    return subprocess.run([sys.executable, "-m", "tracker", *args], capture_output=True, text=True,
                          timeout=timeout, cwd=ROOT, stdin=subprocess.DEVNULL, env=env)


def snapshot(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` and a hash of its bytes."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def assert_refused(r: subprocess.CompletedProcess, *words: str) -> None:
    """Non-zero exit, exactly one line on stderr holding ``words``, no traceback."""
    assert r.returncode != 0, r.stdout
    assert "Traceback" not in r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])


def run_samples(n: int, t0_us: int, seq0: int = 0, mag: bool = True) -> list[P.RawSample]:
    """``n`` samples of one power-up of a board at 200 Hz, from device time ``t0_us``."""
    return [P.RawSample((t0_us + PERIOD_US * k) * 1e-6, t0_us + PERIOD_US * k, seq0 + k,
                        (10 * k % 300, -50, 2048), (k % 7, 2, -3), (100, -20, 300) if mag else None, 400)
            for k in range(n)]


def bin_file(path: Path, parts: list[bytes], header: dict | None = None) -> Path:
    head = {"port": "test", "legacy_text": False, "hello": HELLO.to_json()} if header is None else header
    path.write_bytes(MAGIC + json.dumps(head).encode() + b"\n" + b"".join(parts))
    return path


def frames(samples: list[P.RawSample]) -> bytes:
    return b"".join(P.encode(s) for s in samples)


def csv_file(path: Path, rows: list[list[str]], hello_line: str | None = None,
             columns: list[str] = RAW_COLUMNS) -> Path:
    hello_text = json.dumps(HELLO.to_json()) if hello_line is None else hello_line
    lines = [CSV_FORMAT, f"# hello: {hello_text}", ",".join(columns), *(",".join(r) for r in rows)]
    path.write_text("\n".join(lines) + "\n")
    return path


def csv_rows(samples: list[P.RawSample], run: int = 0) -> list[list[str]]:
    """Rows as CsvRecorder writes them."""
    return [[repr(v) if v is not None else "" for v in (
        s.t, s.t_us, s.seq, *s.acc, *s.gyr, *(s.mag or (None,) * 3), s.flex_adc, s.acc_fs_g,
        s.gyr_fs_dps, s.host_t, s.die_c)] + [str(run)] for s in samples]


# ----------------------------------------------------------------- case 5: a board restart


def test_decode_reports_each_run_of_a_recording_that_spans_a_board_restart(tmp_path):
    """The issue's recording: 3.8 s, the board restarts (HELLO, seq and clock from 0), 2.45 s more.

    Before: "1251 samples over 2.48 s, 64784 dropped". Each run is lossless and
    its span is (samples - 1) periods, worked by hand from the stream built here.
    """
    first, second = run_samples(760, 0), run_samples(491, 70_000)
    path = bin_file(tmp_path / "restart.bin", [P.encode(HELLO), frames(first), P.encode(HELLO), frames(second)])
    r = armtracker(tmp_path, "decode", str(path), "--json")
    assert r.returncode == 0, r.stderr
    report = json.loads(r.stdout)
    assert report["samples"] == 1251 and report["dropped"] == 0
    assert report["board_restarts"] == 1
    assert [(run["samples"], run["dropped"]) for run in report["runs"]] == [(760, 0), (491, 0)]
    assert report["runs"][0]["duration_s"] == pytest.approx(759 * 0.005)
    assert report["runs"][1]["duration_s"] == pytest.approx(490 * 0.005)
    assert report["runs"][1]["t_start"] == pytest.approx(0.07)
    assert report["duration_s"] == pytest.approx((759 + 490) * 0.005)
    text = armtracker(tmp_path, "decode", str(path))
    assert text.returncode == 0, text.stderr
    assert "restarted 1 time" in text.stdout and "run 1: 491 samples over 2.45 s, 0 dropped" in text.stdout


def test_a_restart_without_a_hello_and_one_within_moments_are_both_found(tmp_path):
    """No HELLO in the stream (the link's handshake reads it, not the recorder): the clock going
    back says it. A restart 50 ms after power-up, so the new clock is *ahead* of the old one:
    seq 0 after seq 9 with 20 ms between them is 65527 samples in 20 ms, more than 1000 Hz allows."""
    clock_back = bin_file(tmp_path / "a.bin", [frames(run_samples(300, 0)), frames(run_samples(200, 20_000))])
    moments = bin_file(tmp_path / "b.bin", [frames(run_samples(10, 0)), frames(run_samples(200, 65_000))])
    for path, sizes in ((clock_back, [300, 200]), (moments, [10, 200])):
        report = json.loads(armtracker(tmp_path, "decode", str(path), "--json").stdout)
        assert [run["samples"] for run in report["runs"]] == sizes
        assert report["dropped"] == 0


def test_a_clock_wrap_and_lost_samples_are_not_restarts(tmp_path):
    """The 32-bit clock wraps (PROTOCOL.md 9.3) and 5 samples are lost: one run, 5 dropped."""
    start = 2**32 - 10 * PERIOD_US
    samples = [s._replace(t_us=s.t_us & 0xFFFFFFFF) for s in run_samples(40, start)]
    del samples[20:25]
    path = bin_file(tmp_path / "wrap.bin", [frames(samples)])
    report = json.loads(armtracker(tmp_path, "decode", str(path), "--json").stdout)
    assert report["board_restarts"] == 0 and report["dropped"] == 5
    assert report["runs"][0]["duration_s"] == pytest.approx(39 * 0.005)


@pytest.fixture(scope="module")
def live_reconnect(tmp_path_factory):
    """A virtual board recorded live through the link while its cable is pulled and plugged in
    again, then RESET: the .bin (the link's tap, as `record` writes it) and the .csv."""
    folder = tmp_path_factory.mktemp("live")
    raw_path, csv_path = folder / "live.bin", folder / "live.csv"
    raw = RawRecorder(raw_path)
    with VirtualBoard(settings=BoardSettings()) as board:
        link = Link(LinkSettings(board.port))
        link.tap = raw.write
        link.open()
        raw.begin({"port": board.port, "hello": link.hello.to_json()}, P.encode_hello(link.hello))
        table = CsvRecorder(csv_path, link.hello)
        got = []

        def collect_until(n: int) -> bool:
            got.extend(link.drain())
            return len(got) >= n

        assert wait_until(lambda: collect_until(100), timeout=20)
        board.pull_cable()
        assert wait_until(lambda: not link.connected, timeout=20)
        board.plug_in()
        target = len(got) + 100
        assert wait_until(lambda: link.connected and collect_until(target), timeout=20)
        link.command(P.Command(P.FrameType.RESET))
        target = len(got) + 100
        assert wait_until(lambda: link.stats().restarts >= 1 and collect_until(target), timeout=20)
        link.tap = None
        link.close()
        got.extend(link.drain())
        for s in got:
            table.write(s)
        raw.close()
        table.close()
    return raw_path, csv_path


def test_a_live_reconnect_and_reset_decode_as_three_lossless_runs(live_reconnect, tmp_path):
    raw_path, _ = live_reconnect
    report = json.loads(armtracker(tmp_path, "decode", str(raw_path), "--json").stdout)
    assert report["board_restarts"] == 2
    assert all(run["dropped"] == 0 and run["samples"] >= 50 for run in report["runs"])
    assert sum(run["samples"] for run in report["runs"]) == report["samples"]


def test_the_csv_of_a_reconnect_numbers_its_runs_and_time_increases_within_each(live_reconnect, tmp_path):
    _, csv_path = live_reconnect
    lines = csv_path.read_text().splitlines()
    columns = lines[2].split(",")
    rows = [dict(zip(columns, ln.split(","))) for ln in lines[3:]]
    runs = [int(r["run"]) for r in rows]
    assert runs == sorted(runs) and set(runs) == {0, 1, 2}
    for k in (0, 1, 2):
        t = [float(r["t_s"]) for r in rows if int(r["run"]) == k]
        assert all(b > a for a, b in zip(t, t[1:]))
    host = [float(r["host_t"]) for r in rows]
    assert all(b >= a for a, b in zip(host, host[1:]))  # the host's clock spans the runs
    report = json.loads(armtracker(tmp_path, "decode", str(csv_path), "--json").stdout)
    assert [run["samples"] for run in report["runs"]] == [runs.count(k) for k in (0, 1, 2)]


def test_fuse_starts_the_filter_again_at_each_run_and_says_which_run(tmp_path):
    first, second = run_samples(300, 0), run_samples(200, 20_000)
    path = bin_file(tmp_path / "r.bin", [frames(first), frames(second)])
    out = tmp_path / "q.npz"
    r = armtracker(tmp_path, "fuse", str(path), "--out", str(out))
    assert r.returncode == 0, r.stderr
    with np.load(out) as z:
        assert np.bincount(z["run"]).tolist() == [300, 200]
        assert float(z["rate"]) == pytest.approx(200.0)
        quat = z["quat"]
    # Every run starts from the same first reading, so a filter started again gives the same first estimate.
    assert quat[300] == pytest.approx(quat[0])


# ----------------------------------------------------------------- case 7: headers and cells

BAD_HELLOS = [
    ('"a string"', "expected an object"),
    ("[1, 2]", "expected an object"),
    ("NaN", "NaN is not a JSON number"),
    ("{}", "'firmware' is missing"),
    (json.dumps({**HELLO.to_json(), "mode": "bogus"}), "'mode' is 'bogus'"),
    (json.dumps({**HELLO.to_json(), "errors": ["NOPE"]}), "'errors' holds 'NOPE'"),
    (json.dumps({**HELLO.to_json(), "rate_hz": True}), "'rate_hz' is True"),
    (json.dumps({**HELLO.to_json(), "acc_fs_g": 3}), "'acc_fs_g' is 3; expected 2 or 4 or 8 or 16"),
]


@pytest.mark.parametrize("hello_text, words", BAD_HELLOS)
def test_a_damaged_hello_in_a_bin_header_is_one_line(tmp_path, hello_text, words):
    path = tmp_path / "h.bin"
    path.write_bytes(MAGIC + b'{"legacy_text": false, "hello": ' + hello_text.encode() + b"}\n"
                     + frames(run_samples(5, 0)))
    before = snapshot(tmp_path)
    for command in ("decode", "replay", "fuse"):
        extra = ["--out", str(tmp_path / "out.npz")] if command == "fuse" else ["--fast"] if command == "replay" else []
        assert_refused(armtracker(tmp_path, command, str(path), *extra), str(path), "header", words)
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("hello_text, words", BAD_HELLOS)
def test_a_damaged_hello_line_in_a_csv_is_one_line(tmp_path, hello_text, words):
    path = csv_file(tmp_path / "h.csv", csv_rows(run_samples(5, 0)), hello_line=hello_text)
    before = snapshot(tmp_path)
    assert_refused(armtracker(tmp_path, "decode", str(path)), str(path), "line 2", "hello", words)
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("column, value, words", [
    ("acc_x", "1e9", "acc_x 1e9 is outside the accelerometer's +-16 g range"),
    ("gyr_z", "-inf", "gyr_z -inf is not"),
    ("mag_y", "nan", "mag_y nan is not"),
    ("t_s", "1e300", "t_s 1e300 is outside 0..1e+09"),
    ("t_us", "4294967296", "t_us 4294967296 is not 0..4294967295"),
    ("seq", "-1", "seq -1 is not 0..65535"),
    ("flex_adc", "1024", "flex_adc 1024 is not 0..1023"),
    ("acc_fs_g", "3", "acc_fs_g 3 is not 2 or 4 or 8 or 16"),
    ("run", "x", "run x is not a whole number"),
])
def test_a_bad_csv_cell_names_its_line_and_column(tmp_path, column, value, words):
    rows = csv_rows(run_samples(6, 0))
    rows[3][RAW_COLUMNS.index(column)] = value
    path = csv_file(tmp_path / "c.csv", rows)
    before = snapshot(tmp_path)
    for command in ("decode", "fuse", "replay"):
        extra = ["--out", str(tmp_path / "o.npz")] if command == "fuse" else []
        assert_refused(armtracker(tmp_path, command, str(path), *extra), str(path), "line 7", words)
    assert snapshot(tmp_path) == before


def test_fuse_refuses_equal_and_backward_times_naming_the_line(tmp_path):
    samples = run_samples(8, 0)
    equal = csv_rows(samples)
    equal[4][0] = equal[3][0]
    backward = list(reversed(csv_rows(samples)))
    out = tmp_path / "q.npz"
    out.write_bytes(b"the user's earlier result")
    cases = [(csv_file(tmp_path / name, rows), line)
             for name, rows, line in (("equal.csv", equal, 8), ("reversed.csv", backward, 5))]
    before = snapshot(tmp_path)
    for path, line in cases:
        assert_refused(armtracker(tmp_path, "fuse", str(path), "--out", str(out)),
                       str(path), f"line {line}", "time must increase within a run")
    assert snapshot(tmp_path) == before


def test_fuse_refuses_a_bin_whose_clock_stands_still_naming_the_sample(tmp_path):
    """Two samples stamped alike (seq + 1, the same t_us): not a restart, and no time step to fuse with."""
    samples = run_samples(6, 0)
    samples[3] = samples[3]._replace(t_us=samples[2].t_us)
    path = bin_file(tmp_path / "still.bin", [frames(samples)])
    assert_refused(armtracker(tmp_path, "fuse", str(path), "--out", str(tmp_path / "q.npz")),
                   str(path), "sample 4 (t 0.010000 s) is not after the one before it")
    assert not (tmp_path / "q.npz").exists()


def test_a_csv_line_that_is_not_utf8_is_named(tmp_path):
    path = csv_file(tmp_path / "latin.csv", csv_rows(run_samples(4, 0)))
    path.write_bytes(path.read_bytes() + b"caf\xe9\n")
    assert_refused(armtracker(tmp_path, "decode", str(path)), str(path), "line 8 is not UTF-8 text")


def test_a_csv_whose_runs_go_back_is_refused(tmp_path):
    rows = csv_rows(run_samples(3, 0), run=1) + csv_rows(run_samples(3, 0), run=0)
    path = csv_file(tmp_path / "r.csv", rows)
    assert_refused(armtracker(tmp_path, "decode", str(path)), "line 7", "run 0 follows run 1")


def test_csvs_written_before_the_run_column_still_read(tmp_path):
    samples = run_samples(20, 0)
    path = csv_file(tmp_path / "old.csv", [r[:-1] for r in csv_rows(samples)], columns=RAW_COLUMNS[:-1])
    _, got = read_csv(path)
    assert [s.acc_counts for s in got] == [s.acc_counts for s in samples]


def test_csvs_keep_the_die_temperature_and_those_written_before_it_still_read(tmp_path):
    samples = [s._replace(temp_counts=1335 - k) for k, s in enumerate(run_samples(20, 0))]
    _, got = read_csv(csv_file(tmp_path / "new.csv", csv_rows(samples)))
    assert [s.temp_counts for s in got] == [1335 - k for k in range(20)]  # exact: degC back to counts
    old_columns = [c for c in RAW_COLUMNS if c != "die_c"]
    rows = [r[:16] + r[17:] for r in csv_rows(samples)]
    _, got = read_csv(csv_file(tmp_path / "old.csv", rows, columns=old_columns))
    assert [s.temp_counts for s in got] == [None] * 20 and [s.t for s in got] == [s.t for s in samples]
    _, got = read_csv(csv_file(tmp_path / "older.csv", [r[:-1] for r in rows], columns=old_columns[:-1]))
    assert len(got) == 20


# ----------------------------------------------------------------- case 12: non-files


def test_decode_and_fuse_refuse_a_fifo_a_pty_and_dev_zero_at_once(tmp_path):
    fifo = tmp_path / "pipe.bin"
    os.mkfifo(fifo)
    master, slave = os.openpty()
    try:
        pty = os.ttyname(slave)
        for path, kind in ((str(fifo), "FIFO"), (pty, "character device"), ("/dev/zero", "character device")):
            for command in ("decode", "fuse", "replay"):
                extra = ["--out", str(tmp_path / "o.npz")] if command == "fuse" else []
                r = armtracker(tmp_path, command, path, *extra, timeout=60)  # a hang fails here
                if command != "replay":  # replay's own check (the command line's) words it its way
                    assert_refused(r, path, kind)
                else:
                    assert r.returncode != 0 and "Traceback" not in r.stderr
    finally:
        os.close(master)
        os.close(slave)
    assert not (tmp_path / "o.npz").exists()


def test_realtime_replay_of_an_absurd_timestamp_is_refused_with_its_line(tmp_path):
    rows = csv_rows(run_samples(4, 0))
    rows[2][0] = "1e300"
    path = csv_file(tmp_path / "far.csv", rows)
    assert_refused(armtracker(tmp_path, "replay", str(path)), str(path), "line 6", "t_s 1e300")


def test_a_folder_and_a_missing_file_are_named(tmp_path):
    assert_refused(armtracker(tmp_path, "decode", str(tmp_path)), str(tmp_path), "directory")
    assert_refused(armtracker(tmp_path, "fuse", str(tmp_path / "none.csv"), "--out", str(tmp_path / "o.npz")),
                   "no such file", "none.csv")


# ----------------------------------------------------------------- properties

FAST = settings(derandomize=True, max_examples=150, deadline=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def assert_one_line_or_fine(read, path: Path) -> None:
    """``read(path)`` succeeds or raises RecordingError/DatasetError with one line naming the file."""
    from tracker.evaluate import DatasetError
    before = snapshot(path.parent)
    try:
        read(path)
    except (RecordingError, DatasetError) as e:
        message = str(e)
        assert "\n" not in message and str(path) in message, message
    assert snapshot(path.parent) == before


@FAST
@given(st.binary(max_size=300), st.integers(0, 20), st.binary(max_size=300), st.integers(0, 2**32 - 1))
def test_random_bytes_after_a_valid_header_never_crash_decode_or_fuse(tmp_path_factory, junk, n, more, t0):
    folder = tmp_path_factory.mktemp("bytes")
    samples = [s._replace(t_us=s.t_us & 0xFFFFFFFF, seq=s.seq & 0xFFFF) for s in run_samples(n, t0, t0 >> 16)]
    data = junk + frames(samples) + more
    path = bin_file(folder / "x.bin", [data])
    assert_one_line_or_fine(summarize, path)
    assert_one_line_or_fine(sensor_arrays, path)
    (folder / "y.bin").write_bytes(MAGIC + data)  # a header line of random bytes
    assert_one_line_or_fine(decode_file, folder / "y.bin")


json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-2**70, 2**70) | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=8) | st.sampled_from(["raw", "fused", "bogus", "1.0.0", "IMU_MISSING", "NOPE"]),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(
        st.sampled_from([*HELLO.to_json(), "x"]), inner, max_size=10),
    max_leaves=20)


@FAST
@given(json_values, st.dictionaries(st.sampled_from(list(HELLO.to_json())), json_values, max_size=4))
def test_random_headers_never_crash_the_readers(tmp_path_factory, value, changes):
    folder = tmp_path_factory.mktemp("headers")
    hello = {**HELLO.to_json(), **changes}
    bin_path = bin_file(folder / "h.bin", [frames(run_samples(3, 0))],
                        header={"hello": hello, "legacy_text": value if isinstance(value, bool) else False,
                                "x": value})
    assert_one_line_or_fine(summarize, bin_path)
    raw_header = folder / "v.bin"
    raw_header.write_bytes(MAGIC + json.dumps(value).encode() + b"\n" + frames(run_samples(3, 0)))
    assert_one_line_or_fine(summarize, raw_header)
    for hello_value in (hello, value):
        csv_path = csv_file(folder / "h.csv", csv_rows(run_samples(3, 0)), hello_line=json.dumps(hello_value))
        assert_one_line_or_fine(read_csv, csv_path)


cells = st.one_of(
    st.sampled_from(["", "0", "-0", "1e9", "-1e9", "nan", "inf", "1e300", "16", "2000", "65535", "65536",
                     "4294967296", "-1", "0x10", "1_0", " 3", "1.5", "\x00", "é", '"q"', "#"]),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-2**40, 2**40).map(str),
    st.text(max_size=6))


@FAST
@given(st.lists(st.tuples(st.integers(0, 5), st.integers(0, len(RAW_COLUMNS) - 1), cells), max_size=6),
       st.booleans())
def test_random_csv_cells_never_crash_decode_or_fuse(tmp_path_factory, edits, extra_cell):
    folder = tmp_path_factory.mktemp("cells")
    rows = csv_rows(run_samples(6, 0))
    for row, column, value in edits:
        rows[row][column] = value.replace(",", ";").replace("\n", " ").replace("\r", " ")
    if extra_cell:
        rows[-1].append("1")
    path = csv_file(folder / "c.csv", rows)
    assert_one_line_or_fine(summarize, path)
    assert_one_line_or_fine(sensor_arrays, path)


def test_the_csv_property_inputs_include_refusals_and_successes(tmp_path):
    """The cell strategy is not vacuous: both outcomes occur on hand-picked rows."""
    good = csv_file(tmp_path / "g.csv", csv_rows(run_samples(6, 0)))
    assert summarize(good).samples == 6
    rows = csv_rows(run_samples(6, 0))
    rows[1][3] = "1e9"
    with pytest.raises(RecordingError, match="line 5"):
        summarize(csv_file(tmp_path / "b.csv", rows))


def test_a_recording_larger_than_the_bound_is_refused_before_it_is_read(tmp_path):
    path = bin_file(tmp_path / "big.bin", [frames(run_samples(100, 0))])
    with pytest.raises(RecordingError, match=r"big.bin is 3\d\d\d bytes; a recording of at most 1000 bytes is read"):
        open_input(path, limit=1000)
    with open_input(path, limit=path.stat().st_size) as f:
        assert f.read() == path.read_bytes()
