"""Reading JSON a user hands us: bounded, finite, and one clear message when it is not.

Python's ``json`` module accepts what RFC 8259 leaves open (sec. 9: "An
implementation may set limits on the size of texts ... the maximum depth of
nesting ... the range and precision of numbers"), and by default it reads
``NaN`` and ``Infinity``, which are not JSON at all (sec. 6), and recurses
until the interpreter gives up. Every file of ours a user can edit (settings,
scores, profiles, calibrations, recording headers) is read here, with limits
far above anything we write and far below what hurts.

A byte order mark is skipped (RFC 8259 sec. 8.1: a parser "MAY ignore the
presence of a byte order mark"): editors on some systems write one.
"""

from __future__ import annotations

import json
import math
import os
import re
import stat
from dataclasses import dataclass
from typing import Any

MAX_BYTES = 4_000_000  # our largest file (a calibration with its samples) is ~100 kB
MAX_DEPTH = 32  # we nest at most 4 deep
MAX_NUMBER_CHARS = 64  # a float64 needs 24 characters at most

_STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.DOTALL)
_BRACKETS = re.compile(r"[\[\]{}]")


class JSONInputError(ValueError):
    """A JSON text we refuse; ``str()`` is ``"<source>: <problem>"``."""

    def __init__(self, source: str, problem: str) -> None:
        super().__init__(f"{source}: {problem}")
        self.source = source
        self.problem = problem

    def __reduce__(self) -> tuple[type, tuple[str, str]]:  # pickled across processes as it was made
        return JSONInputError, (self.source, self.problem)


@dataclass(frozen=True)
class BadNumber:
    """A number :func:`parse_json` could not take (``NaN``, ``1e400``, 70 digits), kept as its text.

    Only a lenient parse (``lenient_numbers=True``) yields one, in place of the
    number: a reader that checks each value then refuses that value alone, and
    its message shows what the file said (``repr`` is the text, shortened).
    """

    text: str

    def __repr__(self) -> str:
        return self.text if len(self.text) <= 24 else f"{self.text[:12]}...({len(self.text)} characters)"


def parse_json(text: str | bytes, source: str, *, lenient_numbers: bool = False) -> Any:
    """The value of ``text``, or :class:`JSONInputError` naming ``source``.

    Refuses texts over :data:`MAX_BYTES`, nesting deeper than :data:`MAX_DEPTH`,
    and text that is not UTF-8. Numbers longer than :data:`MAX_NUMBER_CHARS`
    characters, numbers that overflow a float (``1e400``) and
    ``NaN``/``Infinity`` refuse the whole text, or with ``lenient_numbers``
    become :class:`BadNumber` values (for files whose good values are kept
    one by one, such as the game's settings).
    """
    if len(text) > MAX_BYTES:
        raise JSONInputError(source, f"larger than {MAX_BYTES // 1_000_000} MB, not one of our files")
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError:
            raise JSONInputError(source, "not UTF-8 text") from None
    text = text.removeprefix("\ufeff")
    depth = _max_depth(text)
    if depth > MAX_DEPTH:
        raise JSONInputError(source, f"nested {depth} deep; at most {MAX_DEPTH} is read")
    number = _lenient_number if lenient_numbers else _strict_number
    try:
        return json.loads(text, parse_float=lambda s: number(s, float, source),
                          parse_int=lambda s: number(s, int, source),
                          parse_constant=lambda s: number(s, float, source))
    except json.JSONDecodeError as e:
        raise JSONInputError(source, f"not valid JSON ({e.msg} at line {e.lineno}, column {e.colno})") from None


def read_json(path: str | os.PathLike, *, lenient_numbers: bool = False, source: str | None = None) -> Any:
    """:func:`parse_json` of a regular file's bytes; messages name ``source`` (default: the path).

    A missing or unreadable file raises ``OSError``; a folder, a device or a
    FIFO is a :class:`JSONInputError` (opened without blocking, so a FIFO with
    no writer does not hang the reader).
    """
    source = os.fspath(path) if source is None else source
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise JSONInputError(source, "not a regular file")
        data = b""
        while len(data) <= MAX_BYTES and (chunk := os.read(fd, MAX_BYTES + 1 - len(data))):
            data += chunk
    finally:
        os.close(fd)
    return parse_json(data, source, lenient_numbers=lenient_numbers)


def _max_depth(text: str) -> int:
    """The deepest nesting of arrays and objects, strings' contents ignored.

    Up to the first syntax error the strings found here are the parser's (both
    take the first quote outside a string as an opening one), so the parser
    never nests deeper than this says.
    """
    depth = deepest = 0
    for b in _BRACKETS.findall(_STRING.sub("", text)):
        depth += 1 if b in "[{" else -1
        deepest = max(deepest, depth)
    return deepest


def _number_problem(text: str, kind: type) -> tuple[int | float | None, str]:
    """The number ``text`` stands for, or None and why it is refused."""
    if len(text) > MAX_NUMBER_CHARS:
        return None, f"a number of {len(text)} characters ({text[:12]}...); at most {MAX_NUMBER_CHARS} are read"
    if text in ("NaN", "Infinity", "-Infinity"):
        return None, f"{text} is not a JSON number; write a finite number"
    value = kind(text)
    if isinstance(value, float) and not math.isfinite(value):
        return None, f"the number {text} is too large for a float"
    return value, ""


def _strict_number(text: str, kind: type, source: str) -> int | float:
    value, problem = _number_problem(text, kind)
    if value is None:
        raise JSONInputError(source, problem)
    return value


def _lenient_number(text: str, kind: type, source: str) -> int | float | BadNumber:
    value, _ = _number_problem(text, kind)
    return BadNumber(text) if value is None else value
