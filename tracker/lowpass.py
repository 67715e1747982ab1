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
from dataclasses import dataclass, field

Vec = tuple[float, float, float]


@dataclass
class LowPass2:
    """The filter's coefficients and its per-axis state; starts settled at its first input."""

    b0: float
    b1: float
    b2: float
    a1: float
    a2: float
    s1: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    s2: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    primed: bool = False
    y: Vec = (0.0, 0.0, 0.0)  # the last output

    @classmethod
    def design(cls, tau: float, dt: float) -> "LowPass2":
        """The filter of time constant ``tau`` for samples ``dt`` apart (both seconds)."""
        fc = math.sqrt(2.0) / (2.0 * math.pi * tau)
        k = math.tan(math.pi * min(fc * dt, 0.49))
        norm = 1.0 + math.sqrt(2.0) * k + k * k
        b0 = k * k / norm
        return cls(b0, 2 * b0, b0, 2.0 * (k * k - 1.0) / norm, (1.0 - math.sqrt(2.0) * k + k * k) / norm)

    def __call__(self, x: Vec) -> Vec:
        if not self.primed:  # steady state at the first input: no start-up transient
            self.primed = True
            for i in range(3):
                self.s1[i] = x[i] * (1.0 - self.b0)
                self.s2[i] = x[i] * (self.b2 - self.a2)
            self.y = (x[0], x[1], x[2])
            return self.y
        b0, b1, b2, a1, a2, s1, s2 = self.b0, self.b1, self.b2, self.a1, self.a2, self.s1, self.s2
        out = [0.0, 0.0, 0.0]
        for i in range(3):
            y = b0 * x[i] + s1[i]
            s1[i] = b1 * x[i] - a1 * y + s2[i]
            s2[i] = b2 * x[i] - a2 * y
            out[i] = y
        self.y = (out[0], out[1], out[2])
        return self.y
