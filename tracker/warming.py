"""How fast the IMU die's temperature changes: a least-squares slope over a sliding window.

Why. The MPU-9250's accelerometer zero-g level moves by up to 1.5 mg per degC
of its die (PS-MPU-9250A-01 rev. 1.1, table 2, "zero-g level change vs.
temperature") and its gyroscope's zero-rate output by up to 0.24 deg/s per
degC (table 1). A board just powered up warms by a few degC, up to some 17 on
the catalogue's worst board, with a time constant of minutes
(:class:`tracker.sim.ErrorModel`): some 7 degC a minute at first on that board.
A procedure that compares still poses held a minute apart, such as the
accelerometer's (:mod:`tracker.accel_procedure`), sees the zero-g level move
between them by as much as its whole fit's error budget, and the move ends up
in the scale and the cross-axis terms. Such a procedure waits while the die
warms faster than ``max_c_per_min`` (1 degC a minute: at most 1.5 mg over a
minute's poses, a few times the poses' noise, 0.2 mg).

How. The die's temperature comes once a second (the TEMP frame, PROTOCOL.md
sec. 4.3), each raw sample carrying the latest. One point is kept every
``step_s`` of the board's clock over the last ``window_s``, and the rate is the
least-squares slope of the temperature in the time over them (a line's slope
from noisy points: the window's 30 points take a TEMP_OUT noise of 0.05 degC,
a hundred times its resolution of 1/333.87 degC, to a slope of 0.06 degC a
minute). It is known once the points span ``min_span_s``: before that the
procedure waits too, because a board freshly plugged in cannot be told from a
warm one by its clock (the port's opening resets an Arduino,
:mod:`tracker.link`). A board cooling as fast is waited for alike.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class WarmingParams:
    """Settings of :class:`DieWarming` (module docstring)."""

    window_s: float = 30.0  # the points the slope is fitted over: the latest this long
    min_span_s: float = 10.0  # the rate is known once the points span this long
    step_s: float = 1.0  # one point per TEMP frame (the firmware sends one a second)
    max_c_per_min: float = 1.0  # faster than this, in either direction, a procedure waits

    def __post_init__(self) -> None:
        if not (0.0 < self.step_s <= self.min_span_s <= self.window_s and self.max_c_per_min > 0.0):
            raise ValueError(f"WarmingParams need 0 < step_s <= min_span_s <= window_s and a rate "
                             f"limit above 0: {self}")


class DieWarming:
    """The die's rate of warming over a sliding window of the board's clock (module docstring)."""

    def __init__(self, params: WarmingParams = WarmingParams()) -> None:
        self.params = params
        self._points: deque[tuple[float, float]] = deque()  # (board time s, die degC)
        self._rate: float | None = None

    def reset(self) -> None:
        """Forget the points (the board's clock restarted: a power-up, a pulled cable)."""
        self._points.clear()
        self._rate = None

    def update(self, t: float, die_c: float) -> None:
        """Take the die's temperature ``die_c`` at board time ``t`` (every sample may be given: one point
        is kept per ``step_s``). A time before the latest point's restarts the window."""
        points = self._points
        if points and t < points[-1][0]:
            self.reset()
        if points and t - points[-1][0] < self.params.step_s:
            return
        points.append((t, die_c))
        while t - points[0][0] > self.params.window_s:
            points.popleft()
        self._rate = self._slope() if t - points[0][0] >= self.params.min_span_s else None

    def _slope(self) -> float:
        """The least-squares slope of the points, degC per minute: sum (t - t_mean)(T - T_mean) over
        sum (t - t_mean)^2."""
        x = np.array(self._points)
        dt = x[:, 0] - x[:, 0].mean()
        return float(dt @ (x[:, 1] - x[:, 1].mean()) / (dt @ dt)) * 60.0

    @property
    def rate(self) -> float | None:
        """How fast the die's temperature changes, degC per minute (negative: cooling); None until the
        points span ``min_span_s``."""
        return self._rate

    @property
    def measured_s(self) -> float:
        """How long the points span now, s."""
        return self._points[-1][0] - self._points[0][0] if self._points else 0.0

    @property
    def settled(self) -> bool:
        """Whether the rate is known and within ``max_c_per_min`` either way."""
        return self._rate is not None and abs(self._rate) <= self.params.max_c_per_min
