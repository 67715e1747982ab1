"""The serial link against the virtual board on a real pty, opened with pyserial."""

import itertools
import os
import time

import numpy as np
import pytest
from serial.tools.list_ports_common import ListPortInfo

from tracker import protocol as P
from tracker.board import BoardSettings, Faults, VirtualBoard
from tracker.link import Link, LinkError, LinkSettings, classify

from .helpers import wait_until, wire


def stream(link: Link, board: VirtualBoard, seconds: float) -> list:
    """Everything the link delivers in ``seconds``, after the board is told to stop."""
    got = list(link.samples(seconds))
    link.command(P.Command(P.FrameType.STOP))
    time.sleep(0.2)
    return got + link.drain()


def test_five_seconds_at_200hz_arrive_exactly_then_the_link_survives_a_pulled_cable():
    settings = BoardSettings(rate_hz=200, stream_at_boot=False, keep_sent=10_000)
    with VirtualBoard(settings=settings) as board, Link(LinkSettings(board.port)) as link:
        assert link.hello is not None and link.hello.imu_whoami == 0x71
        # Five seconds counted in samples, not in wall time: when the board acts on START
        # depends on the machine's load (a loaded CI runner took 85 ms), its rate does not.
        started = time.monotonic()
        five_s = list(itertools.islice(link.samples(10.0), 1000))
        took = time.monotonic() - started
        assert len(five_s) == 1000
        assert took > 4.9  # the board's clock runs on wall time: no faster than 200 Hz
        got = five_s + stream(link, board, 0.0)
        sent = list(board.sent)
        assert len(sent) >= 1000
        assert [wire(s) for s in got] == [wire(s) for s in sent]
        np.testing.assert_allclose(np.diff([s.t for s in got]), 1 / 200, atol=2e-6)  # no gap
        h = link.health()
        assert (h.dropped, h.crc_errors, h.bytes_skipped, h.queue_overflows) == (0, 0, 0, 0)

        link.command(P.Command(P.FrameType.START))
        board.pull_cable()
        assert wait_until(lambda: not link.health().connected, 2.0)
        assert "reconnecting" in link.health().status
        board.plug_in()
        assert wait_until(lambda: link.health().connected, 5.0)
        link.drain()
        resumed = list(link.samples(1.0))
        assert len(resumed) >= 150
        assert link.health().reconnects == 1
        # The board powered up again: its clock and sequence started over.
        assert resumed[0].t < 1.5


def test_a_hiccup_of_the_host_process_delays_samples_but_loses_none():
    """The board thread blocked for 0.3 s (as a collection or a loaded machine does) sends
    the samples it owes late; their device times stay 1/rate apart (only stall() skips)."""
    settings = BoardSettings(rate_hz=200, stream_at_boot=False, keep_sent=10_000)
    with VirtualBoard(settings=settings) as board, Link(LinkSettings(board.port)) as link:
        link.drain()
        time.sleep(0.3)
        with board._lock:  # the firmware loop takes this lock every turn
            time.sleep(0.3)
        got = stream(link, board, 0.5)
    t = np.array([s.t for s in got])
    assert len(t) >= 150
    np.testing.assert_allclose(np.diff(t), 1 / 200, atol=2e-6)


def test_handshake_sets_the_requested_rate_and_mode():
    with VirtualBoard() as board, Link(LinkSettings(board.port, rate_hz=50, mode=P.Mode.FUSED)) as link:
        link.drain()
        got = list(link.samples(1.0))
        assert all(isinstance(s, P.FusedSample) for s in got)
        assert 40 <= len(got) <= 60
        dt = [b.t - a.t for a, b in zip(got, got[1:])]
        assert all(d == pytest.approx(0.02, abs=1e-6) for d in dt)


def test_corrupted_bytes_are_counted_and_never_delivered():
    settings = BoardSettings(stream_at_boot=False, keep_sent=10_000)
    with VirtualBoard(settings=settings, faults=Faults(corrupt_rate=2e-3, seed=1)) as board:
        with Link(LinkSettings(board.port)) as link:
            got = stream(link, board, 2.0)
        sent = {wire(s) for s in board.sent}
        assert got and all(wire(s) in sent for s in got)
        h = link.health()
        assert h.crc_errors > 0
        assert h.dropped == (got[-1].seq - got[0].seq + 1) - len(got)


def test_a_paper_style_text_board_at_9600_baud_is_found_by_trying_bauds():
    with VirtualBoard(settings=BoardSettings(legacy_text=True, keep_sent=1000)) as board:
        with Link(LinkSettings(board.port)) as link:
            got = list(link.samples(1.0))
            assert link.health().legacy_text
        assert len(got) >= 10 and all(isinstance(s, P.FusedSample) for s in got)
        # Text lines carry no sequence number: the received run is a contiguous run of
        # the sent lines, to the 4 decimals the sketch prints (renormalised by the host).
        sent = list(board.sent)
        start = min(range(len(sent)), key=lambda i: abs(sent[i].flex_deg - got[0].flex_deg)
                    + sum(abs(a - b) for a, b in zip(sent[i].q, got[0].q)))
        for s, truth in zip(got, sent[start:start + len(got)], strict=True):
            assert s.q == pytest.approx(truth.q, abs=2e-4)
            assert s.flex_deg == pytest.approx(truth.flex_deg, abs=0.005)


def test_device_clock_wraps_around_without_a_jump():
    settings = BoardSettings(clock_start_us=2**32 - 500_000, stream_at_boot=False)
    with VirtualBoard(settings=settings) as board, Link(LinkSettings(board.port)) as link:
        got = list(link.samples(1.2))
    assert any(s.t_us < 100_000 for s in got) and any(s.t_us > 2**32 - 100_000 for s in got)
    steps = [b.t - a.t for a, b in zip(got, got[1:])]
    assert all(d == pytest.approx(0.005, abs=1e-6) for d in steps)


def test_a_slow_consumer_loses_the_oldest_samples_not_memory():
    with VirtualBoard(settings=BoardSettings(stream_at_boot=False)) as board, \
            Link(LinkSettings(board.port, queue_size=20)) as link:
        time.sleep(0.5)
        h = link.health()
        waiting = link.drain()
    assert len(waiting) == 20
    assert h.queue_overflows >= 50
    seqs = [s.seq for s in waiting]
    assert seqs == list(range(seqs[0], seqs[0] + 20))  # the newest, in order


def test_a_port_that_sends_nothing_is_a_clear_error():
    master, slave = os.openpty()
    try:
        with pytest.raises(LinkError, match="no data from"):
            Link(LinkSettings(os.ttyname(slave), handshake_timeout_s=0.3)).open()
    finally:
        os.close(master)
        os.close(slave)


def test_a_wrong_baud_rate_is_a_clear_error():
    with VirtualBoard(settings=BoardSettings(baud=9600)) as board:
        with pytest.raises(LinkError, match="no valid frames at 115200 baud"):
            Link(LinkSettings(board.port, baud=115200, handshake_timeout_s=0.5)).open()


def test_a_missing_port_is_a_clear_error():
    with pytest.raises(LinkError, match="no such port"):
        Link(LinkSettings("/dev/ttyNOPE")).open()


def test_an_unknown_url_scheme_is_a_clear_error():
    with pytest.raises(LinkError, match="cannot open"):
        Link(LinkSettings("nope://x")).open()


def test_loopback_url_opens_but_no_board_answers():
    with pytest.raises(LinkError, match="no valid frames|no data"):
        Link(LinkSettings("loop://", handshake_timeout_s=0.3)).open()


def test_known_usb_ids_are_recognised_and_listed_first():
    ports = []
    for device, vid, pid in [("/dev/ttyS0", None, None), ("/dev/ttyUSB0", 0x10C4, 0xEA60),
                             ("/dev/ttyACM0", 0x2341, 0x0043), ("/dev/ttyUSB1", 0x1234, 0x5678)]:
        p = ListPortInfo(device, skip_link_detection=True)
        p.vid, p.pid = vid, pid
        ports.append(p)
    infos = classify(ports)
    assert [i.device for i in infos[:2]] == ["/dev/ttyACM0", "/dev/ttyUSB0"]
    assert [i.chip is not None for i in infos] == [True, True, False, False]


def test_dropped_bytes_show_as_sequence_gaps_and_a_stall_as_silence():
    settings = BoardSettings(stream_at_boot=False, keep_sent=10_000)
    with VirtualBoard(settings=settings, faults=Faults(drop_rate=1e-3, seed=3)) as board, \
            Link(LinkSettings(board.port)) as link:
        got = list(link.samples(1.0))
        board.stall(0.4)
        time.sleep(0.3)
        silent_for = link.health().since_last_s
        got += list(link.samples(0.6))
    sent = {wire(s) for s in board.sent}
    assert all(wire(s) in sent for s in got)  # a frame that lost a byte is never delivered
    assert link.health().dropped == (got[-1].seq - got[0].seq + 1) - len(got) > 0
    assert silent_for >= 0.25
    # The stalled board took no samples: the device clock jumps by the stall.
    assert max(b.t - a.t for a, b in zip(got, got[1:])) >= 0.35


def test_a_pulled_cable_removes_only_its_own_link(tmp_path):
    """The link goes with the pty it names; a path since taken by another program stays."""
    link = tmp_path / "ttyARM"
    board = VirtualBoard(link=link).start()
    assert os.path.realpath(link).startswith("/dev/pts/")
    board.pull_cable()
    assert not link.exists() and not link.is_symlink()
    board.plug_in()
    other = tmp_path / "someone-elses"
    other.write_text("not ours")
    link.unlink()
    link.symlink_to(other)
    board.stop()
    assert link.is_symlink() and link.read_text() == "not ours"
