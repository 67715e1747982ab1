"""Reading JSON a user hands us: bounded, finite, and one clear message when it is not.

Python's ``json`` module accepts what RFC 8259 leaves open (sec. 9: "An
implementation may set limits on the size of texts ... the maximum depth of
nesting ... the range and precision of numbers"), and by default it reads
``NaN`` and ``Infinity``, which are not JSON at all (sec. 6), and recurses
until the interpreter gives up. Every file of ours a user can edit (settings,
scores, profiles, calibrations, recording headers) is read here, with limits
far above anything we write and far below what hurts.
"""

from __future__ import annotations

import json
import math
import os
import re
from typing import Any

MAX_BYTES = 4_000_000  # our largest file (a calibration with its samples) is ~100 kB
MAX_DEPTH = 32  # we nest at most 4 deep
MAX_NUMBER_CHARS = 64  # a float64 needs 24 characters at most

_STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.DOTALL)
_BRACKETS = re.compile(r"[\[\]{}]")


class JSONInputError(ValueError):
    """A JSON text we refuse; the message names its source and what is wrong."""


def parse_json(text: str | bytes, source: str) -> Any:
    """The value of ``text``, or :class:`JSONInputError` naming ``source``.

    Refuses texts over :data:`MAX_BYTES`, nesting deeper than :data:`MAX_DEPTH`,
    numbers longer than :data:`MAX_NUMBER_CHARS` characters, numbers that
    overflow a float (``1e400``), ``NaN``/``Infinity``, and text that is not UTF-8.
    """
    if len(text) > MAX_BYTES:
        raise JSONInputError(f"{source}: larger than {MAX_BYTES // 1_000_000} MB, not one of our files")
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError:
            raise JSONInputError(f"{source}: not UTF-8 text") from None
    depth = _max_depth(text)
    if depth > MAX_DEPTH:
        raise JSONInputError(f"{source}: nested {depth} deep; at most {MAX_DEPTH} is read")
    try:
        return json.loads(text, parse_float=lambda s: _number(s, float, source),
                          parse_int=lambda s: _number(s, int, source),
                          parse_constant=lambda s: _refuse_constant(s, source))
    except json.JSONDecodeError as e:
        raise JSONInputError(f"{source}: not valid JSON ({e.msg} at line {e.lineno}, column {e.colno})") from None


def read_json(path: str | os.PathLike) -> Any:
    """:func:`parse_json` of a regular file's bytes; a missing or unreadable file raises ``OSError``."""
    with open(path, "rb") as f:
        if not os.path.isfile(path):
            raise JSONInputError(f"{os.fspath(path)}: not a regular file")
        data = f.read(MAX_BYTES + 1)
    return parse_json(data, os.fspath(path))


def _max_depth(text: str) -> int:
    """The deepest nesting of arrays and objects, strings' contents ignored."""
    depth = deepest = 0
    for b in _BRACKETS.findall(_STRING.sub("", text)):
        depth += 1 if b in "[{" else -1
        deepest = max(deepest, depth)
    return deepest


def _number(text: str, kind: type, source: str) -> int | float:
    if len(text) > MAX_NUMBER_CHARS:
        raise JSONInputError(f"{source}: a number of {len(text)} characters ({text[:12]}...); "
                             f"at most {MAX_NUMBER_CHARS} are read")
    value = kind(text)
    if isinstance(value, float) and not math.isfinite(value):
        raise JSONInputError(f"{source}: the number {text} is too large for a float")
    return value


def _refuse_constant(text: str, source: str) -> None:
    raise JSONInputError(f"{source}: {text} is not a JSON number; write a finite number")
