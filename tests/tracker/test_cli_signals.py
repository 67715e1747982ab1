"""Ctrl-C, SIGTERM and SIGHUP sent to the real commands (issue 13, cases 1 and 4).

For every signal, at seeded random moments: the previous output is intact,
or the new one is complete; no ``.part`` file is ever left; no traceback.
``record``, ``monitor`` and ``virtual`` end normally on any of the three
(exit 0, the recording kept, the link removed); ``fuse`` exits 128 + the
signal's number when cut off mid-write, leaving the old file as it was.
"""

from __future__ import annotations

import json
import os
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from tracker import protocol as P
from tracker.recording import decode_file, read_csv

from ..commands import SIGNALS, finish, parts, start, wait_for

FUSE_SAMPLES = 200_000  # a write of 6 MB: long enough to be hit mid-write


def assert_no_traceback(r) -> None:
    assert "Traceback" not in r.stderr, r.stderr


def first_line_with(proc, word: str) -> str:
    """Read the command's stderr until a line holding ``word`` (its status line: the work has begun)."""
    while True:
        line = proc.stderr.readline()
        if not line:
            raise AssertionError(f"the command ended before saying {word!r}")
        if word in line:
            return line


def assert_recording(raw: Path, table: Path) -> None:
    """A complete recording: both files decode, with samples and no damage."""
    samples, replay = decode_file(raw)
    assert len(samples) > 0 and replay.stats.crc_errors == 0
    _, rows = read_csv(table)
    assert len(rows) > 0


def test_record_ends_cleanly_on_every_signal_at_random_moments(tmp_path):
    rng = np.random.default_rng(13)
    raw, table = tmp_path / "x.bin", tmp_path / "x.csv"
    kept = 0
    for sig in SIGNALS:
        for _ in range(2):
            raw.write_bytes(b"the previous recording")
            table.write_text("the previous table")
            proc = start("tracker", "record", "--virtual", "--seconds", "60", "--raw", str(raw), "--csv", str(table),
                         home=tmp_path)
            wait_for(lambda: parts(tmp_path) != [], proc)  # the recorder exists: the handshake is on
            time.sleep(rng.uniform(0.0, 1.5))
            proc.send_signal(sig)
            r = finish(proc)
            assert_no_traceback(r)
            assert parts(tmp_path) == []
            if r.returncode == 0:  # the recording had begun: it is kept, whole
                assert_recording(raw, table)
                assert "recorded" in r.stderr
                kept += 1
            else:  # still in the handshake: nothing recorded, nothing replaced
                assert r.returncode == 128 + sig, r.stderr
                assert raw.read_bytes() == b"the previous recording"
                assert table.read_text() == "the previous table"
    assert kept > 0  # the seeded moments include recordings that had begun


def test_a_signal_in_the_handshake_leaves_nothing(tmp_path):
    """A port that never answers (a pty we hold silent): the handshake waits, and is interrupted."""
    master, slave = os.openpty()
    try:
        for sig in SIGNALS:
            proc = start("tracker", "record", "--port", os.ttyname(slave), "--seconds", "5",
                         "--raw", str(tmp_path / "x.bin"), "--csv", str(tmp_path / "x.csv"), home=tmp_path)
            wait_for(lambda: parts(tmp_path) != [], proc)
            time.sleep(0.3)
            proc.send_signal(sig)
            r = finish(proc)
            assert r.returncode == 128 + sig, r.stderr
            assert_no_traceback(r)
            assert sorted(p.name for p in tmp_path.iterdir()) == []
    finally:
        os.close(master)
        os.close(slave)


def test_a_signal_before_the_first_sample_keeps_the_previous_recording(tmp_path):
    """A board that says hello and then sends nothing: the recording has begun but holds no
    sample, so a signal leaves the previous files as they were (CI caught this race once)."""
    master, slave = os.openpty()
    hello = P.encode(P.Hello(1, "1.0.0", 0x71, 0x48, 200, P.Mode.RAW, True, 16, 2000, P.BoardError.NONE))
    answer = threading.Thread(target=lambda: (os.read(master, 64), os.write(master, hello)), daemon=True)
    answer.start()
    raw, table = tmp_path / "x.bin", tmp_path / "x.csv"
    raw.write_bytes(b"the previous recording")
    table.write_text("the previous table")
    try:
        proc = start("tracker", "record", "--port", os.ttyname(slave), "--seconds", "30",
                     "--raw", str(raw), "--csv", str(table), home=tmp_path)
        first_line_with(proc, "recording")
        proc.send_signal(signal.SIGTERM)
        r = finish(proc)
    finally:
        os.close(master)
        os.close(slave)
    assert r.returncode == 128 + signal.SIGTERM, r.stderr
    assert_no_traceback(r)
    assert "nothing recorded" in r.stderr
    assert raw.read_bytes() == b"the previous recording"
    assert table.read_text() == "the previous table"
    assert parts(tmp_path) == []


def test_two_quick_ctrl_c_keep_the_finished_recording(tmp_path):
    rng = np.random.default_rng(21)
    raw, table = tmp_path / "x.bin", tmp_path / "x.csv"
    for gap in (0.0, *rng.uniform(0.0, 0.02, 3)):
        proc = start("tracker", "record", "--virtual", "--seconds", "60", "--raw", str(raw), "--csv", str(table),
                     home=tmp_path)
        first_line_with(proc, "recording")
        time.sleep(rng.uniform(0.2, 1.0))
        proc.send_signal(signal.SIGINT)
        time.sleep(gap)
        proc.send_signal(signal.SIGINT)
        r = finish(proc)
        assert r.returncode == 0, r.stderr
        assert_no_traceback(r)
        assert parts(tmp_path) == []
        assert_recording(raw, table)


@pytest.mark.parametrize("sig", SIGNALS, ids=lambda s: s.name)
def test_monitor_ends_with_its_report_on_every_signal(tmp_path, sig):
    proc = start("tracker", "monitor", "--virtual", "--json", home=tmp_path)
    first_line_with(proc, "Hz")
    proc.send_signal(sig)
    r = finish(proc)
    assert r.returncode == 0, r.stderr
    assert_no_traceback(r)
    assert json.loads(r.stdout)["frames"] > 0


@pytest.mark.parametrize("sig", SIGNALS, ids=lambda s: s.name)
def test_virtual_removes_its_link_on_every_signal(tmp_path, sig):
    link = tmp_path / "ttyBOARD"
    proc = start("tracker", "virtual", "--link", str(link), home=tmp_path)
    first_line_with(proc, "virtual board on")
    assert link.is_symlink()
    proc.send_signal(sig)
    r = finish(proc)
    assert r.returncode == 0, r.stderr
    assert_no_traceback(r)
    assert not link.is_symlink() and not link.exists()


def big_trial(path: Path) -> None:
    rng = np.random.default_rng(8)
    n = FUSE_SAMPLES
    np.savez(path, gyr=rng.normal(0, 0.01, (n, 3)), acc=np.tile([0, 0, 9.81], (n, 1)) + rng.normal(0, 0.05, (n, 3)),
             mag=np.tile([20.0, 0.0, -40.0], (n, 1)), quat=np.tile([1.0, 0, 0, 0], (n, 1)), rate=np.float64(200.0))


def test_fuse_keeps_the_old_output_or_writes_the_whole_new_one(tmp_path):
    """Signals at random moments of the run, and just after the temporary file appears (mid-write)."""
    trial, out = tmp_path / "big.npz", tmp_path / "out.npz"
    big_trial(trial)
    old = np.arange(12.0).reshape(3, 4)
    rng = np.random.default_rng(34)
    outcomes = set()
    for sig in SIGNALS:
        for mid_write in (False, True):
            np.savez(out, quat=old)
            proc = start("tracker", "fuse", str(trial), "--filter", "complementary", "--out", str(out),
                         home=tmp_path)
            if mid_write:
                wait_for(lambda: parts(tmp_path) != [], proc)
                time.sleep(rng.uniform(0.0, 0.03))
            else:
                time.sleep(rng.uniform(0.3, 2.0))
            proc.send_signal(sig)
            r = finish(proc)
            assert_no_traceback(r)
            assert parts(tmp_path) == []
            with np.load(out) as z:
                quat = z["quat"]
            if r.returncode == 0:  # the signal came after the file was in place: the new one, whole
                assert quat.shape == (FUSE_SAMPLES, 4)
                assert np.allclose(np.linalg.norm(quat, axis=1), 1.0)
            else:
                assert r.returncode == 128 + sig, r.stderr
                if quat.shape == old.shape:
                    assert np.array_equal(quat, old)
                else:  # the file was complete when the signal came, and was committed before it took effect
                    assert quat.shape == (FUSE_SAMPLES, 4)
            outcomes.add("old" if quat.shape == old.shape else "new")
    assert "old" in outcomes  # the seeded moments include interruptions before the commit
