"""Running ``armtracker`` and ``energyball`` as a user does (a separate process), and ending them with signals.

Every run gets a throwaway HOME. The child starts with SIGINT, SIGTERM and SIGHUP
at their defaults, as from a terminal, whatever the test runner inherited: a shell
leaves SIGINT ignored in a background job, ``nohup`` SIGHUP, and a child would
inherit that (our commands leave an ignored signal ignored, as the user asked).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


def terminal_dispositions() -> None:
    """In the child before it runs: the ending signals at their defaults."""
    for s in SIGNALS:
        signal.signal(s, signal.SIG_DFL)


def env_for(home: Path) -> dict[str, str]:
    return {**os.environ, "HOME": str(home), "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy"}


def run(package: str, *args: str, home: Path, timeout: float = 120) -> subprocess.CompletedProcess:
    """``python -m package args`` to the end."""
    return subprocess.run([sys.executable, "-m", package, *args], capture_output=True, text=True, timeout=timeout,
                          cwd=ROOT, env=env_for(home), stdin=subprocess.DEVNULL,
                          preexec_fn=terminal_dispositions)


def start(package: str, *args: str, home: Path) -> subprocess.Popen:
    """``python -m package args`` started, its output collected for :func:`finish`."""
    return subprocess.Popen([sys.executable, "-m", package, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=ROOT, env=env_for(home), stdin=subprocess.DEVNULL,
                            preexec_fn=terminal_dispositions)


def finish(proc: subprocess.Popen, timeout: float = 120) -> subprocess.CompletedProcess:
    out, err = proc.communicate(timeout=timeout)
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


def wait_for(predicate, proc: subprocess.Popen, timeout: float = 60) -> bool:
    """Poll ``predicate`` every millisecond until it holds (True) or the process ends first (False)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        if proc.poll() is not None:
            return predicate()
        time.sleep(0.001)
    raise AssertionError("the awaited moment never came")


def parts(folder: Path) -> list[str]:
    """Temporary files of atomic writes left in ``folder``."""
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".part"))


def one_clear_line(r: subprocess.CompletedProcess, *words: str, code: int | None = None) -> str:
    """A refusal: non-zero exit (``code`` if given), exactly one line on stderr holding ``words``, no traceback."""
    assert r.returncode != 0 if code is None else r.returncode == code, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def parse_in_process(parser: argparse.ArgumentParser, argv: list[str]) -> tuple[object, int | None, str]:
    """(namespace or None, exit status or None, stderr) of ``parser`` parsing ``argv`` in this process."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        try:
            return parser.parse_args(argv), None, err.getvalue()
        except SystemExit as e:
            return None, e.code, err.getvalue()
