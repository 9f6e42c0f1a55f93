"""An exclusive lock on an output folder, so that two runs sharing it do not both evaluate
everything (the last writer winning): the second is refused at once, naming the first.

The lock is an advisory OS lock (``fcntl.flock`` on POSIX, ``msvcrt.locking`` on Windows) on
the file ``.mechrel.lock`` in the folder, which holds the process id of its holder. The OS
drops the lock when its holder ends, however it ends (``kill -9`` included), so a stale lock
file never blocks a later run; the file itself stays (removing it would race with a run that
has just opened it).
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

from ..errors import OutputError

LOCK_NAME = ".mechrel.lock"

try:  # POSIX
    import fcntl

    def _try_lock(fd: int) -> bool:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return False
        return True

    def _unlock(fd: int) -> None:
        fcntl.flock(fd, fcntl.LOCK_UN)
except ImportError:  # pragma: no cover - Windows
    import msvcrt

    def _try_lock(fd: int) -> bool:
        os.lseek(fd, 0, os.SEEK_SET)
        try:
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)  # type: ignore[attr-defined]  # Windows
        except OSError:
            return False
        return True

    def _unlock(fd: int) -> None:
        os.lseek(fd, 0, os.SEEK_SET)
        msvcrt.locking(fd, msvcrt.LK_UNLCK, 1)  # type: ignore[attr-defined]  # Windows


def _holder(fd: int) -> str:
    os.lseek(fd, 0, os.SEEK_SET)
    text = os.read(fd, 32).decode("ascii", "replace").strip()
    return text if text.isdigit() else "unknown"


@contextlib.contextmanager
def hold_folder(folder, *, what: str = "out"):
    """Hold the lock on ``folder`` (which exists) for the ``with`` block.

    Parameters
    ----------
    folder : str or os.PathLike
        An existing folder.
    what : str, default "out"
        What named the folder (the option or field), for messages.

    Yields
    ------
    pathlib.Path
        The folder, locked by this process until the block ends.

    Raises
    ------
    OutputError
        ``another run (pid N) holds FOLDER``, when another process holds it; or when the lock
        file cannot be created (a read-only folder).

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     with hold_folder(folder) as held:
    ...         print((Path(held) / LOCK_NAME).read_text().strip() == str(os.getpid()))
    True
    """
    folder = Path(folder)
    path = folder / LOCK_NAME
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise OutputError(f"{what} = {str(folder)!r}: cannot create the lock file {LOCK_NAME} "
                          f"({exc.strerror or exc}); allowed: a writable folder") from None
    try:
        try:
            locked = _try_lock(fd)
        except OSError as exc:  # e.g. ENOLCK: a file system without locks
            raise OutputError(f"{what} = {str(folder)!r}: cannot lock the folder "
                              f"({exc.strerror or exc}); allowed: a folder on a file system "
                              "that supports file locks") from None
        if not locked:
            raise OutputError(f"{what} = {str(folder)!r}: another run (pid {_holder(fd)}) holds "
                              f"{folder}; allowed: wait for it to finish, or give this run "
                              "another output folder")
        try:
            os.ftruncate(fd, 0)
            os.lseek(fd, 0, os.SEEK_SET)
            os.write(fd, f"{os.getpid()}\n".encode("ascii"))
            yield folder
        finally:
            _unlock(fd)
    finally:
        os.close(fd)
