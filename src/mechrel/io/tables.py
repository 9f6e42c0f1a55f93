"""Writing result tables (CSV or Parquet, by file extension), provenance (JSON) and figures.

Every file is written atomically: into a temporary file in the same folder, flushed to disk,
then renamed over the target (``os.replace``, atomic on POSIX and Windows). A reader — or the
next run after a crash, a full disk or Ctrl-C — sees the previous complete file or the new
complete file, never a truncated one; a failed write removes its temporary file and raises one
:class:`~mechrel.errors.OutputError` naming the path.
"""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import re
import secrets
from pathlib import Path

import numpy as np

from ..errors import OutputError

TABLE_SUFFIXES = (".csv", ".parquet")


def check_table_path(path) -> Path:
    """``path`` as a table file that can be written: a ``.csv`` or ``.parquet`` name (the
    latter with pyarrow installed) in a folder that exists or can be created. Called before a
    long computation, so that a wrong ``--out`` fails at once, not after it.

    Parameters
    ----------
    path : str or os.PathLike
        The table file to be written.

    Returns
    -------
    pathlib.Path
        ``path``; its folder now exists.

    Raises
    ------
    mechrel.errors.OutputError
        Wrong extension, Parquet without pyarrow, a folder of that name, or a folder that
        cannot be created.

    Examples
    --------
    >>> check_table_path("results.xlsx")
    Traceback (most recent call last):
    ...
    mechrel.errors.OutputError: --out: 'results.xlsx' has extension '.xlsx'; allowed: .csv, .parquet
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in TABLE_SUFFIXES:
        raise OutputError(f"--out: {str(path)!r} has extension {suffix or '(none)'!r}; "
                           f"allowed: {', '.join(TABLE_SUFFIXES)}")
    if suffix == ".parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            raise OutputError("--out: writing Parquet needs pyarrow: pip install "
                               "'mechrel[parquet]', or write .csv") from None
    if path.is_dir():
        raise OutputError(f"--out: {str(path)!r} is a folder; allowed: a file name ending in "
                           f"{' or '.join(TABLE_SUFFIXES)}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"--out: cannot create the folder {str(path.parent)!r} "
                           f"({exc.strerror}); allowed: a path in a writable folder") from None
    return path


@contextlib.contextmanager
def atomic_path(path, *, what: str = "--out"):
    """Yield a temporary path beside ``path`` (same suffix, so that writers that choose the
    format by suffix still do); on success it is flushed and renamed to ``path``, on any error
    removed. ``OSError`` (a folder in place of the file, a read-only folder, a full disk)
    becomes one :class:`~mechrel.errors.OutputError` naming ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        The file to be written.
    what : str, default "--out"
        What named the file (the option or field), for messages.

    Yields
    ------
    pathlib.Path
        The temporary file to write.

    Raises
    ------
    mechrel.errors.OutputError
        ``path`` is a folder, or the file cannot be written.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     target = Path(folder) / "notes.txt"
    ...     with atomic_path(target) as tmp:
    ...         _ = tmp.write_text("complete", encoding="utf-8")
    ...     print(target.read_text(encoding="utf-8"), [p.name for p in Path(folder).iterdir()])
    complete ['notes.txt']
    """
    path = Path(path)
    if path.is_dir():
        raise OutputError(f"{what}: {str(path)!r} is a folder; allowed: a file name (remove or "
                          "rename the folder)")
    try:
        tmp = _new_file_beside(path)
    except OSError as exc:
        raise OutputError(f"{what}: cannot write into the folder {str(path.parent)!r} "
                          f"({exc.strerror or exc}); allowed: a writable folder") from None
    try:
        yield tmp
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        with contextlib.suppress(FileNotFoundError):  # a replaced file keeps its permissions
            os.chmod(tmp, path.stat().st_mode & 0o7777)
        os.replace(tmp, path)
    except OSError as exc:
        raise OutputError(f"{what}: cannot write {str(path)!r} ({exc.strerror or exc}); the "
                          "previous file, if any, is unchanged; allowed: a path in a writable "
                          "folder on a disk with free space") from None
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()


def _new_file_beside(path: Path) -> Path:
    """A new, empty file ``.NAME.RANDOM.tmpSUFFIX`` beside ``path``, created with the mode a
    new file gets (0666 less the umask; ``tempfile.mkstemp`` makes every file 0600, so that
    results renamed into place were unreadable to the user's group whatever the umask)."""
    for _ in range(100):
        tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp{path.suffix}")
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
        except FileExistsError:
            continue
        return tmp
    raise FileExistsError(errno.EEXIST, "no free temporary file name", str(path.parent))


def write_table(frame, path) -> Path:
    """Write a DataFrame to ``path`` atomically: ``.csv`` or ``.parquet`` (needs pyarrow).

    Parameters
    ----------
    frame : pandas.DataFrame
        The table (its index is not written).
    path : str or os.PathLike
        The file; its suffix chooses the format.

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    mechrel.errors.OutputError
        See :func:`check_table_path` and :func:`atomic_path`.

    Examples
    --------
    >>> import tempfile
    >>> import pandas as pd
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = write_table(pd.DataFrame({"time": [0.0, 0.1]}), Path(folder) / "t.csv")
    ...     print(path.read_text(encoding="utf-8"))
    time
    0.0
    0.1
    <BLANKLINE>
    """
    path = check_table_path(path)
    with atomic_path(path) as tmp:
        if path.suffix.lower() == ".csv":
            frame.to_csv(tmp, index=False)
        else:
            frame.to_parquet(tmp, index=False)
    return path


def save_figure(fig, path, **kwargs) -> Path:
    """``fig.savefig(path, **kwargs)`` atomically (format from ``path``'s suffix).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : str or os.PathLike
        The file; its folder is created.
    **kwargs
        Passed to ``savefig`` (e.g. ``dpi``).

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    mechrel.errors.OutputError
        The file cannot be written.

    Examples
    --------
    >>> import tempfile
    >>> from matplotlib.figure import Figure
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = save_figure(Figure(), Path(folder) / "sub" / "empty.png", dpi=50)
    ...     print(path.name, path.read_bytes()[1:4])
    empty.png b'PNG'
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fmt = path.suffix.lstrip(".").lower() or None
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=fmt, **kwargs)
    return path


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.floating, float)):
        x = float(x)
        return x if math.isfinite(x) else str(x)
    if isinstance(x, np.integer):
        return int(x)
    return x


def _relative(x, folder: str, prefixes: tuple[str, ...]):
    """``x`` with every string that is an absolute path made relative to ``folder``, and the
    folder's own name (as given, and absolute) dropped where a string names a file in it."""
    if isinstance(x, dict):
        return {k: _relative(v, folder, prefixes) for k, v in x.items()}
    if isinstance(x, list):
        return [_relative(v, folder, prefixes) for v in x]
    if not isinstance(x, str):
        return x
    if os.path.isabs(x):
        with contextlib.suppress(ValueError):  # another drive (Windows): kept as it is
            return os.path.relpath(x, folder)
    for prefix in prefixes:  # where a path starts: at the start, after a space or a quote
        x = re.sub(r"(?:^|(?<=[\s'\"(]))" + re.escape(prefix), "", x)
    return x


def write_json(data: dict, path, *, relative_to=None) -> Path:
    """Write a dict (numpy values allowed; non-finite floats as strings) as indented JSON,
    atomically.

    Parameters
    ----------
    data : dict
        The content.
    path : str or os.PathLike
        The file; its folder is created.
    relative_to : str or os.PathLike, optional
        The folder the file is for (its folder, unless it is written into a staging folder
        first): absolute paths in ``data`` are written relative to it, and ``FOLDER/`` before a
        file's name is dropped, so that the file holds no path of this machine.

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    mechrel.errors.OutputError
        The file cannot be written.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = write_json({"n": np.int64(3), "beta": float("inf")}, Path(folder) / "s.json")
    ...     print(path.read_text(encoding="utf-8"))
    {
      "n": 3,
      "beta": "inf"
    }
    <BLANKLINE>
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     data = {"cache": f"{folder}/evaluations.sqlite", "note": f"see {folder}/x.csv"}
    ...     path = write_json(data, Path(folder) / "s.json", relative_to=folder)
    ...     print(path.read_text(encoding="utf-8"))
    {
      "cache": "evaluations.sqlite",
      "note": "see x.csv"
    }
    <BLANKLINE>
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    data = _jsonable(data)
    if relative_to is not None:
        given = os.fspath(relative_to)
        folder = os.path.abspath(given)
        prefixes = tuple(dict.fromkeys(f.rstrip(os.sep) + os.sep for f in (folder, given)))
        data = _relative(data, folder, prefixes)
    text = json.dumps(data, indent=2) + "\n"
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path
