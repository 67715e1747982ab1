"""The serial link to a board: find it, open it, handshake, read, reconnect.

Any pyserial port or URL works (``/dev/ttyACM0``, ``COM3``, ``loop://``,
``socket://host:port``, ``rfc2217://host:port``). A background thread reads
the port, stamps every chunk with the host's receive time, decodes it and
hands samples to the consumer through a bounded queue (the oldest sample is
dropped, and counted, when the consumer falls behind). When the cable is
pulled the thread keeps trying to reopen the same port and handshakes again.

Opening the port resets an Arduino-class board (its USB bridge's DTR line is
wired through a capacitor to RESET), and the bootloader then runs for about
1.5 s before the sketch starts. The handshake waits that out without talking to
the bootloader, and the link avoids every further reset it can: the baud rate
fallback changes the open port's rate instead of reopening it, and on Linux
and macOS the port is left with DTR asserted on close (HUPCL cleared), so a
reconnect to the same port makes no new DTR edge. On Windows the port is
opened with DTR and RTS off. See firmware/README.md, "Reset on open".
"""

from __future__ import annotations

import errno
import os
import queue
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Callable, Iterable, Iterator, NoReturn

import serial
from serial.tools import list_ports
from serial.tools.list_ports_common import ListPortInfo

from . import protocol as P

try:
    import termios
except ImportError:  # Windows
    termios = None

# Optiboot 4.4 after a reset (firmware/sim/README.md, "Reset on open"): the 65 ms start-up
# delay, three LED flashes (375 ms), a 1 s watchdog wait for a programmer, 65 ms again.
BOOTLOADER_S = 0.065 + 0.375 + 1.0 + 0.065
# The watchdog runs on an uncalibrated 128 kHz RC oscillator (the ATmega328P data sheet,
# DS40002061, gives its frequency only as typical curves); allow it 25% slow. Bytes sent inside this
# window go to the bootloader, which takes them for STK500 commands (one, PROG_PAGE,
# erases a flash page before it checks the frame), so the host keeps quiet in it.
BOOT_WINDOW_S = 1.25 * BOOTLOADER_S
# From the sketch's start to its HELLO: IMU bring-up and the 128 ms gyro bias (0.29 s
# measured on firmware/sim/boardsim).
SKETCH_START_S = 0.3
# The boot HELLO comes about 1.8 s after the port opens; the handshake allows the
# watchdog 25% slow, the sketch twice its start and 0.5 s for the answer to travel.
HANDSHAKE_TIMEOUT_S = round(BOOT_WINDOW_S + 2 * SKETCH_START_S + 0.5, 1)
# After the first baud rate's turn the board has booted: a legacy text board prints
# 20 lines a second, a binary one answers IDENTIFY at once.
FALLBACK_LISTEN_S = 1.0

# USB vendor/product ids of the boards and USB-serial chips an Arduino-class board uses.
KNOWN_USB_IDS: dict[tuple[int, int], str] = {
    (0x2341, 0x0043): "Arduino Uno", (0x2341, 0x0001): "Arduino Uno",
    (0x2341, 0x0010): "Arduino Mega", (0x2341, 0x0042): "Arduino Mega",
    (0x2341, 0x8036): "Arduino Leonardo", (0x2341, 0x0036): "Arduino Leonardo",
    (0x2A03, 0x0043): "Arduino Uno (.org)",
    (0x0403, 0x6001): "FTDI FT232R", (0x0403, 0x6015): "FTDI FT231X",
    (0x0403, 0x6010): "FTDI FT2232", (0x0403, 0x6014): "FTDI FT232H",
    (0x1A86, 0x7523): "CH340", (0x1A86, 0x5523): "CH341", (0x1A86, 0x55D4): "CH9102",
    (0x10C4, 0xEA60): "CP210x (Metro Mini)", (0x10C4, 0xEA70): "CP2105",
    (0x239A, 0x8011): "Adafruit",
}


class LinkError(Exception):
    """A problem opening or talking to a board, worded for the user."""


@dataclass(frozen=True)
class PortInfo:
    """A serial port the system knows, and whether it looks like a board."""

    device: str
    description: str
    vid: int | None
    pid: int | None
    chip: str | None  # name of the known board/chip, None if unknown

    def __str__(self) -> str:
        ids = f"{self.vid:04x}:{self.pid:04x}" if self.vid is not None else "----:----"
        return f"{self.device}  {ids}  {self.chip or '-'}  {self.description}"


def classify(ports: Iterable[ListPortInfo]) -> list[PortInfo]:
    """Name the known boards among pyserial's port descriptions; boards first."""
    infos = [PortInfo(p.device, p.description or "", p.vid, p.pid,
                      KNOWN_USB_IDS.get((p.vid, p.pid)) if p.vid is not None else None)
             for p in ports]
    return sorted(infos, key=lambda p: (p.chip is None, p.device))


def list_serial_ports() -> list[PortInfo]:
    """Every serial port the system has, boards first."""
    return classify(list_ports.comports())


def find_boards() -> list[PortInfo]:
    """Ports whose USB ids are those of an Arduino-class board or USB-serial chip."""
    return [p for p in list_serial_ports() if p.chip]


@dataclass
class LinkSettings:
    """How to open and drive a board."""

    port: str
    baud: int | None = None  # None: try 500000 (our firmware), then 9600 (the paper's sketch)
    rate_hz: int | None = None  # None: P.default_rate_hz(mode)
    mode: P.Mode = P.Mode.RAW
    handshake_timeout_s: float = HANDSHAKE_TIMEOUT_S
    queue_size: int = 4096  # samples; about 20 s at 200 Hz
    reconnect: bool = True
    reconnect_interval_s: float = 0.25
    text_order: str = "wxyz"

    def __post_init__(self) -> None:
        if self.rate_hz is None:
            self.rate_hz = P.default_rate_hz(self.mode)


@dataclass
class LinkHealth:
    """A snapshot of how the link is doing."""

    connected: bool
    status: str
    legacy_text: bool
    rate_hz: float  # samples per second over the last second
    frames: int
    dropped: int  # samples lost in sequence gaps
    crc_errors: int
    bytes_skipped: int
    queue_overflows: int  # samples dropped because the consumer fell behind
    since_last_s: float | None  # time since the last sample, None before the first
    reconnects: int

    @property
    def loss(self) -> float:
        """Fraction of samples lost on the wire."""
        total = self.frames + self.dropped
        return self.dropped / total if total else 0.0

    def to_json(self) -> dict:
        return {"connected": self.connected, "status": self.status,
                "legacy_text": self.legacy_text, "rate_hz": round(self.rate_hz, 2),
                "frames": self.frames, "dropped": self.dropped, "loss": round(self.loss, 6),
                "crc_errors": self.crc_errors, "bytes_skipped": self.bytes_skipped,
                "queue_overflows": self.queue_overflows,
                "since_last_s": None if self.since_last_s is None else round(self.since_last_s, 3),
                "reconnects": self.reconnects}


def open_port(port: str, baud: int, timeout: float = 0.05) -> serial.SerialBase:
    """Open a port or URL, turning every failure into a one-line :class:`LinkError`.

    Resets the board as few times as the system allows (see the module's docstring).
    """
    try:
        s = serial.serial_for_url(port, baudrate=baud, timeout=timeout, write_timeout=1.0,
                                  do_not_open=True)
        if os.name == "nt":  # pyserial puts these in the port's first set-up: DTR never rises
            s.dtr = s.rts = False
        s.open()
    except ValueError as e:  # unknown URL scheme, bad baud rate
        raise LinkError(f"cannot open {port}: {e}") from None
    except (serial.SerialException, OSError) as e:
        raise LinkError(_explain_open_error(port, e)) from None
    _keep_dtr_on_close(s)
    return s


def _keep_dtr_on_close(port: serial.SerialBase) -> None:
    """Clear HUPCL (POSIX): closing the port then leaves DTR asserted, and the next open
    makes no DTR edge, so it does not reset the board. The first open always does: the
    kernel raises DTR inside open(2), before any program can say otherwise."""
    fd = getattr(port, "fd", None)
    if termios is None or not isinstance(fd, int):
        return  # Windows, or a URL (socket://, loop://) with no tty under it
    try:
        attrs = termios.tcgetattr(fd)
        attrs[2] &= ~termios.HUPCL
        termios.tcsetattr(fd, termios.TCSANOW, attrs)
    except termios.error:
        pass  # not a tty: nothing to keep


def _explain_open_error(port: str, e: Exception) -> str:
    code = getattr(e, "errno", None)
    text = str(e)
    if code == errno.ENOENT or "No such file" in text or "FileNotFoundError" in text:
        return (f"no such port: {port} (is the board plugged in? "
                "`armtracker ports` lists the ports this computer has)")
    if code == errno.EACCES or "Permission denied" in text or "PermissionError" in text:
        return (f"permission denied opening {port}: on Linux add yourself to the "
                "'dialout' group (sudo usermod -aG dialout $USER, then log in again)")
    if code == errno.EBUSY or "busy" in text.lower():
        return f"{port} is in use by another program (close the Arduino serial monitor?)"
    return f"cannot open {port}: {text}"


@dataclass
class _Session:
    """One connection: the open port and the decoder that reads it."""

    port: serial.SerialBase
    decoder: P.Decoder
    hello: P.Hello | None


class Link:
    """A board on a serial port, read in the background; use as a context manager."""

    def __init__(self, settings: LinkSettings) -> None:
        self.settings = settings
        self.hello: P.Hello | None = None
        self.tap: Callable[[bytes], None] | None = None  # sees every byte read, e.g. a recorder
        self._queue: queue.Queue = queue.Queue(maxsize=settings.queue_size)
        self._session: _Session | None = None
        self._closed_stats = P.DecoderStats()  # summed over earlier sessions
        self._arrivals: deque[float] = deque(maxlen=4096)  # receive times within the last second
        self._last_sample: float | None = None
        self._overflows = 0
        self._reconnects = 0
        self._status = "closed"
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()

    # -------------------------------------------------------------- public

    def open(self) -> P.Hello | None:
        """Connect and handshake (raising :class:`LinkError`), then read in the background."""
        self._session = self._connect()
        self.hello = self._session.hello
        self._status = "connected"
        self._thread = threading.Thread(target=self._read_loop, name="serial-link", daemon=True)
        self._thread.start()
        return self.hello

    def close(self) -> None:
        """Stop streaming and close the port."""
        self._stop.set()
        if self._thread:
            self._thread.join(timeout=2)
        if self._session:
            self._send(self._session, P.Command(P.FrameType.STOP))
            self._end_session()
        self._status = "closed"

    def __enter__(self) -> "Link":
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def get(self, timeout: float | None = None) -> P.RawSample | P.FusedSample | None:
        """The next sample, waiting up to ``timeout`` seconds; None if none came."""
        try:
            return self._queue.get(timeout=timeout)
        except queue.Empty:
            return None

    def drain(self) -> list[P.RawSample | P.FusedSample]:
        """Every sample waiting now."""
        out = []
        while True:
            try:
                out.append(self._queue.get_nowait())
            except queue.Empty:
                return out

    def samples(self, seconds: float) -> Iterator[P.RawSample | P.FusedSample]:
        """Samples as they arrive, for ``seconds`` of wall time."""
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            s = self.get(timeout=min(left, 0.1))
            if s is not None:
                yield s

    def command(self, c: P.Command) -> None:
        """Send a command to the board (ignored while disconnected)."""
        if self._session:
            self._send(self._session, c)

    def health(self) -> LinkHealth:
        """Rate, loss, errors and time since the last sample, now."""
        now = time.monotonic()
        with self._lock:
            stats = self._stats()
            self._forget_before(now - 1.0)
            rate = len(self._arrivals)
            last = self._last_sample
        return LinkHealth(
            connected=self.connected, status=self._status,
            legacy_text=isinstance(self._session.decoder, P.TextDecoder) if self._session else False,
            rate_hz=float(rate), frames=stats.frames, dropped=stats.dropped,
            crc_errors=stats.crc_errors, bytes_skipped=stats.bytes_skipped,
            queue_overflows=self._overflows,
            since_last_s=None if last is None else now - last, reconnects=self._reconnects)

    @property
    def connected(self) -> bool:
        """Whether a board is connected now (cheap: the game asks every frame)."""
        return self._session is not None

    def _forget_before(self, t: float) -> None:
        while self._arrivals and self._arrivals[0] < t:
            self._arrivals.popleft()

    def stats(self) -> P.DecoderStats:
        """Decoder counters summed over every session of this link."""
        with self._lock:
            return self._stats()

    # -------------------------------------------------------------- connecting

    def _stats(self) -> P.DecoderStats:
        total = P.DecoderStats()
        total.add(self._closed_stats)
        if self._session:
            total.add(self._session.decoder.stats)
        return total

    def _connect(self) -> _Session:
        """Open the port and find out what is talking on it.

        The baud rates are tried on the one open port: reopening it would reset the board.
        """
        bauds = [self.settings.baud] if self.settings.baud else [P.DEFAULT_BAUD, P.LEGACY_BAUD]
        port = open_port(self.settings.port, bauds[0])
        received = 0
        try:
            for i, baud in enumerate(bauds):
                port.baudrate = baud
                session, n = self._handshake(port, after_open=i == 0)
                if session:
                    return session
                received += n
        except LinkError:  # the board refused the settings
            port.close()
            raise
        except (serial.SerialException, OSError) as e:
            port.close()
            raise LinkError(f"{self.settings.port} stopped answering during the handshake: {e}") \
                from None
        port.close()
        if received:
            self._no_frames(received, bauds)
        raise LinkError(f"no data from {self.settings.port} in {self.settings.handshake_timeout_s:g} s "
                        "at any baud rate tried: is the board powered and running the "
                        "EnergyBall firmware (see firmware/README.md)?")

    def _no_frames(self, received: int, bauds: list[int]) -> NoReturn:
        tried = " or ".join(str(b) for b in bauds)
        raise LinkError(f"{self.settings.port} sent {received} bytes but no valid frames at "
                        f"{tried} baud: a wrong baud rate, or not an EnergyBall board "
                        "(try --baud 9600 for a paper-style sketch, --baud 115200 for "
                        "EnergyBall firmware built before the 500000 baud change)")

    def _handshake(self, port: serial.SerialBase, after_open: bool) -> tuple[_Session | None, int]:
        """Ask the board who it is and configure it; sniff for the paper's text stream too.

        Right after the port opened the board may be in reset or in its bootloader: the
        first STOP and IDENTIFY reach a board that did not reset (one in reset hears
        nothing), then the host waits, quiet, for the boot HELLO and asks again only once
        the bootloader must be done. Returns the session, or None and how many bytes
        arrived if nothing made sense.
        """
        s = self.settings
        binary = P.FrameDecoder()
        text = P.TextDecoder(order=s.text_order)
        port.reset_input_buffer()
        session = _Session(port, binary, None)
        self._send(session, P.Command(P.FrameType.STOP))
        self._send(session, P.Command(P.FrameType.IDENTIFY))
        received, samples, text_samples = 0, 0, 0
        listen = s.handshake_timeout_s if after_open else min(s.handshake_timeout_s, FALLBACK_LISTEN_S)
        # A timeout inside the bootloader's window is a caller's who knows the board does not reset.
        ask_again = BOOT_WINDOW_S if after_open and listen > BOOT_WINDOW_S else listen / 2
        start = time.monotonic()
        deadline = start + listen
        asked_again = False
        while time.monotonic() < deadline:
            data = port.read(max(1, port.in_waiting))
            received += len(data)
            for p in binary.feed(data):
                if isinstance(p, P.Hello):
                    session.hello = p
                    self._configure(session)
                    return session, received
                samples += isinstance(p, (P.RawSample, P.FusedSample))
            text_samples += len(text.feed(data))
            if text_samples >= 3 and samples == 0:
                return _Session(port, text, None), received
            if not asked_again and time.monotonic() > start + ask_again:
                self._send(session, P.Command(P.FrameType.IDENTIFY))  # the first may have been lost
                asked_again = True
        if samples:  # frames but no hello: an older or minimal firmware; take it as it is
            self._send(session, P.Command(P.FrameType.START))
            return session, received
        return None, received

    def _configure(self, session: _Session) -> None:
        """Mode and rate in an order the board takes (its limit depends on the mode,
        PROTOCOL.md sec. 6: the rate first if the present mode allows it), then START."""
        s = self.settings
        mode = P.Command(P.FrameType.SET_MODE, int(s.mode))
        rate = P.Command(P.FrameType.SET_RATE, s.rate_hz)
        rate_first = session.hello is not None and P.board_rate_error(s.rate_hz, session.hello.mode) is None
        for c in ((rate, mode) if rate_first else (mode, rate)):
            self._send(session, c)
        self._check_acks(session)
        self._send(session, P.Command(P.FrameType.START))

    def _check_acks(self, session: _Session, timeout_s: float = 0.5) -> None:
        """Wait up to ``timeout_s`` for the ACKs of SET_MODE and SET_RATE; a refusal is a
        :class:`LinkError` that says why (a board that does not answer is taken as it is)."""
        s = self.settings
        waiting = {P.FrameType.SET_MODE, P.FrameType.SET_RATE}
        deadline = time.monotonic() + timeout_s
        while waiting and time.monotonic() < deadline:
            data = session.port.read(max(1, session.port.in_waiting))
            for p in session.decoder.feed(data):
                if not isinstance(p, P.Ack) or p.command not in waiting:
                    continue
                waiting.discard(p.command)
                if p.status != P.AckStatus.OK:
                    why = P.board_rate_error(s.rate_hz, s.mode) or "this board's limits differ from this host's"
                    raise LinkError(f"the board refused {P.FrameType(p.command).name} "
                                    f"({s.rate_hz} Hz, {s.mode.name.lower()} mode): {why}")

    @staticmethod
    def _send(session: _Session, c: P.Command) -> None:
        if isinstance(session.decoder, P.TextDecoder):
            return  # the paper's sketch takes no commands
        try:
            session.port.write(P.encode_command(c))
        except (serial.SerialException, OSError):
            pass  # the read loop notices a dead port and reconnects

    # -------------------------------------------------------------- reading

    def _read_loop(self) -> None:
        while not self._stop.is_set():
            session = self._session
            if session is None:
                self._try_reconnect()
                continue
            try:
                data = session.port.read(max(1, session.port.in_waiting))
            except (serial.SerialException, OSError, TypeError, AttributeError):
                # TypeError/AttributeError: pyserial on a port closed under it.
                self._lost()
                continue
            if data:
                if self.tap:
                    self.tap(data)
                self._deliver(session.decoder.feed(data, time.monotonic()))

    def _deliver(self, packets: list[P.Packet]) -> None:
        now = time.monotonic()
        for p in packets:
            if isinstance(p, P.Hello):
                self.hello = p
                continue
            if not isinstance(p, (P.RawSample, P.FusedSample)):
                continue
            with self._lock:
                self._arrivals.append(now)
                self._forget_before(now - 1.0)
                self._last_sample = now
            try:
                self._queue.put_nowait(p)
            except queue.Full:
                try:
                    self._queue.get_nowait()  # drop the oldest: the newest matters most
                except queue.Empty:
                    pass
                self._overflows += 1
                self._queue.put_nowait(p)

    def _lost(self) -> None:
        if not self.settings.reconnect:
            self._status = "disconnected"
            self._end_session()
            self._stop.set()
            return
        self._status = "reconnecting: the board went away (cable pulled?)"
        self._end_session()

    def _end_session(self) -> None:
        with self._lock:
            session, self._session = self._session, None
            if session is None:
                return
            self._closed_stats.add(session.decoder.stats)
        try:
            session.port.close()
        except (serial.SerialException, OSError):
            pass

    def _try_reconnect(self) -> None:
        if self._stop.wait(self.settings.reconnect_interval_s):
            return
        try:
            session = self._connect()
        except LinkError as e:
            self._status = f"reconnecting: {e}"
            return
        with self._lock:
            self._session = session
        if session.hello:
            self.hello = session.hello
        self._reconnects += 1
        self._status = "connected"
