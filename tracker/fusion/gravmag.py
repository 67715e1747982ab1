"""Gravity and magnetic-north correction with SLERP by stillness, after the IMU and infrared
hand-tracking paper, sec. 2.2.

Per sample: the gyroscope bias is re-estimated at rest (eq. 2), the unbiased rate
is integrated (eqs. 3-4) into ``q_G``, ``q_G`` is corrected once toward the
accelerometer's gravity (eqs. 5-9, giving ``q_GA``) and once toward the
magnetometer's north (eqs. 10-14, ``q_GM``), and the output is the SLERP between
the two weighted by the "stillness" ``alpha`` (eqs. 15-16).

Conventions, checked against first principles:

- The hand-tracking paper writes ``q* (x) A (x) q`` for a world vector seen in the sensor frame
  (eqs. 5, 10) and ``q_dot = 1/2 q (x) omega`` (eq. 3): its ``q`` maps sensor to
  world, with the Hamilton product, i.e. our ``q_WS`` as it stands. Then
  ``Delta q = H(a0 x a(q_G), |a0||a(q_G)| + a0 . a(q_G))`` (eqs. 6-8) is the
  shortest rotation taking the measured vector onto the predicted one, and
  ``q_G (x) Delta q`` (eq. 9) maps the measurement exactly onto the reference.
- Gravity reference ``A_int`` = ``UP`` = (0, 0, 1): the accelerometer's specific
  force at rest points up (only the direction matters in eqs. 6-8).
- Magnetic reference ``M_int`` = ``NORTH`` = (0, 1, 0), and the "magnetic North
  vector" ``m0`` = the field's horizontal part: the magnetometer reading less its
  component along the up direction that ``q_G`` predicts in the sensor frame.
  Both are then perpendicular to that up, so ``Delta q_M`` turns about it and
  corrects heading only, and the world frame is East-North-Up with north = the
  field's horizontal direction. (With the full field as ``m0``, at a dip of
  60-70 degrees eqs. 10-14 correct heading at only cos^2(dip) of their gain and
  tilt the estimate by any magnetic disturbance: on the BROAD trials the 9D total
  RMSE was 4.5 instead of 3.2 degrees.) Without a magnetometer the heading is
  arbitrary (whatever the gyroscope integrates to).

Where the paper is silent, our choices (each a parameter):

- The corrections are applied in part: ``q_G (x) Delta q^k`` with
  ``k = 1 - exp(-dt / tau)``; ``tau = 0`` is the paper's full correction (eqs. 9, 14).
- Stillness ``alpha = exp(-(|omega_B| / still_gyr)^2 - ((|a0| - g) / still_acc)^2)``:
  1 at rest, toward 0 while rotating or accelerating.
- A missing vector corrects nothing (``Delta q = 1``): without a magnetometer
  ``q_GM = q_G``, so eq. 15 weights the gravity correction by stillness alone.
- The estimate starts levelled by the first accelerometer sample (eq. 9 with k = 1),
  then turned to face north about the vertical by the first magnetometer sample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from . import qmath as qm
from .base import Filter
from .qmath import Quat, Vec

UP: Vec = qm.UP  # A_int of eq. 5: the specific force at rest, world frame
NORTH: Vec = qm.NORTH  # M_int of eq. 10: the field's horizontal direction, world frame (ENU)
_ZERO: Vec = (0.0, 0.0, 0.0)


@dataclass
class GravMagParams:
    """Settings of the hand-tracking paper's filter."""

    # Defaults: the best mean on the 9 BROAD trials at hand (286 Hz), 6D inclination and 9D total.
    rest_threshold: float = math.radians(1.5)  # rad/s: |omega_0| below this is "at rest" (eq. 2)
    rest_time: float = 0.25  # s at rest whose mean gyroscope is the bias (eq. 2: 5 samples = 250 ms)
    tau_acc: float = 2.0  # s, time constant of the gravity correction (0 = the paper's full one)
    tau_mag: float = 10.0  # s, time constant of the north correction (0 = the paper's full one)
    still_gyr: float = math.radians(30.0)  # rad/s, rotation rate scale of the stillness alpha
    still_acc: float = 1.0  # m/s^2, |acc| - g scale of the stillness alpha
    gravity: float = 9.81  # m/s^2, the accelerometer's norm at rest


@dataclass
class GravMagState:
    q: Quat = qm.IDENTITY  # q_WS
    bias: Vec = _ZERO  # b-hat of eq. 2, rad/s
    rest_sum: Vec = _ZERO  # sum of the raw gyroscope samples in the current rest block, rad/s
    rest_count: int = 0  # samples in that block
    rest_for: float = 0.0  # s, duration of that block
    resting: bool = False  # a full block has passed since the rate last exceeded the threshold
    levelled: bool = False  # whether an accelerometer sample has levelled the estimate yet
    headed: bool = False  # whether a magnetometer sample has turned the levelled estimate north yet


class GravMagFilter(Filter[GravMagParams, GravMagState]):
    """The hand-tracking paper: bias at rest, gyroscope integration, gravity and north corrections, SLERP."""

    name = "gravmag"
    Params = GravMagParams
    State = GravMagState

    def _step(self, gyr: Vec, acc: Vec | None, mag: Vec | None, dt: float) -> Quat:
        s, p = self._state, self.params
        omega = self._unbiased(gyr, dt)
        q_g = qm.integrate(s.q, omega, dt)  # eqs. 3-4: q_dot = 1/2 q (x) omega_B over dt
        if acc is not None and not s.levelled:
            q_g, s.levelled = corrected(q_g, acc, UP, 1.0), True
        if mag is not None and s.levelled and not s.headed:
            q_g, s.headed = qm.align_heading(q_g, mag, NORTH), True  # the field's horizontal part north
        q_ga = corrected(q_g, acc, UP, _gain(dt, p.tau_acc)) if acc is not None else q_g  # eqs. 5-9
        q_gm = q_g
        if mag is not None and s.headed:
            q_gm = corrected(q_g, north_part(q_g, mag), NORTH, _gain(dt, p.tau_mag))  # eqs. 10-14
        # eqs. 15-16: (q_GM sin((1 - alpha) W) + q_GA sin(alpha W)) / sin(W), cos(W) = q_GM . q_GA,
        # along the shorter arc and linear where W is tiny
        s.q = qm.normalize(qm.slerp(q_gm, q_ga, self._stillness(omega, acc)))
        return s.q

    def _unbiased(self, gyr: Vec, dt: float) -> Vec:
        """``omega_B = omega_0 - b`` (the hand-tracking paper, eq. 2); sets ``flags.rest``.

        Each block of ``rest_time`` seconds with ``|omega_0| < rest_threshold``
        throughout makes the bias ``b`` the block's mean raw rate. The paper's block
        is 5 samples at its 20 Hz, 250 ms: kept in seconds here, since 5 samples at
        200-300 Hz (under 25 ms) are often quiet mid-movement and spoil the bias.
        """
        s = self._state
        if qm.norm3(gyr) < self.params.rest_threshold:
            t = s.rest_sum
            s.rest_sum = (t[0] + gyr[0], t[1] + gyr[1], t[2] + gyr[2])
            s.rest_count += 1
            s.rest_for += dt
            if s.rest_for + 0.5 * dt >= self.params.rest_time:  # to the nearest sample
                n = float(s.rest_count)
                s.bias = (s.rest_sum[0] / n, s.rest_sum[1] / n, s.rest_sum[2] / n)
                s.rest_sum, s.rest_count, s.rest_for, s.resting = _ZERO, 0, 0.0, True
        else:
            s.rest_sum, s.rest_count, s.rest_for, s.resting = _ZERO, 0, 0.0, False
        self.flags.rest = s.resting
        b = s.bias
        return (gyr[0] - b[0], gyr[1] - b[1], gyr[2] - b[2])

    def _stillness(self, omega: Vec, acc: Vec | None) -> float:
        """The stillness ``alpha`` of eq. 15: 1 = no movement (the formula is ours, see above)."""
        p = self.params
        r = qm.norm3(omega) / p.still_gyr
        x = r * r  # not r ** 2, which raises OverflowError for absurd finite input
        if acc is not None:
            r = (qm.norm3(acc) - p.gravity) / p.still_acc
            x += r * r
        return math.exp(-x)


def corrected(q_g: Quat, measured: Vec, reference: Vec, gain: float) -> Quat:
    """``q_G (x) Delta q^gain`` (the hand-tracking paper, eqs. 5-9 for gravity, 10-14 for north).

    The reference (``A_int`` or ``M_int``, world frame) seen from ``q_G`` is
    ``q_G* (x) ref (x) q_G`` (eqs. 5, 10); ``Delta q = H(a0 x a(q_G), |a0||a(q_G)| +
    a0 . a(q_G))`` normalised rotates the measurement onto it (eqs. 6-8, 11-13:
    :func:`.qmath.between`, which takes a half-turn about an axis perpendicular to
    the measurement where the two are opposite and the paper's formula is 0/0);
    post-multiplying it, raised to the gain (:func:`.qmath.power`), corrects ``q_G``
    (eqs. 9, 14).
    """
    predicted = qm.rotate_inverse(q_g, reference)  # eq. 5 / 10
    return qm.mul(q_g, qm.power(qm.between(measured, predicted), gain))  # eqs. 6-8 and 9 / 11-13 and 14


def north_part(q_g: Quat, mag: Vec) -> Vec:
    """The magnetic North vector ``m0`` of eqs. 12-13: the field less its component
    along the up direction that ``q_G`` predicts in the sensor frame."""
    u = qm.rotate_inverse(q_g, UP)
    d = qm.dot(mag, u)
    return (mag[0] - d * u[0], mag[1] - d * u[1], mag[2] - d * u[2])


def _gain(dt: float, tau: float) -> float:
    """The fraction of a correction applied per sample, for time constant ``tau`` (0 = all)."""
    return 1.0 - math.exp(-dt / tau) if tau > 0.0 else 1.0


FILTER_CLASS = GravMagFilter
