"""``armtracker``: the tracker's command line (also ``python -m tracker``).

Every command that reports numbers prints them as JSON with ``--json``; every
failure a user can cause is one line on stderr and a non-zero exit.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time
from pathlib import Path
from typing import Callable, Iterator, Sequence

from . import bench, protocol as P
from .evaluate import DatasetError
from .link import Link, LinkError, LinkSettings, find_boards, list_serial_ports
from .recording import CsvRecorder, RawRecorder, RecordingError, Replay, decode_file

EXIT_ERROR = 1
EXIT_INTERRUPTED = 130
STATUS_INTERVAL_S = 0.25


class UsageError(Exception):
    """A command line that asks for something impossible."""


# ----------------------------------------------------------------- sources


def add_source_options(p: argparse.ArgumentParser) -> None:
    """The options every command that reads a board takes."""
    src = p.add_mutually_exclusive_group()
    src.add_argument("--port", help="serial port or pyserial URL (default: the first board found)")
    src.add_argument("--virtual", action="store_true", help="use a virtual board on a pty")
    p.add_argument("--baud", type=int, help="baud rate (default: 115200, falling back to 9600)")
    p.add_argument("--rate", type=int, default=200, help="samples per second to ask for (200)")
    p.add_argument("--mode", choices=["raw", "fused"], default="raw",
                   help="raw sensor counts, or the board's own fused orientation")


@contextlib.contextmanager
def open_source(args: argparse.Namespace, tap: Callable[[bytes], None] | None = None) -> Iterator[Link]:
    """Open the board the options name (a virtual one for ``--virtual``); ``tap`` sees every byte read."""
    with contextlib.ExitStack() as stack:
        if args.virtual:
            from .board import VirtualBoard  # POSIX only: imported when asked for
            port = stack.enter_context(VirtualBoard()).port
        elif args.port:
            port = args.port
        else:
            port = _autodetect()
        settings = LinkSettings(port, baud=args.baud, rate_hz=args.rate, mode=P.Mode[args.mode.upper()])
        link = Link(settings)
        link.tap = tap
        link.open()
        stack.callback(link.close)
        yield link


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


def _vec(v: Sequence[float] | None) -> str:
    return "(" + " ".join(f"{x:6.2f}" for x in v) + ")" if v is not None else "(none)"


def sample_text(s: P.RawSample | P.FusedSample | None) -> str:
    if s is None:
        return "no sample yet"
    if isinstance(s, P.RawSample):
        return f"acc {_vec(s.acc)} m/s2  gyr {_vec(s.gyr)} rad/s  mag {_vec(s.mag)} uT  flex {s.flex_adc:4d}"
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
    """The default filter run on the raw samples a monitor shows, to say what it makes of the
    magnetometer (:attr:`DefaultFilter.status`); fused samples are the board's own estimate."""

    MAX_GAP_S = 0.5  # a longer gap between samples (link loss) keeps the last good time step

    def __init__(self) -> None:
        from .fusion.default import DefaultFilter
        self.filter = DefaultFilter()
        self._last_t: float | None = None
        self._dt = 0.005

    def feed(self, s: P.RawSample | P.FusedSample) -> None:
        if not isinstance(s, P.RawSample):
            return
        if self._last_t is not None and 0.0 < s.t - self._last_t < self.MAX_GAP_S:
            self._dt = s.t - self._last_t
        self._last_t = s.t
        self.filter.update(s.gyr, s.acc, s.mag, self._dt)

    @property
    def status(self) -> str:
        """"magnetometer on", "magnetometer off: <why>", "no magnetometer"; "" before any raw sample."""
        return self.filter.status if self._last_t is not None else ""


def cmd_monitor(args: argparse.Namespace) -> int:
    status = StatusLine()
    last = None
    fusion = MonitorFusion()
    with open_source(args) as link:
        end = _until(args.seconds)
        try:
            while time.monotonic() < end:
                for s in link.drain():
                    last = s
                    fusion.feed(s)
                status.show(_health_text(link) + sample_text(last) + (f"  {fusion.status}" if fusion.status else ""))
                time.sleep(0.02)
        except KeyboardInterrupt:
            pass
        status.done()
        h, stats = link.health(), link.stats()
        elapsed = args.seconds if args.seconds else None
        report = {"frames": stats.frames, "rate_hz": h.rate_hz, "crc_errors": stats.crc_errors,
                  "dropped": stats.dropped, "bytes_skipped": stats.bytes_skipped,
                  "hello": link.hello.to_json() if link.hello else None, "last": sample_json(last),
                  "link": h.to_json(), "seconds": elapsed, "magnetometer": fusion.status or None}
    if args.json:
        print(json.dumps(report))
    else:
        print(f"{report['frames']} frames, {h.rate_hz:.1f} Hz, {stats.dropped} dropped, "
              f"{stats.crc_errors} CRC errors, {stats.bytes_skipped} bytes skipped"
              + (f"; {fusion.status}" if fusion.status else ""))
    return 0


def cmd_record(args: argparse.Namespace) -> int:
    status = StatusLine()
    raw = RawRecorder(args.raw)
    with open_source(args, tap=raw.write) as link:
        legacy = link.health().legacy_text
        header = {"created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "port": link.settings.port,
                  "legacy_text": legacy, "text_order": link.settings.text_order,
                  "hello": link.hello.to_json() if link.hello else None}
        # The stream describes itself: the board's hello goes first.
        raw.begin(header, P.encode_hello(link.hello) if link.hello and not legacy else b"")
        table = CsvRecorder(args.csv, link.hello) if args.csv else None
        end = _until(args.seconds)
        try:
            while time.monotonic() < end:
                for s in link.drain():
                    if table:
                        table.write(s)
                status.show(f"recording {args.raw}: {raw.bytes} bytes  " + _health_text(link))
                time.sleep(0.05)
        except KeyboardInterrupt:
            pass
        link.tap = None
    status.done()
    raw.close()
    if table:
        for s in link.drain():
            table.write(s)
        table.close()
    rows = f", {table.rows} samples to {args.csv}" if table else ""
    print(f"recorded {raw.bytes} bytes to {args.raw}{rows}", file=sys.stderr)
    return 0


def cmd_decode(args: argparse.Namespace) -> int:
    samples, replay = decode_file(args.input)
    st = replay.stats
    report = {"packets": st.frames, "samples": len(samples), "crc_errors": st.crc_errors,
              "dropped": st.dropped, "bytes_skipped": st.bytes_skipped,
              "hello": replay.hello.to_json() if replay.hello else None,
              "duration_s": samples[-1].t - samples[0].t}
    if args.json:
        print(json.dumps(report))
    else:
        print(f"{args.input}: {st.frames} packets, {len(samples)} samples over "
              f"{report['duration_s']:.2f} s, {st.dropped} dropped, {st.crc_errors} CRC errors, "
              f"{st.bytes_skipped} bytes skipped")
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    if not Path(args.input).is_file():
        raise RecordingError(f"no such file: {args.input}")
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
              "bytes_skipped": st.bytes_skipped, "last": sample_json(last)}
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
    from .evaluate import (evaluate, filter_names, find_trials, markdown_table, uses_magnetometer,
                           write_readme_table)
    paths = find_trials(args.dataset)
    names = filter_names(args.filter)
    dofs = [args.dof] if args.dof else [6, 9]
    total = len(paths) * sum(1 for d in dofs for n in names if d == 6 or uses_magnetometer(n))
    if total == 0:
        raise UsageError(f"{args.filter} ignores the magnetometer by design: evaluate it with --dof 6")
    results = []
    for r in evaluate(paths, names, dofs):
        results.append(r)
        print(f"[{len(results)}/{total}] {r['trial']} {r['filter']} {r['dof']}D: "
              f"total {r['total']:.2f}  inclination {r['inclination']:.2f} deg", file=sys.stderr)
    if args.readme:
        write_readme_table(args.readme, results)
        print(f"updated the results table in {args.readme}", file=sys.stderr)
    print(json.dumps({"results": results}) if args.json else markdown_table(results))
    return 0


def cmd_fuse(args: argparse.Namespace) -> int:
    from .fuse import fuse_file
    n = fuse_file(args.input, args.filter, args.dof, args.out)
    print(f"wrote {n} orientations to {args.out}", file=sys.stderr)
    return 0


def cmd_experiment(args: argparse.Namespace) -> int:
    from . import experiments
    run, plot = {"static-drift": (experiments.static_drift, experiments.plot_static_drift),
                 "finger-grasp": (experiments.finger_grasp, experiments.plot_finger_grasp)}[args.name]
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
    with VirtualBoard(settings=settings, faults=faults, link=link) as board:
        print(f"virtual board on {board.port} (Ctrl-C to stop)", file=sys.stderr, flush=True)
        try:
            _wait(args.seconds)
        except KeyboardInterrupt:
            pass
        counters = vars(board.counters).copy()
    if args.json:
        print(json.dumps(counters))
    return 0


def _wait(seconds: float | None) -> None:
    """Sleep ``seconds``, or until interrupted when None."""
    end = _until(seconds)
    while time.monotonic() < end:
        time.sleep(min(1.0, end - time.monotonic()))


# ----------------------------------------------------------------- parser


def _nonnegative(text: str) -> float:
    v = float(text)
    if not v >= 0:
        raise argparse.ArgumentTypeError(f"must be a number >= 0, not {text}")
    return v


def _probability(text: str) -> float:
    v = _nonnegative(text)
    if v > 1:
        raise argparse.ArgumentTypeError(f"must be between 0 and 1, not {text}")
    return v


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="armtracker", description=(
        "Read an EnergyBall sensor board (Metro Mini + MPU-9250 + flex sensor) over serial."))
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("ports", help="list serial ports, boards first")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_ports)

    p = sub.add_parser("monitor", help="show the live stream: rate, loss, readings")
    add_source_options(p)
    p.add_argument("--seconds", type=_nonnegative, help="stop after this long (default: Ctrl-C)")
    p.add_argument("--json", action="store_true", help="print a JSON summary at the end")
    p.set_defaults(func=cmd_monitor)

    p = sub.add_parser("record", help="record the raw byte stream (and decoded samples)")
    add_source_options(p)
    p.add_argument("--seconds", type=_nonnegative, required=True)
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
    p.add_argument("--speed", type=float, default=1.0, help="real-time speed factor (1.0)")
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
    p.add_argument("input", metavar="IN", help=".bin or .csv recording, or a .npz trial")
    p.add_argument("--filter", default="default")
    p.add_argument("--dof", type=int, choices=[6, 9], default=6)
    p.add_argument("--out", required=True, metavar="OUT.npz")
    p.set_defaults(func=cmd_fuse)

    p = sub.add_parser("experiment", help="reproduce a paper's experiment in simulation")
    p.add_argument("name", choices=["static-drift", "finger-grasp"],
                   help="static-drift: seed 002 sec. 4.1; finger-grasp: seed 003 sec. 3")
    p.add_argument("--plot", metavar="PNG", help="also draw the result (needs the plot extra)")
    p.add_argument("--json", action="store_true", help="one line of JSON")
    p.set_defaults(func=cmd_experiment)

    p = sub.add_parser("virtual", help="serve a virtual board on a pty for other programs")
    p.add_argument("--link", help="stable path to create for the pty (a symlink)")
    p.add_argument("--rate", type=int, default=200)
    p.add_argument("--legacy", action="store_true", help="act like the paper's sketch (text, 9600 baud)")
    p.add_argument("--corrupt", type=_probability, default=0.0, help="per-byte corruption rate")
    p.add_argument("--drop", type=_probability, default=0.0, help="per-byte drop rate")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--seconds", type=_nonnegative)
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_virtual)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (LinkError, RecordingError, DatasetError, UsageError) as e:
        print(f"armtracker: {e}", file=sys.stderr)
    except OSError as e:  # e.g. an output file in a folder that does not exist
        print(f"armtracker: {e.filename or ''}: {e.strerror or e}", file=sys.stderr)
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
    return EXIT_ERROR


if __name__ == "__main__":
    sys.exit(main())
