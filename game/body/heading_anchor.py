"""The wearing calibration's "forward", kept while the magnetometer's heading settles.

The wearing calibration takes "forward" from the filter's heading a few
seconds after start-up. With the magnetometer (9D) that heading comes from
the field at the one or two places the arm has been, and an indoor
disturbance that varies with position (5-40 uT against a horizontal field
of about 20 uT) turns it by up to 20 deg there. As the arm moves, the filter
averages the field over many places and its heading settles to the true
one, but "forward" was taken from the unsettled heading, so every launch
afterwards aims off by what the heading settled: the pose was worse than
with no magnetometer at all (where the gyroscope keeps the heading the
calibration saw).

What the field turns after the calibration is two things: the heading the
calibration took was wrong by the field's spread (its variance ``p0``, the
heading's spread against the gyroscope's, ``DefaultFilter.heading_spread``),
and the gyroscope's own drift since (variance growing as (s t)^2 for a
bias uncertain by s). The best estimate of the heading error at the
calibration, from a heading error y seen t seconds later, is y p0 / (p0 +
(s t)^2): the scalar case of the optimal fixed-point smoother (A. Gelb
(ed.), "Applied Optimal Estimation", MIT Press 1974, ch. 5), for a state
uncertain by p0 that has since drifted by a ramp; here it is applied to each
turn as it comes. That share of each turn moves "forward" with the heading,
so a turn that settles the start's error leaves the aim alone, and a turn
that corrects the gyroscope's drift minutes later reaches it.

A field not yet trusted turns the heading provisionally: found bad, the
filter gives back what it turned (``DefaultFilter.provisional_heading``).
"Forward" then gives back what it followed of those turns, all of those made
before it was taken (the calibration saw them) and its share of each made
after, so the aim is where it would have been had the field never turned it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

GYRO_HEADING_SD = math.radians(0.4)  # s: how fast the gyroscope's heading may stray (rad/s) in the
# first minute of play: the MPU-9250's warm-up moves the bias by up to 0.027 deg/s per s at
# power-on (DefaultParams, drift), which the filter's drift loop learns over its drift_t of 15 s.


@dataclass
class HeadingAnchor:
    """How far "forward" has followed the filter's heading since the wearing calibration
    (read-only outside; :meth:`set` at each calibration, :meth:`follow` at each sample)."""

    t0: float | None = None  # when "forward" was taken (s, device time); None: not yet
    p0: float = 0.0  # the variance of the heading it was taken from (rad^2)
    heading: float = 0.0  # the filter's heading at the last sample (rad)
    offset: float = 0.0  # the turn about world z taken off the filter's pose (rad)
    provisional: float = 0.0  # the filter's provisional share of its heading at the last sample (rad) ...
    taken_back: int = 0  # ... and how many times it had given such turns back
    held: float = 0.0  # what "forward" has followed of the provisional turns (rad): given back with them

    def set(self, t: float, heading: float, spread: float, provisional: float = 0.0, taken_back: int = 0) -> None:
        """"Forward" was taken at ``t`` from a heading (rad) whose field spread by ``spread`` (rad),
        ``provisional`` of it turned by a field not yet trusted, given back ``taken_back`` times so far.

        The offset so far stays: the pose the calibration saw had it taken off. So did the
        provisional turns: "forward" followed all of them."""
        self.t0, self.p0, self.heading = t, spread * spread, heading
        self.provisional, self.taken_back, self.held = provisional, taken_back, provisional

    def follow(self, t: float, heading: float, provisional: float = 0.0, taken_back: int = 0) -> float:
        """The offset (rad) after the filter's heading became ``heading`` at ``t``, ``provisional``
        of it turned by a field not yet trusted, such turns given back ``taken_back`` times so far."""
        if self.t0 is None:
            return 0.0
        turn = (heading - self.heading + math.pi) % (2.0 * math.pi) - math.pi
        self.heading = heading
        if taken_back != self.taken_back:  # the filter gave back the provisional turns: so does "forward"
            turn += self.provisional
            self.offset -= self.held
            self.provisional, self.held = 0.0, 0.0
        self.taken_back = taken_back
        drift = GYRO_HEADING_SD * (t - self.t0)
        if self.p0 > 0.0:
            spread = self.p0 + drift * drift  # the smoother's share of a turn is p0 / spread
            self.offset += turn * self.p0 / spread
            self.held += (provisional - self.provisional) * self.p0 / spread
        if not provisional:
            self.held = 0.0  # trusted: nothing is left to give back
        self.provisional = provisional
        return self.offset
