"""Slow/fast switching between gravity and gyro integration (the finger-tracking paper, sec. 2.2).

Inertial Sensor Based Solution for Finger Motion Tracking (Computers 9(2):40, 2020)
tracks one phalanx in its flexion plane with two estimators and an error-bound
criterion that picks between them at every sample:

- slow motion (sec. 2.2.2): the angle from the measured gravity, atan2(f3, f2);
  its error is bounded by the non-gravitational acceleration, eq. (7):
  ``|dtheta_g| <= |mu| / |g_yz|``, with ``|mu| <= (i_k + 1) l_max
  sqrt(omega_dot^2 + omega^4)`` (sec. 2.2.4) for a chain of rigid links;
- fast motion (sec. 2.2.3): integration of the gyroscope from the last
  estimate; its error grows linearly, eq. (8): ``dtheta_w = dtheta(t_s) +
  |domega| (t - t_s)``;
- switching (sec. 2.2.5, steps 1-4): with ``dtheta|w = dtheta(t_{i-1}) +
  dt |domega|``, go fast when ``dtheta|w < dtheta_g``, go slow when
  ``dtheta_g < dtheta|w``, and carry the bound of the mode in use.

Generalisation from the planar link to a 3-D segment (documented choices):

- Slow estimate: gravity gives the inclination, not the heading, so the
  slow-mode estimate is the gyro-propagated orientation turned by the smallest
  rotation that makes the measured specific force point up
  (:func:`.madgwick.level`); the heading comes from integration in both modes.
  The bound tracked is the inclination error.
- Error of the slow estimate: the whole gravity vector is observed, so the
  planar ``|g_yz|`` becomes ``|g|`` (the planar estimator is blind to the
  out-of-plane part; a 3-D one is not): ``dtheta_g = |mu~| / |g|``.
- Disturbance from the measured rate, step 2's ``|mu~|(omega^)``: a sensor at
  ``lever`` from a fixed pivot has the centripetal part
  ``|omega x (omega x r)| <= lever |omega|^2`` of the paper's bound. The
  tangential part needs ``omega_dot``, which one gyroscope sample does not give
  (a difference of consecutive samples is mostly noise: about 1 rad/s^2 at rest
  on BROAD, i.e. a 2 degree bound on a still sensor).
- The paper subtracts the base acceleration ``a_0`` known from optical
  tracking; here the base is not tracked, so the accelerometer supplies two
  lower bounds on the disturbance, each less an allowance ``acc_noise`` for its
  own error: ``| |acc| - |g| |`` (always valid), and the residual against the
  gravity the integrated estimate ``q_i`` predicts,
  ``g_i = q_i* (0, 0, |g|) q_i``: with ``q_i`` within ``dtheta|w`` of the truth,
  ``g_i`` lies within the chord ``2 |g| sin(dtheta|w / 2)`` of the true gravity,
  so ``|mu| >= |acc - g_i| - 2 |g| sin(dtheta|w / 2)``. Without the residual
  bound, translations (no rotation, so no rate-based bound) pass as slow motion
  and BROAD's fast-translation trials reach 80 degrees of inclination error.
  ``|mu~|`` is the largest of the three bounds. The residual bound trusts
  ``dtheta|w``: a gravity fix taken while an undetected disturbance tilted it
  by ``e`` keeps the filter integrating until the bound has grown to about
  ``e - acc_noise/|g|``, i.e. for that over ``gyro_error`` seconds.
- Integration: the exact rotation for a rate held over one sample,
  ``q (x) exp(omega dt / 2)`` (the paper used Runge-Kutta, sec. 3).

As in the paper, the mode is the one with the smaller bound at each sample, so
while moving the filter integrates and takes a gravity fix whenever the
gravity bound falls below the accumulated one (pauses, slow turns).

A gyroscope sample at full scale voids the integration bound (``dtheta|w``
becomes pi), so the next usable gravity reading is taken. Without a usable
accelerometer the filter integrates (fast mode). The
magnetometer is not used (``flags.mag_ignored`` is always set).
``flags.acc_rejected`` is set while the fast mode ignores a usable
accelerometer; ``state.fast`` is the current mode and ``state.error`` the
current bound ``dtheta`` in radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from . import qmath as Q
from .base import GYR_SATURATION, Filter
from .madgwick import level
from .qmath import Quat, Vec


@dataclass
class SwitchingParams:
    """Settings of the switching filter.

    lever: distance from the segment's pivot to the sensor in metres, the paper's
    ``(i_k + 1) l_max`` for a single link; default 0.30 m, the upper arm
    (ARCHITECTURE.md arm model).
    gyro_error: ``|domega|``, the gyroscope's average error in rad/s after bias
    calibration (eq. (8)); default 0.003 rad/s (0.17 deg/s), the best of
    0.002/0.003/0.005/0.01 on the BROAD trials (../shared/data/broad: 6D inclination
    RMSE 6.6/5.8/6.3/11.0 deg): a larger value trusts gravity too soon while moving,
    a smaller one integrates too long.
    acc_noise: the accelerometer error in m/s^2 allowed before a gap counts as a
    disturbance; default 0.5 (about 50 mg: the MPU-9250's noise plus part of its
    zero-g offset); 0.25 and 1.0 score 6.6 and 6.7 deg on BROAD.
    gravity: ``|g|`` in m/s^2.
    """

    lever: float = 0.30
    gyro_error: float = 0.003
    acc_noise: float = 0.5
    gravity: float = 9.81


@dataclass
class SwitchingState:
    q: Quat = Q.IDENTITY
    fast: bool = False  # True: gyro integration (fast motion); False: gravity (slow motion)
    error: float = math.pi  # the bound dtheta in radians; pi: nothing known yet


def gravity_error(q_int: Quat, err_int: float, gyr: Vec, acc: Vec, p: SwitchingParams) -> float:
    """``dtheta_g = |mu~| / |g|``: the finger-tracking paper, eq. (7) and sec. 2.2.5 step 2, in 3-D (module
    docstring)."""
    centripetal = p.lever * (gyr[0] * gyr[0] + gyr[1] * gyr[1] + gyr[2] * gyr[2])
    gx, gy, gz = Q.rotate_inverse(q_int, (0.0, 0.0, p.gravity))
    residual = Q.norm3((acc[0] - gx, acc[1] - gy, acc[2] - gz))
    chord = 2.0 * p.gravity * math.sin(0.5 * min(err_int, math.pi))
    norm_gap = abs(Q.norm3(acc) - p.gravity)
    return max(centripetal, max(norm_gap, residual - chord) - p.acc_noise) / p.gravity


class Switching(Filter[SwitchingParams, SwitchingState]):
    """Gravity in slow motion, gyro integration in fast motion, by the paper's error bounds."""

    name = "switching"
    uses_magnetometer = False
    Params = SwitchingParams
    State = SwitchingState

    def _step(self, gyr: Vec, acc: Vec | None, mag: Vec | None, dt: float) -> Quat:
        s, p = self._state, self.params
        self.flags.mag_ignored = True
        q_int = Q.integrate(s.q, gyr, dt)  # fast-mode estimate (sec. 2.2.3), exact for a held rate
        err_int = s.error + dt * p.gyro_error  # eq. (8), step 2
        if max(abs(gyr[0]), abs(gyr[1]), abs(gyr[2])) >= GYR_SATURATION:
            err_int = math.pi  # the true rate is beyond full scale: the integral is unbounded
        err_g = math.inf if acc is None else gravity_error(q_int, err_int, gyr, acc, p)
        # step 3: the mode with the smaller bound; a tie keeps the current mode
        s.fast = err_int < err_g or (err_int == err_g and s.fast)
        if s.fast:
            s.q, s.error = Q.normalize(q_int), err_int
        else:
            s.q, s.error = level(q_int, acc), err_g
        self.flags.acc_rejected = s.fast and acc is not None
        return s.q


FILTER_CLASS = Switching
