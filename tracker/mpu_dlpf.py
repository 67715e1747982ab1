"""The MPU-9250's digital low-pass filters as the firmware sets them, and a signal read through them.

The MPU-9250 samples its gyroscope and accelerometer at 1 kHz and low-passes
them before the sample-rate divider (register map RM-MPU-9250A-00 rev. 1.6,
sec. 4.6 ``DLPF_CFG`` and sec. 4.8 ``A_DLPF_CFG``). The register map gives each
setting's bandwidth and delay; the firmware writes the same code to both
(``firmware/energyball/imu.cpp``), the widest gyroscope bandwidth at most a
quarter of the sample rate (``eb_dlpf_for_rate``). At the game's 200 Hz that
is code 3: the gyroscope's 41 Hz with 5.9 ms of delay, the accelerometer's
44.8 Hz with 4.88 ms. A reading sent at t describes the arm some milliseconds
earlier, and the gyroscope's and the accelerometer's by different amounts,
which a real board adds to every fast move.

:class:`FractionalDelay` reads a sampled signal that many seconds late (cubic
Lagrange interpolation over four samples, none later than the one being read),
the delay alone: the filters' attenuation is left out (under 5 % below 12 Hz,
where the arm's moves, tremor and most of the strap's rocking lie, for a
second-order response at 41 Hz), which leaves the simulated world the harsher.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

# Register map RM-MPU-9250A-00 sec. 4.6 (FCHOICE_B = 0) and sec. 4.8 (ACCEL_FCHOICE_B = 0), codes 0-6.
GYRO_BANDWIDTH_HZ = (250.0, 184.0, 92.0, 41.0, 20.0, 10.0, 5.0)
GYRO_DELAY_MS = (0.97, 2.9, 3.9, 5.9, 9.9, 17.85, 33.48)
ACCEL_BANDWIDTH_HZ = (218.1, 218.1, 99.0, 44.8, 21.2, 10.2, 5.05)
ACCEL_DELAY_MS = (1.88, 1.88, 2.88, 4.88, 8.87, 16.83, 32.48)
TAPS = 4  # samples a delayed reading is interpolated from (cubic)


def dlpf_for_rate(rate_hz: float) -> int:
    """The DLPF code the firmware writes for a sample rate: the widest gyroscope bandwidth at most a
    quarter of the rate, code 6 (5 Hz) at the least (``eb_dlpf_for_rate``, firmware/energyball/src)."""
    code = 0
    while code < 6 and GYRO_BANDWIDTH_HZ[code] * 4 > rate_hz:
        code += 1
    return code


@dataclass(frozen=True)
class Dlpf:
    """One DLPF setting: the gyroscope's and the accelerometer's bandwidth (Hz) and delay (s)."""

    code: int
    gyro_hz: float
    gyro_delay_s: float
    accel_hz: float
    accel_delay_s: float

    @property
    def acc_lead_s(self) -> float:
        """How much more recent the accelerometer's reading is than the gyroscope's (s): 1.0-1.03 ms at
        every setting but the widest (code 0, 1 kHz), where the accelerometer lags by 0.91 ms."""
        return self.gyro_delay_s - self.accel_delay_s

    @classmethod
    def for_rate(cls, rate_hz: float) -> Dlpf:
        """The setting the firmware chooses at ``rate_hz``."""
        c = dlpf_for_rate(rate_hz)
        return cls(c, GYRO_BANDWIDTH_HZ[c], GYRO_DELAY_MS[c] / 1000.0, ACCEL_BANDWIDTH_HZ[c],
                   ACCEL_DELAY_MS[c] / 1000.0)


@dataclass(frozen=True)
class FractionalDelay:
    """A signal sampled at ``rate_hz`` read ``delay_s`` late: sample k's reading is the signal at
    (k - delay * rate) / rate, a weighted sum of samples k + offsets[j] (all <= 0).

    The two samples either side of the delayed time and one more on each side (the
    last four up to k when the delay is under a sample), and the Lagrange weights
    w_j = prod_{i != j} (x - o_i) / (o_j - o_i) at x = -delay * rate: exact for a
    cubic in time, and for a sine of f Hz sampled at rate r an error of about
    (2 pi f / r)^4 / 24 of its amplitude at most (0.016 at 25 Hz and 200 Hz).
    """

    offsets: tuple[int, ...]
    weights: tuple[float, ...]

    @classmethod
    def of(cls, delay_s: float, rate_hz: float) -> FractionalDelay:
        if not delay_s >= 0.0 or not rate_hz > 0.0:
            raise ValueError(f"a delay needs delay >= 0 and rate > 0, not {delay_s} s and {rate_hz} Hz")
        x = -delay_s * rate_hz
        last = min(0, int(np.floor(x)) + 2)
        offsets = tuple(range(last - TAPS + 1, last + 1))
        weights = tuple(float(np.prod([(x - oi) / (oj - oi) for oi in offsets if oi != oj])) for oj in offsets)
        return cls(offsets, weights)

    @property
    def reach(self) -> int:
        """How many samples before k its reading looks back."""
        return -self.offsets[0]

    def apply(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The delayed readings of x's samples ``reach`` onward (axis 0): ``reach`` fewer rows.
        Summed term by term, so every sample is rounded alike wherever it sits in a block."""
        n = len(x) - self.reach
        total = np.zeros((max(0, n),) + x.shape[1:])
        for o, w in zip(self.offsets, self.weights):
            total = total + w * x[self.reach + o:self.reach + o + n]
        return total
