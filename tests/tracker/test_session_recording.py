"""Session recordings: the container written as it goes, read back whole, cut off, damaged or foreign."""

import os
import threading
import zlib

import numpy as np
import pytest

from tracker import protocol as P
from tracker.fuse import fuse_file
from tracker.recording import MAGIC as RAW_MAGIC, RecordingError, decode_file, summarize
from tracker.session_recording import (BLOCK_HEAD, MAGIC, WIRE, BinaryRecord, SessionReader, SessionWriter)

RECORDS = {"note": "a test's note", "end": "the last record"}


def written(path, n=300, flush_every=50):
    """A session of ``n`` JSON and ``n`` binary records, a block closed every ``flush_every``."""
    w = SessionWriter(path, {"game": "test"}, RECORDS, flush_s=3600.0)
    expected = []
    for k in range(n):
        note = {"type": "note", "k": k}
        data = bytes([k % 256]) * (k % 7)
        w.json(note)
        w.binary(WIRE, k * 0.01, data)
        expected += [note, BinaryRecord(WIRE, k * 0.01, data)]
        if k % flush_every == flush_every - 1:
            w.flush()
    w.close()
    return expected + [{"type": "end"}]


def test_what_is_written_reads_back_in_order_with_its_header(tmp_path):
    path = tmp_path / "s.ebs"
    expected = written(path)
    r = SessionReader(path)
    assert r.header["format"] == "energyball-session" and r.header["version"] == 1
    assert r.header["game"] == "test" and r.header["records"] == RECORDS
    assert list(r.records()) == expected
    assert r.ended and r.stopped is None


def test_a_file_cut_anywhere_gives_exactly_its_complete_blocks(tmp_path):
    """Cut at seeded random bytes: the records read are those of the blocks wholly before the cut,
    and the reader says where it stopped; never an exception."""
    path = tmp_path / "s.ebs"
    expected = written(path)
    data = path.read_bytes()
    header_end = data.index(b"\n", len(MAGIC)) + 1
    starts, at = [], header_end  # where each block starts, and how many records precede it
    while at < len(data):
        _, n, _ = BLOCK_HEAD.unpack_from(data, at)
        starts.append(at)
        at += BLOCK_HEAD.size + n
    counts = np.cumsum([0] + [100] * (len(starts) - 1))  # 50 notes + 50 binaries per block; the end in the last
    cut_path = tmp_path / "cut.ebs"
    for cut in np.random.default_rng(5).integers(header_end, len(data), 40):
        cut_path.write_bytes(data[:cut])
        r = SessionReader(cut_path)
        got = list(r.records())
        whole = sum(1 for s in starts[1:] if s <= cut)  # blocks ending at or before the cut
        assert got == expected[:counts[whole]]
        assert not r.ended and r.stopped is not None
        assert (f"stopped after the {whole} complete" in r.stopped) if cut not in starts else \
            (f"cut off after block {whole}" in r.stopped)


def test_a_damaged_block_stops_the_reading_there(tmp_path):
    path = tmp_path / "s.ebs"
    expected = written(path)
    data = bytearray(path.read_bytes())
    header_end = data.index(b"\n", len(MAGIC)) + 1
    _, n, _ = BLOCK_HEAD.unpack_from(data, header_end)
    second = header_end + BLOCK_HEAD.size + n
    data[second + BLOCK_HEAD.size + 5] ^= 0x40  # one bit inside the second block's payload
    path.write_bytes(bytes(data))
    r = SessionReader(path)
    assert list(r.records()) == expected[:100]
    assert "block 2" in r.stopped and "CRC" in r.stopped and not r.ended


@pytest.mark.parametrize("content, words", [
    (b"", "not an EnergyBall session recording"),
    (b"hello world\n", "not an EnergyBall session recording"),
    (RAW_MAGIC + b"{}\n", "not an EnergyBall session recording"),
    (b"EBSESSION2\n{}\n", "another version"),
    (MAGIC + b"{\"format\": \"energyball-session\", \"version\": 7}\n", "version 7"),
    (MAGIC + b"{\"format\": \"something else\", \"version\": 1}\n", "damaged"),
    (MAGIC + b"not json\n", "damaged"),
    (MAGIC + b"{\"format\": \"energyball-session\"", "damaged"),
])
def test_foreign_and_damaged_headers_are_one_clear_line(tmp_path, content, words):
    path = tmp_path / "x.ebs"
    path.write_bytes(content)
    with pytest.raises(RecordingError) as e:
        SessionReader(path)
    assert words in str(e.value) and str(path) in str(e.value) and "\n" not in str(e.value)


def test_a_block_of_another_writer_that_passes_its_crc_stops_with_a_message(tmp_path):
    path = tmp_path / "x.ebs"
    w = SessionWriter(path, {}, RECORDS)
    w.json({"type": "note"})
    w.flush()
    payload = zlib.compress(b"Zsomething this version does not know")
    with open(path, "ab") as f:
        f.write(BLOCK_HEAD.pack(b"EBBK", len(payload), zlib.crc32(payload)) + payload)
    r = SessionReader(path)
    assert list(r.records()) == [{"type": "note"}]
    assert "cannot read" in r.stopped


def test_the_file_appears_with_its_first_block_and_an_old_one_is_kept_until_then(tmp_path):
    path = tmp_path / "s.ebs"
    path.write_bytes(b"the previous session")
    w = SessionWriter(path, {}, RECORDS, flush_s=3600.0)
    w.json({"type": "note"})
    assert path.read_bytes() == b"the previous session"  # nothing flushed yet
    w.flush()
    assert list(SessionReader(path).records()) == [{"type": "note"}]  # in place, complete so far
    w.json({"type": "note", "k": 2})
    w.close()
    assert list(SessionReader(path).records()) == [{"type": "note"}, {"type": "note", "k": 2}, {"type": "end"}]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.ebs"]  # no temporary file left


def test_blocks_close_by_size_so_memory_stays_bounded(tmp_path):
    w = SessionWriter(tmp_path / "s.ebs", {}, RECORDS, flush_s=3600.0, block_bytes=4096)
    for k in range(2000):
        w.binary(WIRE, k, os.urandom(100))
        assert len(w._pending) < 4096
    w.close()


def test_records_from_two_threads_all_arrive_whole(tmp_path):
    path = tmp_path / "s.ebs"
    w = SessionWriter(path, {}, RECORDS, flush_s=0.001)

    def board():
        for k in range(3000):
            w.binary(WIRE, k, k.to_bytes(4, "little"))

    t = threading.Thread(target=board)
    t.start()
    for k in range(3000):
        w.json({"type": "note", "k": k})
    t.join()
    w.close()
    records = list(SessionReader(path).records())
    assert [r.data for r in records if isinstance(r, BinaryRecord)] == [k.to_bytes(4, "little") for k in range(3000)]
    assert [r["k"] for r in records if isinstance(r, dict) and "k" in r] == list(range(3000))


def test_armtracker_decode_reads_the_boards_bytes_of_a_session(tmp_path):
    """The wire channel holds a board's frames, split anywhere: decode gives its samples, as from a .bin."""
    hello = P.Hello(1, "1.0.0", 0x71, 0x48, 200, P.Mode.RAW, True, 16, 2000, P.BoardError.NONE)
    samples = [P.RawSample(k * 0.005, k * 5000, k % 256, (k, 0, 100), (0, -k, 0), (1, 2, 3), 512)
               for k in range(400)]
    stream = P.encode(hello) + b"".join(P.encode(s) for s in samples)
    path = tmp_path / "s.ebs"
    w = SessionWriter(path, {}, RECORDS)
    cuts = sorted(np.random.default_rng(2).integers(0, len(stream), 30))
    for a, b in zip([0, *cuts], [*cuts, len(stream)]):
        w.json({"type": "note"})
        w.binary(WIRE, a / 1000, stream[a:b])
        w.binary(1, a / 1000, b"another channel's bytes")
    w.close()
    got, replay = decode_file(path)
    assert [(s.seq, s.acc_counts, s.gyr_counts) for s in got] == [(s.seq, s.acc_counts, s.gyr_counts) for s in samples]
    assert replay.hello == hello and replay.stats.crc_errors == 0 and replay.stats.bytes_skipped == 0
    assert summarize(path).samples == 400
    assert fuse_file(path, "madgwick", 6, tmp_path / "q.npz") == 400  # armtracker fuse reads it too
