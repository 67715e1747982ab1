"""TEMP frames from the real firmware on the simulated board (firmware/PROTOCOL.md 4.3).

The frames are decoded here from the bytes on the pty, with struct and binascii.crc_hqx
after PROTOCOL.md sections 2 and 9.1, not with tracker.protocol: the test holds the
firmware to the document. Needs what test_sim.py needs; skips (fails under CI=true)
the same way.
"""

from __future__ import annotations

import binascii
import re
import struct
import time

import serial

from .test_sim import (BOOT_S, FLEX_MV, OPTIBOOT_S, SIM_DIR, boardsim, elf,  # noqa: F401
                       running_board)

BAUD = 500000
RAW, FUSED, HELLO, ACK, TEMP = 0x01, 0x02, 0x03, 0x04, 0x05
PAYLOAD = {RAW: 26, FUSED: 16, HELLO: 14, ACK: 2, TEMP: 6}
START, STOP, SET_MODE = 0x81, 0x82, 0x84
RATE_HZ = 200  # the boot rate
TEMP_COUNTS_PER_C, TEMP_ROOM_C = 333.87, 21.0  # PS-MPU-9250A-01 sec. 3.4.2


def simulated_die_c() -> float:
    """The die temperature the simulated MPU-9250 reports (firmware/sim/imu.h)."""
    text = (SIM_DIR / "imu.h").read_text()
    return float(re.search(r"#define IMU_TEMP_C ([-+0-9.]+)", text).group(1))


def command(ftype: int, payload: bytes = b"") -> bytes:
    body = bytes([len(payload), ftype]) + payload
    return b"\xa5\x5a" + body + struct.pack("<H", binascii.crc_hqx(body, 0xFFFF))


def frames(data: bytes) -> list[tuple[int, bytes]]:
    """(type, payload) of each frame in data, in order (PROTOCOL.md 9.1: find A5 5A, a known
    type must have its len, the CRC over len, type and payload; else skip one byte)."""
    out, i = [], 0
    while (i := data.find(b"\xa5\x5a", i)) >= 0 and i + 4 <= len(data):
        length, ftype = data[i + 2], data[i + 3]
        end = i + 4 + length + 2
        if PAYLOAD.get(ftype, length) != length or end > len(data) or \
                binascii.crc_hqx(data[i + 2:end - 2], 0xFFFF) != struct.unpack_from("<H", data, end - 2)[0]:
            i += 1
            continue
        out.append((ftype, data[i + 4:end - 2]))
        i = end
    return out


def runs(got: list[tuple[int, bytes]]) -> list[list[tuple[int, bytes]]]:
    """The stream cut at every HELLO and ACK: here each one starts the count again (power-up,
    START, SET_MODE) or ends streaming (STOP)."""
    out: list[list[tuple[int, bytes]]] = [[]]
    for f in got:
        if f[0] in (HELLO, ACK):
            out.append([])
        else:
            out[-1].append(f)
    return out


def read_for(port: serial.Serial, seconds: float) -> bytes:
    end, chunks = time.monotonic() + seconds, []
    while time.monotonic() < end:
        chunks.append(port.read(4096))
    return b"".join(chunks)


def check_run(run: list[tuple[int, bytes]]) -> int:
    """In one run of RAW frames: a TEMP frame right before the first RAW frame and then before
    every RATE_HZ-th (their t_us 1 s apart), each with the t_us of the RAW frame after it, so a
    host holding the latest TEMP value has one for every RAW frame; no seq gap. The number of
    TEMP frames."""
    assert {ftype for ftype, _ in run} == {RAW, TEMP}, ("RAW and TEMP frames only", run[:3])
    raws = [i for i, (ftype, _) in enumerate(run) if ftype == RAW]
    seqs = [struct.unpack_from("<H", run[i][1], 4)[0] for i in raws]
    assert all((b - a) % 65536 == 1 for a, b in zip(seqs, seqs[1:])), "a seq gap: the count would differ"
    assert run[0][0] == TEMP, "the first RAW frame of the run has no temperature before it"
    temps = [i for i, (ftype, _) in enumerate(run) if ftype == TEMP]
    assert all(i + 1 < len(run) and run[i + 1][0] == RAW for i in temps), "a TEMP frame, then no RAW"
    preceded = [k for k, i in enumerate(raws) if i > 0 and run[i - 1][0] == TEMP]
    assert preceded == list(range(0, len(raws), RATE_HZ)), (preceded, len(raws))
    stamps = []
    for i in temps:
        t_us, _ = struct.unpack("<Ih", run[i][1])
        assert t_us == struct.unpack_from("<I", run[i + 1][1])[0], "TEMP and RAW t_us differ"
        stamps.append(t_us)
    assert all(b - a == 1_000_000 for a, b in zip(stamps, stamps[1:])), stamps
    return len(temps)


def test_raw_streaming_sends_the_die_temperature_once_a_second(boardsim, elf, tmp_path):
    """Power-up (the host's open resets the board), STOP and START, FUSED and back to RAW, STOP:
    a TEMP frame right before the first RAW frame of each run of raw streaming and then once a
    second of samples, none while stopped nor in fused mode; temp_counts are the simulated
    die's temperature. The final STOP ends the last run between samples, so no TEMP frame
    is cut from its RAW frame by the end of the reading."""
    with running_board(boardsim, elf, tmp_path, "--no-noise", "--flex-mv", str(FLEX_MV)) as board:
        port = serial.Serial(str(board.link), BAUD, timeout=0.02)
        try:
            data = read_for(port, OPTIBOOT_S + BOOT_S + 2.3)  # boot, then 2 s and more of samples
            for ftype, payload, seconds in ((STOP, b"", 0.3), (START, b"", 1.2),
                                            (SET_MODE, b"\x01", 1.5), (SET_MODE, b"\x00", 1.2),
                                            (STOP, b"", 0.3)):
                port.write(command(ftype, payload))
                data += read_for(port, seconds)
        finally:
            port.close()
        report = board.report()
    got = frames(data)
    controls = [(ftype, payload) for ftype, payload in got if ftype in (HELLO, ACK)]
    acks = [(STOP, 0), (START, 0), (SET_MODE, 0), (SET_MODE, 0), (STOP, 0)]
    assert controls[0][0] == HELLO and [tuple(p) for _, p in controls[1:]] == acks, controls
    boot, stopped, started, fused, raw_again, stopped_again = runs(got)[1:]
    assert check_run(boot) >= 2
    assert stopped == stopped_again == [], "frames while stopped"
    assert check_run(started) >= 1 and check_run(raw_again) >= 1
    assert fused and {ftype for ftype, _ in fused} == {FUSED}, "TEMP or RAW in fused mode"
    temps = [struct.unpack("<Ih", p)[1] for ftype, p in got if ftype == TEMP]
    want = (simulated_die_c() - TEMP_ROOM_C) * TEMP_COUNTS_PER_C
    assert all(abs(c - want) <= 1 for c in temps), (temps, want)
    assert all(abs(c / TEMP_COUNTS_PER_C + TEMP_ROOM_C - simulated_die_c()) < 1 / TEMP_COUNTS_PER_C
               for c in temps)
    assert report["uart"]["temp"] >= len(temps)
