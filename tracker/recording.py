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
frames first, so a recording exercises the whole input path. A game's
session recording (:mod:`tracker.session_recording`) is read for the
board's bytes in it, as they arrived.

A recording may span a restart of the board (a pulled and replugged cable, a
RESET): its sequence numbers and clock start over (PROTOCOL.md sec. 7.1). It
is read as *runs*, one per power-up, each with its own counts
(:class:`Run`); within a run device time increases. The CSV says which run a
row belongs to in its ``run`` column (CSVs written before that column are one
run); ``host_t``, the host's receive time, increases across runs.

Everything a user hands us is checked where it is read: only regular files,
at most :data:`MAX_RECORDING_BYTES`, headers through :func:`tracker.userjson.parse_json`
and :meth:`tracker.protocol.Hello.from_json`, every CSV cell against what the
wire can carry; a failure is one :class:`RecordingError` naming the file and
the line or key.
"""

from __future__ import annotations

import json
import math
import os
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Callable, Iterable, Iterator

from . import protocol as P
from .atomic import AtomicFile
from .input_files import MAX_RECORDING_BYTES, RecordingError, open_input, read_header_line
from .session_recording import SessionReader, is_session, wire_chunks
from .userjson import JSONInputError, parse_json

MAGIC = b"EBRAW1\n"
CSV_FORMAT = "# energyball samples v1"
RAW_COLUMNS = ["t_s", "t_us", "seq", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z",
               "mag_x", "mag_y", "mag_z", "flex_adc", "acc_fs_g", "gyr_fs_dps", "host_t", "die_c", "run"]
_RAW_BEFORE_TEMP = [c for c in RAW_COLUMNS if c != "die_c"]  # files written before the TEMP frame
FUSED_COLUMNS = ["t_s", "t_us", "seq", "qw", "qx", "qy", "qz", "flex_deg", "host_t", "run"]
CHUNK = 4096
MAX_HEADER_BYTES = 64 * 2**10  # ours are about 400 bytes
MAX_TIME_S = 1e9  # about 32 years: no device clock (unwrapped) or host clock in a recording comes near
UNIT_NORM_TOLERANCE = 0.05  # a quaternion's norm may be off by this much (as the text decoder allows)

Sample = P.RawSample | P.FusedSample


def _brief(text: str, limit: int = 60) -> str:
    """A piece of a user's file, shortened and on one line, for a message."""
    shown = text if len(text) <= limit else text[:limit - 3] + "..."
    return shown.encode("unicode_escape").decode("ascii")


# ----------------------------------------------------------------- runs


@dataclass
class Run:
    """One stretch of a recording from a single power-up of the board.

    ``start`` is the index of its first sample in the recording; ``dropped``
    counts sequence gaps within it only (PROTOCOL.md sec. 9.2), never across
    a restart; ``first_t``/``last_t`` are device time (or host time for the
    paper's text stream, which has no device clock).
    """

    start: int
    first_t: float
    last_t: float
    first_seq: int
    samples: int = 1
    dropped: int = 0

    @property
    def duration_s(self) -> float:
        return self.last_t - self.first_t

    def to_json(self) -> dict:
        return {"samples": self.samples, "duration_s": self.duration_s, "dropped": self.dropped,
                "t_start": self.first_t, "t_end": self.last_t, "first_seq": self.first_seq}


@dataclass
class RunTracker:
    """Splits a sequence of samples into :class:`Run` s at each restart of the board.

    Feed it every sample in order (:meth:`add`) and every HELLO (:meth:`hello`):
    a restart is what :func:`tracker.protocol.board_restarted` says it is, unless
    the caller knows better (a CSV's ``run`` column).
    """

    runs: list[Run] = field(default_factory=list)
    _last: Sample | None = None
    _count: int = 0  # samples so far
    _hello_since: bool = False

    def hello(self) -> None:
        """A HELLO arrived (a restart's or an answer to IDENTIFY)."""
        self._hello_since = True

    def add(self, s: Sample, restarted: bool | None = None) -> bool:
        """Count ``s`` in; True when it starts a new run."""
        last = self._last
        if last is None:
            new = True
        elif restarted is not None:
            new = restarted
        else:
            new = (s.t_us is not None and last.t_us is not None
                   and P.board_restarted(last.t_us, last.seq, s.t_us, s.seq, self._hello_since))
        if new or last is None:
            self.runs.append(Run(self._count, s.t, s.t, s.seq))
        else:
            run = self.runs[-1]
            run.samples += 1
            run.last_t = s.t
            run.dropped += P.samples_missing(last.seq, s.seq)
        self._last, self._hello_since = s, False
        self._count += 1
        return new


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
    """Writes decoded samples to a ``.csv`` recording atomically.

    The ``run`` column numbers the board's power-ups from 0 (:class:`RunTracker`):
    live samples come from one decoder per connection, so device time starts
    again after a reconnect, and the column says so.
    """

    def __init__(self, path: str | Path, hello: P.Hello | None) -> None:
        self._out = AtomicFile(path, "w", newline="")
        self._out.file.write(f"{CSV_FORMAT}\n# hello: {json.dumps(hello.to_json() if hello else None)}\n")
        self._columns: list[str] | None = None
        self._runs = RunTracker()
        self.rows = 0

    def write(self, s: Sample) -> None:
        columns = RAW_COLUMNS if isinstance(s, P.RawSample) else FUSED_COLUMNS
        if self._columns is None:
            self._columns = columns
            self._line(columns)
        elif columns is not self._columns:
            return  # the board changed mode mid-recording; one kind per file
        self._runs.add(s)
        self._line([*_row(s), str(len(self._runs.runs) - 1)])
        self.rows += 1

    def _line(self, cells: list[str]) -> None:
        self._out.file.write(",".join(cells) + "\r\n")

    def close(self) -> None:
        if self._columns is None:
            self._line(RAW_COLUMNS)
        self._out.commit()


def _cell(v: float | int | None) -> str:
    return "" if v is None else repr(v)


def _row(s: Sample) -> list[str]:
    if isinstance(s, P.RawSample):
        mag = s.mag or (None, None, None)
        return [_cell(v) for v in (s.t, s.t_us, s.seq, *s.acc, *s.gyr, *mag, s.flex_adc,
                                   s.acc_fs_g, s.gyr_fs_dps, s.host_t, s.die_c)]
    return [_cell(v) for v in (s.t, s.t_us, s.seq, *s.q, s.flex_deg, s.host_t)]


# ----------------------------------------------------------------- reading .bin


@dataclass
class RawRecording:
    """A ``.bin`` file: its header (empty when headerless), the board's hello from it, the byte stream."""

    header: dict
    data: bytes
    hello: P.Hello | None = None


def _read_header(f: IO[bytes], path: str | os.PathLike) -> tuple[dict, P.Hello | None]:
    """The header of an open ``.bin`` file, checked; the file is left at the first stream byte."""
    if f.read(len(MAGIC)) != MAGIC:
        f.seek(0)
        return {}, None
    header = read_header_line(f, path, "recording", MAX_HEADER_BYTES)
    if not isinstance(header, dict):
        raise RecordingError(f"{path}: the recording's header is damaged: expected a JSON object, "
                             f"not {_brief(json.dumps(header))}")
    if not isinstance(header.get("legacy_text", False), bool):
        raise RecordingError(f"{path}: the recording's header is damaged: 'legacy_text' must be true or false")
    if header.get("text_order", "wxyz") not in ("wxyz", "xyzw"):
        raise RecordingError(f"{path}: the recording's header is damaged: 'text_order' must be \"wxyz\" or \"xyzw\"")
    hello = None
    if header.get("hello") is not None:
        try:
            hello = P.Hello.from_json(header["hello"])
        except ValueError as e:
            raise RecordingError(f"{path}: the recording's header is damaged: its hello: {e}") from None
    return header, hello


def read_raw(path: str | Path) -> RawRecording:
    """Read a ``.bin`` recording (with or without our header)."""
    with open_input(path) as f:
        header, hello = _read_header(f, path)
        return RawRecording(header, f.read(MAX_RECORDING_BYTES), hello)


def decoder_for(header: dict) -> P.Decoder:
    """The decoder that reads a stream recorded with this (checked) header."""
    if header.get("legacy_text"):
        return P.TextDecoder(order=header.get("text_order", "wxyz"))
    return P.FrameDecoder()


def _chunks(f: IO[bytes]) -> Iterator[bytes]:
    while chunk := f.read(CHUNK):
        yield chunk


# ----------------------------------------------------------------- reading .csv


@dataclass
class CsvRow:
    """One sample of a CSV recording, with the line it was on and its run."""

    line: int
    sample: Sample
    run: int


def read_csv(path: str | Path) -> tuple[P.Hello | None, list[Sample]]:
    """Read a ``.csv`` recording; anything that does not parse is a clear error naming the line."""
    with open_input(path) as f:
        hello, rows = _csv_rows(f, path)
        return hello, [r.sample for r in rows]


def _lines(f: IO[bytes], path: str | os.PathLike) -> Iterator[tuple[int, str]]:
    """(number, text) of each line of a UTF-8 file, line ends removed."""
    for number, line in enumerate(f, start=1):
        try:
            yield number, line.decode("utf-8").rstrip("\r\n")
        except UnicodeDecodeError:
            raise RecordingError(f"{path}: line {number} is not UTF-8 text") from None


def _csv_rows(f: IO[bytes], path: str | os.PathLike) -> tuple[P.Hello | None, Iterator[CsvRow]]:
    """The hello and (lazily) the rows of an open CSV recording.

    The comment lines and the column line are read at once; rows as iterated.
    Rows must keep device time increasing within a run and runs in order.
    """
    lines = _lines(f, path)
    first = next(lines, (1, ""))[1]
    if first.strip() != CSV_FORMAT:
        raise RecordingError(f"{path} is not an EnergyBall CSV recording "
                             f"(its first line should be '{CSV_FORMAT}')")
    hello: P.Hello | None = None
    for number, text in lines:
        if text.startswith("# hello: "):
            hello = _csv_hello(path, number, text[len("# hello: "):])
        elif not text.startswith("#"):
            columns = text.split(",")
            break
    else:
        columns = []
    layouts = (RAW_COLUMNS, _RAW_BEFORE_TEMP, FUSED_COLUMNS)
    with_run = columns in layouts
    if not with_run and columns not in [c[:-1] for c in layouts]:
        raise RecordingError(f"{path}: unexpected columns; expected {','.join(RAW_COLUMNS)} "
                             f"or {','.join(FUSED_COLUMNS)}")
    parse = (_raw_sample if "die_c" in columns else _raw_sample_before_temp) if columns[3] == "acc_x" \
        else _fused_sample
    return hello, _checked_rows(path, lines, parse, len(columns), with_run)


def _checked_rows(path: str | os.PathLike, lines: Iterator[tuple[int, str]],
                  parse: Callable[[list[str]], Sample], width: int, with_run: bool) -> Iterator[CsvRow]:
    last: CsvRow | None = None
    for number, text in lines:
        if text.startswith("#"):
            continue
        cells = text.split(",")
        try:
            if len(cells) != width:
                raise ValueError(f"{len(cells)} cells, expected {width}")
            row = CsvRow(number, parse(cells), _run(cells[-1]) if with_run else 0)
            _check_order(last, row)
        except ValueError as e:
            raise RecordingError(f"{path}: line {number} is not a valid sample: {e} "
                                 f"(the line: {_brief(text)})") from None
        last = row
        yield row


def _run(cell: str) -> int:
    return _int(cell, "run", range(1 << 31))


def _check_order(last: CsvRow | None, row: CsvRow) -> None:
    """Runs count up one at a time, and device time increases within a run."""
    if last is None:
        return
    if row.run not in (last.run, last.run + 1):
        raise ValueError(f"run {row.run} follows run {last.run}; runs count up by one")
    if row.run != last.run:
        return
    t, before = row.sample.t, last.sample.t
    if t < before or (t == before and row.sample.t_us is not None):
        # Without a device clock (the paper's text stream) t_s is the host's time of
        # arrival, shared by the lines that arrived together.
        raise ValueError(f"t_s {t!r} is not after {before!r} on line {last.line} "
                         "(time must increase within a run)")


def _csv_hello(path: str | os.PathLike, number: int, text: str) -> P.Hello | None:
    try:
        d = parse_json(text, f"{path}: line {number}, the board's hello")
        return None if d is None else P.Hello.from_json(d)
    except JSONInputError as e:
        raise RecordingError(f"{e}: the hello line is damaged") from None
    except ValueError as e:
        raise RecordingError(f"{path}: line {number}: the hello line is damaged: {e}") from None


def _float(cell: str, name: str, low: float = -math.inf, high: float = math.inf) -> float:
    """A finite number in [low, high] (ValueError naming the column otherwise)."""
    try:
        v = float(cell)
    except ValueError:
        raise ValueError(f"{name} {_brief(cell, 20)!s} is not a number") from None
    if not math.isfinite(v):
        raise ValueError(f"{name} {cell} is not a finite number")
    if not low <= v <= high:
        raise ValueError(f"{name} {cell} is outside {low:g}..{high:g}")
    return v


def _int(cell: str, name: str, allowed: range | tuple[int, ...]) -> int:
    """An integer among ``allowed`` (ValueError naming the column otherwise)."""
    try:
        v = int(cell)
    except ValueError:
        raise ValueError(f"{name} {_brief(cell, 20)} is not a whole number") from None
    if v not in allowed:
        shown = f"{allowed.start}..{allowed.stop - 1}" if isinstance(allowed, range) else " or ".join(map(str, allowed))
        raise ValueError(f"{name} {v} is not {shown}")
    return v


def _time(cell: str, name: str) -> float:
    return _float(cell, name, 0.0, MAX_TIME_S)


def _optional_time(cell: str, name: str) -> float | None:
    return None if cell == "" else _time(cell, name)


def _counts(cells: list[str], names: list[str], lsb: float, what: str) -> tuple[int, int, int]:
    """Three SI readings back to the sensor's signed 16-bit counts, which must fit."""
    out = []
    for cell, name in zip(cells, names):
        v = _float(cell, name)
        k = round(v / lsb) if abs(v) <= 32769 * lsb else 1 << 16
        if not -32768 <= k <= 32767:
            raise ValueError(f"{name} {cell} is outside the {what} range (+-{32768 * lsb:.4g})")
        out.append(k)
    x, y, z = out
    return x, y, z


_U32 = range(1 << 32)
_U16 = range(1 << 16)


def _raw_sample(row: list[str]) -> P.RawSample:
    """A row of :data:`RAW_COLUMNS`: the die's temperature back to the TEMP frame's counts (exactly:
    a count is 0.003 degC, and the cell holds the degrees to 17 digits)."""
    die = None if row[16] == "" else _float(row[16], "die_c", P.temp_c(-32768), P.temp_c(32767))
    return _raw_sample_before_temp(row)._replace(temp_counts=None if die is None else P.temp_counts(die))


def _raw_sample_before_temp(row: list[str]) -> P.RawSample:
    acc_fs = _int(row[13], "acc_fs_g", P.ACC_FS_G)
    gyr_fs = _int(row[14], "gyr_fs_dps", P.GYR_FS_DPS)
    mag_cells = row[9:12]
    if mag_cells == ["", "", ""]:
        mag = None
    else:
        mag = _counts(mag_cells, RAW_COLUMNS[9:12], P.MAG_UT_PER_COUNT, "magnetometer's")
    return P.RawSample(
        _time(row[0], "t_s"), _int(row[1], "t_us", _U32), _int(row[2], "seq", _U16),
        _counts(row[3:6], RAW_COLUMNS[3:6], acc_fs * P.STANDARD_GRAVITY / 32768.0,
                f"accelerometer's +-{acc_fs} g"),
        _counts(row[6:9], RAW_COLUMNS[6:9], math.radians(gyr_fs) / 32768.0,
                f"gyroscope's +-{gyr_fs} deg/s"),
        mag, _int(row[12], "flex_adc", range(P.FLEX_ADC_MASK + 1)), acc_fs, gyr_fs, False,
        _optional_time(row[15], "host_t"))


def _fused_sample(row: list[str]) -> P.FusedSample:
    t_us = None if row[1] == "" else _int(row[1], "t_us", _U32)
    q = tuple(_float(c, n, -2.0, 2.0) for c, n in zip(row[3:7], FUSED_COLUMNS[3:7]))
    norm = math.sqrt(sum(c * c for c in q))
    if abs(norm - 1.0) > UNIT_NORM_TOLERANCE:
        raise ValueError(f"the quaternion's norm is {norm:.3g}, not 1")
    w, x, y, z = q
    return P.FusedSample(_time(row[0], "t_s"), t_us, _int(row[2], "seq", _U16), (w, x, y, z),
                         _float(row[7], "flex_deg", -327.68, 327.67), _optional_time(row[8], "host_t"))


# ----------------------------------------------------------------- replay


@dataclass
class Replay:
    """Samples of a recording passed through a decoder, optionally at recorded speed.

    Iterate it for samples; afterwards ``stats`` holds the decoder's counters,
    ``hello`` the board's hello (from the stream or the file's header) and
    ``runs`` the recording's runs (one per power-up of the board).
    """

    path: Path
    realtime: bool = False
    speed: float = 1.0
    stats: P.DecoderStats = field(default_factory=P.DecoderStats)
    hello: P.Hello | None = None
    runs: list[Run] = field(default_factory=list)
    session: SessionReader | None = None  # a session recording's reader (its ``stopped`` says if it was cut off)

    def __iter__(self) -> Iterator[Sample]:
        with open_input(self.path) as f:
            stream, decoder = self._source(f)
            self.stats = decoder.stats
            tracker = RunTracker()
            self.runs = tracker.runs
            clock = _Pacer(self.speed) if self.realtime else None
            for chunk, row in stream:
                for p in decoder.feed(chunk):
                    if isinstance(p, P.Hello):
                        self.hello = p
                        tracker.hello()
                    if not isinstance(p, (P.RawSample, P.FusedSample)):
                        continue
                    if row is not None:  # clock fields as the live decoder saw them, host time too
                        p = p._replace(t=row.sample.t, t_us=row.sample.t_us, host_t=row.sample.host_t)
                    new_run = tracker.add(p, None if row is None else len(tracker.runs) - 1 != row.run)
                    if clock:
                        clock.wait_for(_sample_time(p), new_run)
                    yield p

    def _source(self, f: IO[bytes]) -> tuple[Iterable[tuple[bytes, CsvRow | None]], P.Decoder]:
        if self.path.suffix.lower() == ".csv":
            for _ in _csv_rows(f, self.path)[1]:
                pass  # every row is checked before the first comes out
            f.seek(0)
            self.hello, rows = _csv_rows(f, self.path)
            return ((_frames(r.sample), r) for r in rows), P.FrameDecoder()
        if is_session(f):  # a game's session recording: the board's bytes as they arrived
            session = SessionReader(self.path)
            self.session = session
            return ((chunk, None) for chunk in wire_chunks(session)), decoder_for(session.header.get("wire", {}))
        header, self.hello = _read_header(f, self.path)
        return ((chunk, None) for chunk in _chunks(f)), decoder_for(header)


def _frames(s: Sample) -> bytes:
    """A CSV row's sample as the board sent it: a raw one with a temperature after its TEMP frame."""
    temp = s.temp_counts if isinstance(s, P.RawSample) else None
    return (b"" if temp is None else P.encode_temp(s.t_us or 0, temp)) + P.encode(s)


@dataclass
class _Pacer:
    """Sleeps so that samples come out at the pace they were recorded (times ``speed``).

    Each run starts the pace again: the time between runs is not known from
    the board's clock. Sleeps are at most a second each, so an absurd pace
    (a huge gap, a tiny speed) waits to be interrupted instead of overflowing.
    """

    speed: float
    _start: tuple[float, float] | None = None  # (wall, sample time) of the run's first sample

    def wait_for(self, t: float, new_run: bool = False) -> None:
        if self._start is None or new_run:
            self._start = (time.monotonic(), t)
        wall0, t0 = self._start
        due = wall0 + (t - t0) / self.speed
        while (delay := due - time.monotonic()) > 0:
            time.sleep(min(delay, 1.0))


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
        raise _no_samples(path, replay)
    return samples, replay


def _no_samples(path: str | Path, replay: Replay) -> RecordingError:
    return RecordingError(f"{path} is not an EnergyBall recording: no samples found in it "
                          f"({replay.stats.bytes_skipped} bytes of something else)")


# ----------------------------------------------------------------- summary


@dataclass
class Summary:
    """What ``armtracker decode`` reports about a recording."""

    path: str
    samples: int
    stats: P.DecoderStats
    hello: P.Hello | None
    runs: list[Run]

    @property
    def dropped(self) -> int:
        """Samples lost within runs (a restart of the board loses none: it starts counting again)."""
        return sum(r.dropped for r in self.runs)

    def to_json(self) -> dict:
        st = self.stats
        return {"packets": st.frames, "samples": self.samples, "crc_errors": st.crc_errors,
                "dropped": self.dropped, "bytes_skipped": st.bytes_skipped,
                "hello": self.hello.to_json() if self.hello else None,
                "duration_s": sum(r.duration_s for r in self.runs),
                "board_restarts": len(self.runs) - 1, "runs": [r.to_json() for r in self.runs]}

    def text(self) -> str:
        """The report for people: one line, and a line per run when the board restarted."""
        st, n = self.stats, len(self.runs)
        head = (f"{self.path}: {st.frames} packets, {self.samples} samples over "
                f"{sum(r.duration_s for r in self.runs):.2f} s, {self.dropped} dropped, "
                f"{st.crc_errors} CRC errors, {st.bytes_skipped} bytes skipped")
        if n == 1:
            return head
        lines = [f"{head}; the board restarted {n - 1} time{'s' if n > 2 else ''} "
                 f"(a reconnect or reset), so the recording is {n} runs:"]
        lines += [f"  run {i}: {r.samples} samples over {r.duration_s:.2f} s, {r.dropped} dropped"
                  for i, r in enumerate(self.runs)]
        return "\n".join(lines)


def summarize(path: str | Path) -> Summary:
    """Decode a recording and count what is in it, run by run, without keeping the samples."""
    replay = Replay(Path(path))
    samples = sum(1 for _ in replay)
    if not samples:
        raise _no_samples(path, replay)
    return Summary(os.fspath(path), samples, replay.stats, replay.hello, replay.runs)
