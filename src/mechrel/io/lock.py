"""An exclusive lock on an output folder, so that two runs sharing it do not both evaluate
everything (the last writer winning): the second is refused at once, naming the first.

The lock is an advisory OS lock (``fcntl.flock`` on POSIX, ``msvcrt.locking`` on Windows) on
the file ``.mechrel.lock`` in the folder, which holds the process id of its holder. The OS
drops the lock when its holder ends, however it ends (``kill -9`` included), so a stale lock
file never blocks a later run. On POSIX the holder removes the file before it lets go of the
lock, and a run that locked a file checks that it is still the one in the folder (else it
opened it just before its removal, and starts again with a new one): no lock file is left
behind by a run that ended normally, refused or interrupted.
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

    _REMOVABLE = True  # an open file can be removed, and a lock follows the file, not its name
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

    _REMOVABLE = False  # an open file cannot be removed there: the lock file stays


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
    ...     print(sorted(os.listdir(folder)))   # released: the lock file is removed
    True
    []
    """
    folder = Path(folder)
    path = folder / LOCK_NAME
    while True:
        fd = _locked(path, folder, what)
        if _REMOVABLE and not _same_file(fd, path):
            os.close(fd)  # removed by its previous holder as we locked it: take a new one
            continue
        break
    try:
        os.ftruncate(fd, 0)
        os.lseek(fd, 0, os.SEEK_SET)
        os.write(fd, f"{os.getpid()}\n".encode("ascii"))
        yield folder
    finally:
        if _REMOVABLE:
            with contextlib.suppress(OSError):
                path.unlink()
        try:
            _unlock(fd)
        finally:
            os.close(fd)


def _same_file(fd: int, path: Path) -> bool:
    try:
        st = os.stat(path)
    except OSError:
        return False
    own = os.fstat(fd)
    return (st.st_dev, st.st_ino) == (own.st_dev, own.st_ino)


def _locked(path: Path, folder: Path, what: str) -> int:
    """An open descriptor of ``path`` holding its lock, or the error for a held or unusable
    lock file."""
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
    except BaseException:
        os.close(fd)
        raise
    return fd
