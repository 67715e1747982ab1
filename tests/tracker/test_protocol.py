"""Tests of the wire protocol (tracker/protocol.py, specified in firmware/PROTOCOL.md).

Truth comes from outside the module under test wherever possible: the published
CRC catalogue value, a bitwise CRC written here from the polynomial, byte
offsets written out by hand from the spec, unit conversions worked by hand.
Every hypothesis test is derandomised, so the suite is deterministic.
"""

from __future__ import annotations

import math
import random
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tracker import protocol as P
from tracker.board import quantise
from tracker.sim import arm_source

G = 9.80665
MAX_FRAME = P.HEADER_SIZE + 255 + P.CRC_SIZE  # the longest frame any type can have
FLUSH = bytes(MAX_FRAME)  # zeros hold no sync byte: every pending candidate gets judged

i16 = st.integers(-32768, 32767)
u16 = st.integers(0, 0xFFFF)
u32 = st.integers(0, 0xFFFFFFFF)
u8 = st.integers(0, 0xFF)
triple = st.tuples(i16, i16, i16)


# ----------------------------------------------------------------- helpers and strategies


def crc16_reference(data: bytes) -> int:
    """CRC-16/CCITT-FALSE straight from its definition: poly 0x1021, init 0xFFFF,
    MSB first, no reflection, no final xor."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
    return crc


def strip(p: P.Packet) -> P.Packet:
    """A packet without the fields the decoder derives (unwrapped t, host time)."""
    if isinstance(p, (P.RawSample, P.FusedSample)):
        return p._replace(t=0.0, host_t=None)
    return p


def chunked(data: bytes, sizes: list[int]) -> list[bytes]:
    """``data`` cut into pieces whose sizes cycle through ``sizes``."""
    if not sizes:
        return [data]
    out, i, k = [], 0, 0
    while i < len(data):
        n = sizes[k % len(sizes)]
        out.append(data[i:i + n])
        i += n
        k += 1
    return out


def feed_all(dec, pieces: list[bytes]) -> list:
    out = []
    for piece in pieces:
        out += dec.feed(piece)
    return out


@st.composite
def raw_samples(draw, with_mag: bool | None = None) -> P.RawSample:
    t_us = draw(u32)
    has_mag = draw(st.booleans()) if with_mag is None else with_mag
    return P.RawSample(
        t_us * 1e-6, t_us, draw(u16), draw(triple), draw(triple),
        draw(triple) if has_mag else None, draw(st.integers(0, 1023)),
        draw(st.sampled_from(P.ACC_FS_G)), draw(st.sampled_from(P.GYR_FS_DPS)),
        draw(st.booleans()))


@st.composite
def exact_fused_samples(draw) -> P.FusedSample:
    """Fused samples already on the wire's grid (Q14, centidegrees): exact round trip."""
    t_us = draw(u32)
    q = tuple(draw(i16) / P.Q14 for _ in range(4))
    return P.FusedSample(t_us * 1e-6, t_us, draw(u16), q, draw(i16) / 100.0)


@st.composite
def hellos(draw) -> P.Hello:
    version = f"{draw(u8)}.{draw(u8)}.{draw(u8)}"
    return P.Hello(draw(u8), version, draw(u8), draw(u8), draw(u16),
                   draw(st.sampled_from(list(P.Mode))), draw(st.booleans()),
                   draw(st.sampled_from(P.ACC_FS_G)), draw(st.sampled_from(P.GYR_FS_DPS)),
                   P.BoardError(draw(st.integers(0, 0x1F))))


acks = st.builds(P.Ack, st.sampled_from([t for t in P.FrameType if t >= 0x80]),
                 st.sampled_from(list(P.AckStatus)))
commands = st.one_of(
    st.sampled_from([P.Command(t) for t in (P.FrameType.START, P.FrameType.STOP,
                                            P.FrameType.IDENTIFY, P.FrameType.RESET)]),
    st.builds(P.Command, st.just(P.FrameType.SET_RATE), u16),
    st.builds(P.Command, st.just(P.FrameType.SET_MODE), u8))
board_packets = st.one_of(raw_samples(), exact_fused_samples(), hellos(), acks)
chunk_sizes = st.lists(st.integers(1, 40), max_size=8)


# ----------------------------------------------------------------- CRC


def test_crc_check_value_from_the_catalogue():
    # CRC-16/CCITT-FALSE (a.k.a. CRC-16/IBM-3740) check value in the CRC catalogue.
    assert P.crc16(b"123456789") == 0x29B1
    assert crc16_reference(b"123456789") == 0x29B1


def test_crc_of_nothing_is_the_init_value():
    assert P.crc16(b"") == 0xFFFF


@settings(derandomize=True, deadline=None, max_examples=300)
@given(st.binary(max_size=300))
def test_crc_matches_bitwise_reference(data):
    assert P.crc16(data) == crc16_reference(data)


def test_crc_matches_reference_on_seeded_random_blocks():
    rng = random.Random(1234)
    for _ in range(50):
        data = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 260)))
        assert P.crc16(data) == crc16_reference(data)


def test_frame_layout_sync_len_type_payload_crc_little_endian():
    payload = bytes(range(7))
    f = P.frame(0x42, payload)
    assert f[:2] == b"\xa5\x5a"
    assert f[2] == 7 and f[3] == 0x42 and f[4:11] == payload
    assert int.from_bytes(f[11:13], "little") == crc16_reference(bytes([7, 0x42]) + payload)
    assert len(f) == 4 + 7 + 2


# ----------------------------------------------------------------- layout, worked examples


def test_raw_frame_is_32_bytes_and_fits_the_link_budget():
    assert P.RAW_FRAME_SIZE == 32
    s = P.RawSample(0.0, 0, 0, (0, 0, 0), (0, 0, 0), (0, 0, 0), 0)
    assert len(P.encode(s)) == 32
    # 200 Hz * 32 bytes * 10 bits (8N1) / 500000 baud
    assert P.link_utilisation(200) == pytest.approx(200 * 32 * 10 / 500000)
    assert P.link_utilisation(200) == pytest.approx(0.128, abs=1e-4)
    # 1000 Hz, the fastest rate SET_RATE takes, fits the link (it did not at 115200: 278%)
    assert P.link_utilisation(P.MAX_RATE_HZ) == pytest.approx(0.64)
    assert P.link_utilisation(200) <= 0.60


def test_payload_sizes_match_the_spec():
    assert {t.name: n for t, n in P.PAYLOAD_SIZE.items()} == {
        "RAW": 26, "FUSED": 16, "HELLO": 14, "ACK": 2, "TEMP": 6, "START": 0, "STOP": 0,
        "SET_RATE": 2, "SET_MODE": 1, "IDENTIFY": 0, "RESET": 0}


# The worked examples in firmware/PROTOCOL.md.
WORKED_RAW = P.RawSample(1.234567, 1234567, 42, (120, -340, 2048), (-5, 17, 3),
                         (200, -150, -310), 390, 16, 2000)
WORKED_RAW_HEX = ("a5 5a 1a 01 87 d6 12 00 2a 00 78 00 ac fe 00 08 fb ff 11 00 03 00 "
                  "c8 00 6a ff ca fe 86 7d 5f 88")
WORKED_SET_RATE_HEX = "a5 5a 02 83 c8 00 5f 94"


def test_worked_raw_example_bytes():
    data = P.encode(WORKED_RAW)
    assert data == bytes.fromhex(WORKED_RAW_HEX)
    # Offsets within the payload, written out by hand from the spec's table.
    p = data[4:-2]
    le = lambda a, b, signed=True: int.from_bytes(p[a:b], "little", signed=signed)  # noqa: E731
    assert le(0, 4, False) == 1234567
    assert le(4, 6, False) == 42
    assert [le(6 + 2 * i, 8 + 2 * i) for i in range(9)] == [120, -340, 2048, -5, 17, 3,
                                                             200, -150, -310]
    flags = le(24, 26, False)
    assert flags == 390 | 3 << 10 | 3 << 12 | 1 << 14 == 0x7D86
    assert int.from_bytes(data[-2:], "little") == crc16_reference(data[2:-2])


def test_worked_command_example_bytes():
    assert P.encode(P.Command(P.FrameType.SET_RATE, 200)) == bytes.fromhex(WORKED_SET_RATE_HEX)
    assert P.encode(P.Command(P.FrameType.START)) == bytes.fromhex("a5 5a 00 81 a6 9c")


def test_the_spec_shows_exactly_these_bytes():
    """The worked examples in firmware/PROTOCOL.md are what the encoder produces."""
    spec = Path(__file__).resolve().parents[2] / "firmware" / "PROTOCOL.md"
    text = " ".join(spec.read_text().replace("`", " ").split())
    examples = [
        WORKED_RAW,
        P.Command(P.FrameType.SET_RATE, 200),
        P.Ack(P.FrameType.SET_RATE, P.AckStatus.OK),
        P.Command(P.FrameType.START), P.Command(P.FrameType.STOP),
        P.Command(P.FrameType.IDENTIFY), P.Command(P.FrameType.RESET),
        P.Command(P.FrameType.SET_MODE, int(P.Mode.FUSED)),
        P.Hello(1, "1.0.0", 0x71, 0x48, 200, P.Mode.RAW, True, 16, 2000, P.BoardError.NONE),
        P.FusedSample(0.5, 500000, 7, (math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0), 30.25),
    ]
    for packet in examples:
        assert P.encode(packet).hex(" ") in text, packet


def test_raw_flag_bits():
    base = dict(t=0.0, t_us=0, seq=0, acc_counts=(0, 0, 0), gyr_counts=(0, 0, 0))

    def flags(**kw):
        return int.from_bytes(P.encode(P.RawSample(**base, **kw))[28:30], "little")

    assert flags(mag_counts=None, flex_adc=1023, acc_fs_g=2, gyr_fs_dps=250) == 0x03FF
    assert flags(mag_counts=None, flex_adc=0, acc_fs_g=4, gyr_fs_dps=250) == 1 << 10
    assert flags(mag_counts=None, flex_adc=0, acc_fs_g=8, gyr_fs_dps=250) == 2 << 10
    assert flags(mag_counts=None, flex_adc=0, acc_fs_g=2, gyr_fs_dps=500) == 1 << 12
    assert flags(mag_counts=None, flex_adc=0, acc_fs_g=2, gyr_fs_dps=1000) == 2 << 12
    assert flags(mag_counts=(0, 0, 0), flex_adc=0, acc_fs_g=2, gyr_fs_dps=250) == 1 << 14
    assert flags(mag_counts=None, flex_adc=0, acc_fs_g=2, gyr_fs_dps=250,
                 mag_overflow=True) == 1 << 15


def test_fused_and_hello_layout():
    f = P.encode(P.FusedSample(0.5, 500000, 7, (0.5, -0.5, 0.25, -1.0), -12.34))
    p = f[4:-2]
    assert f[2:4] == bytes([16, 0x02])
    assert int.from_bytes(p[0:4], "little") == 500000
    assert int.from_bytes(p[4:6], "little") == 7
    assert [int.from_bytes(p[6 + 2 * i:8 + 2 * i], "little", signed=True) for i in range(5)] \
        == [8192, -8192, 4096, -16384, -1234]
    h = P.encode(P.Hello(1, "2.3.4", 0x71, 0x48, 500, P.Mode.FUSED, True, 8, 1000,
                         P.BoardError.OVERRUN | P.BoardError.MAG_MISSING))
    assert h[2:4] == bytes([14, 0x03])
    assert h[4:-2] == bytes([1, 2, 3, 4, 0x71, 0x48, 0xF4, 0x01, 1, 1, 2, 2, 0x14, 0x00])


def test_ack_and_command_layout():
    assert P.encode(P.Ack(P.FrameType.SET_MODE, P.AckStatus.BAD_ARGUMENT))[2:6] \
        == bytes([2, 0x04, 0x84, 0x01])
    assert P.encode(P.Command(P.FrameType.SET_MODE, 1))[2:5] == bytes([1, 0x84, 1])
    for t in (P.FrameType.START, P.FrameType.STOP, P.FrameType.IDENTIFY, P.FrameType.RESET):
        assert P.encode(P.Command(t))[2:4] == bytes([0, t])


def test_encoder_rejects_a_full_scale_the_flags_cannot_carry():
    with pytest.raises(ValueError):
        P.encode(P.RawSample(0.0, 0, 0, (0, 0, 0), (0, 0, 0), None, 0, acc_fs_g=3))


# ----------------------------------------------------------------- conversions


def _raw(acc=(0, 0, 0), gyr=(0, 0, 0), mag=None, acc_fs=16, gyr_fs=2000) -> P.RawSample:
    return P.RawSample(0.0, 0, 0, acc, gyr, mag, 0, acc_fs, gyr_fs)


def test_accel_conversion_worked_by_hand():
    # At +-16 g one g is 32768 / 16 = 2048 counts.
    assert _raw(acc=(2048, -2048, 0)).acc == pytest.approx((G, -G, 0.0), abs=1e-12)
    # At +-2 g one g is 16384 counts.
    assert _raw(acc=(16384, 0, 0), acc_fs=2).acc[0] == pytest.approx(9.80665, abs=1e-12)
    assert _raw(acc=(-32768, 0, 0), acc_fs=4).acc[0] == pytest.approx(-4 * 9.80665, abs=1e-12)
    assert _raw(acc=(4096, 0, 0), acc_fs=8).acc[0] == pytest.approx(9.80665, abs=1e-12)


def test_gyro_conversion_worked_by_hand():
    # Full scale: 32767 counts at +-2000 deg/s is 2000 * 32767/32768 deg/s.
    full = 2000 * math.pi / 180 * 32767 / 32768
    assert _raw(gyr=(32767, 0, 0)).gyr[0] == pytest.approx(full, rel=1e-12)
    assert full == pytest.approx(34.90552, abs=1e-5)
    # Half scale at +-250 deg/s is 125 deg/s = 2.18166 rad/s.
    assert _raw(gyr=(0, 16384, 0), gyr_fs=250).gyr[1] == pytest.approx(2.1816615649929116,
                                                                       rel=1e-12)
    # 16.4 counts per deg/s at 2000 dps (data sheet sensitivity, 32768/2000 = 16.384).
    assert _raw(gyr=(0, 0, 16384), gyr_fs=2000).gyr[2] == pytest.approx(math.radians(1000))


def test_mag_conversion_is_0_15_microtesla_per_count():
    assert _raw(mag=(100, -200, 1)).mag == pytest.approx((15.0, -30.0, 0.15))
    assert _raw(mag=None).mag is None


def test_board_quantisation_inverts_host_conversion():
    """The virtual board's counts, converted back by the host, are within half an LSB."""
    arm = arm_source(rate_hz=100.0)
    for t in (0.0, 0.37, 1.1, 2.5, 3.9):
        r = arm.reading(t)
        for acc_fs in P.ACC_FS_G:
            for gyr_fs in P.GYR_FS_DPS:
                s = quantise(r, t, 0, 0, acc_fs, gyr_fs)
                s = P.FrameDecoder().feed(P.encode(s))[0]
                acc_lsb = acc_fs * G / 32768
                gyr_lsb = math.radians(gyr_fs) / 32768
                for got, want in zip(s.acc, r.acc):
                    assert abs(got - want) <= acc_lsb / 2 + 1e-12
                for got, want in zip(s.gyr, r.gyr):
                    assert abs(got - want) <= gyr_lsb / 2 + 1e-12
                for got, want in zip(s.mag, r.mag):
                    assert abs(got - want) <= 0.075 + 1e-12
                assert s.flex_adc == r.flex_adc


# ----------------------------------------------------------------- round trips


@settings(derandomize=True, deadline=None, max_examples=200)
@given(raw_samples())
def test_raw_round_trip(s):
    out = P.FrameDecoder().feed(P.encode(s))
    assert out == [s]  # the first sample's t is t_us * 1e-6, as built


@settings(derandomize=True, deadline=None, max_examples=50)
@given(raw_samples(with_mag=False))
def test_raw_round_trip_without_mag(s):
    (out,) = P.FrameDecoder().feed(P.encode(s))
    assert out.mag_counts is None and out.mag is None
    assert out == s


@settings(derandomize=True, deadline=None, max_examples=200)
@given(st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4),
       st.floats(-327.0, 327.0), u32, u16)
def test_fused_round_trip_quantises_to_q14_and_centidegrees(q, flex, t_us, seq):
    s = P.FusedSample(0.0, t_us, seq, tuple(q), flex)
    (out,) = P.FrameDecoder().feed(P.encode(s))
    assert isinstance(out, P.FusedSample)
    assert out.t_us == t_us and out.seq == seq and out.t == pytest.approx(t_us * 1e-6)
    for got, want in zip(out.q, q):
        assert abs(got - want) <= 0.5 / 16384 + 1e-12
    assert abs(out.flex_deg - flex) <= 0.005 + 1e-9


@settings(derandomize=True, deadline=None, max_examples=100)
@given(exact_fused_samples())
def test_fused_on_the_grid_round_trips_exactly(s):
    assert P.FrameDecoder().feed(P.encode(s)) == [s]


def test_fused_saturates_instead_of_wrapping():
    (out,) = P.FrameDecoder().feed(P.encode(P.FusedSample(0, 0, 0, (2.5, -3.0, 0, 0), 500.0)))
    assert out.q[0] == 32767 / 16384 and out.q[1] == -2.0
    assert out.flex_deg == 327.67


@settings(derandomize=True, deadline=None, max_examples=100)
@given(hellos())
def test_hello_round_trip(h):
    assert P.FrameDecoder().feed(P.encode(h)) == [h]
    assert P.Hello.from_json(h.to_json()) == h


@settings(derandomize=True, deadline=None, max_examples=50)
@given(acks)
def test_ack_round_trip(a):
    assert P.FrameDecoder().feed(P.encode(a)) == [a]


@settings(derandomize=True, deadline=None, max_examples=100)
@given(commands)
def test_command_round_trip_on_a_board_decoder(c):
    board = P.FrameDecoder(accept_commands=True)
    assert board.feed(P.encode(c)) == [c]
    assert board.stats.frames == 1 and board.stats.unknown == 0


@pytest.mark.parametrize("ftype", [t for t in P.FrameType if t >= 0x80])
def test_host_decoder_ignores_commands(ftype):
    c = P.Command(ftype, 7 if ftype in (P.FrameType.SET_RATE, P.FrameType.SET_MODE) else None)
    host = P.FrameDecoder()
    after = P.RawSample(0.0, 0, 0, (1, 2, 3), (4, 5, 6), None, 7)
    assert host.feed(P.encode(c) + P.encode(after)) == [after]
    assert host.stats.unknown == 1 and host.stats.frames == 2 and host.stats.crc_errors == 0


def test_board_decoder_still_decodes_board_frames():
    s = P.RawSample(0.0, 0, 3, (1, 2, 3), (4, 5, 6), None, 7)
    assert P.FrameDecoder(accept_commands=True).feed(P.encode(s)) == [s]


def test_host_time_is_attached():
    s = P.RawSample(0.0, 0, 0, (1, 2, 3), (4, 5, 6), None, 7)
    (out,) = P.FrameDecoder().feed(P.encode(s), host_t=12.5)
    assert out.host_t == 12.5


def test_ack_with_an_unknown_status_reads_as_a_failure():
    (a,) = P.FrameDecoder().feed(P.frame(P.FrameType.ACK, bytes([0x83, 0x77])))
    assert a == P.Ack(P.FrameType.SET_RATE, P.AckStatus.BAD_ARGUMENT)


# ----------------------------------------------------------------- unknown and malformed frames


def test_unknown_frame_type_is_counted_and_skipped():
    after = P.FusedSample(0.0, 10, 1, (1.0, 0.0, 0.0, 0.0), 5.0)
    for ftype, payload in ((0x10, b"future"), (0x7F, bytes(255)), (0x90, b""), (0xFF, b"\xa5\x5a")):
        dec = P.FrameDecoder(accept_commands=True)
        out = dec.feed(P.frame(ftype, payload) + P.encode(after))
        assert [strip(p) for p in out] == [strip(after)]
        assert dec.stats.unknown == 1 and dec.stats.frames == 2
        assert dec.stats.bytes_skipped == 0 and dec.stats.crc_errors == 0


def test_known_type_with_wrong_length_is_rejected_even_with_a_valid_crc():
    after = P.RawSample(0.0, 0, 0, (1, 2, 3), (4, 5, 6), None, 7)
    bogus = P.frame(P.FrameType.RAW, bytes(10))
    dec = P.FrameDecoder()
    assert dec.feed(bogus + P.encode(after)) == [after]
    assert dec.stats.frames == 1 and dec.stats.bytes_skipped == len(bogus)


@settings(derandomize=True, deadline=None, max_examples=200)
@given(st.sampled_from(sorted(P.PAYLOAD_SIZE)), st.data(), st.booleans())
def test_any_payload_of_a_known_type_decodes_without_raising(ftype, data, board):
    payload = data.draw(st.binary(min_size=P.PAYLOAD_SIZE[ftype], max_size=P.PAYLOAD_SIZE[ftype]))
    dec = P.FrameDecoder(accept_commands=board)
    out = dec.feed(P.frame(ftype, payload))
    assert dec.stats.frames == 1
    assert len(out) + dec.stats.unknown == (0 if ftype == P.FrameType.TEMP else 1)  # a TEMP frame
    # is no packet: it stamps the raw samples after it (test_a_temp_frame_stamps_the_samples_after_it)


# ----------------------------------------------------------------- incremental decoding


@settings(derandomize=True, deadline=None, max_examples=100)
@given(st.lists(board_packets, max_size=12), chunk_sizes)
def test_chunking_does_not_change_the_result(packets, sizes):
    stream = b"".join(P.encode(p) for p in packets)
    whole = P.FrameDecoder()
    expected = whole.feed(stream)
    assert [strip(p) for p in expected] == [strip(p) for p in packets]
    for pieces in (chunked(stream, sizes), chunked(stream, [1])):
        dec = P.FrameDecoder()
        assert feed_all(dec, pieces) == expected
        assert dec.stats == whole.stats


def test_seeded_random_chunking_of_a_long_stream():
    rng = random.Random(2024)
    packets = [P.RawSample(0.0, 5000 * i, i, (i, -i, 2048), (3, 2, 1), (i % 7, 0, -1), i % 1024)
               for i in range(300)]
    stream = b"".join(map(P.encode, packets))
    pieces, i = [], 0
    while i < len(stream):
        n = rng.randrange(1, 100)
        pieces.append(stream[i:i + n])
        i += n
    dec = P.FrameDecoder()
    out = feed_all(dec, pieces)
    assert [strip(p) for p in out] == [strip(p) for p in packets]
    assert [p.t for p in out] == pytest.approx([0.005 * i for i in range(300)])
    assert dec.stats.frames == 300 and dec.stats.dropped == 0 and dec.stats.bytes_skipped == 0


@settings(derandomize=True, deadline=None, max_examples=300)
@given(st.binary(max_size=600), chunk_sizes, st.booleans())
def test_any_bytes_never_raise_and_stats_are_consistent(data, sizes, board):
    dec = P.FrameDecoder(accept_commands=board)
    fed = 0
    for piece in chunked(data, sizes):
        dec.feed(piece)
        fed += len(piece)
        assert 0 <= dec.stats.bytes_skipped <= fed
    whole = P.FrameDecoder(accept_commands=board)
    whole.feed(data)
    assert whole.stats == dec.stats
    dec.feed(FLUSH)
    if dec.stats.frames == 0:  # every byte fed was garbage and is now accounted for
        assert dec.stats.bytes_skipped == len(data) + len(FLUSH)


@settings(derandomize=True, deadline=None, max_examples=150)
@given(st.lists(st.tuples(st.binary(max_size=80), board_packets), max_size=10),
       st.binary(max_size=80), chunk_sizes)
def test_frames_between_garbage_are_all_recovered_in_order(pairs, tail, sizes):
    packets = [p for _, p in pairs]
    stream = b"".join(g + P.encode(p) for g, p in pairs) + tail + FLUSH
    dec = P.FrameDecoder()
    out = feed_all(dec, chunked(stream, sizes))
    assert [strip(p) for p in out] == [strip(p) for p in packets]
    assert dec.stats.frames == len(packets)
    frame_bytes = sum(len(P.encode(p)) for p in packets)
    assert dec.stats.bytes_skipped == len(stream) - frame_bytes


@settings(derandomize=True, deadline=None, max_examples=300)
@given(st.lists(st.tuples(board_packets, st.booleans()), min_size=1, max_size=10),
       st.data(), chunk_sizes)
def test_single_byte_corruption_rejects_only_the_hit_frames(items, data, sizes):
    stream, intact, frame_bytes, must_fail_crc = b"", [], 0, 0
    for packet, hit in items:
        f = bytearray(P.encode(packet))
        if hit:
            at = data.draw(st.integers(0, len(f) - 1), label="byte")
            f[at] ^= data.draw(st.integers(1, 255), label="xor")
            length, ftype = f[2], f[3]
            # Once sync, len and type pass the header check the CRC is what rejects
            # the frame; a hit sync or length byte is just skipped bytes.
            if f[:2] == P.SYNC and P.PAYLOAD_SIZE.get(ftype, length) == length:
                must_fail_crc += 1
                assert at >= 3
        else:
            intact.append(packet)
            frame_bytes += len(f)
        stream += bytes(f)
    stream += FLUSH
    dec = P.FrameDecoder()
    out = feed_all(dec, chunked(stream, sizes))
    assert [strip(p) for p in out] == [strip(p) for p in intact]
    assert dec.stats.frames == len(intact)
    assert dec.stats.crc_errors >= must_fail_crc
    assert dec.stats.bytes_skipped == len(stream) - frame_bytes


def test_corrupting_every_single_byte_of_a_frame():
    """Exhaustive over positions: one bad frame between two good ones."""
    before = P.RawSample(0.0, 1000, 1, (1, 2, 3), (4, 5, 6), (7, 8, 9), 10)
    victim = P.RawSample(0.0, 2000, 2, (-1, -2, -3), (-4, -5, -6), None, 20)
    after = P.RawSample(0.0, 3000, 3, (11, 12, 13), (14, 15, 16), (17, 18, 19), 30)
    good = P.encode(victim)
    for at in range(len(good)):
        for xor in (0x01, 0x80, 0xFF):
            bad = bytearray(good)
            bad[at] ^= xor
            dec = P.FrameDecoder()
            out = dec.feed(P.encode(before) + bytes(bad) + P.encode(after) + FLUSH)
            assert [strip(p) for p in out] == [strip(before), strip(after)], (at, xor)
            assert dec.stats.dropped == 1  # seq 1 -> 3
            if at >= 4:  # payload or CRC: the header passed, the CRC must catch it
                assert dec.stats.crc_errors >= 1, (at, xor)


# ----------------------------------------------------------------- sequence and clock


def _seq_stream(seqs, t_step_us=5000, fused_every=0):
    """Samples numbered ``seqs`` from one board: the clock advances one period per number (sec. 7.3)."""
    out = []
    t_us = 0
    for i, seq in enumerate(seqs):
        if i:
            t_us += ((seq - seqs[i - 1]) & 0xFFFF) * t_step_us
        if fused_every and i % fused_every == 0:
            out.append(P.FusedSample(0.0, t_us, seq, (1.0, 0.0, 0.0, 0.0), 0.0))
        else:
            out.append(P.RawSample(0.0, t_us, seq, (0, 0, 0), (0, 0, 0), None, 0))
    return b"".join(map(P.encode, out))


def test_sequence_gaps_are_counted_as_dropped():
    dec = P.FrameDecoder()
    dec.feed(_seq_stream([10, 11, 12, 15, 16, 20]))
    assert dec.stats.dropped == 2 + 3


def test_sequence_wraps_at_16_bits():
    dec = P.FrameDecoder()
    dec.feed(_seq_stream([65533, 65534, 65535, 0, 1]))
    assert dec.stats.dropped == 0
    dec = P.FrameDecoder()
    dec.feed(_seq_stream([65534, 1]))  # 65535 and 0 are missing
    assert dec.stats.dropped == 2


def test_raw_and_fused_share_one_sequence():
    dec = P.FrameDecoder()
    out = dec.feed(_seq_stream(range(100, 110), fused_every=3))
    assert {type(p) for p in out} == {P.RawSample, P.FusedSample}
    assert dec.stats.dropped == 0


@settings(derandomize=True, deadline=None, max_examples=100)
@given(u16, st.lists(st.integers(1, 300), min_size=1, max_size=20))
def test_dropped_equals_the_samples_missing(first, steps):
    seqs = [first]
    for s in steps:
        seqs.append((seqs[-1] + s) & 0xFFFF)
    dec = P.FrameDecoder()
    dec.feed(_seq_stream(seqs))
    assert dec.stats.dropped == sum(s - 1 for s in steps)


def test_device_clock_unwraps_across_2_32_microseconds():
    start = 2**32 - 3000
    t_us = [(start + 1000 * k) & 0xFFFFFFFF for k in range(8)]
    assert t_us[3] == 0  # the counter wraps here
    stream = b"".join(P.encode(P.RawSample(0.0, t, k, (0, 0, 0), (0, 0, 0), None, 0))
                      for k, t in enumerate(t_us))
    out = feed_all(P.FrameDecoder(), chunked(stream, [1]))
    assert [p.t_us for p in out] == t_us
    ts = [p.t for p in out]
    assert all(b > a for a, b in zip(ts, ts[1:]))
    assert ts == pytest.approx([(start + 1000 * k) * 1e-6 for k in range(8)], abs=1e-9)


def test_device_clock_unwraps_many_times():
    step = 2**30  # less than half the range: every wrap is unambiguous
    t_us = [(step * k) & 0xFFFFFFFF for k in range(20)]
    stream = b"".join(P.encode(P.FusedSample(0.0, t, k, (1.0, 0.0, 0.0, 0.0), 0.0))
                      for k, t in enumerate(t_us))
    out = P.FrameDecoder().feed(stream)
    assert [p.t for p in out] == pytest.approx([step * k * 1e-6 for k in range(20)])


# ----------------------------------------------------------------- paper text mode


def test_text_paper_line():
    dec = P.TextDecoder()
    (s,) = dec.feed(b"0.7071,0.7071,0.0000,0.0000,30.00\n", host_t=3.5)
    assert s.q == pytest.approx((math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0), abs=1e-9)
    assert math.sqrt(sum(c * c for c in s.q)) == pytest.approx(1.0)
    assert s.flex_deg == 30.0 and s.t_us is None and s.t == 3.5 and s.host_t == 3.5
    assert dec.stats.frames == 1 and dec.stats.bad_lines == 0


def test_text_separators_crlf_and_labels():
    dec = P.TextDecoder()
    out = dec.feed(b"1 0 0 0 10\r\n1\t0\t0\t0\t20\r\n1, 0, 0, 0, 30\r\n"
                   b"q: 1 0 0 0 flex: 40\r\nw=1.0 x=-0.0 y=+0.0 z=0 flex=-5.5e1\n")
    assert [s.flex_deg for s in out] == [10.0, 20.0, 30.0, 40.0, -55.0]
    assert all(s.q == pytest.approx((1.0, 0.0, 0.0, 0.0)) for s in out)
    assert [s.seq for s in out] == [1, 2, 3, 4, 5]
    assert dec.stats.bad_lines == 0


def test_text_line_split_across_chunks():
    line = b"0.5000,0.5000,0.5000,0.5000,12.25\r\n"
    dec = P.TextDecoder()
    out = feed_all(dec, chunked(line * 3, [1]))
    assert len(out) == 3 and all(s.flex_deg == 12.25 for s in out)
    assert dec.feed(line[:10]) == [] and len(dec.feed(line[10:])) == 1


def test_text_xyzw_order():
    (s,) = P.TextDecoder(order="xyzw").feed(b"0.0,0.0,0.7071,0.7071,15\n")
    assert s.q == pytest.approx((math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)), abs=1e-9)
    (s,) = P.TextDecoder(order="wxyz").feed(b"0.0,0.0,0.7071,0.7071,15\n")
    assert s.q == pytest.approx((0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)), abs=1e-9)


@pytest.mark.parametrize("line", [
    b"1,0,0,0\n",  # four numbers
    b"1,0,0,0,30,5\n",  # six
    b"\n",  # empty
    b"nan,0,0,0,30\n",
    b"1,0,0,0,nan\n",
    b"1,0,0,0,1e999\n",  # overflows to inf
    b"2,0,0,0,30\n",  # far from unit norm
    b"0,0,0,0,30\n",
    b"\xa5\x5a\x1a\x01\x00\xff\x10\x80\n",  # binary frame junk
    b"hello board\r\n",
    b"1,0,0,0," + b" " * 300 + b"30\n",  # too long
])
def test_text_bad_lines_are_counted_not_raised(line):
    dec = P.TextDecoder()
    assert dec.feed(line + b"1,0,0,0,7\n") == [P.FusedSample(0.0, None, 1, (1.0, 0.0, 0.0, 0.0),
                                                             7.0)]
    assert dec.stats.bad_lines == 1 and dec.stats.frames == 1
    assert dec.stats.bytes_skipped == len(line)


def test_text_overlong_line_without_newline_is_dropped_whole():
    """Whatever follows an overlong prefix up to its newline belongs to the bad line."""
    junk, tail = b"x" * 300, b"1,0,0,0,30\n"
    whole = P.TextDecoder()
    assert whole.feed(junk + tail) == []
    split = P.TextDecoder()
    assert split.feed(junk) == [] and split.feed(b"x" * 500) == [] and split.feed(tail) == []
    assert split.stats.bad_lines == whole.stats.bad_lines == 1
    assert split.stats.bytes_skipped == 300 + 500 + len(tail)
    assert len(split.feed(b"1,0,0,0,31\n")) == 1  # and the next line is read again


def test_text_format_line_round_trip():
    s = P.FusedSample(0.0, None, 1, (0.5, -0.5, 0.5, -0.5), -12.5)
    line = P.format_text_line(s)
    assert line == b"0.5000,-0.5000,0.5000,-0.5000,-12.50\r\n"
    (out,) = P.TextDecoder().feed(line)
    assert out.q == pytest.approx(s.q) and out.flex_deg == -12.5


@settings(derandomize=True, deadline=None, max_examples=300)
@given(st.lists(st.one_of(st.binary(max_size=60),
                          st.sampled_from([b"\n", b"\r\n", b"1,0,0,0,5\n", b"x" * 200,
                                           b"0.6,0.8,0,0,1\r\n", b"1 0 0"])),
                max_size=20),
       chunk_sizes)
def test_text_any_bytes_never_raise_and_chunking_does_not_matter(parts, sizes):
    data = b"".join(parts) + b"\n"
    whole = P.TextDecoder()
    expected = whole.feed(data)
    dec = P.TextDecoder()
    assert feed_all(dec, chunked(data, sizes)) == expected
    assert dec.stats == whole.stats
    # Every line is exactly one of: a sample, a bad line.
    assert dec.stats.frames + dec.stats.bad_lines == data.count(b"\n")
    assert dec.stats.bytes_skipped <= len(data)
    for s in expected:
        assert math.sqrt(sum(c * c for c in s.q)) == pytest.approx(1.0)
        assert math.isfinite(s.flex_deg)


def test_a_raw_frames_flags_word_worked_by_hand():
    # flex ADC 513 in bits 0-9; 16 g is accelerometer code 3 (bits 10-11), 2000 deg/s gyroscope
    # code 3 (bits 12-13); bit 14 a magnetometer reading, bit 15 its overflow
    assert P.raw_flags(513, 16, 2000) == 513 + (3 << 10) + (3 << 12) + (1 << 14)
    assert P.raw_flags(513, 2, 250, has_mag=False) == 513
    assert P.raw_flags(1023 + 1024, 4, 500, mag_overflow=True) == 1023 + (1 << 10) + (1 << 12) + (1 << 14) + (1 << 15)


def test_a_frame_packed_from_its_fields_decodes_to_them():
    frame = P.encode_raw_counts(123_456, 7, (1, -2, 3), (-4, 5, -6), (7, 8, -9), P.raw_flags(600, 8, 1000))
    (s,) = P.FrameDecoder().feed(frame)
    assert (s.t_us, s.seq, s.acc_counts, s.gyr_counts, s.mag_counts, s.flex_adc, s.acc_fs_g, s.gyr_fs_dps) \
        == (123_456, 7, (1, -2, 3), (-4, 5, -6), (7, 8, -9), 600, 8, 1000)
