"""``energyball``: the game's command line (also ``python -m game``).

``energyball`` plays (the game lands with the game issue; until then it says
so); ``energyball gestures-eval`` measures the gesture recognition on
simulated players through the whole pipeline.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Sequence


class UsageError(Exception):
    """A command line or input file that cannot be used, worded for the user."""


def cmd_play(args: argparse.Namespace) -> int:
    print("EnergyBall: the game is not built yet. The tracker is: try\n"
          "  armtracker monitor --virtual     (a virtual board on a pty)\n"
          "  armtracker monitor               (your board, found by USB id)\n"
          "  energyball gestures-eval         (gesture recognition on simulated players)",
          file=sys.stderr)
    return 0


def cmd_gestures_eval(args: argparse.Namespace) -> int:
    from .gesture_eval import evaluate
    from .motion_model import PlayerProfile
    try:
        profile = PlayerProfile.load(args.profile) if args.profile else PlayerProfile()
    except (ValueError, OSError) as e:  # a missing, broken or wrong profile file
        raise UsageError(str(e) if isinstance(e, ValueError) else f"{args.profile}: {e.strerror or e}") \
            from None
    report = evaluate(profile, args.trials, args.seed, args.gestures,
                      progress=lambda text: print(text, file=sys.stderr, flush=True))
    if args.json:
        print(json.dumps(report))
    else:
        for key, value in report.items():
            print(f"{key:24s} {value}")
    return 0


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, not {text}")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="energyball", description="The EnergyBall game.")
    parser.set_defaults(func=cmd_play)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    p = sub.add_parser("gestures-eval", help="measure gesture recognition on simulated players")
    p.add_argument("--trials", type=_positive, default=20, help="simulated sessions (20)")
    p.add_argument("--gestures", type=_positive, default=10, help="gestures per session (10)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--profile", metavar="FILE.json", help="the simulated player (README lists the keys)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_gestures_eval)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except UsageError as e:
        print(f"energyball: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
