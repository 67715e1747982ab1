"""How far a figure over simulated sessions could move with other sessions: a percentile bootstrap
that draws whole sessions.

A figure such as the late aim's median pools the launches of every session, but the launches of
one session are not independent draws: they share its calibration and its heading's walk, so a
session that walked 8 degrees gives a score of late launches all near 8. Drawing launches again
would take them for independent and give an interval far too narrow. So the units drawn are the
sessions, each with all its launches: the top stage of hierarchical data resampled (A. C. Davison
and D. V. Hinkley, "Bootstrap Methods and their Application", Cambridge University Press, 1997,
sec. 3.8). The interval is the percentile interval (B. Efron and R. J. Tibshirani, "An
Introduction to the Bootstrap", Chapman & Hall, 1993, sec. 13.3): of ``resamples`` sets of as many
sessions as were run, drawn with replacement, the figure's (1 - level) / 2 and (1 + level) / 2
quantiles. The draws are seeded, so a report is the same every time it is made.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

RESAMPLES = 2000  # session sets drawn: an end of a 2.5 deg interval over 30 sessions moves 0.02 deg (sd) by seed
LEVEL = 0.95
SEED = 0


def percentile_interval(sessions: Sequence[Sequence[float]], q: float, level: float = LEVEL,
                        resamples: int = RESAMPLES, seed: int = SEED) -> tuple[float, float] | None:
    """The ``level`` interval of the ``q``-th percentile of the values of all ``sessions`` pooled,
    rounded to 0.01 as the reports' figures are. Sessions without values add nothing to the pooled
    figure and are left out; with fewer than two left, None: one session says nothing of the next."""
    groups = [np.asarray(values, dtype=float) for values in sessions if len(values)]
    if len(groups) < 2:
        return None
    picks = np.random.default_rng(seed).integers(0, len(groups), size=(resamples, len(groups)))
    figures = [np.percentile(np.concatenate([groups[i] for i in row]), q) for row in picks]
    low, high = np.percentile(figures, [50.0 * (1.0 - level), 50.0 * (1.0 + level)])
    return round(float(low), 2), round(float(high), 2)
