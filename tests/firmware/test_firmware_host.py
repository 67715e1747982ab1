"""The firmware's portable C, compiled for the host, against tracker.protocol and the
Python complementary filter (firmware/PROTOCOL.md; Zhu & Shi, sec. 3)."""

from __future__ import annotations

import binascii
import ctypes as C
import math
import random
import re
import struct
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tracker import protocol as P
from tracker.flex import FlexCircuit
from tracker.fusion import make
from tracker.fusion.complementary import ComplementaryState
from tracker.mpu_dlpf import dlpf_for_rate
from tracker.sim import Simulator, arm_chain, arm_swing, mpu9250

from .firmware_lib import (Command, Filter, Fused, Grid, Hello, Mag, Parser, Rail, Raw, State,
                           Still, TimerPlan, build_host_library, frame_buffer)

F32 = np.float32


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    return build_host_library(tmp_path_factory.mktemp("firmware-host"))


def encode(lib, fn, record) -> bytes:
    out = frame_buffer()
    n = getattr(lib, fn)(out, C.byref(record))
    return bytes(out[:n])


def c_raw(lib, s: P.RawSample) -> bytes:
    mag = s.mag_counts or (0, 0, 0)
    rec = Raw(s.t_us, s.seq, (C.c_int16 * 3)(*s.acc_counts), (C.c_int16 * 3)(*s.gyr_counts),
              (C.c_int16 * 3)(*mag), s.flex_adc, P.ACC_FS_G.index(s.acc_fs_g),
              P.GYR_FS_DPS.index(s.gyr_fs_dps), s.mag_counts is not None, s.mag_overflow)
    return encode(lib, "eb_encode_raw", rec)


def c_fused(lib, s: P.FusedSample) -> bytes:
    return encode(lib, "eb_encode_fused", Fused(s.t_us, s.seq, (C.c_float * 4)(*s.q), s.flex_deg))


def c_hello(lib, h: P.Hello) -> bytes:
    major, minor, patch = (int(v) for v in h.firmware.split("."))
    rec = Hello(major, minor, patch, h.imu_whoami, h.mag_whoami, h.rate_hz, int(h.mode),
                int(h.streaming), P.ACC_FS_G.index(h.acc_fs_g), P.GYR_FS_DPS.index(h.gyr_fs_dps),
                int(h.errors))
    return encode(lib, "eb_encode_hello", rec)


def decode_one(data: bytes):
    d = P.FrameDecoder()
    packets = d.feed(data)
    assert d.stats.frames == 1 and d.stats.bytes_skipped == 0 and len(packets) == 1
    return packets[0]


# ------------------------------------------------------------------ CRC and frames


def test_crc_is_ccitt_false(lib):
    assert lib.eb_crc16(b"123456789", 9, 0xFFFF) == 0x29B1
    assert lib.eb_crc16(b"", 0, 0xFFFF) == 0xFFFF
    rng = random.Random(1)
    for n in range(0, 300, 7):
        data = bytes(rng.randrange(256) for _ in range(n))
        assert lib.eb_crc16(data, n, 0xFFFF) == binascii.crc_hqx(data, 0xFFFF)


def test_raw_frame_worked_example(lib):
    s = P.RawSample(0.0, 1234567, 42, (120, -340, 2048), (-5, 17, 3), (200, -150, -310), 390)
    expected = bytes.fromhex("a55a1a0187d612002a007800acfe0008fbff11000300c8006affcafe867d5f88")
    assert c_raw(lib, s) == expected == P.encode_raw(s)


def random_raw(rng: random.Random) -> P.RawSample:
    i16 = lambda: rng.randrange(-32768, 32768)  # noqa: E731
    return P.RawSample(0.0, rng.randrange(2**32), rng.randrange(2**16), (i16(), i16(), i16()),
                       (i16(), i16(), i16()), rng.choice([None, (i16(), i16(), i16())]),
                       rng.randrange(1024), rng.choice(P.ACC_FS_G), rng.choice(P.GYR_FS_DPS),
                       rng.random() < 0.3)


def test_raw_frames_match_the_host_encoder_byte_for_byte(lib):
    rng = random.Random(2)
    for _ in range(500):
        s = random_raw(rng)
        data = c_raw(lib, s)
        assert data == P.encode_raw(s)
        got = decode_one(data)
        assert (got.t_us, got.seq, got.acc_counts, got.gyr_counts, got.mag_counts, got.flex_adc,
                got.acc_fs_g, got.gyr_fs_dps, got.mag_overflow) == \
               (s.t_us, s.seq, s.acc_counts, s.gyr_counts, s.mag_counts, s.flex_adc,
                s.acc_fs_g, s.gyr_fs_dps, s.mag_overflow)


def test_fused_frame_worked_example(lib):
    s = P.FusedSample(0.0, 500000, 7, (0.70711, 0.70711, 0.0, 0.0), 30.25)
    expected = bytes.fromhex("a55a1002 20a10700 0700412d 412d0000 0000d10b 2189".replace(" ", ""))
    assert c_fused(lib, s) == expected == P.encode_fused(s)


def test_fused_frames_match_the_host_encoder_byte_for_byte(lib):
    """Quaternion components of any float32 value (x 16384 is exact), saturation
    included, and flex angles in quarter degrees (x 100 exact in float)."""
    rng = np.random.default_rng(3)
    for _ in range(500):
        q = [float(F32(v)) for v in rng.normal(0, 0.8, 4)]
        flex = float(rng.integers(-1400, 1400)) / 4 if rng.random() < 0.9 else rng.choice([-400.0, 400.0])
        s = P.FusedSample(0.0, int(rng.integers(2**32)), int(rng.integers(2**16)), tuple(q), flex)
        data = c_fused(lib, s)
        assert data == P.encode_fused(s)
        got = decode_one(data)
        assert got.seq == s.seq and got.t_us == s.t_us


def test_q14_and_centidegree_rounding_agree_with_python(lib):
    for x in (0.5 / 16384, 1.5 / 16384, 2.5 / 16384, -2.5 / 16384, 1.0, 2.0, -2.0, 0.999969):
        assert lib.eb_q14(x) == max(-32768, min(32767, round(float(F32(x)) * 16384)))
    rng = np.random.default_rng(4)
    for deg in rng.uniform(-350, 350, 2000).astype(F32):
        # float32 x 100 may round across a half: the C value is within 1 centidegree
        assert abs(lib.eb_centi(float(deg)) - max(-32768, min(32767, round(float(deg) * 100)))) <= 1


def test_hello_frames_match_the_host_encoder(lib):
    reference = P.Hello(1, "1.0.0", 0x71, 0x48, 200, P.Mode.RAW, True, 16, 2000, P.BoardError.NONE)
    assert c_hello(lib, reference) == bytes.fromhex("a55a0e0301010000 7148c80000010303 0000a7dd"
                                                     .replace(" ", ""))
    variants = [
        P.Hello(1, "1.0.0", 0x73, 0, 1000, P.Mode.FUSED, False, 2, 250, P.BoardError.MAG_MISSING),
        P.Hello(1, "1.0.0", 0x70, 0, 1, P.Mode.RAW, True, 8, 1000,
                P.BoardError.IMU_MISSING | P.BoardError.I2C_FAILURE | P.BoardError.OVERRUN),
        P.Hello(1, "1.0.0", 0, 0, 200, P.Mode.RAW, True, 16, 2000, P.BoardError.FLEX_RAIL),
    ]
    for h in [reference, *variants]:
        data = c_hello(lib, h)
        assert data == P.encode_hello(h)
        assert decode_one(data) == h


def test_ack_frames_match_the_host_encoder(lib):
    for cmd in range(0x81, 0x87):
        for status in P.AckStatus:
            out = frame_buffer()
            n = lib.eb_encode_ack(out, cmd, int(status))
            assert bytes(out[:n]) == P.encode_ack(P.Ack(cmd, status))
    out = frame_buffer()
    n = lib.eb_encode_ack(out, P.FrameType.SET_RATE, 0)
    assert bytes(out[:n]).hex() == "a55a02048300a3fb"  # PROTOCOL.md 11.2


# ------------------------------------------------------------------ TEMP frames (PROTOCOL.md 4.3)

PROTOCOL_MD = Path(__file__).resolve().parents[2] / "firmware" / "PROTOCOL.md"
TEMP_TYPE, TEMP_LEN = 0x05, 6
RATE_HZ = 200  # the boot rate


def temp_frame(t_us: int, temp_counts: int) -> bytes:
    """A TEMP frame as PROTOCOL.md 2 and 4.3 describe it, encoded here and not by tracker.protocol:
    sync, len 6, type 0x05, u32 t_us and i16 temp_counts little endian, CRC-16/CCITT-FALSE
    over len, type and payload, little endian."""
    body = struct.pack("<BBIh", TEMP_LEN, TEMP_TYPE, t_us, temp_counts)
    return b"\xa5\x5a" + body + struct.pack("<H", binascii.crc_hqx(body, 0xFFFF))


def c_temp(lib, t_us: int, temp_counts: int) -> bytes:
    out = frame_buffer()
    n = lib.eb_encode_temp(out, t_us, temp_counts)
    return bytes(out[:n])


def documented_temp_frames() -> list[bytes]:
    """The frames in the code blocks of PROTOCOL.md 11.4, in order."""
    section = PROTOCOL_MD.read_text().split("### 11.4 ", 1)[1]
    return [bytes.fromhex(block) for block in re.findall(r"```\n([0-9a-f ]+)\n```", section)]


def test_temp_frame_worked_examples(lib):
    """PROTOCOL.md 11.4: the TEMP frame before 11.1's RAW frame with the die at 25 degC, and one
    of a die at 0 degC (a negative count)."""
    warm, cold = documented_temp_frames()
    assert warm.hex(" ") == "a5 5a 06 05 87 d6 12 00 37 05 3c 14"
    assert round((25 - 21) * 333.87) == 1335 and round((0 - 21) * 333.87) == -7011
    assert c_temp(lib, 1234567, 1335) == warm == temp_frame(1234567, 1335)
    assert c_temp(lib, 500000, -7011) == cold == temp_frame(500000, -7011)
    raw = bytes.fromhex("a55a1a0187d612002a007800acfe0008fbff11000300c8006affcafe867d5f88")  # 11.1
    assert warm[4:8] == raw[4:8]  # the same t_us as the RAW frame it goes before


def test_temp_frames_match_an_independent_encoding(lib):
    """Any t_us and count, the extremes included; every receiver takes the frame whole, whether
    it reads TEMP or skips it as a type it does not know (PROTOCOL.md 3)."""
    rng = random.Random(12)
    cases = [(0, 0), (2**32 - 1, -32768), (2**32 - 1, 32767), (1, -1)]
    cases += [(rng.randrange(2**32), rng.randrange(-32768, 32768)) for _ in range(500)]
    for t_us, counts in cases:
        data = c_temp(lib, t_us, counts)
        assert data == temp_frame(t_us, counts) and len(data) == 12
        d = P.FrameDecoder()
        d.feed(data)
        assert (d.stats.frames, d.stats.crc_errors, d.stats.bytes_skipped) == (1, 0, 0)


def test_the_boards_decoder_skips_temp_frames(lib):
    """A TEMP frame echoed back is skipped; a TEMP header with another len is no frame (sec. 9.1
    step 2) and costs the command behind it nothing."""
    rate = P.encode_command(P.Command(P.FrameType.SET_RATE, 100))
    wrong_len = b"\xa5\x5a\x20\x05" + bytes(3)
    assert c_commands(lib, temp_frame(1234567, 1335) + wrong_len + rate) == [
        P.Command(P.FrameType.SET_RATE, 100)]


def temps_before(lib, state: State, n: int, unsent: frozenset[int] = frozenset()) -> list[int]:
    """Of the next n RAW frames, those a TEMP frame goes before (their indices), as the sketch's
    emit_sample does it: ask eb_temp_due, then count each RAW frame sent (none of ``unsent``)."""
    out = []
    for i in range(n):
        due = lib.eb_temp_due(C.byref(state))
        if due:
            out.append(i)
        if i not in unsent:
            lib.eb_count_raw(C.byref(state), due)
    return out


def test_a_temp_frame_goes_before_the_first_raw_frame_and_then_every_rate_hz_th(lib):
    """PROTOCOL.md 4.3: right before the first RAW frame sent since power-up, RESET, START or a
    switch to RAW mode, then again once rate_hz RAW frames have been sent since the last TEMP
    frame: before RAW frames 0, rate_hz, 2 rate_hz, ..., once a second of samples."""
    T = P.FrameType
    s = State()
    lib.eb_state_power_up(C.byref(s))
    assert temps_before(lib, s, 5 * RATE_HZ + 1) == [0, 200, 400, 600, 800, 1000]
    assert temps_before(lib, s, 150) == []  # the next after 49 more
    execute(lib, s, P.Command(T.START))  # while streaming: from the next frame again
    assert temps_before(lib, s, 2 * RATE_HZ + 1) == [0, 200, 400]
    s.seq = 65534  # the count is not seq: its wrap changes nothing
    assert temps_before(lib, s, RATE_HZ) == [199]
    for stop_start in (T.STOP, T.START):
        execute(lib, s, P.Command(stop_start))
    assert temps_before(lib, s, 3) == [0]
    execute(lib, s, P.Command(T.SET_MODE, 1))
    execute(lib, s, P.Command(T.SET_MODE, 0))  # a switch into RAW
    assert temps_before(lib, s, 3) == [0]
    assert execute(lib, s, P.Command(T.SET_MODE, 0))[2] == 0  # RAW while RAW: no switch
    assert temps_before(lib, s, RATE_HZ) == [197]  # the count ran on
    # SET_RATE keeps the count: 150 RAW frames since (and with) the last one a TEMP frame
    # went before, then a higher rate (250 Hz: 100 to go) or a lower one (100 Hz: already past)
    execute(lib, s, P.Command(T.START))
    assert temps_before(lib, s, 150) == [0]
    execute(lib, s, P.Command(T.SET_RATE, 250))
    assert temps_before(lib, s, 251) == [100]  # 150 since it
    execute(lib, s, P.Command(T.SET_RATE, 100))
    assert temps_before(lib, s, 101) == [0, 100]
    execute(lib, s, P.Command(T.SET_RATE, 1))
    assert temps_before(lib, s, 3) == [0, 1, 2]  # 1 Hz: every RAW frame
    execute(lib, s, P.Command(T.RESET))  # power-up state: the first frame again
    assert temps_before(lib, s, 2) == [0]


def test_a_raw_frame_not_sent_is_not_counted_and_its_temp_frame_goes_again(lib):
    """eb_temp_due has no side effect; a RAW frame the UART could not take is not counted
    (PROTOCOL.md 4.3), so a TEMP frame due before it is due again before the next one."""
    T = P.FrameType
    s = State()
    lib.eb_state_power_up(C.byref(s))
    assert all(lib.eb_temp_due(C.byref(s)) for _ in range(3)) and s.raw_sent == 0
    assert temps_before(lib, s, 4, unsent=frozenset({0, 1})) == [0, 1, 2]
    # 200 counted since the last TEMP frame went: due before 198, not sent, nor 199, so before 200
    assert temps_before(lib, s, RATE_HZ + 1, unsent=frozenset({198, 199})) == [198, 199, 200]
    execute(lib, s, P.Command(T.SET_MODE, 1))  # FUSED: the sketch counts no frames
    execute(lib, s, P.Command(T.START))
    execute(lib, s, P.Command(T.SET_MODE, 0))
    assert temps_before(lib, s, RATE_HZ + 6, unsent=frozenset(range(5, 10))) == [0, 205]  # 5 uncounted


# ------------------------------------------------------------------ the board's decoder


def c_commands(lib, data: bytes, chunks: list[int] | None = None) -> list[P.Command]:
    parser, cmd, out = Parser(), Command(), []
    lib.eb_parser_init(C.byref(parser))
    for b in data:
        lib.eb_parser_push(C.byref(parser), b)
        while lib.eb_parser_next(C.byref(parser), C.byref(cmd)):
            t = P.FrameType(cmd.type)
            out.append(P.Command(t, cmd.arg if t in (P.FrameType.SET_RATE, P.FrameType.SET_MODE) else None))
    return out


def python_commands(data: bytes) -> list[P.Command]:
    return [p for p in P.FrameDecoder(accept_commands=True).feed(data) if isinstance(p, P.Command)]


def random_command(rng: random.Random) -> P.Command:
    t = rng.choice(list(P.FrameType)[4:])
    arg = {P.FrameType.SET_RATE: rng.randrange(2**16), P.FrameType.SET_MODE: rng.randrange(256)}.get(t)
    return P.Command(t, arg)


def test_parser_finds_the_same_commands_as_the_host_decoder(lib):
    """Commands among garbage, false syncs, corrupted frames, board frames and unknown types.

    The board's decoder holds 40 bytes, not 261: it rejects a longer candidate at once
    where the host's waits for it; once the host's has judged it, both agree."""
    rng = random.Random(5)
    for trial in range(60):
        parts = []
        for _ in range(rng.randrange(1, 25)):
            kind = rng.random()
            if kind < 0.5:
                parts.append(P.encode_command(random_command(rng)))
            elif kind < 0.6:
                parts.append(P.encode_raw(random_raw(rng)))  # echoed board frames are skipped
            elif kind < 0.7:
                parts.append(P.frame(0x99, bytes(rng.randrange(256) for _ in range(rng.randrange(20)))))
            elif kind < 0.8:
                bad = bytearray(P.encode_command(random_command(rng)))
                bad[rng.randrange(2, len(bad))] ^= 1 << rng.randrange(8)
                parts.append(bytes(bad))
            elif kind < 0.9:
                parts.append(b"\xa5\x5a" + bytes(rng.randrange(256) for _ in range(rng.randrange(6))))
            else:
                parts.append(bytes(rng.randrange(256) for _ in range(rng.randrange(30))))
        # Trailing padding lets the host decoder finish waiting on a long false candidate
        # (up to 261 bytes) that the board's 40-byte decoder rejects at once.
        data = b"".join(parts) + bytes(300)
        assert c_commands(lib, data) == python_commands(data), f"trial {trial}"


def test_parser_worked_examples(lib):
    data = bytes.fromhex("a55a0281c0ffee" "a55a0283c8005f94" "a55a00869c" "a55a01840 1d13c".replace(" ", ""))
    assert c_commands(lib, data) == python_commands(data) == [
        P.Command(P.FrameType.SET_RATE, 200), P.Command(P.FrameType.SET_MODE, 1)]


# ------------------------------------------------------------------ the board's state machine


def execute(lib, state: State, command: P.Command):
    r = lib.eb_execute(C.byref(state), C.byref(Command(int(command.type), command.arg or 0)))
    return r.ack, r.status, r.action, r.hello


def test_commands_change_the_state_and_answer_as_the_virtual_board(lib):
    s = State()
    lib.eb_state_power_up(C.byref(s))
    assert (s.rate_hz, s.mode, s.streaming, s.seq) == (200, 0, True, 0)
    T = P.FrameType
    OK, BAD = int(P.AckStatus.OK), int(P.AckStatus.BAD_ARGUMENT)
    assert execute(lib, s, P.Command(T.STOP)) == (True, OK, 0, False) and not s.streaming
    assert execute(lib, s, P.Command(T.STOP))[:2] == (True, OK)
    assert execute(lib, s, P.Command(T.START))[:2] == (True, OK) and s.streaming
    raw_top, fused_top = P.BOARD_MAX_RATE_HZ[P.Mode.RAW], P.BOARD_MAX_RATE_HZ[P.Mode.FUSED]
    between = (raw_top + fused_top) // 2
    for rate, status in [(0, BAD), (1001, BAD), (raw_top + 1, BAD), (1, OK), (raw_top, OK), (between, OK)]:
        ack, got, action, _ = execute(lib, s, P.Command(T.SET_RATE, rate))
        assert (ack, got) == (True, status)
        assert action == (1 if status == OK else 0)
    assert s.rate_hz == between
    # FUSED's limit is below RAW's: the mode is refused until the rate comes down
    assert execute(lib, s, P.Command(T.SET_MODE, 1))[:2] == (True, BAD) and s.mode == 0
    assert execute(lib, s, P.Command(T.SET_RATE, fused_top))[:2] == (True, OK)
    assert execute(lib, s, P.Command(T.SET_MODE, 2))[:2] == (True, BAD) and s.mode == 0
    assert execute(lib, s, P.Command(T.SET_MODE, 1)) == (True, OK, 2, False) and s.mode == 1
    assert execute(lib, s, P.Command(T.SET_MODE, 1)) == (True, OK, 0, False)
    assert execute(lib, s, P.Command(T.SET_RATE, fused_top + 1))[:2] == (True, BAD)
    assert s.rate_hz == fused_top
    assert execute(lib, s, P.Command(T.IDENTIFY)) == (False, OK, 0, True)  # HELLO, no ACK
    s.seq = 1234
    s.streaming = False
    assert execute(lib, s, P.Command(T.RESET)) == (True, OK, 3, True)  # ACK, power up, HELLO
    assert (s.rate_hz, s.mode, s.streaming, s.seq) == (200, 0, True, 0)


def test_flex_rail_is_a_band_held_a_second_high_and_ten_seconds_low(lib):
    """Zhu & Shi's circuit outputs at most Vref = 2.5 V (512 counts): near 1023 only a broken
    circuit; near 0 an unplugged sensor, but also a bend past Rflex = Rf (tracker.flex)."""
    circuit = FlexCircuit()
    assert circuit.adc(circuit.volts(0.0)) <= 512  # a shorted sensor, the highest output
    assert circuit.adc(circuit.volts(50e3)) > 8  # the paper's full bend: above the band
    assert circuit.adc(circuit.volts(60e3)) == 0  # past Rf: the rail, legitimately
    assert [a for a in range(1024) if lib.eb_flex_rail_seconds(a)] == [*range(0, 9), *range(1015, 1024)]
    for adc, seconds in ((4, 10), (1020, 1)):  # an op-amp stopping 4 counts short of a rail
        rail = Rail()
        assert not any(lib.eb_rail_update(C.byref(rail), adc, 200) for _ in range(200 * seconds - 1))
        assert lib.eb_rail_update(C.byref(rail), adc, 200)
        assert not lib.eb_rail_update(C.byref(rail), 390, 200)


def test_led_patterns(lib):
    assert all(lib.eb_led_on(0, ms) for ms in range(0, 3000, 7))
    assert [lib.eb_led_on(1, ms) for ms in (0, 49, 50, 999, 1000)] == [True, True, False, False, True]
    assert sum(lib.eb_led_on(3, ms) for ms in range(1000)) == 500  # 5 Hz, half on


# ------------------------------------------------------------------ sample clock


@pytest.mark.parametrize("rate", [1, 3, 7, 20, 64, 128, 200, 216, 300, 314, 333, 997, 1000])
def test_sample_grid_is_round_k_over_rate(lib, rate):
    """Stamps are round(k * 1e6 / rate) (ties up: within 1 us of Python's round, exact otherwise)."""
    g = Grid()
    for k0 in (0, 12345, 2**31 // 1000 * rate // 1000):
        lib.eb_grid_set(C.byref(g), rate, k0)
        for k in range(k0, k0 + 3 * rate + 5):
            exact = (2 * k * 10**6 + rate) // (2 * rate)  # floor(k 1e6 / rate + 1/2)
            assert g.t_us == exact % 2**32
            assert abs(g.t_us - round(k / rate * 1e6) % 2**32) <= 1
            lib.eb_grid_advance(C.byref(g))


def test_first_grid_point_after_now_is_as_the_virtual_board(lib):
    rng = random.Random(6)
    for _ in range(2000):
        rate, now = rng.randrange(1, 1001), rng.randrange(2**32)
        k = lib.eb_grid_first_after(rate, now)
        assert k == now * rate // 10**6 + 1  # board.py _retime: int(now * rate) + 1
        g = Grid()
        lib.eb_grid_set(C.byref(g), rate, k)
        # after now (or rounded onto it, less than half a microsecond away) below the wrap
        assert g.t_us >= now or k * 10**6 // rate >= 2**32


@pytest.mark.parametrize("rate", [1, 2, 3, 30, 31, 200, 300, 333, 1000])
def test_timer_periods_fit_16_bits_and_sum_to_a_second(lib, rate):
    t = TimerPlan()
    lib.eb_timer_plan(C.byref(t), rate, 16_000_000)
    periods = [lib.eb_timer_next_period(C.byref(t)) for _ in range(rate)]
    assert sum(periods) == t.ticks_per_s and max(periods) <= 65536 and max(periods) - min(periods) <= 1
    assert min(periods) >= 1  # the ISR loads OCR1A with period - 1
    prescaler = {2: 8, 3: 64, 4: 256, 5: 1024}[t.prescaler_bits]
    assert t.ticks_per_s * prescaler == 16_000_000
    assert lib.eb_timer_ticks(C.byref(t), 1000) == max(1, 1000 * 16 // prescaler)


def test_the_host_knows_the_rates_the_board_takes(lib):
    """tracker.protocol's limits are the firmware's, rate by rate and mode by mode."""
    for mode in P.Mode:
        valid = [r for r in range(0, 1100) if lib.eb_rate_valid(r, int(mode))]
        assert valid == [r for r in range(0, 1100) if P.board_rate_error(r, mode) is None]
        assert valid == list(range(1, P.BOARD_MAX_RATE_HZ[mode] + 1))


@pytest.mark.parametrize("baud, real", [(115200, 117647), (250000, 250000), (500000, 500000)])
def test_uart_runs_at_the_baud_the_ubrr_gives(lib, baud, real):
    """ATmega328P data sheet table 20-1, double speed: baud = 16 MHz / (8 (UBRR + 1))."""
    assert lib.eb_uart_baud(16_000_000, baud) == real


def test_rate_limits_follow_the_clocks_as_worked_by_hand(lib):
    """eb_budget.h's model, worked by hand. At 100 kHz an SCL period is 160 cycles; a RAW
    sample costs 5200 + 192 x 160 + 7700 + 32 x 140 = 48100 cycles and the AK8963's 100
    reads a second 100 x 102 x 160 = 1632000, so 90% of 16 MHz holds
    (14400000 - 1632000) / 48100 = 265.5 samples a second; the link at 115200 baud
    (really 117647) carries 117647 / 10 x 0.9 / 32 = 330.9, so RAW is CPU-bound. FUSED reads
    no magnetometer: 5200 + 30720 + 31000 + 22 x 140 = 70000 cycles, 205.7 a second. At
    400 kHz (40 cycles a bit) RAW is link-bound at 115200 baud."""
    rate = lambda mode, i2c, baud: lib.eb_max_rate_hz(mode, 16_000_000, i2c, baud)  # noqa: E731
    assert rate(0, 100_000, 115200) == 265
    assert rate(1, 100_000, 115200) == 205
    assert rate(0, 400_000, 115200) == 330
    assert rate(1, 400_000, 115200) == 14_400_000 // (5200 + 192 * 40 + 31000 + 22 * 140)
    assert rate(0, 400_000, 500_000) == (14_400_000 - 100 * 102 * 40) // (5200 + 192 * 40 + 7700 + 32 * 140)


# ------------------------------------------------------------------ complementary filter


def arm_motion(seconds: float = 20.0, rate: float = 200.0):
    data = Simulator(arm_chain(), arm_swing(), mpu9250(), seed=7).simulate(seconds, rate)
    return data.gyr[:, 0].astype(F32), data.acc[:, 0].astype(F32)


def test_c_filter_matches_the_python_complementary_filter(lib):
    """4000 samples of a simulated arm swing (tracker.sim) through both filters."""
    gyr, acc = arm_motion()
    dt = 1.0 / 200.0
    py = make("complementary")
    f = Filter()
    lib.eb_filter_init(C.byref(f), 0.999)
    worst = 0.0
    for g, a in zip(gyr, acc):
        q_py = py.update(g.tolist(), a.tolist(), None, dt)
        lib.eb_filter_update(C.byref(f), g.ctypes.data_as(C.POINTER(C.c_float)),
                             a.ctypes.data_as(C.POINTER(C.c_float)), F32(dt))
        worst = max(worst, max(abs(x - y) for x, y in zip(f.q, q_py)))
    assert worst < 1e-4, worst
    assert abs(math.hypot(*f.q) - 1.0) < 1e-6


FULL_SCALE_RAD_S = math.radians(2000.0)
U = 2.0 ** -24  # float's unit roundoff


def c_step(lib, q, levelled: bool, gyr, acc, dt: float) -> np.ndarray:
    """One eb_filter_update from state (q, levelled)."""
    f = Filter()
    lib.eb_filter_init(C.byref(f), 0.999)
    f.q[:] = [float(x) for x in F32(q)]
    f.levelled = levelled
    g, a = np.asarray(gyr, F32), np.asarray(acc, F32)
    lib.eb_filter_update(C.byref(f), g.ctypes.data_as(C.POINTER(C.c_float)),
                         a.ctypes.data_as(C.POINTER(C.c_float)), F32(dt))
    return np.array(f.q)


def py_step(q, levelled: bool, gyr, acc, dt: float) -> np.ndarray:
    """The same step of the Python filter (float64), from the float32 inputs the C one sees."""
    py = make("complementary")
    py.set_state(ComplementaryState(q=tuple(float(x) for x in F32(q)), levelled=levelled))
    return np.array(py.update([float(x) for x in F32(gyr)], [float(x) for x in F32(acc)], None,
                              float(F32(dt))))


def random_unit(rng: np.random.Generator, n: int) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_c_filter_gyro_step_matches_scipy_over_the_full_range(lib):
    """The gyroscope's rotation (no accelerometer) up to all three axes at full scale,
    2000 deg/s, over 5 ms (the series, up to 0.30 rad) and 25 ms (beyond 0.35 rad: sinf and
    cosf), from random orientations: q * exp(w dt / 2) as scipy composes it, to float rounding."""
    rng = np.random.default_rng(15)
    n = 400
    rates = rng.uniform(-FULL_SCALE_RAD_S, FULL_SCALE_RAD_S, size=(n, 3))
    rates[: n // 4] = FULL_SCALE_RAD_S * np.sign(rates[: n // 4])  # the corners: |w| = 60.5 rad/s
    starts = Rotation.random(n, random_state=16)
    worst = 0.0
    for dt in (0.005, 0.025):
        for w, r0 in zip(rates, starts):
            q0 = np.roll(r0.as_quat(), 1)  # scipy is scalar last
            got = c_step(lib, q0, True, w, (0.0, 0.0, 0.0), dt)
            r0 = Rotation.from_quat(np.roll(F32(q0), -1))
            want = np.roll((r0 * Rotation.from_rotvec(F32(w).astype(float) * float(F32(dt)))).as_quat(), 1)
            worst = max(worst, min(np.abs(got - want).max(), np.abs(got + want).max()))
    assert worst < 8 * U, worst / U


def test_c_filter_tilt_paths_match_the_python_filter(lib):
    """One levelled step (and one first step) with the gyroscope anywhere in its range and the
    specific force tilted from up within the series' 11.3 degrees, just either side of that
    edge and beyond it, from random orientations; and upside down, a half-turn tilt (the exact
    path's special case) and nearly so, from the identity: there the tilt's axis is the
    horizontal part of v, which float rounding of a rotated v would decide, so v is given
    exactly. The C filter equals the Python one to float rounding on every path."""
    rng = np.random.default_rng(17)
    n = 200
    starts = np.roll(Rotation.random(n, random_state=18).as_quat(), 1, axis=1)
    rates = rng.uniform(-FULL_SCALE_RAD_S, FULL_SCALE_RAD_S, size=(n, 3))
    cases = []
    for q0, w, d in zip(starts, rates, random_unit(rng, n)):
        axis = np.cross([0.0, 0.0, 1.0], d)
        axis /= np.linalg.norm(axis)
        world_to_body = Rotation.from_quat(np.roll(q0, -1)).inv()
        for tilt in (0.0, 0.1, np.arctan(0.2) - 1e-4, np.arctan(0.2) + 1e-4, 1.0, 2.5):
            v = Rotation.from_rotvec(axis * tilt).apply([0.0, 0.0, 9.81])
            cases.append((q0, w, world_to_body.apply(v)))
        for down in ((0.0, 0.0, -9.81), (1e-4, -2e-4, -9.81), (0.05, 0.0, -9.81)):
            cases.append(((1.0, 0.0, 0.0, 0.0), w, down))
    worst = {True: 0.0, False: 0.0}
    for q0, w, acc in cases:
        for levelled in (True, False):
            got = c_step(lib, q0, levelled, w, acc, 0.005)
            want = py_step(q0, levelled, w, acc, 0.005)
            worst[levelled] = max(worst[levelled], np.abs(got - want).max())
    assert max(worst.values()) < 8 * U, {k: v / U for k, v in worst.items()}


def test_c_filter_levels_from_the_first_sample_and_skips_a_zero_accelerometer(lib):
    f = Filter()
    lib.eb_filter_init(C.byref(f), 0.999)
    zero = (C.c_float * 3)(0, 0, 0)
    lib.eb_filter_update(C.byref(f), zero, (C.c_float * 3)(0, 0, 0), 0.005)
    assert list(f.q) == [1, 0, 0, 0] and not f.levelled
    lib.eb_filter_update(C.byref(f), zero, (C.c_float * 3)(9.81, 0, 0), 0.005)  # x up
    py = make("complementary")
    py.update((0, 0, 0), (9.81, 0, 0), None, 0.005)
    assert f.levelled and np.allclose(list(f.q), py.quat, atol=1e-6)
    down = (C.c_float * 3)(0, 0, -9.81)  # upside down: a half-turn about east
    lib.eb_filter_init(C.byref(f), 0.999)
    lib.eb_filter_update(C.byref(f), zero, down, 0.005)
    py = make("complementary")
    py.update((0, 0, 0), (0, 0, -9.81), None, 0.005)
    assert np.allclose(list(f.q), py.quat, atol=1e-6)


# ------------------------------------------------------------------ legacy text lines


def c_line(lib, q, flex) -> bytes:
    out = C.create_string_buffer(64)
    n = lib.eb_format_text_line(out, (C.c_float * 4)(*q), flex)
    return out.raw[:n]


def test_text_line_worked_example(lib):
    assert c_line(lib, (0.9553, 0.2955, 0.0, 0.0), 45.0) == b"0.9553,0.2955,0.0000,0.0000,45.00\r\n"
    assert c_line(lib, (-0.5, 0.5, -0.00001, 1.0), -12.346) == b"-0.5000,0.5000,-0.0000,1.0000,-12.35\r\n"


def test_text_lines_read_back_as_python_formats_them(lib):
    rng = np.random.default_rng(8)
    decoder = P.TextDecoder()
    for _ in range(1000):
        q = rng.normal(size=4)
        q = (q / np.linalg.norm(q)).astype(F32)
        flex = F32(rng.uniform(-30, 150))
        line = c_line(lib, q.tolist(), float(flex))
        reference = P.format_text_line(P.FusedSample(0.0, None, 0, tuple(q.tolist()), float(flex)))
        got = [float(v) for v in line.split(b",")]
        want = [float(v) for v in reference.split(b",")]
        assert np.allclose(got, want, rtol=0, atol=1.01e-4), (line, reference)  # float32 ties
        (sample,) = decoder.feed(line)
        assert np.allclose(sample.q, np.asarray(q, float) / np.linalg.norm(got[:4]), atol=2e-4)
    assert decoder.stats.bad_lines == 0


# ------------------------------------------------------------------ sensors


def test_whoami_and_register_values(lib):
    assert [w for w in range(256) if lib.eb_imu_known(w)] == [0x70, 0x71, 0x73]
    assert [lib.eb_fs_register(c) for c in range(4)] == [0x00, 0x08, 0x10, 0x18]
    assert [lib.eb_dlpf_for_rate(r) for r in (1, 40, 80, 200, 368, 400, 736, 1000)] == [6, 5, 4, 3, 2, 2, 1, 0]
    # The simulator's board reads through the filter the firmware sets (tracker.mpu_dlpf).
    assert [lib.eb_dlpf_for_rate(r) for r in range(1, 1001)] == [dlpf_for_rate(r) for r in range(1, 1001)]


@pytest.mark.parametrize("temp", [1335, -7011, -32768, 32767])
def test_mpu_burst_is_big_endian_and_keeps_the_temperature(lib, temp):
    """ACCEL_XOUT_H (0x3B) .. GYRO_ZOUT_L (0x48): TEMP_OUT (0x41-0x42) between the two."""
    acc, gyr = (120, -340, 2048), (-5, 17, -32768)
    burst = struct.pack(">7h", *acc, temp, *gyr)
    a, g, t = (C.c_int16 * 3)(), (C.c_int16 * 3)(), C.c_int16()
    lib.eb_mpu_parse(burst, a, g, C.byref(t))
    assert tuple(a) == acc and tuple(g) == gyr and t.value == temp


def test_magnetometer_adjustment_and_axes(lib):
    """h = H ((ASA - 128) / 256 + 1) rounded; sent as (h_y, h_x, -h_z) (PROTOCOL.md 4.1)."""
    rng = random.Random(9)
    for _ in range(3000):
        h, asa = rng.randrange(-32768, 32768), rng.randrange(256)
        want = max(-32768, min(32767, math.floor(h * (asa + 128) / 256 + 0.5)))
        assert lib.eb_mag_adjust(h, asa) == want
    hx, hy, hz, asa = 1000, -2000, 300, bytes([128, 176, 64])
    data = bytes([0x01]) + struct.pack("<3h", hx, hy, hz) + bytes([0x08])
    m = Mag()
    lib.eb_ak_parse(data, asa, C.byref(m))
    assert tuple(m.mag) == (round(hy * 1.1875), hx, -round(hz * 0.75)) and m.ready and m.overflow
    lib.eb_ak_parse(bytes(8), asa, C.byref(m))
    assert not m.ready and not m.overflow
    lib.eb_ak_parse(bytes([1]) + struct.pack("<3h", 0, 0, -32768) + bytes([0]), bytes([128] * 3), C.byref(m))
    assert m.mag[2] == 32767  # -(-32768) saturates


def test_flex_angle_is_the_papers_eq_3(lib):
    for adc in (0.0, 120.0, 390.0, 391.5, 1023.0):
        assert lib.eb_flex_deg(adc) == pytest.approx(-(adc - 390) / 3, abs=1e-5)


def test_bias_subtraction_saturates_instead_of_wrapping(lib):
    """A gyroscope at full scale, -32768 (beyond -2000 deg/s), less a bias of +5 stays at
    -32768; the int16 cast wrapped it to +32763 (the filter turned the other way)."""
    assert lib.eb_gyr_unbiased(-32768, 5) == -32768
    assert lib.eb_gyr_unbiased(32767, -5) == 32767
    rng = random.Random(11)
    for _ in range(5000):
        g, b = rng.randrange(-32768, 32768), rng.randrange(-2000, 2001)
        assert lib.eb_gyr_unbiased(g, b) == max(-32768, min(32767, g - b))


def test_unit_conversions_match_the_host(lib):
    for code, (fs_g, fs_dps) in enumerate(zip(P.ACC_FS_G, P.GYR_FS_DPS)):
        s = P.RawSample(0, 0, 0, (2048, -32768, 32767), (16384, -1, 32767), None, 0, fs_g, fs_dps)
        for i in range(3):
            assert lib.eb_acc_m_s2(s.acc_counts[i], code) == pytest.approx(s.acc[i], rel=1e-6)
            assert lib.eb_gyr_rad_s(s.gyr_counts[i], code) == pytest.approx(s.gyr[i], rel=1e-6)


# ------------------------------------------------------------------ gyroscope bias


def still_of(lib, samples):
    s = Still()
    lib.eb_still_init(C.byref(s))
    for g, a in samples:
        lib.eb_still_add(C.byref(s), (C.c_int16 * 3)(*g), (C.c_int16 * 3)(*a))
    return s


def test_bias_is_the_mean_when_still(lib):
    rng = np.random.default_rng(10)
    gyr = rng.normal((30, -12, 5), 1.5, (128, 3)).round().astype(int)
    acc = rng.normal((0, 0, 2048), 3, (128, 3)).round().astype(int)
    acc[7, 0] += 25  # one outlier: a peak-to-peak judgement would call this moving
    s = still_of(lib, zip(gyr.tolist(), acc.tolist()))
    assert lib.eb_still_is_still(C.byref(s))
    bias = (C.c_int16 * 3)()
    lib.eb_still_mean(C.byref(s), bias)
    assert np.abs(np.array(bias) - gyr.mean(axis=0)).max() <= 0.5
    moving = gyr.copy()
    moving[64:, 1] += 40  # 2.4 deg/s: turning
    assert not lib.eb_still_is_still(C.byref(still_of(lib, zip(moving.tolist(), acc.tolist()))))
    moving = gyr.copy()
    moving[::2, 2], moving[1::2, 2] = 32000, -32000  # swinging at full scale: no int32 overflow
    assert not lib.eb_still_is_still(C.byref(still_of(lib, zip(moving.tolist(), acc.tolist()))))
    assert not lib.eb_still_is_still(C.byref(still_of(lib, zip(gyr[:100].tolist(), acc.tolist()))))


@pytest.mark.parametrize("offset_dps, still", [(34.0, True), (-34.0, True), (36.0, False), (57.3, False)])
def test_a_steady_turn_at_boot_is_no_bias(lib, offset_dps, still):
    """No spread, but a mean beyond the MPU-9250's zero-rate tolerance (+-5 deg/s at 25 degC,
    +-30 more over temperature, PS-MPU-9250A-01 table 1: 35 deg/s) is a board turning."""
    rng = np.random.default_rng(11)
    gyr = rng.normal((round(offset_dps * 16.4), 3, -2), 1.0, (128, 3)).round().astype(int)
    acc = rng.normal((0, 0, 2048), 3, (128, 3)).round().astype(int)
    assert bool(lib.eb_still_is_still(C.byref(still_of(lib, zip(gyr.tolist(), acc.tolist()))))) == still


def test_bias_record_round_trips_and_rejects_corruption(lib):
    rec = C.create_string_buffer(12)
    lib.eb_bias_pack(rec, (C.c_int16 * 3)(30, -12, -32768))
    raw = rec.raw[:12]
    assert raw[:10] == b"EB\x01\x00" + struct.pack("<3h", 30, -12, -32768)
    assert struct.unpack("<H", raw[10:])[0] == binascii.crc_hqx(raw[:10], 0xFFFF)
    out = (C.c_int16 * 3)(7, 7, 7)
    assert lib.eb_bias_unpack(raw, out) and tuple(out) == (30, -12, -32768)
    for i in range(12):
        bad = bytearray(raw)
        bad[i] ^= 0x10
        out = (C.c_int16 * 3)(7, 7, 7)
        assert not lib.eb_bias_unpack(bytes(bad), out) and tuple(out) == (7, 7, 7)
    assert not lib.eb_bias_unpack(b"\xff" * 12, out)  # a blank EEPROM
