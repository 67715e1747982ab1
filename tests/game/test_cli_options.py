"""``energyball``'s numeric options are checked by the parser (issue 13, case 9).

The ranges, written out: seeds of 0 or more; 1 to 10,000 matches; a match of
more than 0 and up to 86,400 s (a day); 1 to 64 worker processes; 1 to
10,000 gesture-evaluation trials of 1 to 1,000 gestures.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings, strategies as st

from game.__main__ import build_parser

from ..commands import one_clear_line, parse_in_process, run

# (arguments before the option, option, kind, low, high, low excluded)
OPTIONS = [
    ([], "--seed", int, 0, math.inf, False),
    (["--headless"], "--matches", int, 1, 10_000, False),
    (["--headless"], "--duration", float, 0, 86_400, True),
    (["--headless"], "--workers", int, 1, 64, False),
    (["gestures-eval"], "--trials", int, 1, 10_000, False),
    (["gestures-eval"], "--gestures", int, 1, 1_000, False),
    (["gestures-eval"], "--seed", int, 0, math.inf, False),
]
IDS = [f"{' '.join(before)}{option}" for before, option, *_ in OPTIONS]
PARSER = build_parser()

ANY_TEXT = st.one_of(
    st.sampled_from(["nan", "inf", "-inf", "1e-300", "1e309", "0", "0.0", "", "ten", "1.5", "1e3", "9" * 5000,
                     "--", "-1", "86400.0001"]),
    st.integers(-10**6, 10**6).map(str), st.integers().map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr), st.text(max_size=8))


def parse(argv: list[str]) -> tuple[object, int | None, str]:
    return parse_in_process(PARSER, argv)


@pytest.mark.parametrize("before, option, kind, low, high, above", OPTIONS, ids=IDS)
@settings(derandomize=True, max_examples=120, deadline=None)
@given(text=ANY_TEXT)
def test_any_value_is_in_range_or_refused_on_one_line(before, option, kind, low, high, above, text):
    args, code, err = parse([*before, f"{option}={text}"])
    if args is None:
        assert code == 2
        lines = err.strip().splitlines()
        assert len(lines) == 1 and option in lines[0] and lines[0].startswith("energyball")
        return
    value = getattr(args, option.lstrip("-"))
    assert type(value) is kind and math.isfinite(value)
    assert (value > low if above else value >= low) and value <= high


@pytest.mark.parametrize("before, option, kind, low, high, above", OPTIONS, ids=IDS)
@settings(derandomize=True, max_examples=60, deadline=None)
@given(data=st.data())
def test_every_value_in_range_is_accepted(before, option, kind, low, high, above, data):
    top = min(high, 10**9)
    value = data.draw(st.integers(low + (1 if above else 0), int(top)) if kind is int else
                      st.floats(low, top, exclude_min=above))
    args, _, err = parse([*before, option, repr(value) if kind is float else str(value)])
    assert args is not None, err
    assert getattr(args, option.lstrip("-")) == value


def test_help_says_the_ranges(capsys):
    with pytest.raises(SystemExit):
        PARSER.parse_args(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    for said in ("a whole number from 1 to 10000", "a number above 0 and up to 86400",
                 "a whole number from 1 to 64", "a whole number of at least 0"):
        assert said in text


@pytest.mark.parametrize("argv, option", [
    (["--headless", "--matches", "0"], "--matches"),
    (["--headless", "--matches", "1e9"], "--matches"),
    (["--headless", "--duration", "0"], "--duration"),
    (["--headless", "--duration", "inf"], "--duration"),
    (["--headless", "--duration", "1e400"], "--duration"),
    (["--headless", "--workers", "0"], "--workers"),
    (["--headless", "--workers", "100000"], "--workers"),
    (["--seed", "-1"], "--seed"),
    (["gestures-eval", "--trials", "0"], "--trials"),
    (["gestures-eval", "--gestures", "NaN"], "--gestures"),
])
def test_bad_values_are_refused_by_the_real_command(tmp_path, argv, option):
    r = run("game", *argv, home=tmp_path)
    one_clear_line(r, option, argv[argv.index(option) + 1], code=2)
    assert list(tmp_path.iterdir()) == []  # nothing ran: not even the game's config folder


@pytest.mark.parametrize("port", ["p" * 300, "a\tb", ""])
def test_a_port_the_settings_cannot_hold_is_refused_by_the_real_command(tmp_path, port):
    """The input choice is saved in settings.json, whose ``input`` is 1-200 printable characters."""
    r = run("game", "--port", port, home=tmp_path)
    one_clear_line(r, "--port", "1 to 200 printable characters", code=2)
    assert list(tmp_path.iterdir()) == []
