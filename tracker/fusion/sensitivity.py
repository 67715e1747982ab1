"""The gyroscope's residual sensitivity, learned in play from the tilt each turn leaves.

Why. The maker's calibration (:mod:`tracker.gyro_scale`) leaves the gyroscope's
sensitivity matrix off by 0.1-0.2 % per entry (README, the maker table), and a
board whose fit was refused keeps the data sheet's +-3 % and +-2 %
(PS-MPU-9250A-01, table 1). A raise of the arm by theta then tilts the
strapdown frame by that share of theta; the accelerometer takes the tilt out
over ``tau_acc`` after the turn, and the default filter's bias loop, which
reads every inclination correction as a bias, learned it as one along the axes
horizontal then. Whichever of them is vertical in the next pose turns the
heading while the arm stays there, and every raise adds the same share, so
without a magnetometer the heading walked (README, "The gyroscope's residual
sensitivity": 4-5 degrees in 300 s of raises with a 0.2 % residual).

How. The true rate is (I + D) w, w the bias-corrected reading. An estimate
off by dD turns the strapdown frame I by R_IS dD w per second, as a bias error
of -dD w would. The bias's measurement in
:meth:`tracker.fusion.default.DefaultFilter._learn_bias_in_motion` (row a of
R_EI, z = a' LP(R_IS b)) then gains -a' LP(R_IS dD w): linear in D's nine
entries, entry ij contributing -a' LP(R_IS e_i w_j), each regressor low-passed
as the accelerometer in I is (the relation :mod:`tracker.gyro_scale` fits
between two still poses, here through the accelerometer's low-pass). D is a
second Kalman state beside the bias: both take the same innovation, each
treating the other's uncertainty as noise added to its own measurement (the
"consider" states of S. F. Schmidt's filter, "Application of state-space
methods to navigation problems", Advances in Control Systems 3, 1966), so the
correction after a turn is shared between them by how much each can explain.

D learns only while the arm has stopped (the rate low-passed over 1 s below
``sens_still_rate``, 0.25 rad/s): during a move the lever arm's and the
soft tissue's accelerations that the accelerometer's low-pass has not yet
averaged out correlate with the rate itself and read as a sensitivity error
(learned during moves, entries reached 10 % in the worst plausible player's
first minutes; README). After the move the tilt it left is still being taken
out for ``tau_acc`` while its regressor decays alike, which is what tells D
from the bias. Nor does it learn in the first ``sens_start_t`` (60 s) after
the start: whatever the start left of the bias error is still being taken
out, and D, whose covariance shrinks as it learns, would keep its share for
the session (learning from 20 s on, a drawn player's late aim over two-minute
sessions rose from 2.9 and 4.8 degrees to 3.5 and 5.8; from 60 s on, 3.0 and
4.6; README). Each entry stays within ``limit``.

Where. Even at rest after a move, an accelerometer away from the centre of
rotation still carries, low-passed, the tangential acceleration of the move,
which follows the rate's derivative and so correlates with the regressors:
on raises read 0.3 m from the shoulder D's scale entry went to its limit,
and on BROAD's hand-held recordings the default filter got worse (README).
So only a filter told that its accelerometer is at the shoulder
(:func:`tracker.fusion.default.for_mpu9250`, the game's tracking after
:mod:`tracker.lever_arm`) learns it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..lowpass import LowPass2
from .qmath import Vec

Array = NDArray[np.float64]
ZERO9 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@dataclass
class Sensitivity:
    """The residual sensitivity D (row-major: ``d[3 * i + j]`` is the share of the reading about j
    that is true rate about i), its covariance and the low-passed regressors (module docstring)."""

    tau: float  # the regressors' low-pass time constant: the accelerometer's in I (s)
    prior: float  # D's prior covariance per entry, in the bias covariance's units per (rad/s)^2
    limit: float  # |entry| bound
    d: tuple[float, ...] = ZERO9
    p: Array = field(default_factory=lambda: np.zeros((9, 9)))
    lp: list[LowPass2] = field(default_factory=list)  # LP(R_IS e_i w_j) in I, for entry ij
    regressors: Array = field(default_factory=lambda: np.zeros((9, 3)))

    def __post_init__(self) -> None:
        if not self.lp:
            self.p = np.eye(9) * self.prior
            self.lp = [LowPass2(self.tau) for _ in range(9)]

    def correct(self, w: Vec) -> Vec:
        """The true rate (I + D) w of the bias-corrected reading ``w`` (rad/s)."""
        d = self.d
        x, y, z = w
        return (x + d[0] * x + d[1] * y + d[2] * z, y + d[3] * x + d[4] * y + d[5] * z,
                z + d[6] * x + d[7] * y + d[8] * z)

    def regress(self, rows: tuple[Vec, Vec, Vec], w: Vec, dt: float) -> None:
        """Step the regressors: ``rows`` R_IS by rows, ``w`` the corrected rate's mean over ``dt``."""
        out = self.regressors
        for i in range(3):
            ci = (rows[0][i], rows[1][i], rows[2][i])  # R_IS e_i: sensor axis i in I
            for j in range(3):
                out[3 * i + j] = self.lp[3 * i + j].step((ci[0] * w[j], ci[1] * w[j], ci[2] * w[j]), dt)

    def row(self, a: Vec) -> tuple[Array, float]:
        """For the measurement along ``a`` (a row of R_EI), whose row over D's entries is
        H = -(regressors a): P H' and H P H' (the variance D's uncertainty adds to it)."""
        h = -(self.regressors @ np.array(a))
        ph = self.p @ h
        return ph, float(h @ ph)

    def learn(self, ph: Array, spread: float, innovation: float, noise: float) -> None:
        """One scalar Kalman update: ``spread`` = H P H', ``noise`` the measurement's own noise
        and the bias's share (same units): K = P H' / (H P H' + noise)."""
        k = ph / (spread + noise)
        d = np.clip(np.array(self.d) + k * innovation, -self.limit, self.limit)
        self.d = tuple(float(v) for v in d)
        self.p = self.p - np.outer(k, ph)
