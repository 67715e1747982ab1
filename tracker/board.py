"""The virtual board: the firmware's behaviour in Python, on a pseudo-terminal.

It speaks the same protocol as ``firmware/`` (``firmware/PROTOCOL.md``): a
hello at power-up, raw or fused sample frames at the configured rate stamped
by a 32-bit microsecond clock, answers to every command. Programs open it like
a real board, through a pty whose path is a stable symlink (as udev's
``/dev/serial/by-id`` links are), so pulling and plugging the virtual cable
looks to the host exactly like a USB replug.

It honours the baud rate the host sets on the pty: at the wrong baud a real
UART produces garbage, and so does this board. Faults for tests: byte
corruption, dropped bytes, a stall, a disconnect.
"""

from __future__ import annotations

import errno
import math
import os
import random
import select
import tempfile
import termios
import threading
import time
import tty
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import protocol as P
from .motion import MotionSource, SensorReading

MPU9250_WHOAMI = 0x71
AK8963_WHOAMI = 0x48
FIRMWARE_VERSION = "1.0.0"
LEGACY_RATE_HZ = 20  # a 40-byte text line at 9600 baud leaves room for ~24 lines/s
CATCH_UP_S = 0.5  # the longest hiccup of the host process whose samples are still sent late, not lost
_BAUD_CONSTANTS = {getattr(termios, f"B{b}"): b for b in
                   (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400, 500000)}


@dataclass
class BoardSettings:
    """What the firmware is configured to do (defaults are the firmware's)."""

    rate_hz: int = 200
    mode: P.Mode = P.Mode.RAW
    acc_fs_g: int = 16
    gyr_fs_dps: int = 2000
    baud: int = P.DEFAULT_BAUD
    stream_at_boot: bool = True  # a plain serial monitor sees data without a handshake
    legacy_text: bool = False  # behave like the paper's sketch: text lines at 9600 baud
    clock_start_us: int = 0  # set near 2**32 to exercise the wrap-around
    errors: P.BoardError = P.BoardError.NONE
    keep_sent: int = 0  # remember this many sent samples, for tests

    def __post_init__(self) -> None:
        if self.legacy_text:
            self.baud = P.LEGACY_BAUD
            self.rate_hz = LEGACY_RATE_HZ


@dataclass(frozen=True)
class Faults:
    """Faults injected into the byte stream the board sends (seeded).

    ``stalls``: (at_s, seconds) pairs, board time; the headless match freezes
    the board's loop for each (samples are skipped, not queued). The
    pty board's tests call :meth:`VirtualBoard.stall` instead.
    """

    corrupt_rate: float = 0.0  # probability that a byte gets one random bit flipped
    drop_rate: float = 0.0  # probability that a byte is lost
    silent: bool = False  # the board sends nothing at all (a dead or wrong device)
    seed: int = 0
    stalls: tuple[tuple[float, float], ...] = ()

    @classmethod
    def parse(cls, spec: str, seed: int = 0) -> "Faults":
        """Faults from text like ``corrupt=0.01,drop=0.002,stall=0.5@20`` (ValueError saying what is wrong).

        corrupt, drop: per-byte probabilities in [0, 1]; stall=S@T: the board
        freezes for S seconds at T seconds (may be given more than once).
        """
        corrupt, drop, stalls = 0.0, 0.0, []
        given: set[str] = set()
        for item in filter(None, (part.strip() for part in spec.split(","))):
            name, _, value = item.partition("=")
            if name in given and name != "stall":
                raise ValueError(f"fault {name!r} is given twice in {spec!r}")
            given.add(name)
            try:
                if name in ("corrupt", "drop"):
                    rate = float(value)
                    if not 0.0 <= rate <= 1.0:
                        raise ValueError
                    corrupt, drop = (rate, drop) if name == "corrupt" else (corrupt, rate)
                elif name == "stall":
                    seconds, at = (float(v) for v in value.split("@"))
                    if not (math.isfinite(seconds) and math.isfinite(at) and seconds > 0 and at >= 0):
                        raise ValueError
                    stalls.append((at, seconds))
                else:
                    raise KeyError(name)
            except KeyError:
                raise ValueError(f"unknown fault {name!r} in {spec!r} (known: corrupt, drop, stall)") from None
            except ValueError:
                raise ValueError(f"bad fault {item!r}: use corrupt=P or drop=P with P in 0..1, "
                                 "or stall=SECONDS@AT_SECONDS") from None
        return cls(corrupt_rate=corrupt, drop_rate=drop, seed=seed, stalls=tuple(sorted(stalls)))

    def stalled(self, t: float) -> bool:
        """Whether the board's loop is frozen at board time ``t``."""
        return bool(self.stalls) and any(at <= t < at + seconds for at, seconds in self.stalls)


class FaultInjector:
    """Applies :class:`Faults`' byte corruption and loss to outgoing bytes, and counts them."""

    def __init__(self, faults: Faults) -> None:
        self.faults = faults
        self.bytes_corrupted = 0
        self.bytes_dropped = 0
        self._rng = random.Random(faults.seed)

    def apply(self, data: bytes) -> bytes:
        """``data`` as it arrives: each byte lost with ``drop_rate``, else a bit flipped with ``corrupt_rate``."""
        f = self.faults
        if not (f.corrupt_rate or f.drop_rate):
            return data
        out = bytearray()
        rng = self._rng
        for b in data:
            if rng.random() < f.drop_rate:
                self.bytes_dropped += 1
                continue
            if rng.random() < f.corrupt_rate:
                b ^= 1 << rng.randrange(8)
                self.bytes_corrupted += 1
            out.append(b)
        return bytes(out)

    def garble(self, data: bytes) -> bytes:
        """What a UART at the wrong baud makes of the bytes: noise of about the same amount."""
        return bytes(self._rng.randrange(256) for _ in data)


@dataclass
class BoardCounters:
    """What the board did, for tests and the ``virtual`` command's report."""

    samples: int = 0
    frames_sent: int = 0
    bytes_sent: int = 0
    bytes_lost: int = 0  # host not reading: the pty buffer was full
    commands: int = 0
    plugs: int = 0


@dataclass
class _BoardState:
    """The firmware's variables; reset at power-up."""

    streaming: bool
    rate_hz: int
    mode: P.Mode
    seq: int = 0
    boot: float = 0.0  # monotonic time of power-up
    next_sample: int = 0  # index of the next sample since power-up
    raw_since_temp: int = 0  # RAW frames sent since the last TEMP frame; 0: none since streaming raw began
    temp: int | None = None  # the TEMP_OUT last sent


class VirtualBoard:
    """A software sensor board served on a pty; use as a context manager.

    ``link`` is the stable path programs open (a symlink to the current pty);
    by default one in a fresh temporary directory.
    """

    def __init__(self, motion: MotionSource | None = None, settings: BoardSettings | None = None,
                 faults: Faults | None = None, link: str | os.PathLike | None = None) -> None:
        self.settings = settings or BoardSettings()
        self.motion = motion or _default_motion(self.settings.rate_hz)
        self.faults = faults or Faults()
        self._tmpdir = None if link else tempfile.TemporaryDirectory(prefix="energyball-")
        self.link = Path(link) if link else Path(self._tmpdir.name) / "ttyVIRTUAL"
        self.counters = BoardCounters()
        self.sent: deque[P.RawSample | P.FusedSample] = deque(maxlen=self.settings.keep_sent or None)
        # (seq, time.monotonic() just after the bytes were written), for latency measurements
        self.sent_at: deque[tuple[int, float]] = deque(maxlen=self.settings.keep_sent or None)
        self._injector = FaultInjector(self.faults)
        self._lock = threading.RLock()
        self._fds: tuple[int, int] | None = None
        self._stall_until = 0.0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._decoder = P.FrameDecoder(accept_commands=True)
        self._state = self._power_up()

    # -------------------------------------------------------------- lifecycle

    def start(self) -> "VirtualBoard":
        """Plug the cable in and run the firmware loop in a thread."""
        self.plug_in()
        self._thread = threading.Thread(target=self._run, name="virtual-board", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop the firmware loop and pull the cable."""
        self._stop.set()
        if self._thread:
            self._thread.join(timeout=2)
        self.pull_cable()
        if self._tmpdir:
            self._tmpdir.cleanup()

    def __enter__(self) -> "VirtualBoard":
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    @property
    def port(self) -> str:
        """The path to open (the stable symlink)."""
        return str(self.link)

    # -------------------------------------------------------------- faults

    def pull_cable(self) -> None:
        """Unplug: the pty disappears, the host's reads fail, the link vanishes."""
        with self._lock:
            if self._fds is None:
                return
            ours = os.ttyname(self._fds[1])
            for fd in self._fds:
                os.close(fd)
            self._fds = None
            self._unlink_if_ours(ours)

    def _unlink_if_ours(self, tty_path: str) -> None:
        """Remove the link if it still points at our pty: a path someone else has
        since put there (another virtual board, a user's file) is left alone."""
        try:
            if os.readlink(self.link) == tty_path:
                self.link.unlink()
        except OSError:
            pass  # gone already, or not a symlink: not ours to remove

    def plug_in(self) -> None:
        """Plug in: a new pty appears behind the link and the board powers up."""
        with self._lock:
            if self._fds is not None:
                return
            master, slave = os.openpty()
            tty.setraw(slave)  # no echo or line editing before the host configures the port
            self._set_baud(slave, self.settings.baud)
            os.set_blocking(master, False)
            self._fds = (master, slave)
            tmp = self.link.with_name(self.link.name + ".new")
            tmp.unlink(missing_ok=True)
            tmp.symlink_to(os.ttyname(slave))
            tmp.replace(self.link)  # atomic: a reader never sees a missing link mid-swap
            self.counters.plugs += 1
            self._state = self._power_up()
            if not self.settings.legacy_text:
                self._send(P.encode_hello(self.hello()))

    def stall(self, seconds: float) -> None:
        """Freeze the firmware loop for ``seconds`` (samples are not sent, not queued)."""
        self._stall_until = time.monotonic() + seconds

    # -------------------------------------------------------------- firmware

    def hello(self) -> P.Hello:
        """The hello frame the firmware would send now."""
        s, st = self.settings, self._state
        return hello(st.rate_hz, st.mode, st.streaming, s.acc_fs_g, s.gyr_fs_dps, s.errors, self._has_mag())

    def _has_mag(self) -> bool:
        return self.motion.reading(0.0).mag is not None

    def _power_up(self) -> _BoardState:
        s = self.settings
        return _BoardState(streaming=s.stream_at_boot or s.legacy_text, rate_hz=s.rate_hz,
                           mode=s.mode, boot=time.monotonic())

    def _run(self) -> None:
        while not self._stop.is_set():
            with self._lock:
                fds = self._fds
            if fds is None:
                self._stop.wait(0.01)
                continue
            self._serve_commands(fds[0])
            if time.monotonic() < self._stall_until:
                self._state.next_sample = self._due_index()  # a frozen loop skips, not queues
                continue
            self._send_due_samples()

    def _due_index(self) -> int:
        return int((time.monotonic() - self._state.boot) * self._state.rate_hz) + 1

    def _serve_commands(self, master: int) -> None:
        st = self._state
        wait = max(0.0, st.boot + st.next_sample / st.rate_hz - time.monotonic())
        try:
            ready, _, _ = select.select([master], [], [], min(wait, 0.01))
            data = os.read(master, 4096) if ready else b""
        except OSError:  # cable pulled under us, or nobody has the port open yet
            time.sleep(0.005)
            return
        if not data or self.settings.legacy_text:
            return  # the paper's sketch ignores its input
        if not self._baud_matches():
            return  # at the wrong baud the host's bytes are noise to our UART
        for packet in self._decoder.feed(data):
            if isinstance(packet, P.Command):
                self.counters.commands += 1
                self._execute(packet)

    def _execute(self, c: P.Command) -> None:
        st = self._state
        status = P.AckStatus.OK
        if c.type == P.FrameType.START:
            st.streaming, st.raw_since_temp = True, 0
        elif c.type == P.FrameType.STOP:
            st.streaming = False
        elif c.type == P.FrameType.SET_RATE:  # the firmware's limits (P.BOARD_MAX_RATE_HZ)
            if P.board_rate_error(c.arg, st.mode) is None:
                self._retime(c.arg)
            else:
                status = P.AckStatus.BAD_ARGUMENT
        elif c.type == P.FrameType.SET_MODE:
            if c.arg in P.Mode._value2member_map_ and P.board_rate_error(st.rate_hz, P.Mode(c.arg)) is None:
                if st.mode != P.Mode.RAW:
                    st.raw_since_temp = 0  # into raw: a TEMP frame before the first RAW frame
                st.mode = P.Mode(c.arg)
            else:
                status = P.AckStatus.BAD_ARGUMENT
        elif c.type == P.FrameType.IDENTIFY:
            self._send(P.encode_hello(self.hello()))
            return
        elif c.type == P.FrameType.RESET:
            self._send(P.encode_ack(P.Ack(c.type, status)))
            self._state = self._power_up()
            self._send(P.encode_hello(self.hello()))
            return
        self._send(P.encode_ack(P.Ack(c.type, status)))

    def _retime(self, rate_hz: int) -> None:
        """Change the rate keeping the device clock continuous."""
        st = self._state
        now = time.monotonic() - st.boot
        st.rate_hz = rate_hz
        st.next_sample = int(now * rate_hz) + 1

    def _send_due_samples(self) -> None:
        st = self._state
        due = self._due_index()
        if not st.streaming:
            st.next_sample = due
            return
        # Catch up on the samples a hiccup of this process (the GIL, a collection, a loaded
        # machine) delayed, up to CATCH_UP_S: those are the host's delays, not the board's.
        # A frozen board loop is modelled by stall(), which skips instead.
        first = max(st.next_sample, due - max(1, int(st.rate_hz * CATCH_UP_S)))
        chunk = bytearray()
        for k in range(first, due):
            t = k / st.rate_hz
            chunk += self._sample_bytes(t, self.motion.reading(t))
        st.next_sample = max(st.next_sample, due)
        if chunk:
            self._send(bytes(chunk))
            if self.settings.keep_sent:
                now = time.monotonic()
                self.sent_at.extend((self.sent[-k].seq, now) for k in range(due - first, 0, -1))

    def _sample_bytes(self, t: float, r: SensorReading) -> bytes:
        st, s = self._state, self.settings
        t_us = (s.clock_start_us + round(t * 1e6)) & 0xFFFFFFFF
        seq = st.seq
        st.seq = (st.seq + 1) & 0xFFFF
        self.counters.samples += 1
        if s.legacy_text:
            sample = P.FusedSample(t, None, seq, r.q, r.flex_deg)
            self.sent.append(sample)
            return P.format_text_line(sample)
        self.counters.frames_sent += 1
        if st.mode == P.Mode.FUSED:
            sample: P.RawSample | P.FusedSample = P.FusedSample(t, t_us, seq, r.q, r.flex_deg)
            self.sent.append(sample)
            return P.encode(sample)
        temp = b""
        if r.die_c is not None and temp_due(st.raw_since_temp, st.rate_hz):
            st.temp = P.temp_counts(r.die_c)
            temp = P.encode_temp(t_us, st.temp)
            st.raw_since_temp = 0
        st.raw_since_temp += 1
        sample = quantise(r, t, t_us, seq, s.acc_fs_g, s.gyr_fs_dps)._replace(temp_counts=st.temp)  # the host
        # knows the temperature of the latest TEMP frame, not this sample's
        self.sent.append(sample)
        return temp + P.encode(sample)

    # -------------------------------------------------------------- the wire

    def _send(self, data: bytes) -> None:
        with self._lock:
            if self._fds is None or self.faults.silent:
                return
            data = self._injector.apply(data)
            if not self._baud_matches():
                data = self._injector.garble(data)
            try:
                n = os.write(self._fds[0], data)
            except OSError as e:
                if e.errno not in (errno.EAGAIN, errno.EIO):
                    raise
                n = 0
            self.counters.bytes_sent += n
            self.counters.bytes_lost += len(data) - n

    def _baud_matches(self) -> bool:
        if self._fds is None:
            return False
        speed = termios.tcgetattr(self._fds[1])[5]
        return _BAUD_CONSTANTS.get(speed) == self.settings.baud

    @staticmethod
    def _set_baud(fd: int, baud: int) -> None:
        attrs = termios.tcgetattr(fd)
        attrs[4] = attrs[5] = getattr(termios, f"B{baud}")
        termios.tcsetattr(fd, termios.TCSANOW, attrs)


def _default_motion(rate_hz: float) -> MotionSource:
    from .sim import arm_source  # the simulator is heavier than the board; load it when needed
    return arm_source(rate_hz)


def hello(rate_hz: int, mode: P.Mode, streaming: bool, acc_fs_g: int, gyr_fs_dps: int,
          errors: P.BoardError, has_mag: bool) -> P.Hello:
    """The HELLO our firmware sends: its version, an MPU-9250 (and AK8963 if present), its settings."""
    return P.Hello(P.PROTOCOL_VERSION, FIRMWARE_VERSION, MPU9250_WHOAMI, AK8963_WHOAMI if has_mag else 0,
                   rate_hz, mode, streaming, acc_fs_g, gyr_fs_dps, errors)


def temp_due(raw_since_temp: int, rate_hz: int) -> bool:
    """Whether a TEMP frame goes before the next RAW frame, ``raw_since_temp`` RAW frames sent since the
    last one (0: none since streaming raw began): before the first RAW frame and then once ``rate_hz``
    have been sent (a second; PROTOCOL.md sec. 4.3)."""
    return raw_since_temp == 0 or raw_since_temp >= rate_hz


def counts(values: ArrayLike, lsb: float) -> NDArray[np.int64]:
    """Quantise and saturate to int16, as the sensor's ADC does (ties to even, like ``round``)."""
    return np.clip(np.rint(np.asarray(values, dtype=float) / lsb), -32768, 32767).astype(np.int64)


def acc_lsb(acc_fs_g: int) -> float:
    """m/s^2 per accelerometer count at a full scale of +-``acc_fs_g`` g."""
    return acc_fs_g * P.STANDARD_GRAVITY / 32768.0


def gyr_lsb(gyr_fs_dps: int) -> float:
    """rad/s per gyroscope count at a full scale of +-``gyr_fs_dps`` deg/s."""
    return math.radians(gyr_fs_dps) / 32768.0


def quantise(r: SensorReading, t: float, t_us: int, seq: int,
             acc_fs_g: int, gyr_fs_dps: int) -> P.RawSample:
    """The raw sample the firmware would read from the MPU-9250 for ``r``."""
    acc = tuple(counts(r.acc, acc_lsb(acc_fs_g)).tolist())
    gyr = tuple(counts(r.gyr, gyr_lsb(gyr_fs_dps)).tolist())
    mag = tuple(counts(r.mag, P.MAG_UT_PER_COUNT).tolist()) if r.mag is not None else None
    temp = P.temp_counts(r.die_c) if r.die_c is not None else None
    return P.RawSample(t, t_us, seq, acc, gyr, mag, r.flex_adc, acc_fs_g, gyr_fs_dps, temp_counts=temp)
