"""Madgwick's filter with the hinge axis as second reference (the finger-tracking paper, sec. 2.3).

Inertial Sensor Based Solution for Finger Motion Tracking (Computers 9(2):40,
2020) tracks a phalanx on a hinge whose parent (the metacarpus) is known from
optical tracking. It keeps Madgwick's gradient-descent filter but replaces the
magnetometer by "the normal axis of the flexion plane as the second correction
vector" (sec. 2.3): the hinge axis. The axis is fixed in the segment (sec. 2.1:
the x axes of all links lie along the hinge axes), so the sensor "measures" it as
a constant direction ``a_S``, and its world direction ``a_W`` is known from the
parent. Gravity is solved by gradient descent and "the only possible solution is
chosen, taking into account the normal to the flexion plane" (sec. 2.3): gravity
gives the inclination, the axis the heading.

The axis takes the magnetometer's place in Madgwick's MARG filter, including
its distortion compensation (Madgwick 2010, sec. 3.4, :func:`.madgwick.heading_reference`):
the reference is ``a_S`` seen in the world through the current estimate, with
its horizontal part turned onto the horizontal direction of ``a_W``. So the
objective pair is

    f_g = q* (0, 0, 1) q - acc/|acc|        (gravity, the finger-tracking paper, eq. (11))
    f_a = q* a_ref q - a_S                  (flexion-plane normal, heading only)

both handled by :func:`.madgwick.gradient` and stepped by
:func:`.madgwick.descend` (the finger-tracking paper, eqs. (15), (18), (19)). The axis thus
cannot tilt the estimate when the joint is not a perfect hinge or ``a_W`` is a
little off; it fixes the heading unless it is vertical (the paper's
"co-directionality of the correction vectors", sec. 2.3, refused here), and,
unlike a magnetometer, it is immune to magnetic disturbances.

Simplifications against the paper: ``a_W`` is a fixed parameter (the parent
segment is taken as still; the paper updates it from the tracked metacarpus),
and the sensor's own kinematic acceleration ``g_k`` of eq. (11) is not
subtracted from gravity (no chain model here), so fast swings disturb the
inclination as in plain Madgwick.

The magnetometer is not used (``flags.mag_ignored`` is always set). The fast
start is Madgwick's: inclination from the first accelerometer sample, then the
heading that puts the hinge axis on its world direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .madgwick import Madgwick, MadgwickParams, heading_reference
from .qmath import Quat, Vec, unit


@dataclass
class HingeParams(MadgwickParams):
    """Settings of the hinge filter.

    beta: as in :class:`.madgwick.MadgwickParams`, but default 0.04, the best
    inclination setting of the magnetometer-free form on BROAD (which has no hinge
    to test the second reference on); the heading then converges at up to about
    2 beta = 4.6 deg/s, which matters only without the fast start.
    hinge_sensor: the hinge axis in the sensor frame; default the sensor y axis, the
    elbow hinge convention of ARCHITECTURE.md (Zhu & Shi, sec. 3).
    hinge_world: the same axis in the world frame (the flexion-plane normal); default
    world x. Only its horizontal direction is used (gravity sets the inclination),
    so it must not be vertical. Neither axis needs unit length.
    """

    beta: float = 0.04
    hinge_sensor: Vec = (0.0, 1.0, 0.0)
    hinge_world: Vec = (1.0, 0.0, 0.0)


def _axis(label: str, v: Vec) -> Vec:
    """v as a unit 3-tuple; ValueError for anything else than a finite non-zero 3-vector."""
    if len(v) != 3 or not all(math.isfinite(c) for c in v) or not any(v):
        raise ValueError(f"{label} must be a finite non-zero 3-vector, got {v!r}")
    return unit((float(v[0]), float(v[1]), float(v[2])))


class Hinge(Madgwick):
    """Gravity plus the flexion-plane normal: full orientation without a magnetometer."""

    name = "hinge"
    uses_magnetometer = False
    Params = HingeParams

    def __init__(self, params: HingeParams | None = None, **overrides: object) -> None:
        super().__init__(params, **overrides)
        self._sensor = _axis("hinge_sensor", self.params.hinge_sensor)
        wx, wy, wz = _axis("hinge_world", self.params.hinge_world)
        horizontal = math.hypot(wx, wy)
        if horizontal < 1e-6:
            raise ValueError("hinge_world must not be vertical: it would tell no heading "
                             "(the finger-tracking paper, sec. 2.3)")
        self._toward = (wx / horizontal, wy / horizontal, 0.0)

    def _second_pair(self, q: Quat, mag: Vec | None) -> tuple[Vec, Vec]:
        """The hinge axis: (heading-only world reference, sensor-frame direction)."""
        self.flags.mag_ignored = True
        return heading_reference(q, self._sensor, self._toward), self._sensor


FILTER_CLASS = Hinge
