"""ArmPose: what every input source gives the game, one per update.

The tracker (board), the keyboard and mouse, and the simulated player all
produce the same thing, so the avatar and the gesture machine cannot tell
them apart (ARCHITECTURE.md, the data flow).
"""

from __future__ import annotations

from typing import NamedTuple

Quat = tuple[float, float, float, float]


class ArmPose(NamedTuple):
    """The upper arm's sensor orientation and the elbow angle at time ``t``.

    ``q_upper`` is q_WS of the upper-arm sensor, scalar first, in the tracker's
    world frame (z up; its heading is mapped to the game by the wearing
    calibration). ``flex_deg`` is the elbow angle, 0 = straight. A named tuple:
    the cheapest immutable record to make once per board sample.
    """

    q_upper: Quat
    flex_deg: float
    t: float
