"""A second-order Butterworth low-pass on 3-vectors, for streaming use from Python loops.

Coefficients come from the analogue prototype H(s) = 1 / (s^2 + sqrt(2) s + 1)
by the bilinear transform with a prewarped cut-off, K = tan(pi fc Ts) (any DSP
text, e.g. Oppenheim & Schafer, Discrete-Time Signal Processing, sec. 7.1). As
in VQF (Laidig & Seel 2023, sec. 3.2) the cut-off is given as a time constant
tau, fc = sqrt(2) / (2 pi tau). Direct form II transposed per axis, on plain
floats: a filter updated once per sample costs less than numpy's call overhead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mypy_extensions import mypyc_attr

Vec = tuple[float, float, float]


@mypyc_attr(serializable=True)  # copy.deepcopy works when compiled (its __init__ needs arguments)
@dataclass
class LowPass2:
    """The filter of time constant ``tau``: its coefficients for samples ``dt`` apart and its
    per-axis state. It starts settled at its first input.

    :meth:`step` designs it for the sample period it meets (none is known before
    the first sample) and follows a new one.
    """

    tau: float  # seconds
    dt: float = 0.0  # the sample period the coefficients are for, seconds (0: not designed yet)
    b0: float = 0.0
    b1: float = 0.0
    b2: float = 0.0
    a1: float = 0.0
    a2: float = 0.0
    s1: Vec = (0.0, 0.0, 0.0)  # the first state of each axis
    s2: Vec = (0.0, 0.0, 0.0)  # the second
    primed: bool = False
    y: Vec = (0.0, 0.0, 0.0)  # the last output

    @classmethod
    def design(cls, tau: float, dt: float) -> "LowPass2":
        """The filter of time constant ``tau`` for samples ``dt`` apart (both seconds)."""
        lp = cls(tau)
        lp._design(dt)
        return lp

    def _design(self, dt: float) -> None:
        """The coefficients for samples ``dt`` apart; a filter that has run settles at its last output."""
        fc = math.sqrt(2.0) / (2.0 * math.pi * self.tau)
        k = math.tan(math.pi * min(fc * dt, 0.49))
        norm = 1.0 + math.sqrt(2.0) * k + k * k
        b0 = k * k / norm
        self.b0, self.b1, self.b2 = b0, 2 * b0, b0
        self.a1, self.a2 = 2.0 * (k * k - 1.0) / norm, (1.0 - math.sqrt(2.0) * k + k * k) / norm
        self.dt = dt
        if self.primed:
            self.primed = False
            self(self.y)

    def step(self, x: Vec, dt: float) -> Vec:
        """Filter ``x``, which came ``dt`` after the sample before it.

        The first sample designs the filter for ``dt``. A ``dt`` that is a whole
        number n of periods means n - 1 samples were lost: ``x`` is taken as held
        over all n (:meth:`held`), so the filter's time stays right. Any other
        ``dt`` is a new sample rate: the filter is designed again, keeping its output.
        """
        d = self.dt
        if d and abs(dt - d) <= 1e-3 * d:  # one period (periods() gives 1): the common case, at once
            return self(x)
        n = periods(dt, d) if d else 0
        if not n:
            self._design(dt)
            n = 1
        return self.held(x, n)

    def held(self, x: Vec, periods: int) -> Vec:
        """Filter ``x`` as if it had arrived at each of ``periods`` sample times (zero-order hold):
        how a sample that comes after lost ones is taken, so the filter's time stays right."""
        for _ in range(periods - 1):
            self(x)
        return self(x)

    def __call__(self, x: Vec) -> Vec:
        """Filter one sample; returns (and keeps as ``y``) the output."""
        x0, x1, x2 = x
        if not self.primed:  # steady state at the first input: no start-up transient
            self.primed = True
            c1, c2 = 1.0 - self.b0, self.b2 - self.a2
            self.s1 = (x0 * c1, x1 * c1, x2 * c1)
            self.s2 = (x0 * c2, x1 * c2, x2 * c2)
            self.y = (x0, x1, x2)
            return self.y
        # Direct form II transposed, the three axes written out (this runs several
        # times per sample): y = b0 x + s1;  s1 <- b1 x - a1 y + s2;  s2 <- b2 x - a2 y.
        b0, b1, b2, a1, a2 = self.b0, self.b1, self.b2, self.a1, self.a2
        (p0, p1, p2), (q0, q1, q2) = self.s1, self.s2
        y0, y1, y2 = b0 * x0 + p0, b0 * x1 + p1, b0 * x2 + p2
        self.s1 = (b1 * x0 - a1 * y0 + q0, b1 * x1 - a1 * y1 + q1, b1 * x2 - a1 * y2 + q2)
        self.s2 = (b2 * x0 - a2 * y0, b2 * x1 - a2 * y1, b2 * x2 - a2 * y2)
        self.y = (y0, y1, y2)
        return self.y


def periods(dt: float, design_dt: float) -> int:
    """How many sample periods of ``design_dt`` the interval ``dt`` spans when it is a whole
    number of them (to 0.1%): 1 normally, more after lost samples; 0 when it is not (a new rate)."""
    n = round(dt / design_dt)
    return n if n >= 1 and abs(dt - n * design_dt) <= 1e-3 * design_dt * n else 0
