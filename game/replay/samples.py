"""Board samples packed for a session recording, exactly: every field the game reads, bit for bit.

A poll's samples are one binary record (channel :data:`SAMPLES`): each
sample a tag byte and a fixed struct, little-endian. The wire's own
encoding is not used since it drops the device time the decoder unwrapped
and the host's receive time, which the game's pipeline reads.

``R`` raw: t f64, t_us u32, seq u16, acc 3 x i16, gyr 3 x i16, mag 3 x i16,
flex_adc u16, acc_fs_g u8, gyr_fs_dps u16, flags u8 (1 magnetometer read,
2 its overflow, 4 host time known), host_t f64.
``T`` raw with the die's temperature: ``R``'s struct, then temp_counts i16
(the TEMP frame's, PROTOCOL.md sec. 4.3; logs before it hold ``R`` alone).
``F`` fused: t f64, t_us u32, seq u16, q 4 x f64, flex_deg f64, flags u8
(1 device clock known, 4 host time known), host_t f64.
"""

from __future__ import annotations

import struct

from tracker import protocol as P

SAMPLES = 1  # the channel of the samples each poll gave the game (channel 0: the board's bytes)
_RAW = struct.Struct("<dIH3h3h3hHBHBd")
_TEMP = struct.Struct("<h")
_FUSED = struct.Struct("<dIH4ddBd")

Sample = P.RawSample | P.FusedSample


def pack(samples: list[Sample]) -> bytes:
    """One poll's samples as bytes."""
    out = bytearray()
    for s in samples:
        host = s.host_t is not None
        if isinstance(s, P.RawSample):
            mag = s.mag_counts
            flags = (1 if mag is not None else 0) | (2 if s.mag_overflow else 0) | (4 if host else 0)
            out += b"R" if s.temp_counts is None else b"T"
            out += _RAW.pack(s.t, s.t_us, s.seq, *s.acc_counts, *s.gyr_counts, *(mag or (0, 0, 0)),
                             s.flex_adc, s.acc_fs_g, s.gyr_fs_dps, flags, s.host_t if host else 0.0)
            if s.temp_counts is not None:
                out += _TEMP.pack(s.temp_counts)
        else:
            flags = (1 if s.t_us is not None else 0) | (4 if host else 0)
            out += b"F" + _FUSED.pack(s.t, s.t_us or 0, s.seq, *s.q, s.flex_deg, flags, s.host_t if host else 0.0)
    return bytes(out)


def unpack(data: bytes) -> list[Sample]:
    """The samples :func:`pack` packed; a ValueError if the bytes are not such samples."""
    out: list[Sample] = []
    at = 0
    while at < len(data):
        tag, at = data[at:at + 1], at + 1
        size = _RAW.size + (_TEMP.size if tag == b"T" else 0)
        if tag in (b"R", b"T") and at + size <= len(data):
            (t, t_us, seq, ax, ay, az, gx, gy, gz, mx, my, mz, flex, acc_fs, gyr_fs, flags,
             host) = _RAW.unpack_from(data, at)
            temp = _TEMP.unpack_from(data, at + _RAW.size)[0] if tag == b"T" else None
            at += size
            out.append(P.RawSample(t, t_us, seq, (ax, ay, az), (gx, gy, gz), (mx, my, mz) if flags & 1 else None,
                                   flex, acc_fs, gyr_fs, bool(flags & 2), host if flags & 4 else None, temp))
        elif tag == b"F" and at + _FUSED.size <= len(data):
            t, t_us, seq, qw, qx, qy, qz, flex_deg, flags, host = _FUSED.unpack_from(data, at)
            at += _FUSED.size
            out.append(P.FusedSample(t, t_us if flags & 1 else None, seq, (qw, qx, qy, qz), flex_deg,
                                     host if flags & 4 else None))
        else:
            raise ValueError(f"not a sample at byte {at - 1} of a poll's record")
    return out
