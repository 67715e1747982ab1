"""Atomic files: what a user keeps is never half-written.

Data goes to a temporary file beside the target and is renamed over it only
when complete (``os.replace`` is atomic on POSIX and Windows), so a crash,
a pulled plug or Ctrl-C leaves either the old file or the new one.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import IO


class AtomicFile:
    """A file opened for writing that appears at ``path`` only on :meth:`commit`.

    As a context manager it commits when the block ends, also on
    ``KeyboardInterrupt`` (what was written is complete up to that point),
    and discards the temporary file on any other exception.
    """

    def __init__(self, path: str | os.PathLike, mode: str = "wb", newline: str | None = None) -> None:
        self.path = Path(path)
        fd, tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".part",
                                   dir=self.path.parent if str(self.path.parent) else ".")
        self._tmp = Path(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(fd, 0o666 & ~umask)  # mkstemp makes 0600; a saved file gets the usual mode
        self.file: IO = os.fdopen(fd, mode, newline=newline) if "b" not in mode \
            else os.fdopen(fd, mode)

    def commit(self) -> None:
        """Flush to disk and rename over the target."""
        try:
            self.file.flush()
            os.fsync(self.file.fileno())
            self.file.close()
            os.replace(self._tmp, self.path)
        except BaseException:
            self.discard()
            raise

    def discard(self) -> None:
        """Drop the temporary file; the target is untouched."""
        self.file.close()
        self._tmp.unlink(missing_ok=True)

    def __enter__(self) -> "AtomicFile":
        return self

    def __exit__(self, exc_type: type | None, *rest: object) -> None:
        if exc_type is None or issubclass(exc_type, KeyboardInterrupt):
            self.commit()
        else:
            self.discard()


def atomic_write(path: str | os.PathLike, data: bytes | str) -> None:
    """Write a whole file atomically."""
    with AtomicFile(path, "wb") as f:
        f.file.write(data.encode() if isinstance(data, str) else data)
