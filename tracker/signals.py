"""Signals that end a command: Ctrl-C, ``kill`` and a closed terminal take one clean path.

SIGINT (Ctrl-C), SIGTERM (``kill``, ``timeout``, a service manager) and SIGHUP
(the terminal closed) all raise :class:`Interrupted`, a ``KeyboardInterrupt``,
so every ``except KeyboardInterrupt`` that ends a command cleanly serves the
three alike. The exit status of a command ended so is ``128 + signal number``
(130, 143, 129), the convention of POSIX shells (POSIX.1-2017, Shell Command
Language, sec. 2.8.2 "Exit Status for Commands").

Two rules keep files whole (:mod:`tracker.atomic`):

* :func:`interrupts` raises only for the first signal; later ones are ignored,
  since the command is already on its way out. So two Ctrl-C a few
  milliseconds apart cannot break the clean path the first one started.
* :func:`deferred` holds signals back around a short step that must not be cut
  in half (renaming a finished file into place, removing a temporary one);
  the signal takes effect as soon as the step is done.

Signal handlers can only be set from the main thread; elsewhere both context
managers do nothing (Python delivers signals to the main thread only).
"""

from __future__ import annotations

import contextlib
import signal
import threading
from dataclasses import dataclass
from types import FrameType
from typing import Any, Callable, Iterator

ENDING = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
Handler = Callable[[int, FrameType | None], Any] | int | None


class Interrupted(KeyboardInterrupt):
    """A command ended by SIGINT, SIGTERM or SIGHUP (``signum`` says which)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def signum_of(e: BaseException) -> int:
    """The signal that raised an interruption (a plain KeyboardInterrupt is SIGINT's)."""
    return e.signum if isinstance(e, Interrupted) else int(signal.SIGINT)


def exit_status(e: BaseException) -> int:
    """The shell's exit status of a command ended by the interruption ``e``: 128 + signal number."""
    return 128 + signum_of(e)


def name_of(e: BaseException) -> str:
    """"SIGINT", "SIGTERM" or "SIGHUP"."""
    return signal.Signals(signum_of(e)).name


def exit_quietly() -> None:
    """Until a command's own handling begins (:func:`interrupts`): an ending signal exits at once,
    status 128 + its number, without a traceback; nothing has been done yet that needs undoing.

    For a command line run as a program, called before its slow imports.
    """
    for s in ENDING:
        if signal.getsignal(s) is not signal.SIG_IGN:
            signal.signal(s, _exit_now)


def _exit_now(signum: int, frame: FrameType | None) -> None:
    raise SystemExit(128 + signum)


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@dataclass
class Received:
    """The first ending signal seen inside a context (None until one arrives)."""

    signum: int | None = None


@contextlib.contextmanager
def _handlers(handler: Callable[[int, FrameType | None], None],
              ignore_after: bool = False) -> Iterator[dict[int, Handler]]:
    """Install ``handler`` for the ending signals a user has not ignored; restore them on exit
    (or ignore them from then on, with ``ignore_after``).

    A signal ignored when we start stays ignored (``nohup``, a background job
    whose shell ignores SIGINT): the user asked for that.
    """
    saved: dict[int, Handler] = {}
    try:
        for s in ENDING:
            old = signal.getsignal(s)
            if old is not None and old is not signal.SIG_IGN:  # None: a handler set outside Python
                saved[s] = old
                signal.signal(s, handler)
        yield saved
    finally:
        for signum, before in saved.items():
            signal.signal(signum, signal.SIG_IGN if ignore_after else before)


@contextlib.contextmanager
def interrupts(ignore_after: bool = False) -> Iterator[Received]:
    """Turn SIGINT, SIGTERM and SIGHUP into :class:`Interrupted`, the first one only.

    Later signals are ignored: the command is already ending along its clean
    path, which a second Ctrl-C must not cut short. ``ignore_after`` is for a
    process that exits when the block ends (a command line run as a program):
    the signals stay ignored, so none arriving in its last instants turns into
    a traceback. Otherwise the handlers in force before come back, and a signal
    that arrived while they were being put back (the block already done) is
    handed to them, as :func:`deferred` does. A signal while the handlers are
    being installed raises from entering the block, so a command catches
    ``KeyboardInterrupt`` around the ``with``, not inside it.
    """
    received = Received()
    if not _main_thread():
        yield received
        return
    closing = Received()  # the first signal while the handlers are being put back, the block done

    def handler(signum: int, frame: FrameType | None) -> None:
        if received.signum is not None or closing.signum is not None:
            return
        if ending:  # raising now would escape from the restoring loop, outside the caller's handling
            closing.signum = signum
            return
        received.signum = signum
        raise Interrupted(signum)

    ending = False
    with _handlers(handler, ignore_after) as saved:
        try:
            yield received
        finally:
            ending = True
    if closing.signum is not None and not ignore_after:  # the handler back in force acts on it
        _deliver(closing.signum, saved.get(closing.signum))


@contextlib.contextmanager
def deferred() -> Iterator[Received]:
    """Hold SIGINT, SIGTERM and SIGHUP back while the block runs, then act on the first one.

    On leaving the block (however it ends) the handlers in force before it come
    back and the first signal held is handed to its handler, so an
    :func:`interrupts` outer context raises :class:`Interrupted` right after
    the block; a signal whose disposition was the default is raised again, so
    it ends the process as it would have.
    """
    received = Received()
    if not _main_thread():
        yield received
        return

    def hold(signum: int, frame: FrameType | None) -> None:
        if received.signum is None:
            received.signum = signum

    saved: dict[int, Handler] = {}
    try:
        with _handlers(hold) as saved:
            yield received
    finally:  # the handlers are back; a held signal takes effect, also when the block failed
        if received.signum is not None:
            _deliver(received.signum, saved.get(received.signum))


def _deliver(signum: int, handler: Handler) -> None:
    """Act on a held signal as its handler would have when it arrived."""
    if callable(handler):
        handler(signum, None)
    elif handler == signal.SIG_DFL:
        signal.raise_signal(signum)
