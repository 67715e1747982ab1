"""Record and replay: raw byte streams (.bin) and decoded samples (.csv).

A ``.bin`` recording is the board's byte stream exactly as it arrived, after a
short header::

    EBRAW1\\n
    {"created": ..., "port": ..., "legacy_text": false, "hello": {...}}\\n
    <bytes>

A headerless file (say, ``cat /dev/ttyACM0 > capture.bin``) is read as bytes
too. A ``.csv`` recording has ``#`` comment lines (format, the board's hello
as JSON) and then one row per sample in SI units. Both replay through the
same decoder the live link uses: a CSV's samples are encoded back into
frames first, so a recording exercises the whole input path.
"""

from __future__ import annotations

import csv
import io
import json
import math
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Iterator

from . import protocol as P
from .atomic import AtomicFile

MAGIC = b"EBRAW1\n"
CSV_FORMAT = "# energyball samples v1"
RAW_COLUMNS = ["t_s", "t_us", "seq", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z",
               "mag_x", "mag_y", "mag_z", "flex_adc", "acc_fs_g", "gyr_fs_dps", "host_t"]
FUSED_COLUMNS = ["t_s", "t_us", "seq", "qw", "qx", "qy", "qz", "flex_deg", "host_t"]
CHUNK = 4096

Sample = P.RawSample | P.FusedSample


class RecordingError(Exception):
    """A recording that cannot be read, worded for the user."""


# ----------------------------------------------------------------- writing


class RawRecorder:
    """Writes a ``.bin`` recording atomically (it appears complete, or not at all).

    Bytes may arrive (from a link's reader thread) before the header is known:
    they are held until :meth:`begin` writes the header, so nothing is lost
    between opening the link and starting the file.
    """

    def __init__(self, path: str | Path) -> None:
        self._out = AtomicFile(path, "wb")
        self._pending = bytearray()
        self._begun = False
        self._lock = threading.Lock()
        self.bytes = 0

    def begin(self, header: dict, prefix: bytes = b"") -> None:
        """Write the header, then ``prefix`` and whatever arrived so far."""
        with self._lock:
            self._out.file.write(MAGIC + json.dumps(header).encode() + b"\n" + prefix + self._pending)
            self.bytes += len(prefix) + len(self._pending)
            self._pending.clear()
            self._begun = True

    def write(self, chunk: bytes) -> None:
        with self._lock:
            if not self._begun:
                self._pending += chunk
                return
            self._out.file.write(chunk)
            self.bytes += len(chunk)

    def close(self) -> None:
        if not self._begun:
            self.begin({})
        self._out.commit()


class CsvRecorder:
    """Writes decoded samples to a ``.csv`` recording atomically."""

    def __init__(self, path: str | Path, hello: P.Hello | None) -> None:
        self._out = AtomicFile(path, "w", newline="")
        self._out.file.write(f"{CSV_FORMAT}\n# hello: {json.dumps(hello.to_json() if hello else None)}\n")
        self._writer = csv.writer(self._out.file)
        self._columns: list[str] | None = None
        self.rows = 0

    def write(self, s: Sample) -> None:
        columns = RAW_COLUMNS if isinstance(s, P.RawSample) else FUSED_COLUMNS
        if self._columns is None:
            self._columns = columns
            self._writer.writerow(columns)
        elif columns is not self._columns:
            return  # the board changed mode mid-recording; one kind per file
        self._writer.writerow(_row(s))
        self.rows += 1

    def close(self) -> None:
        if self._columns is None:
            self._writer.writerow(RAW_COLUMNS)
        self._out.commit()


def _cell(v: float | int | None) -> str:
    return "" if v is None else repr(v)


def _row(s: Sample) -> list[str]:
    if isinstance(s, P.RawSample):
        mag = s.mag or (None, None, None)
        return [_cell(v) for v in (s.t, s.t_us, s.seq, *s.acc, *s.gyr, *mag, s.flex_adc,
                                   s.acc_fs_g, s.gyr_fs_dps, s.host_t)]
    return [_cell(v) for v in (s.t, s.t_us, s.seq, *s.q, s.flex_deg, s.host_t)]


# ----------------------------------------------------------------- reading


@dataclass
class RawRecording:
    """A ``.bin`` file: its header (empty when headerless) and the byte stream."""

    header: dict
    data: bytes


def _read_bytes(path: str | Path) -> bytes:
    try:
        return Path(path).read_bytes()
    except FileNotFoundError:
        raise RecordingError(f"no such file: {path}") from None
    except IsADirectoryError:
        raise RecordingError(f"{path} is a directory, not a recording") from None
    except OSError as e:
        raise RecordingError(f"cannot read {path}: {e.strerror or e}") from None


def read_raw(path: str | Path) -> RawRecording:
    """Read a ``.bin`` recording (with or without our header)."""
    data = _read_bytes(path)
    if not data.startswith(MAGIC):
        return RawRecording({}, data)
    end = data.find(b"\n", len(MAGIC))
    try:
        header = json.loads(data[len(MAGIC):end]) if end > 0 else None
    except (ValueError, UnicodeDecodeError):
        header = None
    if not isinstance(header, dict):
        raise RecordingError(f"{path}: the recording's header is damaged")
    return RawRecording(header, data[end + 1:])


def decoder_for(header: dict) -> P.Decoder:
    """The decoder that reads a stream recorded with this header."""
    if header.get("legacy_text"):
        return P.TextDecoder(order=header.get("text_order", "wxyz"))
    return P.FrameDecoder()


def read_csv(path: str | Path) -> tuple[P.Hello | None, list[Sample]]:
    """Read a ``.csv`` recording; rows that do not parse are a clear error naming the line."""
    text = _read_bytes(path).decode("utf-8", errors="replace")
    lines = text.splitlines()
    if not lines or lines[0].strip() != CSV_FORMAT:
        raise RecordingError(f"{path} is not an EnergyBall CSV recording "
                             f"(its first line should be '{CSV_FORMAT}')")
    hello = _csv_hello(path, lines)
    body = [ln for ln in lines if not ln.startswith("#")]
    rows = list(csv.reader(io.StringIO("\n".join(body))))
    if not rows or rows[0] not in (RAW_COLUMNS, FUSED_COLUMNS):
        raise RecordingError(f"{path}: unexpected columns; expected {','.join(RAW_COLUMNS)} "
                             f"or {','.join(FUSED_COLUMNS)}")
    parse = _raw_sample if rows[0] == RAW_COLUMNS else _fused_sample
    samples = []
    for number, row in enumerate(rows[1:], start=len(lines) - len(body) + 2):
        try:
            samples.append(parse(row))
        except (ValueError, IndexError, TypeError):
            raise RecordingError(f"{path}: line {number} is not a valid sample: {','.join(row)}") \
                from None
    return hello, samples


def _csv_hello(path: str | Path, lines: list[str]) -> P.Hello | None:
    for ln in lines[1:]:
        if ln.startswith("# hello: "):
            try:
                d = json.loads(ln[len("# hello: "):])
                return P.Hello.from_json(d) if d else None
            except (ValueError, KeyError, TypeError):
                raise RecordingError(f"{path}: the hello line is damaged") from None
    return None


def _float(cell: str) -> float:
    v = float(cell)
    if not math.isfinite(v):
        raise ValueError("not finite")
    return v


def _optional(cell: str) -> float | None:
    return None if cell == "" else _float(cell)


def _raw_sample(row: list[str]) -> P.RawSample:
    acc_fs, gyr_fs = int(row[13]), int(row[14])
    if acc_fs not in P.ACC_FS_G or gyr_fs not in P.GYR_FS_DPS:
        raise ValueError("bad full scale")
    acc_lsb = acc_fs * P.STANDARD_GRAVITY / 32768.0
    gyr_lsb = math.radians(gyr_fs) / 32768.0
    mag = None if row[9] == "" else tuple(round(_float(c) / P.MAG_UT_PER_COUNT) for c in row[9:12])
    return P.RawSample(
        _float(row[0]), int(row[1]), int(row[2]),
        tuple(round(_float(c) / acc_lsb) for c in row[3:6]),
        tuple(round(_float(c) / gyr_lsb) for c in row[6:9]),
        mag, int(row[12]), acc_fs, gyr_fs, False, _optional(row[15]))


def _fused_sample(row: list[str]) -> P.FusedSample:
    t_us = None if row[1] == "" else int(row[1])
    return P.FusedSample(_float(row[0]), t_us, int(row[2]),
                         tuple(_float(c) for c in row[3:7]), _float(row[7]), _optional(row[8]))


# ----------------------------------------------------------------- replay


@dataclass
class Replay:
    """Samples of a recording passed through a decoder, optionally at recorded speed.

    Iterate it for samples; afterwards ``stats`` holds the decoder's counters
    and ``hello`` the board's hello (from the stream or the file's header).
    """

    path: Path
    realtime: bool = False
    speed: float = 1.0
    stats: P.DecoderStats = field(default_factory=P.DecoderStats)
    hello: P.Hello | None = None

    def __iter__(self) -> Iterator[Sample]:
        stream, decoder = self._source()
        self.stats = decoder.stats
        clock = _Pacer(self.speed) if self.realtime else None
        for chunk, row in stream:
            for p in decoder.feed(chunk):
                if isinstance(p, P.Hello):
                    self.hello = p
                if not isinstance(p, (P.RawSample, P.FusedSample)):
                    continue
                if row is not None:  # clock fields as the live decoder saw them, host time too
                    p = p._replace(t=row.t, t_us=row.t_us, host_t=row.host_t)
                if clock:
                    clock.wait_for(_sample_time(p))
                yield p

    def _source(self) -> tuple[Iterable[tuple[bytes, Sample | None]], P.Decoder]:
        if self.path.suffix.lower() == ".csv":
            hello, samples = read_csv(self.path)
            self.hello = hello
            return ((P.encode(s), s) for s in samples), P.FrameDecoder()
        rec = read_raw(self.path)
        if rec.header.get("hello"):
            self.hello = P.Hello.from_json(rec.header["hello"])
        data = rec.data
        return (((data[i:i + CHUNK], None) for i in range(0, len(data), CHUNK)),
                decoder_for(rec.header))


@dataclass
class _Pacer:
    """Sleeps so that samples come out at the pace they were recorded (times ``speed``)."""

    speed: float
    _start: tuple[float, float] | None = None  # (wall, sample time) of the first sample

    def wait_for(self, t: float) -> None:
        if self._start is None:
            self._start = (time.monotonic(), t)
        wall0, t0 = self._start
        delay = (t - t0) / self.speed - (time.monotonic() - wall0)
        if delay > 0:
            time.sleep(delay)


def _sample_time(s: Sample) -> float:
    """Device time when the board stamped it, else the host's receive time."""
    if s.t_us is not None:
        return s.t
    return s.host_t if s.host_t is not None else s.t


def decode_file(path: str | Path) -> tuple[list[Sample], Replay]:
    """Every sample of a recording, as fast as possible; raises if it holds none."""
    replay = Replay(Path(path))
    samples = list(replay)
    if not samples:
        raise RecordingError(f"{path} is not an EnergyBall recording: no samples found in it "
                             f"({replay.stats.bytes_skipped} bytes of something else)")
    return samples, replay
