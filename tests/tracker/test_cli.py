"""The `armtracker` command line, run as a user runs it: a separate process."""

import json
import os
import subprocess
import sys
from pathlib import Path

from tracker.__main__ import main
from tracker.board import BoardSettings, VirtualBoard

ROOT = Path(__file__).resolve().parents[2]


def armtracker(*args: str, timeout: float = 60) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "tracker", *args], capture_output=True, text=True,
                          timeout=timeout, cwd=ROOT, stdin=subprocess.DEVNULL)


def assert_clear_error(result: subprocess.CompletedProcess, words: str) -> None:
    """Non-zero exit, one line on stderr naming the problem, no traceback."""
    assert result.returncode != 0
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0], result.stderr


def test_monitor_json_has_the_documented_shape():
    r = armtracker("monitor", "--virtual", "--seconds", "1.5", "--json")
    assert r.returncode == 0, r.stderr
    report = json.loads(r.stdout)
    assert report["frames"] >= 250 and report["dropped"] == 0 and report["crc_errors"] == 0
    assert report["hello"]["imu_whoami"] == 0x71 and report["hello"]["rate_hz"] == 200
    last = report["last"]
    assert set(last) >= {"t", "acc", "gyr", "mag", "flex_adc"}
    # At rest or swinging, the accelerometer feels about 1 g.
    assert 7 < sum(a * a for a in last["acc"]) ** 0.5 < 13
    assert 150 < report["rate_hz"] <= 210


def test_record_then_decode_then_replay(tmp_path):
    raw, table = tmp_path / "s.bin", tmp_path / "s.csv"
    r = armtracker("record", "--virtual", "--seconds", "1", "--raw", str(raw), "--csv", str(table))
    assert r.returncode == 0, r.stderr
    decoded = json.loads(armtracker("decode", str(raw), "--json").stdout)
    assert decoded["crc_errors"] == 0 and decoded["dropped"] == 0
    assert decoded["packets"] >= 190
    rows = len(table.read_text().splitlines()) - 3
    replayed = json.loads(armtracker("replay", "--fast", str(table), "--json").stdout)
    assert replayed["samples"] == rows and replayed["crc_errors"] == 0
    replayed_bin = json.loads(armtracker("replay", "--fast", str(raw), "--json").stdout)
    assert replayed_bin["samples"] == decoded["samples"]


def test_bench_reports_decoder_throughput():
    r = armtracker("bench", "--json")
    report = json.loads(r.stdout)
    assert report["decode_frames_per_s"] > 0
    assert report["link_utilisation_200hz"] <= 0.60


def test_a_nonexistent_port():
    assert_clear_error(armtracker("monitor", "--port", "/dev/ttyDOESNOTEXIST"), "no such port")


def test_a_port_that_sends_nothing():
    master, slave = os.openpty()
    try:
        r = armtracker("monitor", "--port", os.ttyname(slave), "--seconds", "1")
    finally:
        os.close(master)
        os.close(slave)
    assert_clear_error(r, "no data from")


def test_a_wrong_baud_rate():
    with VirtualBoard(settings=BoardSettings(baud=9600)) as board:
        r = armtracker("monitor", "--port", board.port, "--baud", "115200", "--seconds", "1")
    assert_clear_error(r, "wrong baud rate")


def run_unprivileged(argv: list[str]) -> subprocess.CompletedProcess:
    """``armtracker argv`` in a forked process that has given up root (root opens anything).

    Everything it imports is imported before the fork: an unprivileged user may not
    be able to read this interpreter's library.
    """
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: become nobody, send stderr down the pipe, run the command
        code = 99
        try:
            os.dup2(write_end, 2)
            sys.stderr = os.fdopen(write_end, "w", buffering=1)
            if os.geteuid() == 0:
                os.setgid(65534)
                os.setuid(65534)
            code = main(argv)
        finally:
            os._exit(code)
    os.close(write_end)
    with os.fdopen(read_end) as f:
        stderr = f.read()
    _, status = os.waitpid(pid, 0)
    return subprocess.CompletedProcess(argv, os.waitstatus_to_exitcode(status), "", stderr)


def test_a_port_without_permission():
    with VirtualBoard() as board:
        pty = os.path.realpath(board.port)
        os.chmod(pty, 0o600)
        r = run_unprivileged(["monitor", "--port", pty, "--seconds", "1"])
    assert_clear_error(r, "permission denied")


def test_a_file_that_is_not_a_recording(tmp_path):
    junk = tmp_path / "photo.jpg"
    junk.write_bytes(bytes(range(256)) * 20)
    assert_clear_error(armtracker("decode", str(junk)), "not an EnergyBall recording")
    assert_clear_error(armtracker("replay", str(tmp_path / "none.bin")), "no such file")


def test_an_output_folder_that_does_not_exist(tmp_path):
    r = armtracker("record", "--virtual", "--seconds", "0.2", "--raw", str(tmp_path / "no" / "x.bin"))
    assert_clear_error(r, "does not exist")
