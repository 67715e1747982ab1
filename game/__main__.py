"""``energyball``: the game's command line (also ``python -m game``).

``energyball`` plays (``--keyboard``, ``--virtual``, ``--port P``);
``shots`` renders every screen to PNG, ``bench`` measures frame time and
input latency, ``gestures-eval`` measures gesture recognition on simulated
players through the whole pipeline.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")  # our messages, not pygame's banner
from typing import Sequence


class UsageError(Exception):
    """A command line or input file that cannot be used, worded for the user."""


HEADLESS_HELP = ("energyball: no display found, so the game window cannot open.\n"
                 "  Run it on a desktop, or headless:\n"
                 "    energyball shots --out shots    (every screen to PNG)\n"
                 "    energyball gestures-eval        (gesture accuracy, simulated players)\n"
                 "    energyball bench                (frame time and input latency)")


def _input_choice(args: argparse.Namespace) -> str | None:
    if args.keyboard:
        return "keyboard"
    if args.virtual:
        return "virtual"
    return args.port


def display_available() -> bool:
    """Whether a window can open here (or a video driver was named), checked without pygame."""
    if os.environ.get("SDL_VIDEODRIVER"):
        return True
    if sys.platform.startswith("linux"):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def cmd_play(args: argparse.Namespace) -> int:
    if not display_available():
        print(HEADLESS_HELP, file=sys.stderr)
        return 1
    import pygame
    from .app import App
    try:
        app = App(input_choice=_input_choice(args), seed=args.seed)
    except pygame.error as e:
        raise UsageError(f"cannot open the game window ({e}); for headless use see `energyball shots --help`")
    return app.run()


def cmd_shots(args: argparse.Namespace) -> int:
    from .showcase import shots
    try:
        written = shots(args.out)
    except OSError as e:  # the folder cannot be made or written
        raise UsageError(f"cannot write the screenshots to {args.out}: {e.strerror or e}") from None
    for path in written:
        print(f"wrote {path}", file=sys.stderr)
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from .showcase import bench
    report = bench(progress=lambda text: print(text, file=sys.stderr, flush=True))
    print(json.dumps(report) if args.json else "\n".join(f"{k:26s} {v}" for k, v in report.items()))
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
    parser = argparse.ArgumentParser(prog="energyball", description=(
        "The EnergyBall game: throw energy balls at zombies with your arm (a tracker board, "
        "or keyboard and mouse)."))
    parser.set_defaults(func=cmd_play)
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--keyboard", action="store_true", help="play with keyboard and mouse")
    source.add_argument("--virtual", action="store_true", help="play with a virtual board (simulated arm)")
    source.add_argument("--port", help="the board's serial port or pyserial URL (default: find one)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the zombie waves")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("gestures-eval", help="measure gesture recognition on simulated players")
    p.add_argument("--trials", type=_positive, default=20, help="simulated sessions (20)")
    p.add_argument("--gestures", type=_positive, default=10, help="gestures per session (10)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--profile", metavar="FILE.json", help="the simulated player (README lists the keys)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_gestures_eval)

    p = sub.add_parser("shots", help="render every screen to PNG (dummy video driver)")
    p.add_argument("--out", required=True, metavar="DIR")
    p.set_defaults(func=cmd_shots)

    p = sub.add_parser("bench", help="frame time and input latency")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_bench)
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
