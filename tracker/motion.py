"""Motion sources: what the virtual board's sensors feel, as a function of time.

A motion source answers ``reading(t)`` with the true physical quantities at
the sensor (specific force, angular rate, magnetic field, elbow angle and the
true orientation). The virtual board turns them into counts, frames and bytes
exactly as the firmware would. :class:`ScriptedArm` is a closed-form arm
motion for link and protocol tests; the sensor simulator (``tracker.sim``)
is the physically complete source.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

GRAVITY = 9.81  # m/s^2, world z up (ARCHITECTURE.md)
EARTH_FIELD_UT = (0.0, 20.0, -40.0)  # ENU: north component and dip, a mid-latitude field
PAPER_FLEX_OFFSET = 390.0  # seed 000 sec. 4: theta = -(adc - 390) / 3
PAPER_FLEX_SLOPE = 3.0


@dataclass(frozen=True, slots=True)
class SensorReading:
    """True quantities at the sensor, in the sensor frame S (SI units, ARCHITECTURE.md)."""

    acc: tuple[float, float, float]  # specific force, m/s^2
    gyr: tuple[float, float, float]  # angular rate, rad/s
    mag: tuple[float, float, float] | None  # microtesla
    flex_deg: float  # elbow angle, 0 = straight
    flex_adc: int  # what the board's 10-bit ADC reads
    q: tuple[float, float, float, float]  # true q_WS, scalar first


class MotionSource(Protocol):
    """Anything that can say what the sensors feel at time ``t`` (seconds)."""

    def reading(self, t: float) -> SensorReading: ...


def paper_flex_adc(flex_deg: float) -> int:
    """ADC count for an elbow angle by inverting seed 000's linear map (sec. 4)."""
    return max(0, min(1023, round(PAPER_FLEX_OFFSET - PAPER_FLEX_SLOPE * flex_deg)))


@dataclass(frozen=True)
class ScriptedArm:
    """The upper arm swinging forward and back about the shoulder, the elbow flexing.

    The arm hangs along -z with the sensor ``upper_arm_m`` below the shoulder;
    it rotates about the world x axis (east) by ``raise(t) = A (1 - cos(2 pi t / T))``,
    so q_WS = (cos(raise/2), sin(raise/2), 0, 0). For a rotation about a fixed
    axis the body rate equals the world rate, ``gyr = (raise'(t), 0, 0)``. The
    sensor position is p = R r0 with r0 = (0, 0, -L); its acceleration is the
    tangential plus centripetal term a = alpha x p + omega x (omega x p), and
    the accelerometer feels f_S = R^T (a + g_up).
    """

    raise_amplitude_rad: float = 0.6
    raise_period_s: float = 4.0
    flex_amplitude_deg: float = 45.0
    flex_period_s: float = 3.0
    upper_arm_m: float = 0.30
    with_mag: bool = True

    def reading(self, t: float) -> SensorReading:
        w = 2 * math.pi / self.raise_period_s
        a = self.raise_amplitude_rad
        angle = a * (1 - math.cos(w * t))
        rate = a * w * math.sin(w * t)
        accel = a * w * w * math.cos(w * t)
        c, s = math.cos(angle), math.sin(angle)
        # Sensor position p = R_x(angle) (0, 0, -L) = (0, L s, -L c).
        L = self.upper_arm_m
        py, pz = L * s, -L * c
        # alpha x p + omega x (omega x p) with omega = (rate, 0, 0), alpha = (accel, 0, 0).
        ay = -accel * pz - rate * rate * py
        az = accel * py - rate * rate * pz
        f_world = (0.0, ay, az + GRAVITY)
        flex = self.flex_amplitude_deg * (1 - math.cos(2 * math.pi * t / self.flex_period_s))
        return SensorReading(
            acc=_rotate_x_inverse(angle, f_world),
            gyr=(rate, 0.0, 0.0),
            mag=_rotate_x_inverse(angle, EARTH_FIELD_UT) if self.with_mag else None,
            flex_deg=flex,
            flex_adc=paper_flex_adc(flex),
            q=(math.cos(angle / 2), math.sin(angle / 2), 0.0, 0.0),
        )


def _rotate_x_inverse(angle: float, v: tuple[float, float, float]) -> tuple[float, float, float]:
    """R_x(angle)^T v: a world vector seen in the sensor frame."""
    c, s = math.cos(angle), math.sin(angle)
    return (v[0], c * v[1] + s * v[2], -s * v[1] + c * v[2])
