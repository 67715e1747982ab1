"""Opening a file a user named for reading: a regular file of bounded size, or one clear line.

Recordings, session recordings, trials and READMEs a user hands us are all
opened here, so a serial port, a FIFO, a terminal or ``/dev/zero`` named by
mistake is refused before it is opened (opening a serial port can reset a
board; reading a FIFO or a terminal can wait for ever; ``/dev/zero`` never ends).
"""

from __future__ import annotations

import os
import stat
from typing import IO, Callable

from .userjson import JSONInputError, parse_json

MAX_RECORDING_BYTES = 256 * 2**20  # about 11 hours of raw frames at 200 Hz (32 bytes each)


class RecordingError(Exception):
    """A recording that cannot be read, worded for the user."""


def _kind(mode: int) -> str:
    """What a file that is not a regular file is, in words."""
    for test, kind in ((stat.S_ISDIR, "a directory"), (stat.S_ISCHR, "a character device (a terminal or serial port?)"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return kind
    return "not a regular file"


def _megabytes(n: int) -> str:
    return f"{n / 2**20:.0f} MB" if n >= 2**20 else f"{n} bytes"


def open_input(path: str | os.PathLike, what: str = "recording",
               error: Callable[[str], Exception] = RecordingError,
               limit: int = MAX_RECORDING_BYTES) -> IO[bytes]:
    """Open a file a user named for reading: a regular file of at most ``limit`` bytes.

    Anything else raises ``error`` with one line naming the path: a missing or
    unreadable file, a directory, and devices, FIFOs and sockets, which are
    refused before they are opened (opening a serial port can reset a board,
    reading a FIFO or a terminal can wait for ever, ``/dev/zero`` never ends).
    The check is repeated on the open file, so a file swapped in between is
    refused too.
    """
    shown = os.fspath(path)
    try:
        before = os.stat(path)
        if not stat.S_ISREG(before.st_mode):
            raise error(f"{shown} is {_kind(before.st_mode)}, not a {what} file")
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_NONBLOCK", 0))
    except FileNotFoundError:
        raise error(f"no such file: {shown}") from None
    except OSError as e:
        raise error(f"cannot read {shown}: {e.strerror or e}") from None
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        os.close(fd)
        raise error(f"{shown} is {_kind(st.st_mode)}, not a {what} file")
    if st.st_size > limit:
        os.close(fd)
        raise error(f"{shown} is {_megabytes(st.st_size)}; a {what} of at most {_megabytes(limit)} is read")
    os.set_blocking(fd, True)
    return os.fdopen(fd, "rb")




def read_header_line(f: IO[bytes], path: str | os.PathLike, what: str, limit: int) -> object:
    """The JSON on the next line of an open file (a recording's header), or a RecordingError saying the
    ``what``'s header is damaged; the file is left at the next line."""
    line = f.readline(limit + 1)
    if not line.endswith(b"\n"):
        raise RecordingError(f"{os.fspath(path)}: the {what}'s header is damaged (no end of line within "
                             f"{limit // 1024} kB)")
    try:
        return parse_json(line, f"{os.fspath(path)}: the {what}'s header")
    except JSONInputError as e:
        raise RecordingError(f"{e}: the {what}'s header is damaged") from None
