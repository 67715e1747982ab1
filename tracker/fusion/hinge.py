"""Madgwick's filter with the hinge axis as second reference (seed 003, sec. 2.3).

Seed paper 003 tracks a phalanx on a hinge whose parent (the metacarpus) is known
from optical tracking. It keeps Madgwick's gradient-descent filter but replaces
the magnetometer by "the normal axis of the flexion plane as the second
correction vector" (sec. 2.3): the hinge axis. The axis is fixed in the segment
(sec. 2.1: the x axes of all links lie along the hinge axes), so the sensor
"measures" it as a constant direction ``a_S``, and its world direction ``a_W``
is known from the parent. The objective pair is therefore

    f_g = q* (0, 0, 1) q - acc/|acc|        (gravity, seed 003 eq. (11))
    f_a = q* a_W q - a_S                    (flexion-plane normal)

both handled by :func:`.madgwick.gradient` and stepped by
:func:`.madgwick.descend` (seed 003 eqs. (15), (18), (19)). Gravity fixes the
inclination; the axis fixes the heading as long as it is not vertical (the
paper's "co-directionality of the correction vectors", sec. 2.3), and, unlike a
magnetometer, it is immune to magnetic disturbances.

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

from dataclasses import dataclass

from .madgwick import Madgwick, MadgwickParams, unit
from .qmath import Quat, Vec


@dataclass
class HingeParams(MadgwickParams):
    """Settings of the hinge filter (``beta`` as in :class:`.madgwick.MadgwickParams`).

    hinge_sensor: the hinge axis in the sensor frame; default the sensor y axis, the
    elbow hinge convention of ARCHITECTURE.md (seed 000, sec. 3).
    hinge_world: the same axis in the world frame (the flexion-plane normal); default
    world x, a horizontal axis. Neither needs unit length; both must be non-zero.
    """

    hinge_sensor: Vec = (0.0, 1.0, 0.0)
    hinge_world: Vec = (1.0, 0.0, 0.0)


class Hinge(Madgwick):
    """Gravity plus the flexion-plane normal: full orientation without a magnetometer."""

    name = "hinge"
    Params = HingeParams

    def __init__(self, params: HingeParams | None = None, **overrides: object) -> None:
        super().__init__(params, **overrides)
        p = self.params
        for label, axis in (("hinge_sensor", p.hinge_sensor), ("hinge_world", p.hinge_world)):
            if len(axis) != 3 or not 0.0 < sum(c * c for c in axis) < float("inf"):
                raise ValueError(f"{label} must be a finite non-zero 3-vector, got {axis!r}")
        self._pair = (unit(tuple(map(float, p.hinge_world))), unit(tuple(map(float, p.hinge_sensor))))

    def _second_pair(self, q: Quat, mag: Vec | None) -> tuple[Vec, Vec]:
        """The hinge axis: (world direction, sensor-frame direction)."""
        self.flags.mag_ignored = True
        return self._pair


FILTER_CLASS = Hinge
