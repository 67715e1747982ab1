"""``armtracker``'s numeric options are checked by the parser (issue 13, case 9).

The ranges are the specification's, written out here: a sample rate the
board accepts (firmware/PROTOCOL.md sec. 6, SET_RATE: 1 to 1000 Hz), a baud
rate the Metro Mini's USB bridge can make (CP2104 data sheet sec. 6.1: 300 bps
to 2 Mbps), durations above zero, probabilities in [0, 1], replay speeds from
1/100 to 1000 times real time, seeds of 0 or more.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings, strategies as st

from tracker.__main__ import build_parser

from ..commands import one_clear_line, parse_in_process, run

# (command, the arguments it needs besides the option, option, kind, low, high, low excluded)
OPTIONS = [
    ("monitor", [], "--rate", int, 1, 1000, False),
    ("monitor", [], "--baud", int, 300, 2_000_000, False),
    ("monitor", [], "--seconds", float, 0, math.inf, True),
    ("record", ["--seconds", "1", "--raw", "x.bin"], "--rate", int, 1, 1000, False),
    ("record", ["--raw", "x.bin"], "--seconds", float, 0, math.inf, True),
    ("replay", ["in.bin"], "--speed", float, 0.01, 1000, False),
    ("virtual", [], "--rate", int, 1, 1000, False),
    ("virtual", [], "--corrupt", float, 0, 1, False),
    ("virtual", [], "--drop", float, 0, 1, False),
    ("virtual", [], "--seed", int, 0, math.inf, False),
    ("virtual", [], "--seconds", float, 0, math.inf, True),
]
PARSER = build_parser()

ODD_TEXT = st.sampled_from(["nan", "NaN", "inf", "-inf", "Infinity", "1e-300", "1e309", "-0", "0", "0.0", "",
                            " ", "1_000", "0x10", "ten", "1.5", "1e3", "9" * 5000, "--", "-1"])
ANY_TEXT = st.one_of(ODD_TEXT, st.integers(-10**7, 10**7).map(str), st.integers().map(str),
                     st.floats(allow_nan=True, allow_infinity=True).map(repr), st.text(max_size=8))


def parse(argv: list[str]) -> tuple[object, int | None, str]:
    return parse_in_process(PARSER, argv)


def in_range(value: float, low: float, high: float, above: bool) -> bool:
    return (value > low if above else value >= low) and value <= high


@pytest.mark.parametrize("command, needs, option, kind, low, high, above", OPTIONS,
                         ids=[f"{c}{o}" for c, _, o, *_ in OPTIONS])
@settings(derandomize=True, max_examples=120, deadline=None)
@given(text=ANY_TEXT)
def test_any_value_is_in_range_or_refused_on_one_line(command, needs, option, kind, low, high, above, text):
    args, code, err = parse([command, *needs, f"{option}={text}"])
    if args is None:
        assert code == 2
        lines = err.strip().splitlines()
        assert len(lines) == 1 and option in lines[0] and f"armtracker {command}" in lines[0]
        return
    value = getattr(args, option.lstrip("-"))
    assert type(value) is kind
    assert math.isfinite(value) and in_range(value, low, high, above)


@pytest.mark.parametrize("command, needs, option, kind, low, high, above", OPTIONS,
                         ids=[f"{c}{o}" for c, _, o, *_ in OPTIONS])
@settings(derandomize=True, max_examples=60, deadline=None)
@given(data=st.data())
def test_every_value_in_range_is_accepted(command, needs, option, kind, low, high, above, data):
    top = min(high, 10**9)
    value = data.draw(st.integers(math.ceil(low) + (1 if above else 0), int(top)) if kind is int else
                      st.floats(low, top, exclude_min=above))
    args, code, err = parse([command, *needs, option, repr(value) if kind is float else str(value)])
    assert args is not None, err
    assert getattr(args, option.lstrip("-")) == value


@pytest.mark.parametrize("command, needs, option, kind, low, high, above", OPTIONS,
                         ids=[f"{c}{o}" for c, _, o, *_ in OPTIONS])
def test_help_says_each_range(command, needs, option, kind, low, high, above, capsys):
    with pytest.raises(SystemExit):
        PARSER.parse_args([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    number = "a whole number" if kind is int else "a number"
    low_text = f"{low:g}" if kind is float else str(low)
    if high == math.inf:
        said = f"{number} {'above' if above else 'of at least'} {low_text}"
    else:
        said = f"{number} from {low_text} to {high:g}" if kind is float else f"{number} from {low} to {high}"
    assert said in text, text


def test_the_rate_range_is_the_protocols():
    """PROTOCOL.md sec. 6: SET_RATE takes "1 <= rate_hz <= 1000"; the option says the same."""
    import re
    from pathlib import Path
    spec = (Path(__file__).resolve().parents[2] / "firmware" / "PROTOCOL.md").read_text()
    low, high = map(int, re.search(r"if (\d+) <= rate_hz <= (\d+)", spec).groups())
    rates = {o[3:6] for o in OPTIONS if o[2] == "--rate"}
    assert rates == {(int, low, high)}


@pytest.mark.parametrize("argv, option", [
    (["replay", "in.bin", "--speed", "0"], "--speed"),
    (["replay", "in.bin", "--speed", "1e-300"], "--speed"),
    (["monitor", "--virtual", "--rate", "-1"], "--rate"),
    (["monitor", "--virtual", "--rate", "70000"], "--rate"),
    (["monitor", "--virtual", "--rate", "0"], "--rate"),
    (["monitor", "--virtual", "--rate", "5000"], "--rate"),
    (["monitor", "--virtual", "--baud", "99999999999"], "--baud"),
    (["virtual", "--rate", "0"], "--rate"),
    (["virtual", "--rate", "-5"], "--rate"),
    (["virtual", "--rate", "1000000"], "--rate"),
    (["record", "--virtual", "--seconds", "0", "--raw", "x.bin"], "--seconds"),
    (["virtual", "--seconds", "0"], "--seconds"),
    (["monitor", "--virtual", "--seconds", "nan"], "--seconds"),
    (["virtual", "--corrupt", "inf"], "--corrupt"),
])
def test_the_issues_option_values_are_refused_by_the_real_command(tmp_path, argv, option):
    """Exit 2 and one line before anything runs: no board, no file."""
    r = run("tracker", *argv, home=tmp_path)
    one_clear_line(r, option, argv[argv.index(option) + 1], code=2)
    assert list(tmp_path.iterdir()) == []
