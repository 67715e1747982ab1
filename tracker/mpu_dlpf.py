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

The register map names no filter, only those two figures per setting.
:class:`Response` reads them as a first-order low-pass at the bandwidth (whose
delay at low frequencies is 1 / (2 pi f)) and the rest of the delay as dead
time: that rest comes out 1.65-2.17 ms for every gyroscope setting but the
widest and 0.96-1.36 ms for every accelerometer setting, nearly one constant,
as a fixed conversion latency would be, where a second-order filter would
need a negative dead time at the narrow settings. Of the low-passes that fit
the register map it is the gentlest above its band (a first order falls 6 dB
per octave), which leaves the simulated world the harsher. What it takes out
matters all the same: read at the 200 Hz samples' instants without it, a
strap rocking at 23 Hz aliases into the samples as a turn the arm never made
(README, "The chip's own low-pass").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

# Register map RM-MPU-9250A-00 sec. 4.6 (FCHOICE_B = 0) and sec. 4.8 (ACCEL_FCHOICE_B = 0), codes 0-6.
GYRO_BANDWIDTH_HZ = (250.0, 184.0, 92.0, 41.0, 20.0, 10.0, 5.0)
GYRO_DELAY_MS = (0.97, 2.9, 3.9, 5.9, 9.9, 17.85, 33.48)
ACCEL_BANDWIDTH_HZ = (218.1, 218.1, 99.0, 44.8, 21.2, 10.2, 5.05)
ACCEL_DELAY_MS = (1.88, 1.88, 2.88, 4.88, 8.87, 16.83, 32.48)
INTERNAL_HZ = 1000.0  # the chip samples and low-passes at this rate with the DLPF on (sec. 4.6)
TAIL = 12.0  # time constants of a response kept: e^-12 of a full-scale step is 0.2 counts of 16 bits


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

    @property
    def gyro(self) -> Response:
        """How the gyroscope reads through this setting."""
        return Response(self.gyro_hz, self.gyro_delay_s)

    @property
    def accel(self) -> Response:
        """How the accelerometer reads through this setting."""
        return Response(self.accel_hz, self.accel_delay_s)

    @classmethod
    def for_rate(cls, rate_hz: float) -> Dlpf:
        """The setting the firmware chooses at ``rate_hz``."""
        c = dlpf_for_rate(rate_hz)
        return cls(c, GYRO_BANDWIDTH_HZ[c], GYRO_DELAY_MS[c] / 1000.0, ACCEL_BANDWIDTH_HZ[c],
                   ACCEL_DELAY_MS[c] / 1000.0)


@dataclass(frozen=True)
class Response:
    """A signal read through one of the filters: sample k's reading is the filter's output at
    the last of the chip's internal 1 kHz samples up to t_k = k / rate (the divider passes every
    n-th), a weighted sum of that internal sample and the ``taps`` - 1 before it.

    The filter (module docstring): g(s) = exp(-(s - D) / T) / T for s >= D, T = 1 / (2 pi
    ``bandwidth_hz``) and D = ``delay_s`` - T, so that the low-frequency delay, the
    response's first moment D + T, is the register map's. It acts on the signal
    sampled at 1 kHz and joined by straight lines (the hat function L): the weight of
    the internal sample m back is w_m = int g(s) L(s / h - m) ds, h = 1 ms, worked in
    closed form (:meth:`weights`). The straight lines keep both the gain at 0 Hz (the
    hats sum to 1) and the delay (their first moments are m), and attenuate by
    sinc^2(f h) at most, 0.5 % at 41 Hz. The response is kept for TAIL time constants,
    where it has fallen below half a count of the 16-bit reading.
    """

    bandwidth_hz: float
    delay_s: float

    def __post_init__(self) -> None:
        if not self.bandwidth_hz > 0.0 or not self.delay_s >= self.time_constant_s:
            raise ValueError(f"a low-pass response needs bandwidth > 0 and delay >= 1 / (2 pi bandwidth), "
                             f"not {self.bandwidth_hz} Hz and {self.delay_s} s")

    @property
    def time_constant_s(self) -> float:
        """T = 1 / (2 pi bandwidth): a first-order low-pass is 3 dB down at its bandwidth."""
        return 1.0 / (2.0 * math.pi * self.bandwidth_hz)

    @property
    def dead_time_s(self) -> float:
        """D: the register map's delay less the low-pass's own."""
        return self.delay_s - self.time_constant_s

    def amplitude_lead_s(self, rate_hz: float) -> float:
        """L (s): the lead that gives rates read through this low-pass at ``rate_hz`` back their
        amplitude when each sample's turn is taken as w_k dt + L (w_k - w_k-1), dt = 1 / rate.

        Why it matters: rotations do not commute, so an arm that trembles about two axes
        at once turns steadily about the third (coning: an oscillation of a and b rad at
        angular frequency W, a quarter period apart, has a mean rate of a b W / 2 there,
        J. E. Bortz, "A new mathematical formulation for strapdown inertial navigation",
        IEEE TAES 7(1), 1971), which its oscillations take back. Read through a low-pass
        of gain |H| the mean rate arrives whole and the oscillations at |H| their size,
        so they take back only |H|^2 of it: the turn integrated from the readings drifts
        at a b W (1 - |H|^2) / 2, pseudo-coning (J. G. Mark and D. A. Tazartes, "Tuning
        of coning algorithms to gyro data frequency response characteristics", Journal
        of Guidance, Control, and Dynamics 23(4), 2000, who shape the integration to the
        gyroscope's response). At 200 Hz the 41 Hz low-pass passes a 10 Hz tremor at
        |H|^2 = 0.944: 5.6 % of the tremor's coning becomes drift.

        The lead's gain is |C|^2 = 1 + 2 (l + l^2) (1 - cos W dt), l = L / dt, which is
        1 + (l + l^2) (W dt)^2 to second order, and the first-order low-pass's 1 / |H|^2
        is 1 + (W T)^2: equal when l + l^2 = (T / dt)^2, the root taken here. (10 Hz at
        200 Hz: |C H|^2 = 0.9996; 25 Hz: 0.987, from 0.729.)
        """
        ratio = self.time_constant_s * rate_hz
        return (math.sqrt(1.0 + 4.0 * ratio * ratio) - 1.0) / (2.0 * rate_hz)

    @property
    def taps(self) -> int:
        """Internal samples a reading weighs: up to D + TAIL T back, and the one before for the hat."""
        return math.ceil((self.dead_time_s + TAIL * self.time_constant_s) * INTERNAL_HZ) + 2

    def weights(self) -> NDArray[np.float64]:
        """w_m for m = 0 .. taps - 1, summing to 1 (the tail beyond, e^-TAIL of the gain, left out).

        In units of the internal period (d = D / h, c = T / h, s = sigma h), the
        hat of sample m back is 1 - |sigma - m| over m - 1 <= sigma <= m + 1, and
        g(sigma) = exp(-(sigma - d) / c) / c for sigma >= d. With E = exp(-(sigma - d) / c),
        int (a + b sigma) E / c dsigma = -(a + b sigma + b c) E, so each half of the hat
        contributes the difference of that at its ends, both clipped to sigma >= d.
        """
        d, c = self.dead_time_s * INTERNAL_HZ, self.time_constant_s * INTERNAL_HZ

        def part(lo: float, hi: float, a: float, b: float) -> float:
            """The integral of (a + b sigma) g(sigma) from lo to hi, both clipped to sigma >= d."""
            lo, hi = max(lo, d), max(hi, d)
            return (a + b * lo + b * c) * math.exp(-(lo - d) / c) - (a + b * hi + b * c) * math.exp(-(hi - d) / c)

        w = np.array([part(m - 1.0, m, 1.0 - m, 1.0) + part(m, m + 1.0, 1.0 + m, -1.0) for m in range(self.taps)])
        return w / w.sum()

    def read(self, x: NDArray[np.float64], last: NDArray[np.int64]) -> NDArray[np.float64]:
        """The readings made at internal samples ``last`` of x (the signal at 1 kHz, axis 0; each
        ``last`` at least taps - 1). Summed term by term, so a reading is rounded alike wherever
        it sits in a block."""
        total = np.zeros((len(last),) + x.shape[1:])
        for m, w in enumerate(self.weights()):
            total = total + w * x[last - m]
        return total
