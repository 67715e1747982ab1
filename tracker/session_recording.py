"""Session recordings: a versioned, self-describing, compressed stream of records, written as it goes.

A game session is kept as records: JSON objects (what the game was given
and did: its settings, each frame's input, its events) and binary records
on numbered channels (the board's bytes as they arrived, with the host's
receive time). This container knows nothing of the game: ``tracker`` reads
the board's channel (``armtracker decode`` and ``fuse`` take a session as
they take a ``.bin``), :mod:`game.replay` reads the rest.

The file (integers little-endian)::

    EBSESSION1\\n                         the magic, with the container's version
    {"format": "energyball-session", ...}\\n   the header: one line of JSON
    block*

    block   := "EBBK" u32 n u32 crc32 payload[n]    payload: zlib-compressed records
    record  := "J" u32 n json[n]                    a JSON object with a "type"
             | "B" u8 channel f64 t u32 n data[n]   bytes on a channel at host time t (s)

The header says what the records mean (``"records"``) besides the writer's
own keys. The writer closes a block every ``flush_s`` seconds or
``block_bytes`` of records and flushes it to the disk, so its memory stays
bounded and a crash, a kill or a pulled plug loses at most the last second:
every block before it is complete. The file appears under its name with
its first block (an existing file of that name is replaced only then) and
grows from there. Its last record is ``{"type": "end"}``: a file without
it was cut off. A reader checks each block's length and CRC-32 and stops at
the first that is cut off or damaged, saying where (:attr:`SessionReader.stopped`),
having given every record before it.
"""

from __future__ import annotations

import json
import os
import struct
import threading
import time
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Iterator

from .atomic import AtomicFile
from .input_files import RecordingError, open_input, read_header_line

MAGIC = b"EBSESSION1\n"
FORMAT = "energyball-session"
VERSION = 1
BLOCK = b"EBBK"
BLOCK_HEAD = struct.Struct("<4sII")  # marker, payload length, CRC-32 of the payload
JSON_HEAD = struct.Struct("<cI")
BINARY_HEAD = struct.Struct("<cBdI")
MAX_BLOCK_BYTES = 16 * 2**20  # compressed or not: a block of ours holds about a second
MAX_HEADER_BYTES = 256 * 2**10
MAX_SESSION_BYTES = 2 * 2**30  # some 50 hours of play with a board
WIRE = 0  # the channel of the board's bytes as they arrived (what armtracker decode reads)


@dataclass(frozen=True)
class BinaryRecord:
    """Bytes on a channel, received at host time ``t`` (seconds since the session began)."""

    channel: int
    t: float
    data: bytes


Record = dict | BinaryRecord


class SessionWriter:
    """Writes a session recording as it goes (see the module's docstring); thread-safe.

    ``header`` is the writer's own part of the header (JSON); ``records``
    documents each record type it writes, in words, so a file explains
    itself. :meth:`close` ends the file with ``{"type": "end"}``.
    """

    def __init__(self, path: str | os.PathLike, header: dict, records: dict[str, str],
                 flush_s: float = 1.0, block_bytes: int = 256 * 2**10) -> None:
        self._out = AtomicFile(path, "wb")
        self.path = self._out.path
        self.flush_s, self.block_bytes = flush_s, block_bytes
        self._lock = threading.Lock()
        self._pending = bytearray()
        self._flushed_at = time.monotonic()
        self._published = False
        self._closed = False
        self.bytes_written = 0
        head = {"format": FORMAT, "version": VERSION, "records": records, **header}
        self._write(MAGIC + json.dumps(head, separators=(",", ":")).encode() + b"\n")

    def json(self, record: dict) -> None:
        """Add a JSON record (a dict with a ``"type"``)."""
        body = json.dumps(record, separators=(",", ":")).encode()
        self._add(JSON_HEAD.pack(b"J", len(body)) + body)

    def binary(self, channel: int, t: float, data: bytes) -> None:
        """Add ``data`` on ``channel`` at host time ``t``."""
        self._add(BINARY_HEAD.pack(b"B", channel, t, len(data)) + bytes(data))

    def _add(self, record: bytes) -> None:
        with self._lock:
            if self._closed:
                return
            self._pending += record
            if len(self._pending) >= self.block_bytes or time.monotonic() - self._flushed_at >= self.flush_s:
                self._flush()

    def flush(self) -> None:
        """Write what is pending as a block now, and put it on the disk."""
        with self._lock:
            if not self._closed:
                self._flush()

    def _flush(self) -> None:
        self._flushed_at = time.monotonic()
        if self._pending:
            payload = zlib.compress(bytes(self._pending), 6)
            self._pending.clear()
            self._write(BLOCK_HEAD.pack(BLOCK, len(payload), zlib.crc32(payload)) + payload)
        self._out.file.flush()
        os.fsync(self._out.file.fileno())
        if not self._published:  # the file appears under its name now, and grows from here
            self._out.publish()
            self._published = True

    def _write(self, data: bytes) -> None:
        self._out.file.write(data)
        self.bytes_written += len(data)

    def close(self) -> None:
        """End the file (``{"type": "end"}``) and close it."""
        self.json({"type": "end"})
        with self._lock:
            if self._closed:
                return
            self._flush()
            self._closed = True
            self._out.commit()


class SessionReader:
    """Reads a session recording: :attr:`header`, then :meth:`records` block by block (bounded memory).

    A file that is not a session, or whose header is damaged, raises a
    :class:`~tracker.recording.RecordingError` naming it. A block cut off or
    damaged ends the records; :attr:`stopped` then says where, in words, and
    :attr:`ended` stays False (as for a file cut off after its last block).
    """

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        self.stopped: str | None = None
        self.ended = False
        with open_input(path, "session recording", limit=MAX_SESSION_BYTES) as f:
            self.header = read_header(f, self.path)

    def records(self) -> Iterator[Record]:
        """Every record of every complete block, in order."""
        with open_input(self.path, "session recording", limit=MAX_SESSION_BYTES) as f:
            read_header(f, self.path)
            number = 0
            while (payload := self._block(f, number)) is not None:
                number += 1
                records, whole = self._parse(payload, number)
                yield from records
                if not whole:
                    self.stopped = f"block {number} holds records this version cannot read: stopped there"
                    return

    def _block(self, f: IO[bytes], number: int) -> bytes | None:
        """The next block's records, or None at the end or where the file is cut off or damaged."""
        at = f.tell()
        head = f.read(BLOCK_HEAD.size)
        if not head:
            if not self.ended:
                self.stopped = f"cut off after block {number} (byte {at}): it has no end record"
            return None
        if len(head) < BLOCK_HEAD.size:
            return self._stop(number, at, "cut off")
        marker, n, crc = BLOCK_HEAD.unpack(head)
        if marker != BLOCK or n > MAX_BLOCK_BYTES:
            return self._stop(number, at, "damaged")
        payload = f.read(n)
        if len(payload) < n:
            return self._stop(number, at, "cut off")
        if zlib.crc32(payload) != crc:
            return self._stop(number, at, "damaged (CRC)")
        try:
            return zlib.decompressobj().decompress(payload, MAX_BLOCK_BYTES)
        except zlib.error:
            return self._stop(number, at, "damaged (not zlib)")

    def _stop(self, number: int, at: int, how: str) -> None:
        self.stopped = f"block {number + 1} at byte {at} is {how}: stopped after the {number} complete before it"
        return None

    def _parse(self, payload: bytes, number: int) -> tuple[list[Record], bool]:
        """The records of one block, and whether all of it parsed (one that passed its CRC but does
        not parse was written by another version)."""
        out: list[Record] = []
        at = 0
        while at < len(payload):
            kind = payload[at:at + 1]
            if kind == b"J" and at + JSON_HEAD.size <= len(payload):
                _, n = JSON_HEAD.unpack_from(payload, at)
                start, at = at + JSON_HEAD.size, at + JSON_HEAD.size + n
                record = _json_record(payload[start:at]) if at <= len(payload) else None
                if record is None:
                    return out, False
                self.ended = self.ended or record.get("type") == "end"
                out.append(record)
            elif kind == b"B" and at + BINARY_HEAD.size <= len(payload):
                _, channel, t, n = BINARY_HEAD.unpack_from(payload, at)
                start, at = at + BINARY_HEAD.size, at + BINARY_HEAD.size + n
                if at > len(payload):
                    return out, False
                out.append(BinaryRecord(channel, t, payload[start:at]))
            else:
                return out, False
        return out, True


def _json_record(body: bytes) -> dict | None:
    try:
        record = json.loads(body)
    except ValueError:
        return None
    return record if isinstance(record, dict) and isinstance(record.get("type"), str) else None


def is_session(f: IO[bytes]) -> bool:
    """Whether an open file starts as a session recording (the file is left where it was)."""
    at = f.tell()
    start = f.read(len(MAGIC))
    f.seek(at)
    return start == MAGIC


def read_header(f: IO[bytes], path: Path) -> dict:
    """The header of an open session file, checked; the file is left at the first block."""
    start = f.read(len(MAGIC))
    if start != MAGIC:
        if start.startswith(MAGIC[:9]):
            raise RecordingError(f"{path} is a session recording of another version "
                                 f"({start.strip().decode('ascii', 'replace')}); "
                                 f"this EnergyBall reads {MAGIC.strip().decode()}")
        raise RecordingError(f"{path} is not an EnergyBall session recording (it does not start with "
                             f"{MAGIC.strip().decode()})")
    header = read_header_line(f, path, "session", MAX_HEADER_BYTES)
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise RecordingError(f"{path}: the session's header is damaged: it does not say \"format\": \"{FORMAT}\"")
    if header.get("version") != VERSION:
        raise RecordingError(f"{path} is a session recording of version {header.get('version')!r}; "
                             f"this EnergyBall reads version {VERSION}")
    return header


def wire_chunks(reader: SessionReader) -> Iterator[bytes]:
    """The board's bytes of a session, as they arrived (channel :data:`WIRE`)."""
    for record in reader.records():
        if isinstance(record, BinaryRecord) and record.channel == WIRE:
            yield record.data
