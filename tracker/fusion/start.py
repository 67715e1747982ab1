"""The start-up's gravity: the accelerometer in frame I averaged over the first second.

A plain mean of the accelerometer in the (almost) inertial frame I over
[0, T] is gravity plus the board's mean linear acceleration, which is
exactly (v(T) - v(0)) / T: the difference of its velocities at the window's
ends over the window's length. A player's tremor is not pure rotation at
the board: the board sits 0.2-0.3 m from the shoulder it turns about, so a
1.8 deg tremor at 10 Hz swings it at up to 0.6 m/s, and a mean that ends at
an unlucky phase keeps up to 2 * 0.6 m/s over 1 s, a tilt of 7 deg, which
the game's wearing calibration would then keep for the whole session.

For a board turning about a fixed point p away (the shoulder; the body
itself sways far more slowly), v = w x p, so two moments at which the
board turns the same way, w_I(t1) = w_I(0), have the same velocity and
the mean between them is gravity alone (p moves by millimetres over the
second). The mean therefore ends before the sample, in the second half of the
start-up, whose rate in I is closest to the first sample's: a tremor at 3 Hz
or faster repeats its phase in that half second, and the search needs no
model of the lever (its length, the shoulder's place). The fit of the
lever itself (Seel, Schauer and Raisch, "Joint axis and position estimation
from inertial measurement data by exploiting kinematic constraints", IEEE
CCA 2012, sec. III) is what this avoids having to trust over one second.
"""

from __future__ import annotations

from dataclasses import dataclass

from mypy_extensions import mypyc_attr

Vec = tuple[float, float, float]

SEARCH_FROM = 0.5  # the mean may end anywhere in the start-up's second half


@mypyc_attr(serializable=True)  # copy.deepcopy works when compiled (its __init__ needs arguments)
@dataclass
class StartMean:
    """The running mean of the accelerometer in I, and where it is best ended (read-only outside)."""

    mean: Vec = (0.0, 0.0, 0.0)  # the plain mean so far (m/s^2, frame I) ...
    n: int = 0  # ... of this many samples
    w0: Vec = (0.0, 0.0, 0.0)  # the rate in I at the first sample (rad/s)
    best: Vec = (0.0, 0.0, 0.0)  # the mean up to (not with) the sample turning most like the first ...
    best_miss: float = -1.0  # ... and how unlike it turned: |w_I - w0|^2 ((rad/s)^2; < 0: none yet)

    def add(self, a_i: Vec, w_i: Vec, t: float, length: float) -> Vec:
        """Take the sample ``a_i`` (accelerometer in I) at ``t`` seconds of a start-up
        ``length`` long, the board turning at ``w_i`` (rad/s, in I); the plain mean so far."""
        if self.n == 0:
            self.w0 = w_i
        elif t >= SEARCH_FROM * length:
            # The samples before this one span whole swings if it turns as the first did (their
            # sum is the integral from the first to this one: the rectangle rule's ends cancel).
            w0 = self.w0
            miss = (w_i[0] - w0[0]) ** 2 + (w_i[1] - w0[1]) ** 2 + (w_i[2] - w0[2]) ** 2
            if self.best_miss < 0.0 or miss < self.best_miss:
                self.best, self.best_miss = self.mean, miss
        self.n += 1
        (mx, my, mz), k = self.mean, 1.0 / self.n
        self.mean = (mx + k * (a_i[0] - mx), my + k * (a_i[1] - my), mz + k * (a_i[2] - mz))
        return self.mean

    @property
    def gravity(self) -> Vec | None:
        """Gravity in I (m/s^2): the mean between equal rates, the plain mean if the start-up
        was too short to search; None before any sample."""
        if self.n == 0:
            return None
        return self.best if self.best_miss >= 0.0 else self.mean
