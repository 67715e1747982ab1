"""The serial line on the simulated board: the reset when the host opens the port, and baud rates.

A Metro Mini's CP2104 drives DTR through a 0.1 uF capacitor to RESET, so opening
the port restarts the ATmega328P into Optiboot; boardsim does the same when the
host opens its pty (firmware/sim/README.md, "The serial line"). Each end's real
baud rate decides whether the other reads its bytes: the AVR's from UBRR0 and
U2X0 (ATmega328P data sheet table 20-1), the bridge's from the CP2104's divider
(CP2104 data sheet sec. 6.1); past the receiver's tolerance (tables 20-2/20-3,
+-1.5% for 8N1 with U2X0; the CP2104's +-2%) every byte arrives garbled.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest
import serial

from tracker import protocol as P
from tracker.link import Link, LinkSettings

from .test_sim import (BOOT_S, FIRMWARE, OPTIBOOT_S, RATE_HZ, _boardsim_fails, _make, boardsim,  # noqa: F401
                       elf, running_board, samples_until)

LEGACY_ELF = FIRMWARE / "build" / "energyball-legacy.elf"
F_CPU = 16_000_000
IDENTIFY = P.encode_command(P.Command(P.FrameType.IDENTIFY))


@pytest.fixture(scope="module")
def legacy_elf(elf: Path) -> Path:
    """The paper's text-stream variant (9600 baud), built with the firmware's own Makefile."""
    _make("-C", str(FIRMWARE), "LEGACY_TEXT=1", timeout=900)
    assert LEGACY_ELF.exists(), f"make LEGACY_TEXT=1 did not produce {LEGACY_ELF}"
    return LEGACY_ELF


def read_frames(port: serial.Serial, seconds: float, start: float,
                decoder: P.FrameDecoder | None = None) -> list[tuple[float, P.Packet]]:
    """(seconds since ``start``, packet) for every frame read from ``port`` for ``seconds``;
    give the ``decoder`` of earlier calls so a frame split between two calls is not lost."""
    decoder, got = decoder or P.FrameDecoder(), []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        got += [(time.monotonic() - start, p) for p in decoder.feed(port.read(256))]
    return got


# ---------------------------------------------------------------- reset on open


def test_opening_the_port_resets_the_board_and_the_bootloader_swallows_the_hosts_bytes(
        boardsim, elf, tmp_path):
    with running_board(boardsim, elf, tmp_path, "--reset-on-open") as board:  # the default
        time.sleep(0.8)  # the board boots once by itself and streams into the unopened pty
        port = serial.Serial(str(board.link), P.DEFAULT_BAUD, timeout=0.02)
        opened = time.monotonic()
        port.reset_input_buffer()
        port.write(IDENTIFY)  # a board in reset or in Optiboot never hears it
        got: list[tuple[float, P.Packet]] = []
        decoder = P.FrameDecoder()
        while not any(isinstance(p, P.RawSample) for _, p in got) and time.monotonic() < opened + 6:
            got += read_frames(port, 0.1, opened, decoder)
        port.close()
        report = board.report()
    line = report["line"]
    assert (line["host_opens"], line["resets"]) == (1, 1)
    assert line["bytes_to_bootloader"] == len(IDENTIFY)
    first_t, hello = got[0]
    assert isinstance(hello, P.Hello), got[:3]
    assert first_t >= OPTIBOOT_S, f"the board spoke {first_t:.3f} s after the open, inside Optiboot's time"
    samples = [p for _, p in got if isinstance(p, P.RawSample)]
    # The board started over: sequence and device clock from power-up (PROTOCOL.md 7.1).
    assert samples and samples[0].seq == 0 and samples[0].t < 0.1, samples[:1]
    assert sum(isinstance(p, P.Hello) for _, p in got) == 1  # only the boot HELLO: IDENTIFY was lost


def test_a_reconnect_to_the_same_port_does_not_reset_the_board_again(boardsim, elf, tmp_path):
    with running_board(boardsim, elf, tmp_path) as board:
        with Link(LinkSettings(port=str(board.link), reconnect=False)) as link:
            assert link.hello is not None
            before = link.get(timeout=1.0)
            assert before is not None
        start = time.monotonic()
        with Link(LinkSettings(port=str(board.link), reconnect=False)) as link:
            handshake_s = time.monotonic() - start
            hello = link.hello
            sample = link.get(timeout=1.0)
        report = board.report()
    assert report["line"]["host_opens"] == 2
    assert report["line"]["resets"] == 1, "the second open reset the board again"
    assert hello is not None and hello.streaming is False  # the running sketch answered IDENTIFY
    assert sample is not None and sample.seq > before.seq  # its count ran on: no power-up
    assert handshake_s < OPTIBOOT_S / 2, f"the reconnect took {handshake_s:.2f} s"


def test_an_open_that_resets_the_board_in_the_middle_of_a_read_leaves_a_bus_it_clears(
        boardsim, elf, tmp_path):
    """--stuck-sda: the host's open resets the AVR while the MPU is sending a byte, the worst
    moment: the MPU, not reset, holds SDA low (UM10204 sec. 3.1.16). After Optiboot's time
    the sketch must clear the bus and stream, not report IMU_MISSING until a power cycle."""
    with running_board(boardsim, elf, tmp_path, "--stuck-sda", "--flex-mv", "2000") as board:
        time.sleep(0.8)  # the board boots by itself and reads the MPU every 5 ms
        with Link(LinkSettings(port=str(board.link), reconnect=False)) as link:
            hello = link.hello
            got = samples_until(link, lambda got: len(got) >= RATE_HZ)
        report = board.report()
    assert (report["line"]["resets"], report["i2c"]["stuck"]) == (1, 1), report["i2c"]
    assert report["i2c"]["cleared"] >= 1 and not report["i2c"]["blocked"], report["i2c"]
    assert hello is not None and not hello.errors, hello
    assert len(got) >= 190, f"{len(got)} samples of the {RATE_HZ} asked for"


def test_the_9600_baud_fallback_finds_a_text_board_without_resetting_it(
        boardsim, legacy_elf, tmp_path):
    with running_board(boardsim, legacy_elf, tmp_path) as board:
        with Link(LinkSettings(port=str(board.link), reconnect=False)) as link:
            legacy = link.health().legacy_text
            got = samples_until(link, lambda got: len(got) >= 20)  # the sketch prints 20 a second
        report = board.report()
    assert legacy, "the link did not take the board for the paper's text stream"
    assert len(got) >= 15, f"{len(got)} lines of the 20 asked for"
    assert report["line"]["resets"] == 1, "trying 9600 baud reopened the port and reset the board"


def test_the_handshake_waits_out_a_bootloader_running_slow(boardsim, elf, tmp_path):
    """Optiboot's 1 s is 128K cycles of an uncalibrated 128 kHz RC oscillator: 25% slow here."""
    slow_ms = round(1.25 * OPTIBOOT_S * 1000)
    with running_board(boardsim, elf, tmp_path, "--bootloader-ms", str(slow_ms)) as board:
        with Link(LinkSettings(port=str(board.link), reconnect=False)) as link:
            hello = link.hello
        report = board.report()
    assert hello is not None and hello.imu_whoami == 0x71
    assert report["line"]["resets"] == 1


# ---------------------------------------------------------------- baud rates


def test_the_board_obeys_the_hosts_settings_at_the_default_baud_rate(boardsim, elf, tmp_path):
    """SET_RATE and SET_MODE reach the board: 100 Hz fused frames, not the boot's 200 Hz raw."""
    with running_board(boardsim, elf, tmp_path) as board:
        with Link(LinkSettings(port=str(board.link), reconnect=False, rate_hz=100,
                               mode=P.Mode.FUSED)) as link:
            link.get(timeout=1.0)
            link.drain()
            got = list(link.samples(0.5))
        report = board.report()
    line = report["line"]
    assert line["rx_garbled"] == 0 and line["tx_garbled"] == 0
    # The UART's rate, worked by hand from table 20-1 for the core's UBRR0 = 3 with U2X0.
    assert line["avr_baud"] == pytest.approx(F_CPU / (8 * (3 + 1)))
    assert line["host_baud"] == pytest.approx(P.DEFAULT_BAUD)
    assert got and all(isinstance(s, P.FusedSample) for s in got), got[:2]
    assert {round(b.t - a.t, 6) for a, b in zip(got, got[1:])} == {0.01}


def streaming_port(link: Path) -> serial.Serial:
    """The port opened at the default rate, once the sketch streams (its boot HELLO behind)."""
    port = serial.Serial(str(link), P.DEFAULT_BAUD, timeout=0.02)
    decoder = P.FrameDecoder()
    end = time.monotonic() + 5
    while not any(isinstance(p, P.RawSample) for p in decoder.feed(port.read(256))):
        assert time.monotonic() < end, "the board never streamed"
    return port


def count_answers(port: serial.Serial, asks: int, seconds: float) -> tuple[int, int]:
    """(HELLOs, raw samples) in ``seconds`` after sending IDENTIFY ``asks`` times."""
    for _ in range(asks):
        port.write(IDENTIFY)
        time.sleep(0.02)
    got = [p for _, p in read_frames(port, seconds, time.monotonic())]
    return sum(isinstance(p, P.Hello) for p in got), sum(isinstance(p, P.RawSample) for p in got)


@pytest.mark.parametrize("errors_pct, answered", [
    ("1.4", True),    # within table 20-3's +-1.5% (8 data bits, U2X0 = 1)
    ("1.6", False),
    ("-1.6", False),  # the AVR misreads the host; the CP2104 still reads the AVR (1.63% of +-2%)
    ("0,-1.6", False),  # the AVR's own clock 1.6% slow: the host is 1.63% fast to it
    ("0.8,0.8", True),  # both ends off alike: they agree
])
def test_the_avr_reads_the_host_only_within_its_receivers_tolerance(
        boardsim, elf, tmp_path, errors_pct, answered):
    with running_board(boardsim, elf, tmp_path, "--no-reset-on-open", "--flex-mv", "2000",
                       "--baud-error", errors_pct) as board:
        port = streaming_port(board.link)
        hellos, samples = count_answers(port, 3, 0.6)
        port.close()
        report = board.report()
    assert hellos == (3 if answered else 0), (hellos, report["line"])
    assert samples > 50 and report["line"]["tx_garbled"] == 0  # the host reads the board throughout
    assert (report["line"]["rx_garbled"] == 0) == answered


def test_the_bridge_makes_its_rate_from_its_48_mhz_clock(boardsim, elf, tmp_path):
    """115200 is 48 MHz / (2 x 208) = 115384.6 on the CP2104 (data sheet sec. 6.1, eq. 1-2),
    far from the AVR's 500000: neither end reads the other."""
    with running_board(boardsim, elf, tmp_path, "--no-reset-on-open", "--host-baud", "115200") as board:
        time.sleep(0.5)  # past the sketch's start: its bytes reach the open port from now on
        port = serial.Serial(str(board.link), P.DEFAULT_BAUD, timeout=0.02)
        port.write(IDENTIFY)
        got = read_frames(port, 0.3, time.monotonic())
        port.close()
        report = board.report()
    assert report["line"]["host_baud"] == pytest.approx(48e6 / (2 * 208), abs=0.05)
    assert report["line"]["tx_garbled"] > 50 and report["line"]["rx_garbled"] == len(IDENTIFY)
    assert not any(isinstance(p, P.Hello) for _, p in got)


@pytest.mark.parametrize("args, words", [
    (("--bootloader-ms", "-1"), "--bootloader-ms takes milliseconds 0..10000, not '-1'"),
    (("--host-baud", "100"), "--host-baud takes a baud rate 300..2000000 (the CP2104's range), not '100'"),
    (("--baud-error", "11"), "--baud-error takes HOST[,AVR]: percentages -10..10, not '11'"),
    (("--baud-error", "0,x"), "--baud-error takes HOST[,AVR]: percentages -10..10, not '0,x'"),
    (("--seed", "-3"), "--seed takes a whole number"),
])
def test_bad_serial_line_option_is_a_clear_error(boardsim, tmp_path, args, words):
    _boardsim_fails(boardsim, str(tmp_path / "unused.elf"), *args, words=words)


def test_a_board_without_reset_on_open_streams_to_a_late_host_at_once(boardsim, elf, tmp_path):
    with running_board(boardsim, elf, tmp_path, "--no-reset-on-open") as board:
        time.sleep(BOOT_S + 0.5)  # streaming by then
        port = serial.Serial(str(board.link), P.DEFAULT_BAUD, timeout=0.02)
        port.reset_input_buffer()
        got = read_frames(port, 0.3, time.monotonic())
        port.close()
        report = board.report()
    assert report["line"]["resets"] == 0 and report["line"]["host_opens"] == 1
    assert got and got[0][0] < 0.1 and isinstance(got[0][1], P.RawSample)
