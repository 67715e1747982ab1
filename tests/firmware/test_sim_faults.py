"""I2C bus and IMU faults on the simulated board (firmware/sim/README.md, "Faults").

Each test puts one fault of a real board on the simulated one: the MPU's start-up
time after power-on, an AVR reset in the middle of a read (the MPU holds SDA low),
a drop-out of the IMU's supply, a CPU that never comes back, the AVR's internal
pull-ups, the bus clock. The expected behaviour comes from the data sheets cited
in firmware/README.md, not from the firmware's own output.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
import serial

from tracker import protocol as P
from tracker.board import acc_lsb, counts
from tracker.link import Link, LinkSettings

from .test_sim import (BOOT_S, SKETCH_STARTS_BY_S, boardsim, elf, run_to_end,  # noqa: F401
                       running_board, _boardsim_fails)

F_CPU = 16_000_000
RATE_HZ = 200
FLEX_MV = "2000"  # mid-range: no FLEX_RAIL status frames
TYPICAL_STARTUP = ("--imu-startup-ms", "11")  # PS-MPU-9250A-01 sec. 3.4.2: one fault at a time
WATCHDOG_S = 0.5  # WDTO_500MS (energyball.ino)
STILL_ACC = (0.0, 0.0, 9.81)


def stream_rate_ok(raw: int, seconds: float) -> bool:
    """At least the samples of `seconds` of streaming at 200 Hz, less 5%."""
    return raw >= 0.95 * RATE_HZ * seconds


def test_the_imu_is_found_within_its_start_up_time(boardsim, elf):
    """The MPU answers 100 ms after power-on at worst (PS-MPU-9250A-01 sec. 3.4.2), 35 ms
    after the AVR's first instruction (its reset is held 65 ms): the board must wait for
    it, not report IMU_MISSING and lose a second."""
    r = run_to_end(boardsim, elf, "--seconds", "1.5", "--flex-mv", FLEX_MV)
    assert r["i2c"]["nacks"] > 0, "the firmware never asked before the MPU was up"
    assert r["uart"]["hello"] == 1, f"status HELLOs (IMU_MISSING?): {r['uart']}"
    assert stream_rate_ok(r["uart"]["raw"], 1.5 - BOOT_S), r["uart"]


def test_a_reset_in_the_middle_of_a_read_does_not_lose_the_imu(boardsim, elf):
    """--reset-at --stuck-sda: the AVR restarts while the MPU is sending; the MPU holds SDA
    low until nine clocks and a STOP (UM10204 sec. 3.1.16). The board must clear the bus
    and stream."""
    r = run_to_end(boardsim, elf, "--seconds", "3", "--reset-at", "1.0", "--stuck-sda",
                   "--flex-mv", FLEX_MV, *TYPICAL_STARTUP)
    bus = r["i2c"]
    assert r["resets"] == 1 and bus["stuck"] == 1
    assert bus["cleared"] >= 1 and not bus["blocked"], bus
    assert r["uart"]["hello"] == 2, f"boot, reset, and status HELLOs: {r['uart']}"
    # streaming from BOOT_S to the reset, and again from BOOT_S after it
    assert stream_rate_ok(r["uart"]["raw"], (1.0 - BOOT_S) + (3 - 1.0 - BOOT_S)), r["uart"]


def test_a_hung_board_is_reset_by_the_watchdog(boardsim, elf):
    """--hang-at: the CPU falls into an endless loop; the watchdog resets it and the board
    streams again (a HELLO and RAW frames after WATCHDOG_S + BOOT_S)."""
    r = run_to_end(boardsim, elf, "--seconds", "3.5", "--hang-at", "1.0", "--flex-mv", FLEX_MV,
                   *TYPICAL_STARTUP)
    assert r["end"] == "seconds" and r["resets"] == 1, (r["end"], r["resets"])
    assert r["uart"]["hello"] == 2, r["uart"]
    after = 3.5 - 1.0 - WATCHDOG_S - BOOT_S
    assert stream_rate_ok(r["uart"]["raw"], (1.0 - BOOT_S) + after), r["uart"]


def test_the_avr_pull_ups_stay_off(boardsim, elf):
    """A 3.3 V breakout must not see the AVR's 5 V internal pull-ups (firmware/README.md)."""
    r = run_to_end(boardsim, elf, "--seconds", "1.5", "--reset-at", "1.0", "--stuck-sda",
                   "--flex-mv", FLEX_MV, *TYPICAL_STARTUP)
    assert r["i2c"]["stuck"] == 1 and r["i2c"]["pullup_ms"] == 0, r["i2c"]


def test_the_bus_runs_at_100_khz_within_the_sample_budget(boardsim, elf):
    """TWBR sets SCL = F_CPU / (16 + 2 TWBR) (DS40002061): the harness charges 9 SCL
    periods per byte, so the bus time is the bytes' at the firmware's own clock. At
    100 kHz (firmware/README.md: rise time) a RAW sample with its real bus time still
    fits well within the 5 ms period at 200 Hz."""
    r = run_to_end(boardsim, elf, "--seconds", "2", "--flex-mv", FLEX_MV, *TYPICAL_STARTUP)
    bus = r["i2c"]
    assert bus["scl_hz"] == 100_000, bus
    assert bus["bus_cycles"] == pytest.approx(bus["bytes"] * 9 * F_CPU / 100_000, rel=0.002)
    assert r["cycles_per_sample"] <= 0.8 * F_CPU / RATE_HZ, r["cycles_per_sample"]


def _packets(board_link: Path, seconds: float) -> list:
    """Every frame the board sends for `seconds` (wall time, the board runs in real time)."""
    decoder = P.FrameDecoder()
    out: list = []
    port = serial.Serial(str(board_link), P.DEFAULT_BAUD, timeout=0.05)
    try:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            out += decoder.feed(port.read(512))
    finally:
        port.close()
    assert decoder.stats.crc_errors == 0
    return out


@pytest.mark.parametrize("when", [(), ("--glitch-in-read",)], ids=["between-reads", "in-a-read"])
def test_an_imu_supply_glitch_never_yields_wrong_data(boardsim, elf, tmp_path, when):
    """--glitch: the IMU's supply drops out; every register of the MPU and the
    AK8963 is back at its reset value (+-2 g, +-250 deg/s, bypass off), and the MPU
    answers again after its typical start-up time, 11 ms. No sample may claim +-16 g
    with +-2 g counts, no magnetometer reading may be sent as valid once stale, and
    the board must say what happened (I2C_FAILURE) and stream on. In a read, the
    burst's later bytes come from the reset registers."""
    field = tmp_path / "ramp.csv"  # a field that changes: a stale reading shows
    field.write_text("t,gx,gy,gz,ax,ay,az,mx,my,mz\n0,0,0,0,0,0,9.81,0,20,-40\n"
                     "4,0,0,0,0,0,9.81,40,20,-40\n")
    glitch_s = 1.2
    with running_board(boardsim, elf, tmp_path, "--motion", str(field), "--flex-mv", FLEX_MV,
                       "--glitch", str(glitch_s), "--imu-startup-ms", "11",
                       "--no-noise", "--no-reset-on-open", *when) as board:
        packets = _packets(board.link, 2.6)
        report = board.report()
    samples = [p for p in packets if isinstance(p, P.RawSample)]
    hellos = [p for p in packets if isinstance(p, P.Hello)]
    assert report["simulated_s"] > glitch_s + 1.0
    still = tuple(counts(STILL_ACC, acc_lsb(16)).tolist())
    wrong = [(s.seq, s.acc_counts) for s in samples if s.acc_fs_g != 16 or s.acc_counts != still]
    assert not wrong, f"{len(wrong)} samples with the wrong scale, first {wrong[:3]}"
    # The field ramps by 10 uT/s, one 0.15 uT count in 15 ms: a valid reading held
    # for 60 ms (4 counts of change) is stale.
    run_start = None
    for a, b in zip(samples, samples[1:]):
        if b.mag_counts is not None and b.mag_counts == a.mag_counts:
            run_start = a.t if run_start is None else run_start
            assert b.t - run_start < 0.06, f"stale magnetometer reading {b.mag_counts} at t={b.t:.3f}"
        else:
            run_start = None
    assert any(P.BoardError.I2C_FAILURE in h.errors for h in hellos), hellos
    assert samples and samples[-1].t > glitch_s, "the board stopped streaming"


@pytest.mark.parametrize("args, words", [
    (("--reset-at", "0"), "--reset-at takes a time in seconds above 0 and up to 1e6, not '0'"),
    (("--hang-at", "x"), "--hang-at takes a time in seconds above 0 and up to 1e6, not 'x'"),
    (("--glitch", "-1"), "--glitch takes a time in seconds above 0 and up to 1e6, not '-1'"),
    (("--imu-startup-ms", "2000"), "--imu-startup-ms takes milliseconds 0..1000, not '2000'"),
])
def test_bad_fault_option_is_a_clear_error(boardsim, tmp_path, args, words):
    _boardsim_fails(boardsim, str(tmp_path / "unused.elf"), *args, words=words)


def test_fused_mode_integrates_the_time_of_samples_it_could_not_take(boardsim, elf, tmp_path):
    """A steady turn of 1 rad/s about the vertical in FUSED mode; the IMU's supply drops out
    and its set-up again stalls the loop for about 110 ms. The samples due meanwhile are
    skipped (OVERRUN), but their time is not: across the gap the fused yaw must turn at the
    rate it turned before, not by one sample period's worth (a tenth of it).
    --glitch-in-read: the drop-out lands in a read, so the read that sees the reset comes
    before the MPU has started up again; the board must wait for it (a second's gap
    otherwise, with the filter's clock restarted: a CI run found it)."""
    turn_from = SKETCH_STARTS_BY_S + 0.5  # still through the boot after the host's open
    csv = tmp_path / "turn.csv"
    csv.write_text("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,9.81\n"
                   f"{turn_from},0,0,0,0,0,9.81\n{turn_from + 0.001},0,0,1,0,0,9.81\n")
    with running_board(boardsim, elf, tmp_path, "--motion", str(csv), "--interp", "linear",
                       "--no-noise", "--flex-mv", FLEX_MV, "--glitch", str(turn_from + 1.0),
                       "--glitch-in-read", *TYPICAL_STARTUP) as board:
        with Link(LinkSettings(port=str(board.link), reconnect=False, mode=P.Mode.FUSED,
                               rate_hz=100)) as link:
            samples = [x for x in link.samples(SKETCH_STARTS_BY_S + 2.5) if isinstance(x, P.FusedSample)]
        board.report()
    t = np.array([x.t for x in samples])
    yaw = np.unwrap([2 * np.arctan2(x.q[3], x.q[0]) for x in samples])
    gaps = np.flatnonzero(np.diff(t) > 0.05)
    assert len(gaps) == 1, f"gaps in the fused stream: {np.diff(t)[gaps]}"
    i = gaps[0]
    before = (yaw[i] - yaw[i - 10]) / (t[i] - t[i - 10])  # the filter's yaw rate
    across = (yaw[i + 1] - yaw[i]) / (t[i + 1] - t[i])
    assert 0.8 < before < 1.1 and t[i + 1] - t[i] > 0.1, (before, t[i + 1] - t[i])
    assert across == pytest.approx(before, rel=0.15), (across, before)
