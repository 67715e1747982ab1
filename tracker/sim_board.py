"""The board's firmware loop in simulated time: the sensor simulator's samples, quantised and framed.

:class:`tracker.board.VirtualBoard` runs the firmware's behaviour in real
time on a pty; :class:`SimBoard` runs its sample loop in simulated time and
hands back the bytes, for the gesture evaluation and the headless matches.
Each sample is quantised by :func:`tracker.board.quantise`'s rule, stamped
with the sample grid's microseconds and a sequence number, framed
(:mod:`tracker.protocol`) and passed through the injected link faults
(:class:`tracker.board.Faults`), counting what they damaged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from . import protocol as P
from .board import BoardSettings, FaultInjector, Faults, acc_lsb, counts, gyr_lsb, hello, temp_due
from .sim import STENCIL_REACH_S, Simulator

RATE_HZ = BoardSettings.rate_hz  # the firmware's defaults
ACC_FS_G, GYR_FS_DPS = BoardSettings.acc_fs_g, BoardSettings.gyr_fs_dps
BLOCK = 800  # samples the simulator computes ahead at once (4 s): a change of the motion within them has the
# rest computed again
Counts = tuple[tuple[int, int, int], tuple[int, int, int], tuple[int, int, int], int, int]
# acc, gyr, mag, flags (the raw frame's flags word: the flex ADC, the full scales and the magnetometer's
# valid bit) and the die's TEMP_OUT


@dataclass
class BoardTally:
    """What the simulated board sent and what the faults did to it."""

    frames_sent: int = 0  # sample frames
    frames_damaged: int = 0  # sample frames that lost or changed a byte
    damaged_header_intact: int = 0  # of those, the header (sync, length, type) arrived whole: the CRC must fail
    samples_stalled: int = 0  # samples not taken while the loop was frozen


class SimBoard:
    """The board's firmware loop in simulated time: the simulator's samples, quantised and framed.

    Samples are computed ahead, ``block`` at a time (one call of the
    simulator for many samples is far cheaper than many calls). When the
    motion changes (``edits()`` gives the earliest time a change touches, inf
    for none), the samples from there on are computed again; a change to
    samples already sent is an error.
    """

    def __init__(self, sim: Simulator, edits: Callable[[], float] = lambda: math.inf,
                 faults: Faults = Faults(), rate_hz: int = RATE_HZ, block: int = BLOCK) -> None:
        self.stream = sim.stream(rate_hz)
        self.edits = edits
        self.rate_hz, self.block = rate_hz, block
        self.faults = faults
        self.injector = FaultInjector(faults)
        self.tally = BoardTally()
        self._readings: list[Counts] = []
        self._first = 0  # sample index of _readings[0]
        self._next = 0  # the next sample index to send
        self._seq = 0
        self._raw_since_temp = 0  # RAW frames sent since the last TEMP frame (tracker.board.temp_due)

    def hello(self) -> bytes:
        """The hello frame the firmware sends at power-up (streaming raw frames)."""
        return P.encode_hello(hello(self.rate_hz, P.Mode.RAW, True, ACC_FS_G, GYR_FS_DPS,
                                    P.BoardError.NONE, has_mag=True))

    def run_until(self, t: float) -> bytes:
        """The bytes the board sends for every sample due by ``t`` (seconds since power-up)."""
        self._forget_edited()
        out = bytearray()
        while self._next <= t * self.rate_hz + 1e-9:
            k = self._next
            self._next += 1
            ts = k / self.rate_hz
            if self.faults.stalled(ts):
                self.tally.samples_stalled += 1  # a frozen loop takes no sample: no sequence number
                continue
            acc, gyr, mag, flags, temp = self._reading(k)
            t_us = round(ts * 1e6) & 0xFFFFFFFF
            if temp_due(self._raw_since_temp, self.rate_hz):
                out += self.injector.apply(P.encode_temp(t_us, temp))
                self._raw_since_temp = 0
            self._raw_since_temp += 1
            seq, self._seq = self._seq, (self._seq + 1) & 0xFFFF
            out += self._send(P.encode_raw_counts(t_us, seq, acc, gyr, mag, flags))
        return bytes(out)

    def _send(self, frame: bytes) -> bytes:
        wire = self.injector.apply(frame)
        tally = self.tally
        tally.frames_sent += 1
        if wire != frame:
            tally.frames_damaged += 1
            tally.damaged_header_intact += wire[:P.HEADER_SIZE] == frame[:P.HEADER_SIZE]
        return wire

    def _forget_edited(self) -> None:
        """Drop the samples computed ahead that a change of the motion touches."""
        edited = self.edits()
        if edited == math.inf:
            return
        k = max(0, math.floor((edited - STENCIL_REACH_S) * self.rate_hz))  # the first sample it touches
        if k < self._next:
            raise RuntimeError(f"the motion changed at {edited:.4f} s, before samples already sent")
        del self._readings[max(0, k - self._first):]

    def _reading(self, k: int) -> Counts:
        i = k - self._first
        if i >= len(self._readings):
            self._first = k
            self._readings = self._compute(k, k + self.block)
            i = 0
        return self._readings[i]

    def _compute(self, k0: int, k1: int) -> list[Counts]:
        """Samples k0..k1-1 as the MPU-9250 and the ADC read them (:func:`tracker.board.quantise`'s rule),
        with each one's flags word."""
        data = self.stream.block(k0, k1)
        acc = counts(data.acc[:, 0], acc_lsb(ACC_FS_G)).tolist()
        gyr = counts(data.gyr[:, 0], gyr_lsb(GYR_FS_DPS)).tolist()
        mag = counts(data.mag[:, 0], P.MAG_UT_PER_COUNT).tolist()
        flags = P.raw_flags(0, ACC_FS_G, GYR_FS_DPS)
        temps = [P.temp_counts(c) for c in data.die_c.tolist()]
        return [((a[0], a[1], a[2]), (g[0], g[1], g[2]), (m[0], m[1], m[2]), flags | (f & P.FLEX_ADC_MASK), c)
                for a, g, m, f, c in zip(acc, gyr, mag, data.flex_adc.tolist(), temps)]
