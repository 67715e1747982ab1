"""Command-line options checked by the parser: numbers in range, errors on one line.

Both command lines (``armtracker``, ``energyball``) build their parsers from
:class:`Parser`, whose errors are one line (``prog: what is wrong (see prog
--help)``) and exit status 2, as argparse's own are; and every numeric option
takes a :class:`Ranged` type, which refuses text that is not a number, NaN,
infinities and values out of its range, and says its range for ``--help``.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from typing import NoReturn

EXIT_USAGE = 2  # argparse's exit status for a command line it refuses


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line on stderr naming the option and what it takes."""

    def error(self, message: str) -> NoReturn:
        sys.stderr.write(f"{self.prog}: {message} (see {self.prog} --help)\n")
        sys.exit(EXIT_USAGE)

    def parse_known_args(self, args=None, namespace=None):  # type: ignore[no-untyped-def]
        """argparse's, and an error for a value its type never saw: Python 3.11's argparse turns
        ``--rate=--`` into an empty list without calling the option's type."""
        parsed, extras = super().parse_known_args(args, namespace)
        for action in self._actions:
            if isinstance(action.type, Ranged) and isinstance(getattr(parsed, action.dest, None), list):
                self.error(f"argument {'/'.join(action.option_strings)}: expected one value, "
                           f"{action.type.text}")
        return parsed, extras


SHOWN_CHARS = 40  # of a refused value, in the message


def _shown(text: str) -> str:
    """The refused text as the message quotes it (a very long one cut short)."""
    return repr(text if len(text) <= SHOWN_CHARS else text[:SHOWN_CHARS - 3] + "...")


def _number_text(v: float) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


@dataclass(frozen=True)
class Ranged:
    """An argparse ``type``: a finite number of ``kind`` (int or float) in a range.

    ``low`` is included unless ``above`` (then the value must be more than
    it); ``high`` (None: no bound) is always included.
    """

    kind: type
    low: float
    high: float | None = None
    above: bool = False

    @property
    def text(self) -> str:
        """The range in words, for ``--help`` and messages."""
        noun = "a whole number" if self.kind is int else "a number"
        low = _number_text(self.kind(self.low))
        if self.high is None:
            return f"{noun} {'above' if self.above else 'of at least'} {low}"
        high = _number_text(self.kind(self.high))
        return f"{noun} {'above ' + low + ' and up to' if self.above else 'from ' + low + ' to'} {high}"

    def __call__(self, text: str) -> int | float:
        try:
            value = self.kind(text)
        except (ValueError, OverflowError):
            raise argparse.ArgumentTypeError(f"must be {self.text}, not {_shown(text)}") from None
        if (isinstance(value, float) and not math.isfinite(value)) or not self.contains(value):
            raise argparse.ArgumentTypeError(f"must be {self.text}, not {_shown(text)}")
        return value

    def contains(self, value: float) -> bool:
        """Whether ``value`` is in the range."""
        if value < self.low or (self.above and value == self.low):
            return False
        return self.high is None or value <= self.high

    def __repr__(self) -> str:  # argparse names the type in some messages
        return self.text
