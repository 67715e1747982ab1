"""Motion sources: what the virtual board's sensors feel, as a function of time.

A motion source answers ``reading(t)`` with the true physical quantities at
the sensor (specific force, angular rate, magnetic field, elbow angle and the
true orientation). The virtual board turns them into counts, frames and bytes
exactly as the firmware would. The sensor simulator (``tracker.sim``)
provides them; ``tracker.sim.arm_source`` is the virtual board's default.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

GRAVITY = 9.81  # m/s^2, world z up (ARCHITECTURE.md)
EARTH_FIELD_UT = (0.0, 20.0, -40.0)  # ENU: north component and dip, a mid-latitude field


@dataclass(frozen=True, slots=True)
class SensorReading:
    """True quantities at the sensor, in the sensor frame S (SI units, ARCHITECTURE.md)."""

    acc: tuple[float, float, float]  # specific force, m/s^2
    gyr: tuple[float, float, float]  # angular rate, rad/s
    mag: tuple[float, float, float] | None  # microtesla
    flex_deg: float  # elbow angle, 0 = straight
    flex_adc: int  # what the board's 10-bit ADC reads
    q: tuple[float, float, float, float]  # true q_WS, scalar first
    die_c: float | None = None  # the IMU die's temperature, degC (None: not simulated)


class MotionSource(Protocol):
    """Anything that can say what the sensors feel at time ``t`` (seconds)."""

    def reading(self, t: float) -> SensorReading: ...
