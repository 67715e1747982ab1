"""Ctrl-C, SIGTERM and SIGHUP end a headless run with the report of the matches finished (issue 13).

At seeded random moments (after a random number of finished matches): exit 0 with every match played, or exit 128 + the
signal's number with the report of the finished matches (``interrupted``
names the signal); never a traceback, and no worker process left behind.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest

from ...commands import SIGNALS, finish, start

MATCHES = 3


def first_line(proc) -> str:
    line = proc.stderr.readline()
    assert line, "the run ended before saying anything"
    return line


def processes_with(marker: str) -> list[int]:
    """Processes whose command line holds ``marker`` (this test's own runs only)."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if marker in (entry / "cmdline").read_bytes().decode(errors="replace").split("\0"):
                    found.append(int(entry.name))
            except OSError:
                pass
    return found


@pytest.mark.parametrize("workers", [1, 2])
def test_a_signal_at_a_random_moment_prints_the_finished_matches(tmp_path, workers):
    rng = np.random.default_rng(55 + workers)
    interrupted = 0
    for sig in SIGNALS:
        seed = str(913_000 + 10 * workers + int(sig))  # marks this run's processes
        proc = start("game", "--headless", "--matches", str(MATCHES), "--duration", "30", "--workers", str(workers),
                     "--seed", seed, "--json", home=tmp_path)
        first_line(proc)  # the build note: the run has begun
        finished = int(rng.integers(0, MATCHES))  # signal after this many matches, at a random moment of the next
        while finished and f"match {finished}/{MATCHES}" not in first_line(proc):
            pass
        time.sleep(rng.uniform(0.0, 0.5))
        proc.send_signal(sig)
        r = finish(proc)
        assert "Traceback" not in r.stderr, r.stderr
        report = json.loads(r.stdout)
        assert report["summary"]["matches"] == len(report["matches"])
        if r.returncode == 0:
            assert report["interrupted"] is None and len(report["matches"]) == MATCHES
        else:
            assert r.returncode == 128 + sig
            assert report["interrupted"] == sig.name and finished <= len(report["matches"]) < MATCHES
            assert [m["seed"] for m in report["matches"]] == list(range(int(seed), int(seed) + len(report["matches"])))
            assert f"stopped after {len(report['matches'])} of {MATCHES} matches" in r.stderr.splitlines()[-1]
            interrupted += 1
        assert processes_with(seed) == [], "a worker outlived the run"
    assert interrupted > 0


def test_the_text_report_is_printed_too(tmp_path):
    """SIGTERM once the first of a thousand matches is done: the text report of the matches finished.
    (Each match opens the game's window, and a signal handled while pygame loads its icon was lost:
    the run played on, six matches to the end and a thousand past the timeout on the hosted CI;
    tests/game/ui/test_app.py::test_a_signal_while_the_window_opens_is_not_lost.)"""
    proc = start("game", "--headless", "--matches", "1000", "--duration", "30", home=tmp_path)
    first_line(proc)
    while "match 1/1000" not in first_line(proc):
        pass
    proc.send_signal(SIGNALS[1])
    r = finish(proc)
    assert r.returncode == 143 and "Traceback" not in r.stderr, r.stderr[-2000:]
    done = int(r.stderr.splitlines()[-1].split("stopped after ")[1].split(" of ")[0])
    assert 1 <= done < 1000
    assert r.stdout.splitlines()[0].split() == ["matches", str(done)]
