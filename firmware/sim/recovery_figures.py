"""Recovery figures: the firmware on the simulated board, from a fault to good samples again.

    .venv/bin/python firmware/sim/recovery_figures.py [--runs N] [--json]

Builds nothing: run ``make -C firmware`` and ``make -C firmware sim`` first. Each
fault is put on firmware/build/energyball.elf in firmware/sim/boardsim N times
(default 5), at moments spread over a sample period, and boardsim's report says
when the first sample read after the fault reached the wire and how many samples
the gap cost (firmware/sim/README.md, "Recovery"):

* ``stuck_bus``: the AVR reset in the middle of an MPU read, the MPU holding SDA
  low (``--reset-at T --stuck-sda``): the sketch restarts, clears the bus and boots;
* ``glitch``: the IMU's supply drops out (``--glitch T``): the board notices and
  configures it again;
* ``hang``: the loop hangs (``--hang-at T``): the watchdog resets the board;
* ``first_open`` and ``reopen``: a host (``tracker.link.Link``) opens the pty, which
  resets the board into Optiboot's time, reads, closes the port and opens it again.
  The link leaves DTR asserted on close (Linux, macOS), so the reopen resets nothing.

Prints the worst run of each (recovery_s and samples_lost); with --json, JSON.
"""

from __future__ import annotations

import argparse
import json
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SIM = Path(__file__).resolve().parent
ELF = SIM.parent / "build" / "energyball.elf"
BOARDSIM = SIM / "boardsim"
FAULT_AT_S = 1.2  # after the sketch's boot (about 0.8 s from power-up)
RUN_S = 3.0
PERIOD_S = 1 / 200  # the sketch's default rate
FLEX_MV = "2000"  # mid-range: no flex rail faults
TYPICAL_STARTUP = ("--imu-startup-ms", "11")  # PS-MPU-9250A-01 sec. 3.4.2, typical
FAULTS = {
    "stuck_bus": ("--reset-at", "--stuck-sda"),
    "glitch": ("--glitch",),
    "hang": ("--hang-at",),
}


def _boardsim(*args: str, timeout: float = 120) -> dict:
    r = subprocess.run([str(BOARDSIM), str(ELF), "--json", "--flex-mv", FLEX_MV, *args],
                       capture_output=True, text=True, timeout=timeout, stdin=subprocess.DEVNULL)
    if r.returncode != 0:
        raise SystemExit(f"recovery_figures: boardsim failed: {r.stderr.strip()}")
    return json.loads(r.stdout)


def fault_events(option: str, flags: tuple[str, ...], at_s: float, seed: int) -> list[dict]:
    """One run of boardsim without a host with the fault at at_s; its recovery events."""
    report = _boardsim("--seconds", str(RUN_S), "--seed", str(seed), option, f"{at_s:.6f}",
                       *flags, *TYPICAL_STARTUP)
    return report["recovery"]


def host_events(seed: int) -> list[dict]:
    """A host opens the board's pty, reads 1 s, closes it and opens it again for 1 s."""
    from tracker.link import Link, LinkSettings

    with tempfile.TemporaryDirectory() as tmp:
        link = Path(tmp) / "ttySIM"
        proc = subprocess.Popen([str(BOARDSIM), str(ELF), "--json", "--pty", str(link),
                                 "--flex-mv", FLEX_MV, "--seed", str(seed), *TYPICAL_STARTUP],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                stdin=subprocess.DEVNULL)
        try:
            deadline = time.monotonic() + 10
            while not link.exists() and time.monotonic() < deadline:
                time.sleep(0.02)
            for _ in range(2):
                with Link(LinkSettings(port=str(link), reconnect=False)) as board:
                    list(board.samples(1.0))
                time.sleep(0.3)
            proc.send_signal(signal.SIGTERM)
            out, err = proc.communicate(timeout=10)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
    if proc.returncode != 0:
        raise SystemExit(f"recovery_figures: boardsim failed: {err.strip()}")
    return json.loads(out)["recovery"]


def worst(events: list[dict]) -> dict:
    """The slowest recovery of several, with the most samples lost; None if any never recovered."""
    if any(e["recovery_s"] is None for e in events):
        return {"recovery_s": None, "samples_lost": None, "runs": len(events)}
    lost = [e["samples_lost"] for e in events if e["samples_lost"] is not None]
    return {"recovery_s": round(max(e["recovery_s"] for e in events), 4),
            "samples_lost": max(lost) if lost else None, "runs": len(events)}


def measure(runs: int) -> dict:
    figures = {}
    for name, (option, *flags) in FAULTS.items():
        events = []
        for k in range(runs):
            at_s = FAULT_AT_S + k * PERIOD_S / runs  # spread over one sample period
            events += [e for e in fault_events(option, tuple(flags), at_s, seed=k + 1)
                       if e["kind"] != "open"]
        figures[name] = worst(events)
    opens = [host_events(seed=k + 1) for k in range(max(1, runs // 5))]
    figures["first_open"] = worst([events[0] for events in opens])
    figures["reopen"] = worst([events[1] for events in opens])
    return figures


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=5, help="runs of each fault (default 5)")
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error("--runs takes a whole number of at least 1")
    for path, how in ((ELF, "make -C firmware"), (BOARDSIM, "make -C firmware sim")):
        if not path.exists():
            parser.exit(2, f"recovery_figures: {path} is missing: run `{how}` first\n")
    figures = measure(args.runs)
    if args.json:
        print(json.dumps(figures, indent=2))
    else:
        for name, f in figures.items():
            print(f"{name:>10}: {f['recovery_s']} s to a good sample, {f['samples_lost']} samples lost"
                  f" (worst of {f['runs']})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
