"""The quaternion complementary filter of Zhu & Shi, sec. 3, steps 1-5.

Each sample, the gyroscope rotation ``q_delta`` is integrated (the body rate
post-multiplies), and the estimate is tilted by a fraction ``1 - alpha`` of the
angle ``phi`` between the accelerometer's direction, seen in the world frame,
and "up". No magnetometer, by the paper's design: the heading is whatever the
gyroscope integrates to (it drifts; sec. 6 lists this weakness).

Conventions, converted at the boundary:

- The paper's ``q^(t)`` maps sensor to inertial, ``q_a^(inertial) = q q_a^(sensor) q^-1``
  (step 1), with the Hamilton product: that is our ``q_WS`` unchanged.
- The paper's inertial "up" is ``v_up = (-1, 0, 0)`` (the arm hangs down along the
  sensor x axis at ``q^(0) = 1``); ours is ``+z``. So steps 3-4 use ``UP = (0, 0, 1)``
  and the paper's ``phi = arccos(-q_a1 / |q_a|)`` becomes ``arccos(v . UP)``.
- The paper starts at ``q^(0) = 1``, which in its frame is the posture it asks
  the player to hold (arm hanging down); here the first accelerometer sample
  corrects the tilt in full (step 5 with ``alpha = 0``), which is that posture
  when the arm hangs down and the right start when it does not.
- Step 1 rotates the accelerometer by ``q^(t)``, the estimate *before* this
  sample's rotation ``q_delta``: the paper pairs ``a(t)`` with ``q(t)``. Kept as
  written; with an accelerometer read at the end of the sample interval this lags
  the reference by one sample (no measurable effect on the BROAD trials).
- ``alpha`` weights the gyroscope per sample, so the tilt correction's time
  constant is about ``dt / (1 - alpha)``: 5 s at 200 Hz, 3.5 s at 286 Hz for
  the default.
"""

from __future__ import annotations

from dataclasses import dataclass

from . import qmath as qm
from .base import Filter
from .qmath import Quat, Vec


@dataclass
class ComplementaryParams:
    """Settings of Zhu & Shi's complementary filter."""

    # Weight of the gyroscope per sample (Zhu & Shi, sec. 3, step 5): each update
    # removes (1 - alpha) of the tilt error. Tuned over 0.95..0.9998 on the 9 BROAD
    # trials at hand (286 Hz): 0.999 is best or near it on the 6 rotation and slow
    # trials; 0.9995 is 1 degree better on the mean, carried by the 2 fast-translation
    # trials (24-33 degrees either way), but doubles the tilt lag a residual gyroscope
    # bias causes (about bias * dt / (1 - alpha)).
    alpha: float = 0.999


@dataclass
class ComplementaryState:
    q: Quat = qm.IDENTITY  # q_WS
    levelled: bool = False  # whether an accelerometer sample has set the tilt yet


class ComplementaryFilter(Filter[ComplementaryParams, ComplementaryState]):
    """Zhu & Shi, sec. 3: gyroscope integration with a partial tilt correction."""

    name = "complementary"
    uses_magnetometer = False
    Params = ComplementaryParams
    State = ComplementaryState

    def _step(self, gyr: Vec, acc: Vec | None, mag: Vec | None, dt: float) -> Quat:
        s = self._state
        q_delta = qm.from_rotvec(gyr[0] * dt, gyr[1] * dt, gyr[2] * dt)  # the paper's q_delta
        q = qm.mul(s.q, q_delta)
        if acc is not None:
            fraction = 1.0 - self.params.alpha if s.levelled else 1.0
            q = qm.mul(tilt_correction(s.q, acc, fraction), q)
            s.levelled = True
        s.q = qm.normalize(q)  # step 5: q(t+dt) = q((1 - alpha) phi, v_tilt) q(t) q_delta
        return s.q


def tilt_correction(q: Quat, acc: Vec, fraction: float) -> Quat:
    """``q(fraction * phi, v_tilt)`` of Zhu & Shi, sec. 3, steps 1-5.

    Step 1: the accelerometer in the world frame, ``q acc q^-1``; step 2: its
    direction ``v``; step 3: ``phi = arccos(v . UP)``, computed as
    ``atan2(|v x UP|, v . UP)`` (the same angle, accurate near 0); step 4: the axis
    ``v_tilt = v x UP`` (normalised; any horizontal axis at ``phi = pi``: EAST);
    step 5: the rotation by ``fraction * phi`` about ``v_tilt``. Steps 2-4 and the
    fraction are :func:`.qmath.tilt_to_up`, the rotation vector
    ``fraction * phi * v_tilt``.
    """
    v = qm.rotate(q, acc)  # step 1 (step 2's normalisation cancels in atan2 and the axis)
    rx, ry, rz = qm.tilt_to_up(v, fraction)  # steps 2-4 with UP = +z, scaled for step 5
    return qm.from_rotvec(rx, ry, rz)


FILTER_CLASS = ComplementaryFilter
