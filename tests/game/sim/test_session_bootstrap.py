"""The sessions' bootstrap: an exact case enumerated by hand, scipy's bootstrap as the oracle, and what
drawing launches instead of sessions would have hidden."""

import numpy as np
import pytest
from scipy.stats import bootstrap

from game.__main__ import envelope_table
from game.sim.gesture_eval import TrialResult, summarise
from game.sim.session_bootstrap import percentile_interval


def test_three_sessions_of_one_launch_worked_by_hand():
    """Sessions {1}, {2}, {3}: of the 27 equally likely ordered draws of three, the median is 1 when
    two or three draws are 1 (3 * 2 + 1 = 7 draws), 3 likewise (7), 2 otherwise (13). So the median's
    bootstrap distribution is 1, 2, 3 with 7/27, 13/27, 7/27: its 10 % and 90 % quantiles are 1 and
    3 (7/27 = 0.26 lies above 0.10, 20/27 = 0.74 below 0.90), its 30 % and 70 % quantiles both 2."""
    sessions = [[1.0], [2.0], [3.0]]
    assert percentile_interval(sessions, 50, level=0.8, resamples=20_000) == (1.0, 3.0)
    assert percentile_interval(sessions, 50, level=0.4, resamples=20_000) == (2.0, 2.0)


def clustered(seed: int) -> list[list[float]]:
    """30 sessions whose launches share each session's own offset (its heading's walk), 5-40 each."""
    rng = np.random.default_rng(seed)
    return [list(abs(rng.normal(3.0, 2.0) + rng.normal(0.0, 0.3, rng.integers(5, 41)))) for _ in range(30)]


@pytest.mark.parametrize("q", [50, 95])
def test_the_interval_is_scipys_percentile_bootstrap_over_sessions(q):
    """scipy.stats.bootstrap, given the sessions' indices as its one sample and the pooled percentile
    as the statistic, draws sessions as ours does: the two percentile intervals agree within what
    4000 draws leave to chance. Drawing the launches instead (scipy over the pooled values) gives
    an interval several times narrower, which would have passed a walk shared by a whole session
    for a launch's own luck."""
    sessions = clustered(1)
    pooled = np.concatenate(sessions)

    def pooled_percentile(index: np.ndarray) -> float:
        return float(np.percentile(np.concatenate([sessions[i] for i in index]), q))

    oracle = bootstrap((np.arange(len(sessions)),), pooled_percentile, vectorized=False, method="percentile",
                       n_resamples=4000, random_state=7).confidence_interval
    ours = percentile_interval(sessions, q, resamples=4000)
    assert ours is not None
    width = oracle.high - oracle.low
    assert ours == pytest.approx((oracle.low, oracle.high), abs=0.08 * width)
    launches = bootstrap((pooled,), lambda x, axis: np.percentile(x, q, axis=axis), method="percentile",
                         n_resamples=4000, random_state=7).confidence_interval
    assert launches.high - launches.low < width / 3


def test_too_few_sessions_say_nothing_and_equal_sessions_say_it_exactly():
    assert percentile_interval([], 50) is None
    assert percentile_interval([[2.0, 3.0], []], 50) is None  # one session with launches
    assert percentile_interval([[1.5, 2.5], [1.5, 2.5], [1.5, 2.5]], 50) == (2.0, 2.0)
    sessions = clustered(2)
    assert percentile_interval(sessions, 50) == percentile_interval(sessions, 50)  # seeded: the same report


def test_the_report_gives_each_aim_figure_its_interval_and_the_table_shows_the_late_one():
    results = []
    for aims in clustered(3):
        r = TrialResult(true_launches=len(aims), matched=len(aims), calibration_ok=True)
        r.aim_errors_deg = aims
        r.late_aim_errors_deg = aims[len(aims) // 2:]
        results.append(r)
    report = summarise(results)
    for key in ("aim_error_deg_median", "aim_error_deg_p95", "aim_error_deg_median_late"):
        low, high = report[key + "_ci95"]
        assert low < report[key] < high
    low, high = report["aim_error_deg_median_late_ci95"]
    header, row = envelope_table({"someone": report}).splitlines()
    assert "late 95%" in header and f"{low}-{high}" in row.split()
    assert summarise(results[:1])["aim_error_deg_median_late_ci95"] is None
