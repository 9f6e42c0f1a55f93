"""Writing result tables (CSV or Parquet, by file extension), provenance (JSON) and figures.

Every file is written atomically: into a temporary file in the same folder, flushed to disk,
then renamed over the target (``os.replace``, atomic on POSIX and Windows). A reader — or the
next run after a crash, a full disk or Ctrl-C — sees the previous complete file or the new
complete file, never a truncated one; a failed write removes its temporary file and raises one
:class:`~mechrel.errors.OutputError` naming the path.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import tempfile
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
        fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp" + path.suffix,
                                        dir=path.parent)
        os.close(fd)
    except OSError as exc:
        raise OutputError(f"{what}: cannot write into the folder {str(path.parent)!r} "
                          f"({exc.strerror or exc}); allowed: a writable folder") from None
    tmp = Path(tmp_name)
    try:
        yield tmp
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        raise OutputError(f"{what}: cannot write {str(path)!r} ({exc.strerror or exc}); the "
                          "previous file, if any, is unchanged; allowed: a path in a writable "
                          "folder on a disk with free space") from None
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()


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


def write_json(data: dict, path) -> Path:
    """Write a dict (numpy values allowed; non-finite floats as strings) as indented JSON,
    atomically.

    Parameters
    ----------
    data : dict
        The content.
    path : str or os.PathLike
        The file; its folder is created.

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
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(_jsonable(data), indent=2) + "\n"
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path
