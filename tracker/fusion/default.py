"""``default``: EnergyBall's own filter, the one the game uses.

Its structure follows the published VQF method (D. Laidig and T. Seel, "VQF:
Highly accurate IMU orientation estimation with bias estimation and magnetic
disturbance rejection", Information Fusion 91, 2023; cited below as VQF),
written afresh from the paper's description, with a bias estimator in motion
after Mahony's integral term (R. Mahony, T. Hamel, J.-M. Pflimlin, "Nonlinear
complementary filters on the special orthogonal group", IEEE TAC 53(5), 2008;
cited as Mahony). Each step of :meth:`DefaultFilter._step` says which.

The orientation is kept as three factors (VQF sec. 3)::

    q_WS = q_heading (about world z)  *  q_inc (I -> E, no heading)  *  q_gyr (S -> I)

``q_gyr`` is pure strapdown integration of the bias-corrected gyroscope into
an almost-inertial frame I. The accelerometer, rotated into I, is low-pass
filtered there: in I the gravity direction moves only as slowly as q_gyr
drifts, while linear accelerations of real motion average out. ``q_inc`` is
the rotation that makes this filtered direction vertical. ``q_heading`` turns
the horizontal part of the magnetic field, seen in the 6D frame, to north.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mypy_extensions import mypyc_attr

from ..calibration import RestDetector, RestParams
from ..lowpass import LowPass2
from .base import Filter
from .qmath import (IDENTITY, Quat, Vec, about_z, from_rotvec, integrate, mul, normalize, rotate,
                    rotate_inverse, tilt_to_up)

GRAVITY = 9.81


@dataclass(frozen=True)
class DefaultParams:
    """Settings of the default filter (times in seconds, thresholds in SI units)."""

    tau_acc: float = 3.0  # low-pass time constant of the accelerometer in frame I (VQF sec. 3.2)
    tau_mag: float = 20.0  # time constant of the heading correction (VQF sec. 3.4 uses 9 s)
    rest_gyr_th: float = math.radians(2.0)  # rest: gyro deviation below this (rad/s) (VQF sec. 3.3)
    rest_acc_th: float = 0.5  # rest: accelerometer deviation below this (m/s^2)
    rest_min_t: float = 1.5  # rest: held this long
    rest_tau: float = 0.5  # low-pass time constant of the rest detector's signals
    bias_tau_rest: float = 1.0  # at rest the bias follows the low-passed gyro with this time constant
    bias_ki: float = 0.01  # integral gain of the bias estimate in motion (Mahony eq. 32), 1/s
    bias_max: float = math.radians(5.0)  # |bias| limit: the MPU-9250's zero-rate offset bound
    mag_norm_th: float = 0.1  # field norm deviating by more than this fraction: disturbed
    mag_dip_th: float = math.radians(10.0)  # dip angle deviating by more than this: disturbed
    mag_ref_tau: float = 20.0  # how fast the undisturbed field reference (norm, dip) adapts
    startup_t: float = 1.0  # during the first second corrections use plain averaging (fast start)


@mypyc_attr(serializable=True)  # copy.deepcopy works when compiled (its __init__ needs arguments)
@dataclass
class DefaultState:
    """Everything the default filter has learned (read with get_state, restore with set_state)."""

    acc_lp: LowPass2  # the accelerometer in frame I, low-passed
    rest: RestDetector
    q: Quat = IDENTITY  # the output, q_WS
    q_gyr: Quat = IDENTITY  # strapdown S -> I
    q_inc: Quat = IDENTITY  # inclination correction I -> E
    heading: float = 0.0  # rotation about world z, radians
    bias: Vec = (0.0, 0.0, 0.0)  # gyroscope bias, rad/s, sensor frame
    t: float = 0.0  # time since start
    rest_t: float = 0.0  # how long the rest conditions have held
    mag_norm: float = 0.0  # reference field norm (uT), 0 until known
    mag_dip: float = 0.0  # reference dip angle (rad)
    mag_samples: int = 0  # undisturbed magnetometer samples used so far


class DefaultFilter(Filter[DefaultParams, DefaultState]):
    """EnergyBall's default filter: VQF-style inclination and heading, bias at rest and in motion."""

    name = "default"
    Params = DefaultParams
    State = DefaultState

    def _initial_state(self) -> DefaultState:
        p = self.params
        # The rest detector is fed the raw rate, so the low-passed rate may be as large as the bias can be.
        rest = RestDetector(RestParams(p.rest_gyr_th, p.rest_acc_th, 2 * p.bias_max, p.rest_min_t, p.rest_tau))
        return DefaultState(LowPass2(p.tau_acc), rest)

    def _step(self, gyr: Vec, acc: Vec | None, mag: Vec | None, dt: float) -> Quat:
        s, p = self._state, self.params
        s.t += dt
        if acc is not None:
            self._detect_rest(gyr, acc, dt)
        # 1. Strapdown integration of the bias-corrected rate (VQF sec. 3.1).
        b = s.bias
        s.q_gyr = normalize(integrate(s.q_gyr, (gyr[0] - b[0], gyr[1] - b[1], gyr[2] - b[2]), dt))
        # 2. Inclination from the accelerometer low-passed in frame I (VQF sec. 3.2),
        #    and the bias from the correction while in motion (Mahony eq. 32).
        tilt = self._correct_inclination(acc, dt) if acc is not None else None
        q6 = mul(s.q_inc, s.q_gyr)
        if tilt is not None and not self.flags.rest and s.t > p.startup_t:
            self._learn_bias_in_motion(q6, tilt[0] / dt, tilt[1] / dt, dt)
        # 3. Heading from the magnetometer, with disturbance rejection (VQF sec. 3.4).
        if mag is not None:
            self._correct_heading(q6, mag, dt)
        s.q = normalize(mul(about_z(s.heading), q6))
        return s.q

    # ------------------------------------------------------------ rest and bias

    def _detect_rest(self, gyr: Vec, acc: Vec, dt: float) -> None:
        """Rest when gyro and accelerometer stay near their low-passed values (VQF sec. 3.3)."""
        s, p = self._state, self.params
        rest = s.rest.update(gyr, acc, dt)
        self.flags.rest = rest
        gyr_lp = s.rest.gyr_lp
        if rest and gyr_lp is not None:
            # At rest the low-passed gyro is the bias (VQF sec. 3.3): follow it quickly.
            k = min(1.0, dt / p.bias_tau_rest)
            (bx, by, bz), (gx, gy, gz) = s.bias, gyr_lp
            s.bias = self._clamp(bx + k * (gx - bx), by + k * (gy - by), bz + k * (gz - bz))

    def _clamp(self, x: float, y: float, z: float) -> Vec:
        """The bias (x, y, z) limited to +-bias_max per axis."""
        m = self.params.bias_max
        # max(-m, min(m, .)) per axis (NaN included) as conditionals: no builtin calls.
        x, y, z = (x if x < m else m), (y if y < m else m), (z if z < m else m)
        return (x if x > -m else -m), (y if y > -m else -m), (z if z > -m else -m)

    # ------------------------------------------------------------ inclination

    def _correct_inclination(self, acc: Vec, dt: float) -> tuple[float, float] | None:
        """Turn q_inc so the low-passed accelerometer points up; the turn's (x, y) rotation vector.

        ``dt``: the time since the last sample (several periods after lost ones, which
        the low-pass takes as this sample held: :meth:`LowPass2.step`). None while there
        is no gravity yet.
        """
        s = self._state
        a_i = s.acc_lp.step(rotate(s.q_gyr, acc), dt)
        ax, ay, az = rotate(s.q_inc, a_i)
        n = math.sqrt(ax * ax + ay * ay + az * az)
        if n < 1e-6:
            return None  # no gravity yet
        # The rotation taking the filtered direction to vertical: about (ay, -ax, 0) by
        # acos(az / n) (computed as atan2(|a_xy|, a_z), the same angle; a half-turn
        # about east when it points straight down).
        rx, ry, _ = tilt_to_up((ax, ay, az))
        s.q_inc = normalize(mul(from_rotvec(rx, ry, 0.0), s.q_inc))
        return rx, ry

    def _learn_bias_in_motion(self, q6: Quat, cx: float, cy: float, dt: float) -> None:
        """Integral action on the inclination correction rate (Mahony eq. 32).

        A constant bias b makes the strapdown frame turn by -R b per second; the
        correction then turns it back at (cx, cy) ~ (R b) horizontally. Only the
        horizontal part is observable from gravity. ``q6`` is the corrected
        ``q_inc * q_gyr``, which takes (cx, cy, 0) back to the sensor frame.
        """
        s, p = self._state, self.params
        bx, by, bz = rotate_inverse(q6, (cx, cy, 0.0))
        k = p.bias_ki * dt
        s.bias = self._clamp(s.bias[0] - k * bx, s.bias[1] - k * by, s.bias[2] - k * bz)

    # ------------------------------------------------------------ heading

    def _correct_heading(self, q6: Quat, mag: Vec, dt: float) -> None:
        s, p = self._state, self.params
        mx, my, mz = rotate(q6, mag)
        norm = math.sqrt(mx * mx + my * my + mz * mz)
        if norm < 1e-6:
            return
        dip = math.asin(max(-1.0, min(1.0, mz / norm)))
        if not self._field_undisturbed(norm, dip, dt):
            self.flags.mag_rejected = True
            return
        # The horizontal field points atan2(mx, my) east of north (+y) in the 6D frame;
        # turning about +z by that angle brings it back to north.
        target = math.atan2(mx, my)
        err = (target - s.heading + math.pi) % (2 * math.pi) - math.pi
        k = dt / p.tau_mag
        if s.t <= p.startup_t:
            k = max(k, 1.0 / s.mag_samples)  # fast start: plain average of the first second
        s.heading = (s.heading + k * err + math.pi) % (2 * math.pi) - math.pi


    def _field_undisturbed(self, norm: float, dip: float, dt: float) -> bool:
        """Magnetic disturbance test on the field's norm and dip angle (VQF sec. 3.4)."""
        s, p = self._state, self.params
        s.mag_samples += 1
        if s.mag_norm == 0.0 or s.t <= p.startup_t:
            n = s.mag_samples
            s.mag_norm += (norm - s.mag_norm) / n
            s.mag_dip += (dip - s.mag_dip) / n
            return True
        ok = abs(norm - s.mag_norm) < p.mag_norm_th * s.mag_norm and abs(dip - s.mag_dip) < p.mag_dip_th
        if ok:
            k = dt / p.mag_ref_tau
            s.mag_norm += k * (norm - s.mag_norm)
            s.mag_dip += k * (dip - s.mag_dip)
        return ok


FILTER_CLASS = DefaultFilter
