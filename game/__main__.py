"""``energyball``: the game's command line (also ``python -m game``).

``energyball`` plays (``--keyboard``, ``--virtual``, ``--port P``);
``--headless`` plays simulated matches with a bot instead (no window);
``shots`` renders every screen to PNG, ``bench`` measures frame time and
input latency, ``gestures-eval`` measures gesture recognition on simulated
players through the whole pipeline.

Numeric options are range-checked by the parser (the ranges are in
``--help``); a refused command line is one line on stderr and exit 2.
Ctrl-C, SIGTERM and SIGHUP end every command alike (:mod:`tracker.signals`):
exit 128 + the signal's number (130, 143, 129); ``--headless`` first prints
the report of the matches finished by then.
"""

from __future__ import annotations

if __name__ == "__main__":  # run as a program: a signal while it starts up ends it without a traceback
    from tracker import signals as _startup

    _startup.exit_quietly()

import argparse
import json
import os
import signal
import sys
from pathlib import Path

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")  # our messages, not pygame's banner
from typing import Sequence

from tracker import signals  # noqa: E402
from tracker.options import Parser, Ranged  # noqa: E402

# The ranges of numeric options (README, "energyball").
SEED = Ranged(int, 0)
MATCHES = Ranged(int, 1, 10_000)
DURATION = Ranged(float, 0, 86_400, above=True)  # a match of up to a day of play
WORKERS = Ranged(int, 1, 64)
TRIALS = Ranged(int, 1, 10_000)
GESTURES = Ranged(int, 1, 1_000)
DRAWN = Ranged(int, 1, 1_000)
SPEED = Ranged(float, 0.25, 8.0)
FROM = Ranged(float, 0.0, 86_400.0)


def _port(text: str) -> str:
    """``--port``: a name the saved settings can hold (the input choice is remembered)."""
    from game.ui.preferences import Preferences
    try:
        Preferences(input=text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e).replace("input must be", "must be", 1)) from None
    return text


class UsageError(Exception):
    """A command line or input file that cannot be used, worded for the user."""


HEADLESS_HELP = ("energyball: no display found, so the game window cannot open.\n"
                 "  Run it on a desktop, or headless:\n"
                 "    energyball --headless           (simulated matches: a bot plays)\n"
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


HEADLESS_ONLY = ("matches", "duration", "difficulty", "profile", "faults", "workers", "endless", "render", "pty",
                 "record_dir", "json")


SOURCES = ("keyboard", "virtual", "port")  # what the player plays with (the bot wears its own board)


def _given(args: argparse.Namespace, names: Sequence[str]) -> list[str]:
    """The options among ``names`` that the command line set, as the user wrote them."""
    return [f"--{name}" for name in names if getattr(args, name, None) not in (None, False)]


def _check_options(args: argparse.Namespace, command_options: Sequence[str]) -> None:
    """A UsageError for an option that the chosen command would silently ignore."""
    if args.command:
        stray = _given(args, [n for n in ("headless", "record", *SOURCES, *HEADLESS_ONLY) if n not in command_options])
        if stray:
            raise UsageError(f"{', '.join(stray)} do not go with the {args.command} command")
    elif args.headless and args.record:
        raise UsageError("--record keeps a game you play; headless matches are kept with --record-dir")
    elif args.headless and _given(args, SOURCES):
        raise UsageError(f"{', '.join(_given(args, SOURCES))} do not go with --headless: "
                         "the bot wears a simulated board")
    elif not args.headless and _given(args, HEADLESS_ONLY):
        raise UsageError(f"{', '.join(_given(args, HEADLESS_ONLY))} only go with --headless")


def cmd_play(args: argparse.Namespace) -> int:
    if args.headless:
        return cmd_headless(args)
    if not display_available():
        print(HEADLESS_HELP, file=sys.stderr)
        return 1
    from .ui.app import App, WindowError
    from .ui.session_events import keep_session, recorder
    try:
        app = App(input_choice=_input_choice(args), seed=args.seed,
                  session=recorder(_output(args.record)) if args.record else keep_session)
    except WindowError as e:
        raise UsageError(f"cannot open the game window ({e}); for headless use see `energyball shots --help`")
    return app.run()


def _output(path: str) -> Path:
    """A file the command will write, checked before anything starts (a UsageError naming it)."""
    from tracker.atomic import OutputError, check_output
    try:
        return check_output(path)
    except OutputError as e:
        raise UsageError(str(e)) from None


def _folder(path: str | None) -> str | None:
    """A folder the command will write files into, made if need be (a UsageError naming it)."""
    if path is None:
        return None
    try:
        os.makedirs(path, exist_ok=True)
        _output(os.path.join(path, "match-0.ebs"))
    except OSError as e:
        raise UsageError(f"--record-dir {path}: {e.strerror or e}") from None
    return path


def _gesture_settings(path: str | None):
    """The gesture settings in a JSON file (GestureSettings' keys), or a UsageError saying what is wrong."""
    if path is None:
        return None
    from tracker.userjson import read_json
    from .body.gestures import GestureSettings
    try:
        data = read_json(path)
        if not isinstance(data, dict):
            raise ValueError(f"{path}: expected a JSON object of gesture settings")
        return GestureSettings(**data)
    except TypeError as e:  # a key GestureSettings does not have
        raise UsageError(f"--gestures {path}: {e}".replace("__init__() ", "")) from None
    except (ValueError, OSError) as e:
        raise UsageError(f"--gestures {path}: {e.strerror if isinstance(e, OSError) else e}") from None


def cmd_replay(args: argparse.Namespace) -> int:
    from tracker.recording import RecordingError
    from .replay.replay import replay
    from .replay.rescore import Rescorer, plot
    if args.plot:
        _output(args.plot)
    rescoring = args.filter or args.gestures or args.plot  # a re-scoring plays headless
    rescorer = Rescorer(args.filter, _gesture_settings(args.gestures)) if rescoring else None
    if not args.headless and rescorer is None and not display_available():
        raise UsageError("no display found, so the replay cannot be shown: add --headless")
    try:
        if args.headless or rescorer is not None:
            report = replay(args.file, rescorer=rescorer)
        else:
            from .ui.replay_window import watch
            report = watch(args.file, start_s=args.start, speed=args.speed)
    except RecordingError as e:
        raise UsageError(str(e)) from None
    out = report.to_json()
    if rescorer is not None:
        out["rescored"] = rescorer.compare()
        if args.filter and not rescorer.samples:
            raise UsageError(f"{args.file} holds no board samples in play (a keyboard session?): "
                             "--filter has nothing to re-score")
        if args.plot:
            try:
                plot(rescorer, args.plot, f"{Path(args.file).name}: the game against {out['rescored']['filter']}")
            except RuntimeError as e:  # matplotlib missing
                raise UsageError(str(e)) from None
    if args.json:
        print(json.dumps(out))
    else:
        for key in ("frames", "seconds", "summary", "same_as_recorded"):
            print(f"{key:18s} {out[key]}")
        print(f"{'launches':18s} {len(out['launches'])}")
        if "rescored" in out:
            r = out["rescored"]
            print(f"{'rescored':18s} {r['other_launches']} launches: {len(r['appeared'])} appeared, "
                  f"{len(r['disappeared'])} disappeared, {len(r['moved'])} moved")
    if report.difference:
        print(f"energyball: the replay differs from the recording from frame {report.difference.frame} "
              f"({report.difference.t:.2f} s): recorded {report.difference.recorded}, "
              f"replayed {report.difference.replayed}", file=sys.stderr)
    if report.stopped:
        print(f"energyball: {args.file}: {report.stopped}; replayed the complete part", file=sys.stderr)
    return 0 if report.difference is None else 3


def _profile(path: str | None):
    """The simulated player's profile file (defaults when None), or a UsageError saying what is wrong."""
    from .sim.motion_model import PlayerProfile
    try:
        return PlayerProfile.load(path) if path else PlayerProfile()
    except (ValueError, OSError) as e:  # a missing, broken or wrong profile file
        raise UsageError(str(e) if isinstance(e, ValueError) else f"{path}: {e.strerror or e}") from None


def cmd_headless(args: argparse.Namespace) -> int:
    from tracker.board import Faults
    from .sim.headless import configs, run_matches
    try:
        faults = Faults.parse(args.faults or "")
    except ValueError as e:
        raise UsageError(f"--faults: {e}") from None
    jobs = configs(args.seed, args.matches or 1, duration_s=args.duration or 120.0,
                   difficulty=args.difficulty or "normal", profile=_profile(args.profile), faults=faults,
                   endless=args.endless, render=args.render, pty=args.pty, record_dir=_folder(args.record_dir))
    try:
        report = run_matches(jobs, workers=args.workers or 1,
                             progress=lambda text: print(text, file=sys.stderr, flush=True))
    except OSError as e:  # e.g. no pty could be opened
        raise UsageError(f"the match could not run: {e}") from None
    if args.json:
        print(json.dumps(report))
    else:
        for key, value in report["summary"].items():
            print(f"{key:26s} {value}")
    if report["interrupted"]:
        print(f"energyball: {report['interrupted']}: stopped after {len(report['matches'])} of {len(jobs)} "
              "matches; the report covers the finished ones", file=sys.stderr)
        return 128 + signal.Signals[report["interrupted"]].value
    return 0


def cmd_shots(args: argparse.Namespace) -> int:
    from .ui.showcase import shots
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise UsageError(f"--out {args.out} is not a folder: the screenshots go into a folder, one PNG each")
    try:
        written = shots(args.out)
    except OSError as e:  # the folder cannot be made or written
        raise UsageError(f"cannot write the screenshots to {args.out}: {e.strerror or e}") from None
    for path in written:
        print(f"wrote {path}", file=sys.stderr)
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from .ui.showcase import bench
    report = bench(progress=lambda text: print(text, file=sys.stderr, flush=True))
    print(json.dumps(report) if args.json else "\n".join(f"{k:26s} {v}" for k, v in report.items()))
    return 0


ENVELOPE_COLUMNS = (("calibration_ok_rate", "calib ok"), ("launch_precision", "precision"),
                    ("launch_recall", "recall"), ("false_launches_per_min", "false/min"),
                    ("aim_error_deg_median", "aim med"), ("aim_error_deg_p95", "aim p95"),
                    ("aim_error_deg_median_late", "aim late"), ("aim_error_deg_median_late_ci95", "late 95%"),
                    ("latency_ms_median", "lat med"),
                    ("latency_ms_p95", "lat p95"), ("launches", "launches"))


def _cell(value: object) -> str:
    """A report's value as the envelope's table shows it: "-" for none, an interval as its two ends."""
    if value is None:
        return "-"
    return "-".join(map(str, value)) if isinstance(value, (list, tuple)) else str(value)


def envelope_table(players: dict[str, dict]) -> str:
    """The envelope as a plain-text table, one row per player."""
    width = max(len(name) for name in players)
    rows = [f"{'player':{width}s}  " + "  ".join(f"{title:>9s}" for _, title in ENVELOPE_COLUMNS)]
    for name, report in players.items():
        rows.append(f"{name:{width}s}  " + "  ".join(f"{_cell(report[key]):>9}" for key, _ in ENVELOPE_COLUMNS))
    return "\n".join(rows)


def cmd_gestures_eval(args: argparse.Namespace) -> int:
    from .sim.gesture_eval import evaluate, evaluate_envelope
    from .sim.motion_model import catalogue, drawn_players
    progress = lambda text: print(text, file=sys.stderr, flush=True)  # noqa: E731
    given = [name for name, on in (("--envelope", args.envelope), ("--drawn", args.drawn),
                                   ("--profile", getattr(args, "profile", None))) if on]
    if len(given) > 1:
        raise UsageError(f"{' and '.join(given)} each choose the players: give one of them")
    if args.envelope or args.drawn:
        players = drawn_players(args.drawn, args.seed) if args.drawn else catalogue()
        report = evaluate_envelope(players, args.trials, args.seed, args.gestures, progress,
                                   magnetometer=args.dof == 9)
        if args.drawn:  # each drawn player's values, to run one again with --profile
            for name, row in report["players"].items():
                row["profile"] = players[name].to_json()
        print(json.dumps(report) if args.json else envelope_table(report["players"]))
        return 0
    report = evaluate(_profile(args.profile), args.trials, args.seed, args.gestures, progress,
                      magnetometer=args.dof == 9)
    if args.json:
        print(json.dumps(report))
    else:
        width = max(len(key) for key in report)
        for key, value in report.items():
            print(f"{key:{width}s} {value}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from tracker.fusion import FILTERS

    from .sim.bot import DIFFICULTIES

    parser = Parser(prog="energyball", description=(
        "The EnergyBall game: throw energy balls at zombies with your arm (a tracker board, "
        "or keyboard and mouse)."))
    parser.set_defaults(func=cmd_play)
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--keyboard", action="store_true", help="play with keyboard and mouse")
    source.add_argument("--virtual", action="store_true", help="play with a virtual board (simulated arm)")
    source.add_argument("--port", type=_port, help="the board's serial port or pyserial URL (default: find one)")
    parser.add_argument("--seed", type=SEED, default=0,
                        help=f"seed of the zombie waves (and of the first match), {SEED.text} (0)")
    parser.add_argument("--record", metavar="FILE",
                        help="keep the session in FILE (energyball replay FILE plays it again)")
    h = parser.add_argument_group("headless matches (a simulated player, no window)")
    h.add_argument("--headless", action="store_true", help="play simulated matches with a bot")
    h.add_argument("--matches", type=MATCHES, help=f"how many matches, seeds S, S+1, ..., {MATCHES.text} (1)")
    h.add_argument("--duration", type=DURATION, metavar="SEC",
                   help=f"play time of a match at most, seconds, {DURATION.text} (120)")
    h.add_argument("--difficulty", choices=tuple(DIFFICULTIES), help="the bot's skill (normal)")
    h.add_argument("--profile", metavar="FILE.json", help="the simulated player (README lists the keys)")
    h.add_argument("--faults", metavar="SPEC", help="link faults, e.g. corrupt=0.01,drop=0.002,stall=0.5@20")
    h.add_argument("--workers", type=WORKERS, help=f"processes to spread the matches over, {WORKERS.text} (1)")
    h.add_argument("--endless", action="store_true",
                   help="zombies do no harm, so a match lasts its whole duration (soak runs)")
    h.add_argument("--render", action="store_true", help="draw every frame (dummy video driver)")
    h.add_argument("--pty", action="store_true", help="send the board's bytes through a real pty and pyserial")
    h.add_argument("--record-dir", metavar="DIR", help="keep a session recording of every match in DIR "
                   "(match-SEED.ebs: energyball replay plays it again)")
    h.add_argument("--json", action="store_true", help="print the report as JSON")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("gestures-eval", help="measure gesture recognition on simulated players")
    p.add_argument("--trials", type=TRIALS, default=20, help=f"simulated sessions, {TRIALS.text} (20)")
    p.add_argument("--gestures", type=GESTURES, default=10, help=f"gestures per session, {GESTURES.text} (10)")
    # Given before or after the command alike: no default here to overwrite the main one.
    p.add_argument("--seed", type=SEED, default=argparse.SUPPRESS, help=f"{SEED.text} (0)")
    p.add_argument("--profile", metavar="FILE.json", default=argparse.SUPPRESS,
                   help="the simulated player (README lists the keys)")
    p.add_argument("--envelope", action="store_true",
                   help="run every player of the catalogue (game/profiles), one row each")
    p.add_argument("--drawn", type=DRAWN, default=0, metavar="N",
                   help=f"run N players drawn uniformly within the ranges (README), one row each, {DRAWN.text}")
    p.add_argument("--dof", type=int, choices=(6, 9), default=9,
                   help="9: fuse the magnetometer, as the game does (9); 6: without it")
    p.add_argument("--json", action="store_true", default=argparse.SUPPRESS)
    p.set_defaults(func=cmd_gestures_eval, options=("profile", "json"))

    p = sub.add_parser("replay", help="play a session recording again (--record) and compare")
    p.add_argument("file", metavar="FILE", help="a session recording (--record, --record-dir, or a kept session)")
    p.add_argument("--headless", action="store_true", help="no window: play it through and report")
    p.add_argument("--speed", type=SPEED, default=1.0, help=f"in the window, times the recorded pace, {SPEED.text} (1)")
    p.add_argument("--from", dest="start", type=FROM, default=0.0, metavar="T",
                   help=f"in the window, start showing at T seconds of play, {FROM.text} (0)")
    p.add_argument("--json", action="store_true", default=argparse.SUPPRESS,
                   help="the session's summary, its launches and every event, as JSON")
    p.add_argument("--filter", choices=FILTERS, help="re-score: the recorded samples through this filter")
    p.add_argument("--gestures", metavar="SETTINGS.json", help="re-score: with these gesture settings")
    p.add_argument("--plot", metavar="PNG", help="re-score: the elbow, elevation and state over time, launches marked")
    p.set_defaults(func=cmd_replay, options=("json", "headless", "speed", "start", "filter", "gestures", "plot"))

    p = sub.add_parser("shots", help="render every screen to PNG (dummy video driver)")
    p.add_argument("--out", required=True, metavar="DIR")
    p.set_defaults(func=cmd_shots)

    p = sub.add_parser("bench", help="frame time and input latency")
    p.add_argument("--json", action="store_true", default=argparse.SUPPRESS)
    p.set_defaults(func=cmd_bench, options=("json",))
    return parser


def run(args: argparse.Namespace) -> int:
    """Run the parsed command; a command line or file that cannot be used is one line on stderr, exit 1."""
    try:
        _check_options(args, getattr(args, "options", ()))
        return args.func(args)
    except UsageError as e:
        print(f"energyball: {e}", file=sys.stderr)
        return 1


def main(argv: Sequence[str] | None = None) -> int:
    """The command line ``argv`` (None: this process's own, which then ends with the command)."""
    args = build_parser().parse_args(argv)
    try:  # outside the handlers' block: a signal while they are being installed is caught too
        with signals.interrupts(ignore_after=argv is None):
            return run(args)
    except KeyboardInterrupt as e:  # Ctrl-C, SIGTERM or SIGHUP
        return signals.exit_status(e)


if __name__ == "__main__":
    sys.exit(main())
