"""The simulated player at rest against a real person's arm at rest.

The real recording (``../shared/data/real-arm/qmt_full_body_arms.npz``, its
README: the qmt toolbox's full-body example, 100 Hz, a person standing still
0-2.5 s and 17.5-37.5 s from its start) gives what an upper-arm board feels
when its wearer holds still. :func:`compare_with_recording` simulates a player
(the "typical" one by default) hanging the arm still, worn and measured as the
game's harness does (:meth:`PlayerProfile.chain`, :meth:`PlayerProfile.sensor_errors`,
:class:`tracker.sim.Simulator` at the recording's 100 Hz), cuts both into
2-second windows and compares, window by window, what a stillness check sees:

- gyro RMS: the gyroscope's spread about the window's mean, RMS over samples
  and axes (deg/s);
- gyro stray: the largest distance of a gyroscope sample from that mean (deg/s);
- acc stray: the same for the accelerometer (m/s^2);
- gyro centroid: where the power of the gyroscope's deviation lies, the
  power-weighted mean frequency of its periodogram (Hz);
- gyro power above 3 Hz: that periodogram's share above 3 Hz.

Each row holds the medians over the windows (both upper arms of the real
person) and their ratio.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


from .motion_model import PlayerProfile, Script

Array = NDArray[np.float64]

RECORDING = os.environ.get("ENERGYBALL_REAL_ARM", os.path.join(
    os.path.dirname(__file__), "..", "..", "..", "shared", "data", "real-arm", "qmt_full_body_arms.npz"))
STILL_PHASES_S = ((0.0, 2.5), (17.5, 37.5))  # the recording's README, from its start
SEGMENTS = ("upper_arm_left", "upper_arm_right")
WINDOW_S = 2.0
RATE_HZ = 100.0  # the recording's
SPLIT_HZ = 3.0  # tremor and tissue above, sway and drift below
METRICS = ("gyro RMS (deg/s)", "gyro stray (deg/s)", "acc stray (m/s^2)", "gyro centroid (Hz)",
           "gyro power above 3 Hz")


@dataclass(frozen=True)
class Row:
    """One statistic: the medians over the windows of the real arm and the simulated player."""

    metric: str
    real: float
    simulated: float

    @property
    def ratio(self) -> float:
        return self.simulated / self.real


def window_stats(gyr: Array, acc: Array, rate_hz: float = RATE_HZ) -> Array:
    """The statistics (:data:`METRICS`, module docstring) of one window of gyroscope (rad/s)
    and accelerometer (m/s^2) samples, (N, 3) each."""
    g = np.degrees(gyr - gyr.mean(axis=0))
    a = acc - acc.mean(axis=0)
    power = np.sum(np.abs(np.fft.rfft(g, axis=0)) ** 2, axis=1)[1:]  # without the (removed) mean
    freq = np.fft.rfftfreq(len(g), 1.0 / rate_hz)[1:]
    return np.array([np.sqrt(np.mean(g * g)), np.linalg.norm(g, axis=1).max(),
                     np.linalg.norm(a, axis=1).max(), np.sum(freq * power) / np.sum(power),
                     np.sum(power[freq > SPLIT_HZ]) / np.sum(power)])


def windows(gyr: Array, acc: Array, t: Array, spans: tuple[tuple[float, float], ...]) -> Array:
    """:func:`window_stats` of every whole 2-second window inside ``spans`` (seconds of ``t``),
    (windows, metrics)."""
    stats = []
    for t0, t1 in spans:
        start = t0
        while start + WINDOW_S <= t1 + 1e-9:
            inside = (t >= start - 1e-9) & (t < start + WINDOW_S - 1e-9)
            stats.append(window_stats(gyr[inside], acc[inside]))
            start += WINDOW_S
    return np.array(stats)


def recording_stats(path: str | os.PathLike = RECORDING) -> Array:
    """The windows of the recording's still phases, both upper arms, (windows, metrics)."""
    data = np.load(path)
    t = data["t"] - data["t"][0]
    return np.concatenate([windows(data[f"{s}_gyr"], data[f"{s}_acc"], t, STILL_PHASES_S)
                           for s in SEGMENTS])


def simulated_stats(profile: PlayerProfile = PlayerProfile(), seconds: float = 60.0,
                    seed: int = 0) -> Array:
    """The windows of ``profile``'s player holding the arm hanging still for ``seconds``:
    tremor, sway and the board on the soft tissue, measured with the board's errors."""
    motion = Script(profile, seed).motion  # no segment: the arm hangs, the elbow relaxed
    sim = profile.simulator(motion, seed)
    data = sim.simulate(seconds, RATE_HZ)
    return windows(data.gyr[:, 0], data.acc[:, 0], data.t, ((0.0, seconds),))


def compare_with_recording(profile: PlayerProfile = PlayerProfile(),
                           path: str | os.PathLike = RECORDING, seconds: float = 60.0,
                           seed: int = 0) -> list[Row]:
    """The real arm at rest against ``profile``'s player at rest (module docstring), one
    :class:`Row` per statistic."""
    real = np.median(recording_stats(path), axis=0)
    simulated = np.median(simulated_stats(profile, seconds, seed), axis=0)
    return [Row(m, float(r), float(s)) for m, r, s in zip(METRICS, real, simulated)]


def table(rows: list[Row]) -> str:
    """The comparison as a Markdown table."""
    lines = ["| at rest, 2-s windows (medians) | real upper arm | simulated typical | ratio |",
             "|---|---|---|---|"]
    lines += [f"| {r.metric} | {r.real:.3g} | {r.simulated:.3g} | {r.ratio:.2f} |" for r in rows]
    return "\n".join(lines)
