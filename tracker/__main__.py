"""``armtracker``: the tracker's command line (also ``python -m tracker``).

Every command that reports numbers prints them as JSON with ``--json``; every
failure a user can cause is one line on stderr and a non-zero exit (2 for a
command line the parser refuses, 1 for anything else). Output paths are
checked before the work starts (:func:`tracker.atomic.check_output`) and
written atomically. Ctrl-C, SIGTERM and SIGHUP end every command alike
(:mod:`tracker.signals`): ``record``, ``monitor``, ``replay`` and ``virtual``
end normally (exit 0, the recording kept); the others exit 128 + the signal's
number (130, 143, 129) leaving any previous output file as it was.
"""

from __future__ import annotations

if __name__ == "__main__":  # run as a program: a signal while it starts up ends it without a traceback
    from . import signals as _startup

    _startup.exit_quietly()

import argparse
import contextlib
import json
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterable, Iterator, Sequence

from . import bench, protocol as P, signals
from .atomic import OutputError, check_output, discard_pending, same_output
from .calibration import BoardCalibration, CalibrationFileError, Corrected, load_for_hello
from .evaluate import DatasetError
from .link import Link, LinkError, LinkSettings, find_boards, list_serial_ports
from .options import Parser, Ranged
from .recording import CsvRecorder, RawRecorder, RecordingError, Replay, summarize

if TYPE_CHECKING:
    from .board import VirtualBoard
    from .motion import MotionSource

EXIT_ERROR = 1
STATUS_INTERVAL_S = 0.25

# The ranges of numeric options (README, "armtracker").
RATE = Ranged(int, P.MIN_RATE_HZ, P.MAX_RATE_HZ)  # PROTOCOL.md sec. 6, SET_RATE
BAUD = Ranged(int, 300, 2_000_000)  # the Metro Mini's CP2104 bridge: 300 bps to 2 Mbps (CP2104 data sheet sec. 6.1)
SECONDS = Ranged(float, 0, above=True)
SPEED = Ranged(float, 0.01, 1000)  # 100 times slower to 1000 times faster; --fast for no pacing at all
PROBABILITY = Ranged(float, 0, 1)
SEED = Ranged(int, 0)
# The simulated board's errors for `calibrate --virtual`: a player profile's ranges (tracker.sim.MagneticErrors,
# ErrorModel: 0-200 uT of hard iron, 0-20 % of soft iron, 0-40 uT of room disturbance, noise up to 20 times
# the data sheet's).
HARD_IRON = Ranged(float, 0, 200)
SOFT_IRON = Ranged(float, 0, 20)
ROOM = Ranged(float, 0, 40)
NOISE_SCALE = Ranged(float, 0, 20)
BOARDS = Ranged(int, 1, 100)  # simulated boards of each kind for calibrate simulated
POWERED_FOR = Ranged(float, 0)  # seconds the virtual board had been on (its die warming) before the procedure


class UsageError(Exception):
    """A command line that asks for something impossible."""


# ----------------------------------------------------------------- sources


def add_source_options(p: argparse.ArgumentParser, modes: bool = True) -> None:
    """The options every command that reads a board takes (``--mode`` only where fused samples serve)."""
    src = p.add_mutually_exclusive_group()
    src.add_argument("--port", help="serial port or pyserial URL (default: the first board found)")
    src.add_argument("--virtual", action="store_true", help="use a virtual board on a pty")
    p.add_argument("--baud", type=BAUD, help=f"baud rate, {BAUD.text} (default: 500000, falling back to 9600; "
                   "115200 for EnergyBall firmware built before 500000 became its rate)")
    p.add_argument("--rate", type=RATE, help=f"samples per second to ask for, {RATE.text} (default "
                   f"{P.default_rate_hz(P.Mode.RAW)} raw, {P.default_rate_hz(P.Mode.FUSED)} fused; the "
                   f"board takes at most {P.BOARD_MAX_RATE_HZ[P.Mode.RAW]} and "
                   f"{P.BOARD_MAX_RATE_HZ[P.Mode.FUSED]})")
    if modes:
        p.add_argument("--mode", choices=["raw", "fused"], default="raw",
                       help="raw sensor counts, or the board's own fused orientation")


@contextlib.contextmanager
def open_source(args: argparse.Namespace, tap: Callable[[bytes], None] | None = None,
                motion: MotionSource | None = None) -> Iterator[tuple[Link, VirtualBoard | None]]:
    """Open the board the options name (a virtual one for ``--virtual``, moved by ``motion``, default
    the simulated arm); ``tap`` sees every byte read. Yields the link and the virtual board, if any."""
    mode = P.Mode[getattr(args, "mode", "raw").upper()]
    rate = args.rate if args.rate is not None else P.default_rate_hz(mode)
    if (why := P.board_rate_error(rate, mode)) is not None:
        raise UsageError(f"--rate {why}")
    with contextlib.ExitStack() as stack:
        board = None
        if args.virtual:
            from .board import VirtualBoard  # POSIX only: imported when asked for
            board = stack.enter_context(VirtualBoard(motion=motion))
            port = board.port
        elif args.port:
            port = args.port
        else:
            port = _autodetect()
        settings = LinkSettings(port, baud=args.baud, rate_hz=rate, mode=mode)
        link = Link(settings)
        link.tap = tap
        stack.callback(link.close)  # before open: an interruption mid-handshake still stops its reader
        link.open()
        yield link, board


def _autodetect() -> str:
    boards = find_boards()
    if not boards:
        raise LinkError("no board found: plug one in, name it with --port, "
                        "or try --virtual (`armtracker ports` lists serial ports)")
    if len(boards) > 1:
        print(f"several boards found; using {boards[0].device} (choose with --port)", file=sys.stderr)
    return boards[0].device


# ----------------------------------------------------------------- formatting


def sample_json(s: P.RawSample | P.FusedSample | None) -> dict | None:
    """A sample as the JSON other tools rely on (SI units, ``t`` in seconds)."""
    if s is None:
        return None
    if isinstance(s, P.RawSample):
        return {"t": s.t, "seq": s.seq, "acc": list(s.acc), "gyr": list(s.gyr),
                "mag": list(s.mag) if s.mag is not None else None, "flex_adc": s.flex_adc}
    return {"t": s.t, "seq": s.seq, "q": list(s.q), "flex_deg": s.flex_deg}


def corrected_json(c: Corrected | None) -> dict | None:
    """A calibrated sample's readings as JSON (SI units)."""
    if c is None:
        return None
    return {"acc": list(c.acc), "gyr": list(c.gyr), "mag": list(c.mag) if c.mag is not None else None}


def _vec(v: Iterable[float] | None) -> str:
    return "(" + " ".join(f"{x:6.2f}" for x in v) + ")" if v is not None else "(none)"


def sample_text(s: P.RawSample | P.FusedSample | None, corrected: Corrected | None = None) -> str:
    """A sample in one line; a raw one's readings as ``corrected`` by the board's calibration if given."""
    if s is None:
        return "no sample yet"
    if isinstance(s, P.RawSample):
        acc, gyr, mag = corrected if corrected is not None else (s.acc, s.gyr, s.mag)
        return f"acc {_vec(acc)} m/s2  gyr {_vec(gyr)} rad/s  mag {_vec(mag)} uT  flex {s.flex_adc:4d}"
    return f"q {_vec(s.q)}  flex {s.flex_deg:6.1f} deg"


class StatusLine:
    """A live status line on stderr when it is a terminal, a line a second otherwise."""

    def __init__(self) -> None:
        self.tty = sys.stderr.isatty()
        self._next = 0.0

    def show(self, text: str) -> None:
        now = time.monotonic()
        if now < self._next:
            return
        self._next = now + (STATUS_INTERVAL_S if self.tty else 1.0)
        if self.tty:
            print("\r\x1b[K" + text, end="", file=sys.stderr, flush=True)
        else:
            print(text, file=sys.stderr, flush=True)

    def say(self, text: str) -> None:
        """A line of its own, above the live line."""
        print(("\r\x1b[K" if self.tty else "") + text, file=sys.stderr, flush=True)
        self._next = 0.0

    def done(self) -> None:
        if self.tty:
            print(file=sys.stderr)


def _health_text(link: Link) -> str:
    h = link.health()
    return (f"{h.rate_hz:6.1f} Hz  loss {100 * h.loss:5.2f}%  crc {h.crc_errors}  "
            f"{'' if h.connected else '[' + h.status + ']  '}")


def _until(seconds: float | None) -> float:
    return time.monotonic() + seconds if seconds else float("inf")


# ----------------------------------------------------------------- commands


def cmd_ports(args: argparse.Namespace) -> int:
    ports = list_serial_ports()
    if args.json:
        print(json.dumps([{"device": p.device, "description": p.description, "vid": p.vid,
                           "pid": p.pid, "board": p.chip} for p in ports]))
    elif not ports:
        print("no serial ports found (plug a board in; or use --virtual)")
    else:
        for p in ports:
            print(p)
    return 0


class MonitorFusion:
    """The default filter run on the raw samples a monitor shows, calibrated as the board's file
    says, to say what it makes of the magnetometer (:attr:`DefaultFilter.status`); fused samples
    are the board's own estimate."""

    MAX_GAP_S = 0.5  # a longer gap between samples (link loss) keeps the last good time step

    def __init__(self) -> None:
        from .fusion.default import for_mpu9250
        self.filter = for_mpu9250(P.BOOT_RATE_HZ)
        self._last_t: float | None = None
        self._dt = 0.005

    def feed(self, s: P.RawSample | P.FusedSample, corrected: Corrected | None = None) -> None:
        """One sample (fused ones are ignored); a raw one's readings ``corrected`` by the board's
        calibration if given."""
        if not isinstance(s, P.RawSample):
            return
        if self._last_t is not None and 0.0 < s.t - self._last_t < self.MAX_GAP_S:
            self._dt = s.t - self._last_t
        self._last_t = s.t
        acc, gyr, mag = corrected if corrected is not None else (s.acc, s.gyr, s.mag)
        self.filter.update(gyr, acc, mag, self._dt)

    @property
    def status(self) -> str:
        """"magnetometer on", "magnetometer off: <why>", "no magnetometer"; "" before any raw sample."""
        return self.filter.status if self._last_t is not None else ""


def _calibration_json(cal: BoardCalibration, notice: str, hello: P.Hello | None) -> dict:
    """What monitor reports of the calibration it applies."""
    return {"board_id": cal.board_id if hello else None, "notice": notice,
            "procedures": {r.name: r.to_json() for r in cal.procedures}}


def cmd_monitor(args: argparse.Namespace) -> int:
    status = StatusLine()
    last: P.RawSample | P.FusedSample | None = None
    corrected: Corrected | None = None
    fusion = MonitorFusion()
    reported = P.BoardError.NONE  # every error bit the board's HELLOs carried
    with open_source(args) as (link, _):
        cal, notice = load_for_hello(link.hello, virtual=args.virtual)  # raw samples shown and fused calibrated
        if args.mode == "fused":
            notice += "; it applies to raw samples only (the board fuses its own readings)"
        print(notice, file=sys.stderr, flush=True)
        end = _until(args.seconds)
        try:
            while time.monotonic() < end:
                for s in link.drain():
                    last = s
                    if isinstance(s, P.RawSample):
                        corrected = cal.apply(s)
                        fusion.feed(s, corrected)
                errors = link.hello.errors if link.hello else P.BoardError.NONE
                for line in P.board_error_lines(errors & ~reported):
                    status.say(line)
                reported |= errors
                shown = corrected if isinstance(last, P.RawSample) else None
                status.show(_health_text(link) + sample_text(last, shown)
                            + (f"  {fusion.status}" if fusion.status else ""))
                time.sleep(0.02)
        except KeyboardInterrupt:
            pass
        status.done()
        h, stats = link.health(), link.stats()
        elapsed = args.seconds if args.seconds else None
        report = {"frames": stats.frames, "rate_hz": h.rate_hz, "crc_errors": stats.crc_errors,
                  "dropped": stats.dropped, "bytes_skipped": stats.bytes_skipped,
                  "hello": link.hello.to_json() if link.hello else None, "last": sample_json(last),
                  "last_calibrated": corrected_json(corrected) if isinstance(last, P.RawSample) else None,
                  "calibration": _calibration_json(cal, notice, link.hello),
                  "link": h.to_json(), "seconds": elapsed, "magnetometer": fusion.status or None,
                  "board_errors": [bit.name for bit in P.BOARD_ERROR_ADVICE if bit in reported]}
    if args.json:
        print(json.dumps(report))
    else:
        print(f"{report['frames']} frames, {h.rate_hz:.1f} Hz, {stats.dropped} dropped, "
              f"{stats.crc_errors} CRC errors, {stats.bytes_skipped} bytes skipped"
              + (f"; {fusion.status}" if fusion.status else "")
              + (f"; the board reported {', '.join(report['board_errors'])}" if reported else ""))
    return 0


def _record_outputs(args: argparse.Namespace) -> None:
    """Check --raw and --csv before anything is opened (a UsageError or OutputError naming the path)."""
    check_output(args.raw)
    if args.csv:
        check_output(args.csv)
        if same_output(args.raw, args.csv):
            raise UsageError(f"--raw {args.raw} and --csv {args.csv} name the same file: give two files")


def _keep(samples: list[P.RawSample | P.FusedSample], table: CsvRecorder | None) -> int:
    """Write ``samples`` to the table, if any; how many there were."""
    if table:
        for s in samples:
            table.write(s)
    return len(samples)


def cmd_record(args: argparse.Namespace) -> int:
    _record_outputs(args)
    status = StatusLine()
    raw = RawRecorder(args.raw)
    table: CsvRecorder | None = None
    with contextlib.ExitStack() as ending:
        with open_source(args, tap=raw.write) as (link, _):
            legacy = link.health().legacy_text
            header = {"created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "port": link.settings.port,
                      "legacy_text": legacy, "text_order": link.settings.text_order,
                      "hello": link.hello.to_json() if link.hello else None}
            # The stream describes itself: the board's hello goes first.
            raw.begin(header, P.encode_hello(link.hello) if link.hello and not legacy else b"")
            table = CsvRecorder(args.csv, link.hello) if args.csv else None
            end = _until(args.seconds)
            samples = 0
            try:
                try:
                    while time.monotonic() < end:
                        samples += _keep(link.drain(), table)
                        status.show(f"recording {args.raw}: {raw.bytes} bytes  " + _health_text(link))
                        time.sleep(0.05)
                finally:  # what was recorded is complete: from here a signal waits until it is kept
                    ending.enter_context(signals.deferred())
            except KeyboardInterrupt as stop:
                interrupted: KeyboardInterrupt | None = stop  # the usual way to end a recording
            else:
                interrupted = None
            link.tap = None
        status.done()
        samples += _keep(link.drain(), table)
        if interrupted and not samples:  # stopped before the first sample: nothing to keep, nothing replaced
            print(f"stopped before the first sample: nothing recorded, {args.raw} left as it was", file=sys.stderr)
            raise interrupted
        raw.close()
        if table:
            table.close()
        rows = f", {table.rows} samples to {args.csv}" if table else ""
        print(f"recorded {raw.bytes} bytes to {args.raw}{rows}", file=sys.stderr)
    return 0


def cmd_decode(args: argparse.Namespace) -> int:
    summary = summarize(args.input)
    print(json.dumps(summary.to_json()) if args.json else summary.text())
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    replay = Replay(Path(args.input), realtime=not args.fast, speed=args.speed)
    status = StatusLine()
    n, last = 0, None
    try:
        for s in replay:
            n, last = n + 1, s
            status.show(f"{n:7d} samples  t {s.t:8.3f} s  " + sample_text(s))
    except KeyboardInterrupt:
        pass
    status.done()
    if n == 0:
        raise RecordingError(f"{args.input} is not an EnergyBall recording: no samples found in it")
    st = replay.stats
    report = {"samples": n, "crc_errors": st.crc_errors, "dropped": st.dropped,
              "bytes_skipped": st.bytes_skipped, "board_restarts": len(replay.runs) - 1,
              "last": sample_json(last)}
    print(json.dumps(report) if args.json else f"replayed {n} samples from {args.input}")
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    result = bench.run_all()
    if args.json:
        print(json.dumps(result))
    else:
        for k, v in result.items():
            print(f"{k:32s} {v}")
    return 0


def cmd_evaluate(args: argparse.Namespace) -> int:
    from .evaluate import (check_readme, evaluate, filter_names, find_trials, markdown_table,
                           result_line, uses_magnetometer, write_readme_table)
    if args.readme:  # said at once, not after the whole evaluation
        check_output(args.readme)
        check_readme(args.readme)
    paths = find_trials(args.dataset)
    names = filter_names(args.filter)
    dofs = [args.dof] if args.dof else [6, 9]
    total = len(paths) * sum(1 for d in dofs for n in names if d == 6 or uses_magnetometer(n))
    if total == 0:
        raise UsageError(f"{args.filter} ignores the magnetometer by design: evaluate it with --dof 6")
    results = []
    for r in evaluate(paths, names, dofs):
        results.append(r)
        print(f"[{len(results)}/{total}] {result_line(r)}", file=sys.stderr)
    if args.readme:
        write_readme_table(args.readme, results)
        print(f"updated the results table in {args.readme}", file=sys.stderr)
    print(json.dumps({"results": results}) if args.json else markdown_table(results))
    return 0


def cmd_fuse(args: argparse.Namespace) -> int:
    from .fuse import fuse_file
    check_output(args.out)
    n = fuse_file(args.input, args.filter, args.dof, args.out)
    print(f"wrote {n} orientations to {args.out}", file=sys.stderr)
    return 0


def cmd_experiment(args: argparse.Namespace) -> int:
    from . import experiments
    run, plot = {"static-drift": (experiments.static_drift, experiments.plot_static_drift),
                 "finger-grasp": (experiments.finger_grasp, experiments.plot_finger_grasp)}[args.name]
    if args.plot:
        check_output(args.plot)
    result = run(progress=lambda text: print(text, file=sys.stderr, flush=True))
    if args.plot:
        try:
            plot(result, args.plot)
        except RuntimeError as e:  # matplotlib missing
            raise UsageError(str(e)) from None
        print(f"wrote {args.plot}", file=sys.stderr)
    print(json.dumps(result) if args.json else json.dumps(result, indent=1))
    return 0


def cmd_virtual(args: argparse.Namespace) -> int:
    from .board import BoardSettings, Faults, VirtualBoard
    settings = BoardSettings(rate_hz=args.rate, legacy_text=args.legacy)
    faults = Faults(corrupt_rate=args.corrupt, drop_rate=args.drop, seed=args.seed)
    link = Path(args.link) if args.link else None
    if link and link.exists() and not link.is_symlink():
        raise UsageError(f"{link} exists and is not a symlink; choose another --link path")
    if link and not link.parent.is_dir():
        raise UsageError(f"--link {link}: the folder {link.parent} does not exist")
    with VirtualBoard(settings=settings, faults=faults, link=link) as board:
        try:
            print(f"virtual board on {board.port} (Ctrl-C to stop)", file=sys.stderr, flush=True)
            _wait(args.seconds)
        except KeyboardInterrupt:
            pass
        counters = vars(board.counters).copy()
    if args.json:
        print(json.dumps(counters))
    return 0


def unplug_spec(text: str) -> tuple[float, float]:
    """``--unplug SECONDS@AT``: the virtual cable pulled AT seconds into the procedure, for SECONDS."""
    seconds, sep, at = text.partition("@")
    try:
        value = (SECONDS(at), SECONDS(seconds)) if sep else None
    except argparse.ArgumentTypeError:
        value = None
    if value is None:
        raise argparse.ArgumentTypeError(f"must be SECONDS@AT with two numbers above 0 (e.g. 1.5@6), "
                                         f"not {text[:40]!r}")
    return value


_SIMULATED = ("unplug", "seed", "hard_iron", "soft_iron", "room", "noise_scale", "magnet", "nudge", "repeat_face",
              "powered_for")


def seconds_list(text: str) -> tuple[float, ...]:
    """``AT[,AT...]``: times in seconds, each above 0."""
    try:
        return tuple(SECONDS(part) for part in text.split(","))
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"must be seconds above 0, separated by commas (e.g. 1.5,12), "
                                         f"not {text[:40]!r}") from None


def cmd_calibrate(args: argparse.Namespace) -> int:
    from . import calibrate_cli as K
    if args.procedure == "show":
        text, problems = K.show(args.json)
        if text:
            print(text)
        for problem in problems:
            print(f"armtracker: {problem}", file=sys.stderr)
        return EXIT_ERROR if problems else 0
    given = [name for name in _SIMULATED if getattr(args, name) not in (None, False)]
    if given and not args.virtual:
        raise UsageError(f"--{given[0].replace('_', '-')} describes the simulated board and maker: "
                         "it needs --virtual")
    maker = K.VirtualMaker(args.seed or 0, 1.0 if args.noise_scale is None else args.noise_scale,
                           args.hard_iron, args.soft_iron, args.room, args.magnet, args.nudge or (),
                           args.repeat_face, args.powered_for or 0.0).maker() if args.virtual else None
    term = K.Terminal()
    with open_source(args, motion=maker) as (link, board):
        with contextlib.ExitStack() as faults:
            if board is not None and args.unplug:
                faults.enter_context(K.unplugging(board, *args.unplug))
            try:
                report = K.calibrate(args.procedure, link, term, args.seconds, maker)
            except K.CalibrationRefused as e:
                term.done()
                print(f"armtracker: calibrate {args.procedure}: {e}", file=sys.stderr)
                return EXIT_ERROR
            except KeyboardInterrupt:
                term.say(f"calibrate {args.procedure}: interrupted; nothing was saved")
                raise
    print(json.dumps(report.values) if args.json else "\n".join(report.lines))
    return 0


def cmd_calibrate_simulated(args: argparse.Namespace) -> int:
    """``calibrate simulated``: the errors the procedures leave on simulated boards, the worst over
    ``--seeds`` boards of each kind (:func:`tracker.maker_sim.recovered_errors`); 1 if a procedure failed on one."""
    from .maker_sim import recovered_errors
    report = recovered_errors(args.seeds)
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        for name in ("typical", "extreme"):
            print(f"{name}: " + ", ".join(f"{k} {v}" for k, v in report[name].items() if k != "failures"))
            for failure in report[name]["failures"]:
                print(f"  {failure}")
    return EXIT_ERROR if report["typical"]["failures"] or report["extreme"]["failures"] else 0


def _wait(seconds: float | None) -> None:
    """Sleep ``seconds``, or until interrupted when None."""
    end = _until(seconds)
    while time.monotonic() < end:
        time.sleep(min(1.0, end - time.monotonic()))


# ----------------------------------------------------------------- parser


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="armtracker", description=(
        "Read an EnergyBall sensor board (Metro Mini + MPU-9250 + flex sensor) over serial."))
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("ports", help="list serial ports, boards first")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_ports)

    p = sub.add_parser("monitor", help="show the live stream: rate, loss, readings")
    add_source_options(p)
    p.add_argument("--seconds", type=SECONDS, help=f"stop after this long, {SECONDS.text} (default: Ctrl-C)")
    p.add_argument("--json", action="store_true", help="print a JSON summary at the end")
    p.set_defaults(func=cmd_monitor)

    p = sub.add_parser("record", help="record the raw byte stream (and decoded samples)")
    add_source_options(p)
    p.add_argument("--seconds", type=SECONDS, required=True,
                   help=f"how long to record, {SECONDS.text} (Ctrl-C ends it sooner, keeping what was recorded)")
    p.add_argument("--raw", required=True, metavar="OUT.bin", help="raw byte stream")
    p.add_argument("--csv", metavar="OUT.csv", help="decoded samples, one row each")
    p.set_defaults(func=cmd_record)

    p = sub.add_parser("decode", help="decode a recording and count what is in it")
    p.add_argument("input", metavar="IN")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_decode)

    p = sub.add_parser("replay", help="replay a .bin or .csv recording through the decoder")
    p.add_argument("input", metavar="IN")
    p.add_argument("--fast", action="store_true", help="as fast as possible, not in real time")
    p.add_argument("--speed", type=SPEED, default=1.0, help=f"real-time speed factor, {SPEED.text} (1.0)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_replay)

    p = sub.add_parser("bench", help="measure the decoder's throughput")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_bench)

    p = sub.add_parser("evaluate", help="score fusion filters on ground-truth trials (BROAD metric)")
    p.add_argument("--dataset", required=True, metavar="DIR", help="folder of BROAD-format .npz trials")
    p.add_argument("--filter", default="all", help="a filter name, a peer (vqf, imufusion) or all")
    p.add_argument("--dof", type=int, choices=[6, 9], help="6 (no magnetometer) or 9 (default: both)")
    p.add_argument("--json", action="store_true")
    p.add_argument("--readme", metavar="README.md", help="also rewrite the results table in this file")
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser("fuse", help="run a filter over a recording or trial file")
    p.add_argument("input", metavar="IN", help=".bin or .csv recording, a game session (.ebs), or a .npz trial")
    p.add_argument("--filter", default="default")
    p.add_argument("--dof", type=int, choices=[6, 9], default=6)
    p.add_argument("--out", required=True, metavar="OUT.npz")
    p.set_defaults(func=cmd_fuse)

    p = sub.add_parser("experiment", help="reproduce a paper's experiment in simulation")
    p.add_argument("name", choices=["static-drift", "finger-grasp"],
                   help="static-drift: the IMU and infrared hand-tracking paper, sec. 4.1; finger-grasp: "
                        "Inertial Sensor Based Solution for Finger Motion Tracking (Computers 9(2):40, 2020), sec. 3")
    p.add_argument("--plot", metavar="PNG", help="also draw the result (needs the plot extra)")
    p.add_argument("--json", action="store_true", help="one line of JSON")
    p.set_defaults(func=cmd_experiment)

    p = sub.add_parser("calibrate", help="the maker's calibrations of a board: accel, mag, thermal; "
                                         "show what is saved")
    steps = p.add_subparsers(dest="procedure", required=True, metavar="PROCEDURE")
    for name, text, limit in (("accel", "six poses: each face of the board up in turn", "give up (saving nothing) "
                               "after this long"),
                              ("mag", "turn the board through all orientations", "give up (saving nothing) after "
                               "this long"),
                              ("thermal", "the gyroscope's bias as the board warms: leave it still from cold",
                               "watch the board warm this long")):
        q = steps.add_parser(name, help=text)
        add_source_options(q, modes=False)
        default = {"accel": "600", "mag": "180", "thermal": "600"}[name]
        q.add_argument("--seconds", type=SECONDS, help=f"{limit}, {SECONDS.text} ({default})")
        q.add_argument("--json", action="store_true", help="print the result as JSON")
        v = q.add_argument_group("the simulated board and maker (with --virtual)")
        v.add_argument("--seed", type=SEED, help=f"seed of its errors and the maker's hands, {SEED.text} (0)")
        v.add_argument("--hard-iron", type=HARD_IRON, metavar="UT", help=f"hard iron, uT, {HARD_IRON.text} (30)")
        v.add_argument("--soft-iron", type=SOFT_IRON, metavar="PCT", help=f"soft iron, %%, {SOFT_IRON.text} (5)")
        v.add_argument("--room", type=ROOM, metavar="UT", help=f"the room's field disturbance, uT, {ROOM.text} (5)")
        v.add_argument("--noise-scale", type=NOISE_SCALE, help=f"times the data sheet's noise, {NOISE_SCALE.text} (1)")
        v.add_argument("--unplug", type=unplug_spec, metavar="SECONDS@AT",
                       help="pull the virtual cable AT seconds into the procedure for SECONDS")
        v.add_argument("--magnet", type=SECONDS, metavar="AT",
                       help="the maker brings a magnet near the board AT seconds in (for 10 s)")
        v.add_argument("--nudge", type=seconds_list, metavar="AT[,AT...]",
                       help="the maker bumps the board AT seconds in (each time given)")
        v.add_argument("--repeat-face", action="store_true",
                       help="the maker lays the first face down twice before obeying")
        v.add_argument("--powered-for", type=POWERED_FOR, metavar="SECONDS",
                       help=f"the board had been on this long before, {POWERED_FOR.text} (0: just plugged in, "
                            "its die warming for minutes)")
        q.set_defaults(func=cmd_calibrate)
    q = steps.add_parser("simulated", help="the procedures on simulated boards, typical and extreme: the errors "
                                           "they leave, worst over the boards (saves nothing)")
    q.add_argument("--seeds", type=BOARDS, default=4, help=f"boards of each kind, {BOARDS.text} (4)")
    q.add_argument("--json", action="store_true", help="print JSON")
    q.set_defaults(func=cmd_calibrate_simulated)
    q = steps.add_parser("show", help="what is saved, for which board, and when")
    q.add_argument("--json", action="store_true")
    q.set_defaults(func=cmd_calibrate)

    p = sub.add_parser("virtual", help="serve a virtual board on a pty for other programs")
    p.add_argument("--link", help="stable path to create for the pty (a symlink)")
    p.add_argument("--rate", type=RATE, default=200, help=f"samples per second, {RATE.text} (200)")
    p.add_argument("--legacy", action="store_true", help="act like the paper's sketch (text, 9600 baud)")
    p.add_argument("--corrupt", type=PROBABILITY, default=0.0,
                   help=f"per-byte corruption rate, {PROBABILITY.text} (0)")
    p.add_argument("--drop", type=PROBABILITY, default=0.0, help=f"per-byte drop rate, {PROBABILITY.text} (0)")
    p.add_argument("--seed", type=SEED, default=0, help=f"seed of the faults, {SEED.text} (0)")
    p.add_argument("--seconds", type=SECONDS, help=f"stop after this long, {SECONDS.text} (default: Ctrl-C)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_virtual)
    return parser


def run(args: argparse.Namespace) -> int:
    """Run the parsed command; a failure the user can cause is one line on stderr and exit 1."""
    try:
        return args.func(args)
    except (LinkError, RecordingError, DatasetError, UsageError, OutputError, CalibrationFileError) as e:
        print(f"armtracker: {e}", file=sys.stderr)
    except OSError as e:  # e.g. an input file that cannot be read
        print(f"armtracker: {e.filename + ': ' if e.filename else ''}{e.strerror or e}", file=sys.stderr)
    return EXIT_ERROR


def main(argv: Sequence[str] | None = None) -> int:
    """The command line ``argv`` (None: this process's own, which then ends with the command)."""
    args = build_parser().parse_args(argv)
    try:  # outside the handlers' block: a signal while they are being installed is caught too
        with signals.interrupts(ignore_after=argv is None):
            try:
                return run(args)
            finally:
                discard_pending()  # a file never completed leaves no temporary behind
    except KeyboardInterrupt as e:  # Ctrl-C, SIGTERM or SIGHUP where ending early is not normal
        return signals.exit_status(e)


if __name__ == "__main__":
    sys.exit(main())
