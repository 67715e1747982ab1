"""Atomic files: what a user keeps is never half-written, and never written over what is not a file.

The one way this project writes a user's file:

* the output path is checked before the work starts (:func:`check_output`):
  its folder exists and can be written, and the target is absent or a
  regular file (a symlink is followed to its target, and the link kept);
  devices, FIFOs, sockets and folders are refused, with a message naming the
  path the user gave;
* data goes to a temporary file beside the target and is renamed over it
  (``os.replace``, atomic on POSIX and Windows) only on :meth:`AtomicFile.commit`,
  so a crash, a pulled plug or a signal leaves either the old file or the new
  one;
* an exception, Ctrl-C, SIGTERM or SIGHUP during the write discards the
  temporary file; a signal that arrives while a finished file is being
  committed waits until it is in place (:func:`tracker.signals.deferred`);
* a temporary file never outlives the process: any not committed or
  discarded when the interpreter exits is removed then.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import stat
import tempfile
from pathlib import Path
from typing import IO, Iterator

from .signals import deferred


class OutputError(OSError):
    """An output path that cannot be written, worded for the user (it names their path)."""


def _kind(mode: int) -> str | None:
    """What a non-regular file is, in words; None for a regular file."""
    for test, kind in ((stat.S_ISDIR, "a folder"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISFIFO, "a pipe (FIFO)"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return kind
    return None if stat.S_ISREG(mode) else "not a regular file"


def _refuse_non_regular(shown: str, target: Path) -> None:
    """An OutputError when ``target`` exists and is not a regular file."""
    try:
        mode = os.stat(target).st_mode
    except FileNotFoundError:
        return
    except OSError as e:
        raise OutputError(f"cannot write {shown}: {e.strerror or e}") from None
    kind = _kind(mode)
    if kind == "a folder":
        raise OutputError(f"{shown} is a folder: name a file to write (e.g. {Path(shown) / 'out'})")
    if kind:
        raise OutputError(f"{shown} is {kind}, not a regular file: refusing to write over it")


def check_output(path: str | os.PathLike) -> Path:
    """The real file to write for the output ``path``, or an :class:`OutputError` naming ``path``.

    Symlinks are followed (the link stays, its target is replaced); the
    target must be absent or a regular file the user may write, in a folder
    that exists and can be written.
    """
    shown = os.fspath(path)
    if not shown:
        raise OutputError("an empty output path: name a file to write")
    _refuse_non_regular(shown, Path(shown))  # stat follows every link, /dev/stdout's and /proc's too
    target = Path(os.path.realpath(shown))
    folder = target.parent
    given = Path(shown).parent  # the folder as the user wrote it, unless a symlink led elsewhere
    named = given if os.path.realpath(given) == str(folder) else folder
    if not folder.is_dir():
        raise OutputError(f"cannot write {shown}: the folder {named} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputError(f"cannot write {shown}: no permission to write in the folder {named}")
    if target.exists() and not os.access(target, os.W_OK):
        raise OutputError(f"cannot write {shown}: it is read-only")
    return target


def same_output(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether two output paths name one file (other spellings, symlinks and hard links included)."""
    ra, rb = os.path.realpath(a), os.path.realpath(b)
    if ra == rb:
        return True
    try:
        return os.path.samefile(ra, rb)
    except OSError:  # one of them does not exist yet: then only equal real paths are one file
        return False


def _umask() -> int:
    """The process's umask (read by setting it, so set back at once)."""
    umask = os.umask(0)
    os.umask(umask)
    return umask


_PENDING: set["AtomicFile"] = set()  # temporary files neither committed nor discarded yet


class AtomicFile:
    """A file opened for writing that appears at ``path`` only on :meth:`commit`.

    As a context manager it commits when the block ends normally and
    discards the temporary file when the block raises, interruptions
    (``KeyboardInterrupt``, :class:`tracker.signals.Interrupted`) included:
    data cut off mid-write is never committed. A caller for whom an
    interruption is a normal end (``armtracker record``) catches it and
    calls :meth:`commit` itself.
    """

    def __init__(self, path: str | os.PathLike, mode: str = "wb", newline: str | None = None) -> None:
        self.shown = os.fspath(path)  # as the user wrote it, for messages
        self.path = check_output(path)
        self.published = False  # in place already (publish), written as it goes
        with deferred():  # a temporary file, once it exists, is open and known to _PENDING
            try:
                fd, tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".part", dir=self.path.parent)
            except OSError as e:
                raise OutputError(f"cannot write {self.shown}: {e.strerror or e}") from None
            self._tmp = Path(tmp)
            try:
                os.chmod(fd, 0o666 & ~_umask())  # mkstemp makes 0600; a saved file gets the usual mode
                self.file: IO = os.fdopen(fd, mode, newline=newline) if "b" not in mode else os.fdopen(fd, mode)
            except OSError as e:
                os.close(fd)
                self._tmp.unlink(missing_ok=True)
                raise OutputError(f"cannot write {self.shown}: {e.strerror or e}") from None
            _PENDING.add(self)

    def commit(self) -> None:
        """Flush to disk and rename over the target; a signal meanwhile waits until it is done."""
        with deferred(), self._dropped_on_failure():
            self.file.flush()
            os.fsync(self.file.fileno())
            self.file.close()
            if not self.published:
                _refuse_non_regular(self.shown, self.path)  # the target may have changed since the check
                os.replace(self._tmp, self.path)
            _PENDING.discard(self)

    def publish(self) -> None:
        """Put the file in place now and keep writing to it: for a file written as it goes (a session
        recording), whose every flushed part is to be kept, a crash included. Then :meth:`commit`
        only flushes and closes it, and :meth:`discard` only closes it."""
        with deferred(), self._dropped_on_failure():
            self.file.flush()
            os.fsync(self.file.fileno())
            _refuse_non_regular(self.shown, self.path)
            os.replace(self._tmp, self.path)
            self.published = True
            _PENDING.discard(self)

    @contextlib.contextmanager
    def _dropped_on_failure(self) -> Iterator[None]:
        """Any failure drops the temporary file; an OSError becomes an OutputError naming the user's path."""
        try:
            yield
        except OSError as e:
            self._drop()
            if isinstance(e, OutputError):
                raise
            raise OutputError(f"cannot write {self.shown}: {e.strerror or e}") from None
        except BaseException:
            self._drop()
            raise

    def discard(self) -> None:
        """Drop the temporary file; the target is untouched. A signal meanwhile waits until it is done."""
        with deferred():
            self._drop()

    def _drop(self) -> None:
        try:
            self.file.close()
        except OSError:
            pass  # a failed flush of data we are throwing away anyway
        if not self.published:
            self._tmp.unlink(missing_ok=True)
        _PENDING.discard(self)

    def __enter__(self) -> "AtomicFile":
        return self

    def __exit__(self, exc_type: type | None, exc: BaseException | None, tb: object) -> None:
        if exc_type is None:
            self.commit()
            return
        self.discard()
        if isinstance(exc, OSError) and not isinstance(exc, OutputError):  # e.g. the disk filled up
            raise OutputError(f"cannot write {self.shown}: {exc.strerror or exc}") from None


def atomic_write(path: str | os.PathLike, data: bytes | str) -> None:
    """Write a whole file atomically."""
    with AtomicFile(path, "wb") as f:
        f.file.write(data.encode() if isinstance(data, str) else data)


@atexit.register
def discard_pending() -> None:
    """Remove every temporary file not committed or discarded (also run when the interpreter exits)."""
    for f in list(_PENDING):
        f.discard()
