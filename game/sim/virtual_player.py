"""The player behind ``energyball --virtual``: a simulated person wearing a simulated board, forever.

The virtual board (:class:`tracker.board.VirtualBoard`) turns whatever a
motion source feels into the firmware's bytes. Here that source is the
harsh world's "typical" player (:mod:`game.sim.motion_model`: tremor, sway, the
strap's rocking, twist and slip) wearing the typical board
(:func:`tracker.sim.realistic_errors`: warm-up drift, an uncalibrated
magnetometer, the flex sensor's hysteresis and creep), so the game played
with ``--virtual`` meets what it meets with a real board on a real arm.

The player idles (fidgets, walks, bends the elbow, scratches) and throws in
turn, without end: the script is extended ahead of the board's clock and
forgotten behind it, so an evening's play keeps a constant, small memory.
It does not follow the game's prompts: the app skips the wearing
calibration for the virtual board, which the typical player wears as it was
designed to be worn.
"""

from __future__ import annotations

from tracker.motion import SensorReading
from tracker.sim import SimulatedSource

from .motion_model import PlayerProfile, Script

AHEAD_S = 12.0  # the script reaches at least this far past the newest reading asked for
KEEP_S = 2.0  # and keeps this much of the past (the simulator looks a few ms back at most)
IDLE_S = (3.0, 8.0)  # each idle stretch between throws, drawn within this range


class VirtualPlayer:
    """A :class:`tracker.motion.MotionSource`: the profile's player, idling and throwing in turn."""

    def __init__(self, rate_hz: float = 200.0, profile: PlayerProfile = PlayerProfile(), seed: int = 0) -> None:
        self.script = Script(profile, seed)
        self._draws = self.script.rng()
        sim = profile.simulator(self.script.motion, seed)
        self._source = SimulatedSource(sim, rate_hz)

    def reading(self, t: float) -> SensorReading:
        """What the board feels at ``t`` seconds after power-on."""
        horizon = t + AHEAD_S + self._source.block / self._source.rate_hz
        while self.script.now < horizon:
            self.script.idle(float(self._draws.uniform(*IDLE_S)))
            self.script.gesture()
        self.script.forget_before(t - KEEP_S)
        return self._source.reading(t)
