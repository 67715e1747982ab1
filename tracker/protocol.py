"""The EnergyBall wire protocol: frames, packets, an incremental decoder.

The normative description is ``firmware/PROTOCOL.md``; this module is its
host-side implementation, and the firmware (``firmware/``) the board side.

A frame is::

    A5 5A | len (u8) | type (u8) | payload (len bytes) | CRC-16 (u16, little endian)

The CRC is CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection, no
final xor) over ``len``, ``type`` and the payload; ``binascii.crc_hqx`` computes
exactly that in C. All multi-byte fields are little endian (the AVR's order).

The paper's board (Zhu & Shi, sec. 4) instead printed one text line per sample
at 9600 baud: a quaternion and the flex angle. :class:`TextDecoder` reads that
stream so a board running a paper-style sketch still works.
"""

from __future__ import annotations

import binascii
import functools
import math
import re
import struct
from dataclasses import dataclass, field, fields
from enum import IntEnum, IntFlag
from typing import Any, Callable, NamedTuple, Union

SYNC = b"\xa5\x5a"
HEADER_SIZE = 4  # sync (2) + len + type
CRC_SIZE = 2
PROTOCOL_VERSION = 1
# Exact at both ends at 16 MHz: the ATmega328P's UART with U2X0 and UBRR0 = 3, and the
# CP2104's 48 MHz / 96 (PROTOCOL.md sec. 1); 115200 ran the AVR 2.1% fast.
DEFAULT_BAUD = 500000
LEGACY_BAUD = 9600

STANDARD_GRAVITY = 9.80665  # m/s^2 per g, the unit the accelerometer counts in
ACC_FS_G = (2, 4, 8, 16)  # full-scale code -> +-g (MPU-9250 ACCEL_FS_SEL)
GYR_FS_DPS = (250, 500, 1000, 2000)  # full-scale code -> +-deg/s (GYRO_FS_SEL)
MAG_UT_PER_COUNT = 0.15  # AK8963 in 16-bit output mode
FLEX_ADC_MASK = 0x03FF  # 10-bit ADC
MIN_RATE_HZ, MAX_RATE_HZ = 1, 1000  # the rates SET_RATE accepts (PROTOCOL.md sec. 6)


class FrameType(IntEnum):
    """Packet types; board-to-host below 0x80, host-to-board (commands) above."""

    RAW = 0x01
    FUSED = 0x02
    HELLO = 0x03
    ACK = 0x04
    TEMP = 0x05
    START = 0x81
    STOP = 0x82
    SET_RATE = 0x83
    SET_MODE = 0x84
    IDENTIFY = 0x85
    RESET = 0x86


class Mode(IntEnum):
    """What the board streams: raw sensor counts, or its own fused orientation."""

    RAW = 0
    FUSED = 1


class BoardError(IntFlag):
    """Board-side error bits reported in the hello frame."""

    NONE = 0
    IMU_MISSING = 0x01  # MPU-9250 did not answer WHO_AM_I
    I2C_FAILURE = 0x02  # an I2C transfer failed or timed out
    MAG_MISSING = 0x04  # AK8963 did not answer
    FLEX_RAIL = 0x08  # flex ADC stuck at a rail (sensor unplugged)
    OVERRUN = 0x10  # the sample loop missed its deadline


# What a maker checks when the board reports each error bit (README, "First bench test").
BOARD_ERROR_ADVICE = {
    BoardError.IMU_MISSING: "the IMU does not answer: check SDA on A4, SCL on A5, the breakout's "
                            "VIN and GND, and AD0 low (address 0x68); the board retries every second",
    BoardError.I2C_FAILURE: "an I2C transfer failed: a loose IMU cable or a drop-out of the breakout's "
                            "power; the board set the IMU up again",
    BoardError.MAG_MISSING: "no magnetometer answers: an MPU-6500 family chip has none and play goes on "
                            "without it; on an MPU-9250 breakout check its power",
    BoardError.FLEX_RAIL: "the flex reading sits at a rail: check the flex sensor's plug and the "
                          "op-amp circuit on A0 (Vref 2.5 V, Rf 51 kOhm)",
    BoardError.OVERRUN: "the board missed a sample's time: a rate above what it sustains, a "
                        "stalled I2C bus, or the IMU set up again after an I2C failure",
}


def board_error_lines(errors: BoardError) -> list[str]:
    """One line per error bit set: its name and what to check."""
    return [f"board reports {bit.name}: {advice}" for bit, advice in BOARD_ERROR_ADVICE.items()
            if bit in errors]


# The highest rate the EnergyBall board sustains in each mode: 90% of its CPU (the I2C
# bus at 100 kHz, the on-board filter) and of its UART, as the firmware computes it
# (firmware/energyball/src/eb_budget.h; tests/firmware checks the two agree).
# The board answers SET_RATE above it, or SET_MODE to a mode whose limit is below the
# present rate, with BAD_ARGUMENT (PROTOCOL.md sec. 6).
BOARD_MAX_RATE_HZ = {Mode.RAW: 265, Mode.FUSED: 205}
BOOT_RATE_HZ = 200  # the board's rate after power-up (PROTOCOL.md sec. 7.1), what the host asks for by default


def default_rate_hz(mode: Mode) -> int:
    """The rate a host asks for unless told otherwise: the boot rate, or the mode's limit if lower."""
    return min(BOOT_RATE_HZ, BOARD_MAX_RATE_HZ[mode])


def board_rate_error(rate_hz: int, mode: Mode) -> str | None:
    """Why the board refuses ``rate_hz`` in ``mode``, in a sentence; None if it takes it."""
    top = BOARD_MAX_RATE_HZ[mode]
    if MIN_RATE_HZ <= rate_hz <= top:
        return None
    return (f"{rate_hz} Hz is not a rate the board sustains in {mode.name.lower()} mode: "
            f"it takes {MIN_RATE_HZ}..{top} Hz (firmware/README.md, rate limits)")


class AckStatus(IntEnum):
    """Board's answer to a command."""

    OK = 0
    BAD_ARGUMENT = 1
    UNKNOWN_COMMAND = 2
    BAD_LENGTH = 3


# Flags packed into the top 6 bits of the raw frame's flex field.
_ACC_FS_SHIFT = 10
_GYR_FS_SHIFT = 12
_MAG_VALID_BIT = 1 << 14
_MAG_OVERFLOW_BIT = 1 << 15

_RAW = struct.Struct("<IH9hH")  # t_us, seq, acc xyz, gyr xyz, mag xyz, flex|flags
_CRC = struct.Struct("<H")
_FUSED = struct.Struct("<IH4hh")  # t_us, seq, quaternion (Q14), flex centidegrees
_HELLO = struct.Struct("<BBBBBBHBBBBH")
_ACK = struct.Struct("<BB")
_TEMP = struct.Struct("<Ih")  # t_us, the MPU-9250's TEMP_OUT
_RATE = struct.Struct("<H")
_MODE = struct.Struct("<B")
Q14 = 16384.0
TEMP_COUNTS_PER_C = 333.87  # the MPU-9250's temperature sensitivity (PS-MPU-9250A-01 sec. 3.4.2)
TEMP_ROOM_C = 21.0  # where TEMP_OUT reads 0

PAYLOAD_SIZE: dict[int, int] = {
    FrameType.RAW: _RAW.size,
    FrameType.FUSED: _FUSED.size,
    FrameType.HELLO: _HELLO.size,
    FrameType.ACK: _ACK.size,
    FrameType.TEMP: _TEMP.size,
    FrameType.START: 0,
    FrameType.STOP: 0,
    FrameType.SET_RATE: _RATE.size,
    FrameType.SET_MODE: _MODE.size,
    FrameType.IDENTIFY: 0,
    FrameType.RESET: 0,
}
RAW_FRAME_SIZE = HEADER_SIZE + _RAW.size + CRC_SIZE
_RAW_TYPE = int(FrameType.RAW)  # a plain int compares faster than the enum member


def crc16(data: bytes | bytearray, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (check value of b"123456789" is 0x29B1)."""
    return binascii.crc_hqx(data, crc)


def link_utilisation(rate_hz: float, frame_size: int = RAW_FRAME_SIZE,
                     baud: int = DEFAULT_BAUD) -> float:
    """Fraction of a UART link (8N1: 10 bits a byte) that a frame stream uses."""
    return rate_hz * frame_size * 10 / baud


# ----------------------------------------------------------------- packets

# The unit conversions run for every sample, so the scale factors are computed once
# per full scale and the three products written out.

@functools.cache
def _acc_scale(fs_g: int) -> float:
    """m/s^2 per count of a signed 16-bit accelerometer reading at full scale ``fs_g``."""
    return fs_g * STANDARD_GRAVITY / 32768.0


@functools.cache
def _gyr_scale(fs_dps: int) -> float:
    """rad/s per count of a signed 16-bit gyroscope reading at full scale ``fs_dps``."""
    return math.radians(fs_dps) / 32768.0


def _scaled(counts: tuple[int, int, int], k: float) -> tuple[float, float, float]:
    """Three counts times the unit ``k``."""
    x, y, z = counts
    return (x * k, y * k, z * k)


class RawSample(NamedTuple):
    """One raw IMU + flex reading, as counts, with the scales to convert them.

    ``t`` is device time in seconds, unwrapped by the decoder; ``t_us`` the
    board's 32-bit microsecond counter as sent. ``host_t`` is the host's
    receive time (``time.monotonic``) when the sample came over a link.
    A named tuple: the cheapest immutable record to make 200 times a second.
    """

    t: float
    t_us: int
    seq: int
    acc_counts: tuple[int, int, int]
    gyr_counts: tuple[int, int, int]
    mag_counts: tuple[int, int, int] | None
    flex_adc: int
    acc_fs_g: int = 16
    gyr_fs_dps: int = 2000
    mag_overflow: bool = False
    host_t: float | None = None
    temp_counts: int | None = None  # the IMU die's TEMP_OUT from the latest TEMP frame; None before one

    @property
    def die_c(self) -> float | None:
        """The IMU die's temperature in degC (PROTOCOL.md sec. 4.3), or None when the board sent none."""
        return None if self.temp_counts is None else temp_c(self.temp_counts)

    @property
    def acc(self) -> tuple[float, float, float]:
        """Specific force in m/s^2 (+9.81 on the up axis at rest)."""
        return _scaled(self.acc_counts, _acc_scale(self.acc_fs_g))

    @property
    def gyr(self) -> tuple[float, float, float]:
        """Angular rate in rad/s."""
        return _scaled(self.gyr_counts, _gyr_scale(self.gyr_fs_dps))

    @property
    def mag(self) -> tuple[float, float, float] | None:
        """Magnetic field in microtesla, or None when the board has no magnetometer reading."""
        if self.mag_counts is None:
            return None
        return _scaled(self.mag_counts, MAG_UT_PER_COUNT)


class FusedSample(NamedTuple):
    """The board's own orientation estimate (the paper's mode, Zhu & Shi, sec. 3-4).

    ``q`` is q_WS, scalar first; ``flex_deg`` the elbow angle (0 = straight).
    Text-mode samples have no device clock: ``t_us`` is None and ``t`` is host time.
    A named tuple, like :class:`RawSample`.
    """

    t: float
    t_us: int | None
    seq: int
    q: tuple[float, float, float, float]
    flex_deg: float
    host_t: float | None = None


@dataclass(frozen=True, slots=True)
class Hello:
    """Board identity and status, sent at boot and in answer to IDENTIFY."""

    protocol: int
    firmware: str
    imu_whoami: int
    mag_whoami: int
    rate_hz: int
    mode: Mode
    streaming: bool
    acc_fs_g: int
    gyr_fs_dps: int
    errors: BoardError

    def to_json(self) -> dict:
        """JSON-ready fields; errors as a list of flag names."""
        return {
            "protocol": self.protocol,
            "firmware": self.firmware,
            "imu_whoami": self.imu_whoami,
            "mag_whoami": self.mag_whoami,
            "rate_hz": self.rate_hz,
            "mode": self.mode.name.lower(),
            "streaming": self.streaming,
            "acc_fs_g": self.acc_fs_g,
            "gyr_fs_dps": self.gyr_fs_dps,
            "errors": [e.name for e in BoardError if e and e in self.errors],
        }

    @classmethod
    def from_json(cls, d: object) -> "Hello":
        """Inverse of :meth:`to_json`; anything else is a ``ValueError`` naming the field.

        The fields are checked against what a HELLO frame can carry (PROTOCOL.md
        sec. 5.1): bytes 0..255, a u16 rate, the four full scales of each sensor,
        the error flags by name. Keys we do not know are ignored.
        """
        if not isinstance(d, dict):
            raise ValueError(f"expected an object of the board's fields, not {_brief(d)}")
        byte = range(256)
        firmware = _field(d, "firmware", str)
        parts = firmware.split(".")
        if len(parts) != 3 or not all(p.isdigit() and int(p) in byte for p in parts):
            raise ValueError(f"'firmware' is {_brief(firmware)}; expected a version like \"1.0.0\" (each part 0..255)")
        mode = _field(d, "mode", str)
        if mode.upper() not in Mode.__members__:
            raise ValueError(f"'mode' is {_brief(mode)}; expected one of {', '.join(m.name.lower() for m in Mode)}")
        errors_field = d.get("errors", [])
        if not isinstance(errors_field, list):
            raise ValueError(f"'errors' is {_brief(errors_field)}; expected a list of flag names")
        errors = BoardError.NONE
        for name in errors_field:
            if not isinstance(name, str) or name not in BoardError.__members__ or name == "NONE":
                raise ValueError(f"'errors' holds {_brief(name)}; expected flag names from "
                                 f"{', '.join(str(e.name) for e in BoardError if e)}")
            errors |= BoardError[name]
        return cls(_int_in(d, "protocol", byte), firmware, _int_in(d, "imu_whoami", byte),
                   _int_in(d, "mag_whoami", byte), _int_in(d, "rate_hz", range(1 << 16)),
                   Mode[mode.upper()], _field(d, "streaming", bool),
                   _int_in(d, "acc_fs_g", ACC_FS_G), _int_in(d, "gyr_fs_dps", GYR_FS_DPS), errors)


def _brief(value: object, limit: int = 40) -> str:
    """A value as a short one-line text, for messages."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _field(d: dict, key: str, kind: type) -> Any:
    """``d[key]``, which must be of type ``kind`` (a bool is not an int here)."""
    if key not in d:
        raise ValueError(f"'{key}' is missing")
    value = d[key]
    if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
        raise ValueError(f"'{key}' is {_brief(value)}; expected {'true or false' if kind is bool else kind.__name__}")
    return value


def _int_in(d: dict, key: str, allowed: range | tuple[int, ...]) -> int:
    """``d[key]``, an integer among ``allowed``."""
    value: int = _field(d, key, int)
    if value not in allowed:
        shown = (f"{allowed.start}..{allowed.stop - 1}" if isinstance(allowed, range)
                 else " or ".join(map(str, allowed)))
        raise ValueError(f"'{key}' is {value}; expected {shown}")
    return value


@dataclass(frozen=True, slots=True)
class Ack:
    """The board's answer to a host command."""

    command: int
    status: AckStatus


@dataclass(frozen=True, slots=True)
class Command:
    """A host-to-board command (START, STOP, SET_RATE, SET_MODE, IDENTIFY, RESET)."""

    type: FrameType
    arg: int | None = None


Packet = Union[RawSample, FusedSample, Hello, Ack, Command]


# ----------------------------------------------------------------- encoding


def frame(ftype: int, payload: bytes = b"") -> bytes:
    """Wrap a payload in sync, length, type and CRC."""
    body = bytes((len(payload), ftype)) + payload
    return SYNC + body + _CRC.pack(crc16(body))


# A raw frame's sync, length and type never change; its CRC continues from theirs.
_RAW_HEAD = SYNC + bytes((_RAW.size, FrameType.RAW))
_RAW_HEAD_CRC = crc16(_RAW_HEAD[2:])


def _fs_code(table: tuple[int, ...], value: int, what: str) -> int:
    try:
        return table.index(value)
    except ValueError:
        raise ValueError(f"{what} full scale {value} is not one of {table}") from None


def raw_flags(flex_adc: int, acc_fs_g: int, gyr_fs_dps: int, has_mag: bool = True,
              mag_overflow: bool = False) -> int:
    """A raw frame's flags word: the flex ADC, the full-scale codes and the magnetometer's bits."""
    flags = (flex_adc & FLEX_ADC_MASK) \
        | _fs_code(ACC_FS_G, acc_fs_g, "accelerometer") << _ACC_FS_SHIFT \
        | _fs_code(GYR_FS_DPS, gyr_fs_dps, "gyroscope") << _GYR_FS_SHIFT
    if has_mag:
        flags |= _MAG_VALID_BIT
    if mag_overflow:
        flags |= _MAG_OVERFLOW_BIT
    return flags


def encode_raw_counts(t_us: int, seq: int, acc: tuple[int, int, int], gyr: tuple[int, int, int],
                      mag: tuple[int, int, int], flags: int) -> bytes:
    """A raw sample frame from its fields as sent (``flags`` from :func:`raw_flags`): for a
    board that knows its flags word ahead, without making a :class:`RawSample` first."""
    payload = _RAW.pack(t_us & 0xFFFFFFFF, seq & 0xFFFF, *acc, *gyr, *mag, flags)
    return _RAW_HEAD + payload + _CRC.pack(crc16(payload, _RAW_HEAD_CRC))


def encode_raw(s: RawSample) -> bytes:
    """Encode a raw sample frame (the decoder's exact inverse)."""
    _, t_us, seq, acc, gyr, mag, flex, acc_fs_g, gyr_fs_dps, overflow, *_ = s
    flags = raw_flags(flex, acc_fs_g, gyr_fs_dps, mag is not None, overflow)
    return encode_raw_counts(t_us, seq, acc, gyr, (0, 0, 0) if mag is None else mag, flags)


def encode_temp(t_us: int, temp_counts: int) -> bytes:
    """A TEMP frame (PROTOCOL.md sec. 4.3): the die's TEMP_OUT read in the burst of the sample at ``t_us``."""
    return frame(FrameType.TEMP, _TEMP.pack(t_us & 0xFFFFFFFF, max(-32768, min(32767, temp_counts))))


def temp_c(temp_counts: int) -> float:
    """TEMP_OUT counts in degC: counts / 333.87 + 21 (RM-MPU-9250A-00, TEMP_OUT; PS-MPU-9250A-01 sec. 3.4.2)."""
    return temp_counts / TEMP_COUNTS_PER_C + TEMP_ROOM_C


def temp_counts(die_c: float) -> int:
    """What TEMP_OUT reads at ``die_c`` degC: the inverse of :func:`temp_c`, rounded."""
    return round((die_c - TEMP_ROOM_C) * TEMP_COUNTS_PER_C)


def _q14(x: float) -> int:
    return max(-32768, min(32767, round(x * Q14)))


def encode_fused(s: FusedSample) -> bytes:
    """Encode a fused sample frame: quaternion in Q14, flex in centidegrees."""
    flex = max(-32768, min(32767, round(s.flex_deg * 100)))
    return frame(FrameType.FUSED, _FUSED.pack((s.t_us or 0) & 0xFFFFFFFF, s.seq & 0xFFFF,
                                              *(_q14(c) for c in s.q), flex))


def encode_hello(h: Hello) -> bytes:
    """Encode a hello/status frame."""
    major, minor, patch = (int(p) for p in h.firmware.split("."))
    return frame(FrameType.HELLO, _HELLO.pack(
        h.protocol, major, minor, patch, h.imu_whoami, h.mag_whoami, h.rate_hz,
        int(h.mode), int(h.streaming), _fs_code(ACC_FS_G, h.acc_fs_g, "accelerometer"),
        _fs_code(GYR_FS_DPS, h.gyr_fs_dps, "gyroscope"), int(h.errors)))


def encode_ack(a: Ack) -> bytes:
    """Encode the board's answer to a command."""
    return frame(FrameType.ACK, _ACK.pack(a.command, int(a.status)))


def encode_command(c: Command) -> bytes:
    """Encode a host-to-board command frame."""
    if c.type == FrameType.SET_RATE:
        return frame(c.type, _RATE.pack(c.arg))
    if c.type == FrameType.SET_MODE:
        return frame(c.type, _MODE.pack(c.arg))
    return frame(c.type)


def encode(p: Packet) -> bytes:
    """Encode any packet."""
    encoders: dict[type, Callable[[Any], bytes]] = {
        RawSample: encode_raw, FusedSample: encode_fused, Hello: encode_hello,
        Ack: encode_ack, Command: encode_command}
    return encoders[type(p)](p)


# ----------------------------------------------------------------- decoding


@dataclass
class DecoderStats:
    """Counters a decoder keeps; read them, never write them."""

    frames: int = 0  # valid frames decoded
    crc_errors: int = 0  # candidate frames whose CRC did not match
    dropped: int = 0  # samples missing according to sequence gaps
    bytes_skipped: int = 0  # bytes that were not part of a valid frame
    unknown: int = 0  # valid frames of a type this host does not know
    bad_lines: int = 0  # text mode: lines that were not a sample
    restarts: int = 0  # times the board powered up again (or was RESET) mid-stream: see board_restarted

    def to_json(self) -> dict:
        return {"frames": self.frames, "crc_errors": self.crc_errors, "dropped": self.dropped,
                "bytes_skipped": self.bytes_skipped, "unknown": self.unknown,
                "bad_lines": self.bad_lines, "restarts": self.restarts}

    def add(self, other: DecoderStats) -> None:
        """Count ``other``'s counts in with these (a link's total over its sessions)."""
        for f in fields(self):
            setattr(self, f.name, getattr(self, f.name) + getattr(other, f.name))


@dataclass
class FrameDecoder:
    """Incremental decoder of the binary protocol.

    Feed it chunks of any size; it returns the packets completed so far. It
    resynchronises after garbage by scanning for the sync marker one byte at a
    time past any rejected candidate, so a valid frame is never skipped, and it
    never raises on any input. Between feeds it keeps at most one incomplete
    frame (from a sync marker on: 261 bytes), so memory stays bounded.
    """

    stats: DecoderStats = field(default_factory=DecoderStats)
    accept_commands: bool = False  # the board side decodes commands
    _buf: bytearray = field(default_factory=bytearray)
    _last_us: int = 0  # the device clock of the last sample
    _epoch: int = 0  # microseconds the device clock has wrapped by so far (in this power-up)
    _last_seq: int = -1  # the sequence number of the last sample; -1 before the first
    _hello_since: bool = False  # a HELLO arrived after the last sample
    _temp: int | None = None  # TEMP_OUT of the latest TEMP frame since the last HELLO

    def feed(self, data: bytes, host_t: float | None = None) -> list[Packet]:
        """Decode ``data`` appended to what is buffered; return complete packets."""
        buf = self._buf
        buf += data
        stats = self.stats
        out: list[Packet] = []
        pos = 0
        n = len(buf)
        while True:
            start = buf.find(SYNC, pos)
            if start < 0:
                # Keep a trailing first sync byte: it may start the next frame.
                keep = 1 if pos < n and buf[-1] == SYNC[0] else 0
                stats.bytes_skipped += n - pos - keep
                pos = n - keep
                break
            if start > pos:
                stats.bytes_skipped += start - pos
                pos = start
            if n - pos < HEADER_SIZE:
                break
            length, ftype = buf[pos + 2], buf[pos + 3]
            expected = PAYLOAD_SIZE.get(ftype)
            if expected is not None and expected != length:
                stats.bytes_skipped += 1
                pos += 1
                continue
            end = pos + HEADER_SIZE + length + CRC_SIZE
            if end > n:
                break
            if crc16(buf[pos + 2:end - CRC_SIZE]) != buf[end - 2] | buf[end - 1] << 8:
                stats.crc_errors += 1
                stats.bytes_skipped += 1
                pos += 1
                continue
            if ftype == _RAW_TYPE:  # nearly every frame: skip the dispatch
                out.append(self._raw(buf, pos + HEADER_SIZE, host_t))
            else:
                packet = self._packet(ftype, buf, pos + HEADER_SIZE, host_t)
                if packet is not None:
                    out.append(packet)
            stats.frames += 1
            pos = end
        del buf[:pos]
        return out

    def _packet(self, ftype: int, buf: bytearray, at: int, host_t: float | None) -> Packet | None:
        """The packet whose (CRC-checked) payload starts at ``buf[at]``, for all but raw frames."""
        if ftype == FrameType.FUSED:
            return self._fused(buf, at, host_t)
        if ftype == FrameType.TEMP:
            self._temp = _TEMP.unpack_from(buf, at)[1]
            return None
        if ftype == FrameType.HELLO:
            self._hello_since, self._temp = True, None
            return _hello(buf, at)
        if ftype == FrameType.ACK:
            cmd, status = _ACK.unpack_from(buf, at)
            return Ack(cmd, AckStatus(status) if status in AckStatus._value2member_map_
                       else AckStatus.BAD_ARGUMENT)
        if ftype >= 0x80 and self.accept_commands and ftype in PAYLOAD_SIZE:
            return _command(ftype, buf, at)
        self.stats.unknown += 1
        return None

    def _raw(self, buf: bytearray, at: int, host_t: float | None) -> RawSample:
        t_us, seq, ax, ay, az, gx, gy, gz, mx, my, mz, flags = _RAW.unpack_from(buf, at)
        return RawSample(
            self._advance(t_us, seq), t_us, seq, (ax, ay, az), (gx, gy, gz),
            (mx, my, mz) if flags & _MAG_VALID_BIT else None, flags & FLEX_ADC_MASK,
            ACC_FS_G[flags >> _ACC_FS_SHIFT & 3], GYR_FS_DPS[flags >> _GYR_FS_SHIFT & 3],
            (flags & _MAG_OVERFLOW_BIT) != 0, host_t, self._temp)

    def _fused(self, buf: bytearray, at: int, host_t: float | None) -> FusedSample:
        t_us, seq, w, x, y, z, flex = _FUSED.unpack_from(buf, at)
        return FusedSample(self._advance(t_us, seq), t_us, seq,
                           (w / Q14, x / Q14, y / Q14, z / Q14), flex / 100.0, host_t)

    def _advance(self, t_us: int, seq: int) -> float:
        """Count the samples lost before this one and return its device time in seconds.

        Sequence gaps count as dropped (PROTOCOL.md sec. 9.2); the 32-bit microsecond
        clock is unwrapped (sec. 9.3). A board that powered up again since the last
        sample (:func:`board_restarted`) starts a new count and a new clock instead:
        no false gap, and device time counts from its power-up again.
        """
        last_us, last_seq = self._last_us, self._last_seq
        if t_us > last_us and seq == last_seq + 1:
            pass  # nearly every sample: the next one, the clock ahead (what the rules below say, quicker)
        elif last_seq >= 0:
            if board_restarted(last_us, last_seq, t_us, seq, self._hello_since):
                self.stats.restarts += 1
                self._epoch = 0
            else:
                self.stats.dropped += samples_missing(last_seq, seq)
                if t_us < last_us:  # a step back by more than half the range: a wrap
                    self._epoch += 1 << 32
        self._last_us, self._last_seq, self._hello_since = t_us, seq, False
        return (self._epoch + t_us) * 1e-6


def samples_missing(last_seq: int, seq: int) -> int:
    """Samples numbered between two consecutive ones that did not arrive (16-bit ``seq``, wrapping)."""
    return (seq - last_seq - 1) & 0xFFFF


def board_restarted(last_us: int, last_seq: int, t_us: int, seq: int, hello_between: bool) -> bool:
    """Whether a sample (``t_us``, ``seq``) comes from a board that powered up again, or was
    RESET, after the sample (``last_us``, ``last_seq``), rather than from the same power-up.

    Within one power-up the device clock only advances, wrapping modulo 2^32
    (PROTOCOL.md sec. 4, the rule written out in sec. 9.4), and ``seq`` counts samples taken on the sampling grid
    (sec. 7.3-7.4) at no more than :data:`MAX_RATE_HZ` (sec. 6); at power-up and
    after RESET ``seq`` is 0, the clock starts again and a HELLO is sent (sec. 7.1).
    So a sample starts a new power-up when

    - the clock went back by at most half its range (a larger step back is a
      wrap, sec. 9.3), or went back at all after a HELLO (the power-up's own);
    - or ``seq`` advanced by more samples than the clock's advance leaves room
      for at 1000 Hz (plus one: the first sample after SET_RATE may follow the
      previous one closely, sec. 7.3), as when a board restarts within moments.

    A restart after more than 35.8 minutes of the board's uptime with no HELLO
    in the stream looks like a wrap to the clock and may pass as one.
    """
    if t_us < last_us and (hello_between or last_us - t_us <= 1 << 31):
        return True
    advance = samples_missing(last_seq, seq) + 1
    return advance > ((t_us - last_us) & 0xFFFFFFFF) // (1_000_000 // MAX_RATE_HZ) + 1


def _hello(buf: bytearray, at: int) -> Hello:
    (proto, major, minor, patch, imu, mag, rate, mode, streaming,
     acc_fs, gyr_fs, errors) = _HELLO.unpack_from(buf, at)
    return Hello(proto, f"{major}.{minor}.{patch}", imu, mag, rate,
                 Mode(mode) if mode in Mode._value2member_map_ else Mode.RAW,
                 bool(streaming), ACC_FS_G[acc_fs & 3], GYR_FS_DPS[gyr_fs & 3],
                 BoardError(errors & 0xFF))


def _command(ftype: int, buf: bytearray, at: int) -> Command:
    if ftype == FrameType.SET_RATE:
        return Command(FrameType.SET_RATE, _RATE.unpack_from(buf, at)[0])
    if ftype == FrameType.SET_MODE:
        return Command(FrameType.SET_MODE, _MODE.unpack_from(buf, at)[0])
    return Command(FrameType(ftype))


# ----------------------------------------------------------------- paper text mode

_NUMBER = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
MAX_LINE = 256


@dataclass
class TextDecoder:
    """Decoder of the paper's text stream (Zhu & Shi, sec. 4: 9600 baud to the PC).

    One line per sample holding five numbers, a quaternion and the flex angle
    in degrees, separated by commas, spaces or tabs (labels are ignored).
    ``order`` says how the sketch printed the quaternion: ``"wxyz"`` (ours) or
    ``"xyzw"`` (Unity's ``Quaternion(x, y, z, w)``). Lines whose quaternion is
    far from unit norm are counted as bad, not passed on.
    """

    order: str = "wxyz"
    stats: DecoderStats = field(default_factory=DecoderStats)
    _buf: bytearray = field(default_factory=bytearray)
    _seq: int = 0
    _in_long_line: bool = False  # dropping the rest of an overlong line up to its newline

    def feed(self, data: bytes, host_t: float | None = None) -> list[FusedSample]:
        self._buf += data
        *lines, rest = self._buf.split(b"\n")
        if self._in_long_line:  # already counted as one bad line: skip through its newline
            if lines:
                self.stats.bytes_skipped += len(lines.pop(0)) + 1
                self._in_long_line = False
            else:
                self.stats.bytes_skipped += len(rest)
                rest = bytearray()
        if len(rest) > MAX_LINE:
            self.stats.bad_lines += 1
            self.stats.bytes_skipped += len(rest)
            rest = bytearray()
            self._in_long_line = True
        self._buf = rest
        out = []
        for line in lines:
            sample = self._line(line, host_t)
            if sample is None:
                self.stats.bad_lines += 1
                self.stats.bytes_skipped += len(line) + 1
            else:
                out.append(sample)
        return out

    def _line(self, line: bytes | bytearray, host_t: float | None) -> FusedSample | None:
        numbers = _NUMBER.findall(line)
        if len(numbers) != 5 or len(line) > MAX_LINE:
            return None
        values = [float(v) for v in numbers]
        if not all(math.isfinite(v) for v in values):
            return None
        q = values[:4] if self.order == "wxyz" else [values[3], *values[:3]]
        norm = math.sqrt(sum(c * c for c in q))
        if abs(norm - 1.0) > 0.05:
            return None
        self.stats.frames += 1
        self._seq = (self._seq + 1) & 0xFFFF
        t = host_t if host_t is not None else 0.0
        w, x, y, z = (c / norm for c in q)
        return FusedSample(t, None, self._seq, (w, x, y, z), values[4], host_t)


def format_text_line(s: FusedSample) -> bytes:
    """One line of the paper-style text stream (what a paper sketch prints)."""
    w, x, y, z = s.q
    return f"{w:.4f},{x:.4f},{y:.4f},{z:.4f},{s.flex_deg:.2f}\r\n".encode()


Decoder = Union[FrameDecoder, TextDecoder]
