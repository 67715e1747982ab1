"""Recordings: written atomically, read back exactly, replayed through the decoder."""

import json
import time

import pytest

from tracker import protocol as P
from tracker.atomic import AtomicFile, atomic_write
from tracker.board import BoardSettings, VirtualBoard
from tracker.link import Link, LinkSettings
from tracker.recording import (CsvRecorder, MAGIC, RawRecorder, RecordingError, Replay,
                               decode_file, read_csv, read_raw)

from .helpers import wire


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """One second of a virtual board recorded live to .bin and .csv."""
    folder = tmp_path_factory.mktemp("rec")
    raw_path, csv_path = folder / "a.bin", folder / "a.csv"
    settings = BoardSettings(stream_at_boot=False, keep_sent=1000)
    raw = RawRecorder(raw_path)
    with VirtualBoard(settings=settings) as board:
        link = Link(LinkSettings(board.port))
        link.tap = raw.write
        link.open()
        raw.begin({"port": board.port, "hello": link.hello.to_json()})
        table = CsvRecorder(csv_path, link.hello)
        live = list(link.samples(1.0))
        link.tap = None
        for s in live:
            table.write(s)
        raw.close()
        table.close()
        link.close()
    return raw_path, csv_path, live


def test_bin_recording_decodes_to_the_live_samples(recorded):
    raw_path, _, live = recorded
    samples, replay = decode_file(raw_path)
    n = min(len(samples), len(live))  # the tap may catch a frame the consumer did not
    assert n >= 190
    assert [wire(s) for s in samples[:n]] == [wire(s) for s in live[:n]]
    assert replay.stats.crc_errors == 0 and replay.hello.imu_whoami == 0x71


def test_csv_recording_reads_back_the_exact_samples(recorded):
    _, csv_path, live = recorded
    hello, samples = read_csv(csv_path)
    assert hello.rate_hz == 200
    assert [wire(s) for s in samples] == [wire(s) for s in live]
    assert [s.host_t for s in samples] == [s.host_t for s in live]


def test_csv_replay_goes_through_the_decoder_and_keeps_host_times(recorded):
    _, csv_path, live = recorded
    replayed = list(Replay(csv_path))
    assert replayed == live


def test_realtime_replay_keeps_the_recorded_pace(recorded):
    raw_path, _, live = recorded
    start = time.monotonic()
    n = sum(1 for _ in Replay(raw_path, realtime=True, speed=4.0))
    elapsed = time.monotonic() - start
    span = (live[-1].t - live[0].t) / 4.0
    assert n >= len(live) - 1
    assert elapsed >= span * 0.9  # sleeping only ever makes it later


def test_headerless_capture_is_read_as_a_byte_stream(tmp_path):
    samples = [P.RawSample(i * 0.005, i * 5000, i, (0, 0, 2048), (1, 2, 3), None, 400)
               for i in range(10)]
    path = tmp_path / "capture.bin"
    path.write_bytes(b"junk" + b"".join(P.encode(s) for s in samples))
    got, replay = decode_file(path)
    assert [wire(s) for s in got] == [wire(s) for s in samples]
    assert replay.stats.bytes_skipped == 4


def test_a_file_that_is_not_a_recording_is_a_clear_error(tmp_path):
    path = tmp_path / "notes.txt"
    path.write_text("shopping list\n" * 100)
    with pytest.raises(RecordingError, match="not an EnergyBall recording"):
        decode_file(path)
    with pytest.raises(RecordingError, match="no such file"):
        decode_file(tmp_path / "missing.bin")
    with pytest.raises(RecordingError, match="directory"):
        decode_file(tmp_path)


def test_damaged_header_and_bad_csv_rows_are_named(tmp_path):
    bad = tmp_path / "bad.bin"
    bad.write_bytes(MAGIC + b"{not json\n" + b"\x00" * 10)
    with pytest.raises(RecordingError, match="header is damaged"):
        read_raw(bad)
    csv_path = tmp_path / "bad.csv"
    writer = CsvRecorder(csv_path, None)
    writer.write(P.RawSample(0.0, 0, 0, (1, 2, 3), (4, 5, 6), None, 10))
    writer.close()
    csv_path.write_text(csv_path.read_text() + "0.1,1,1,nan,0,0,0,0,0,,,,1,16,2000,\n")
    with pytest.raises(RecordingError, match="line 5 is not a valid sample"):
        read_csv(csv_path)
    (tmp_path / "other.csv").write_text("a,b,c\n1,2,3\n")
    with pytest.raises(RecordingError, match="not an EnergyBall CSV"):
        read_csv(tmp_path / "other.csv")


def test_atomic_file_leaves_the_old_file_on_error_and_on_interrupt(tmp_path):
    target = tmp_path / "keep.json"
    atomic_write(target, json.dumps({"v": 1}))
    with pytest.raises(RuntimeError):
        with AtomicFile(target, "w") as f:
            f.file.write('{"v": 2, "half')
            raise RuntimeError("crash mid-write")
    assert json.loads(target.read_text()) == {"v": 1}
    with pytest.raises(KeyboardInterrupt):
        with AtomicFile(target, "w") as f:
            f.file.write('{"v": 3, "cut off')  # Ctrl-C mid-write: never committed (issue 13, case 1)
            raise KeyboardInterrupt
    assert json.loads(target.read_text()) == {"v": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["keep.json"]  # no temporary left behind


def test_atomic_files_get_the_usual_permissions(tmp_path):
    import os
    umask = os.umask(0o022)
    try:
        atomic_write(tmp_path / "a.txt", "x")
    finally:
        os.umask(umask)
    assert (tmp_path / "a.txt").stat().st_mode & 0o777 == 0o644
