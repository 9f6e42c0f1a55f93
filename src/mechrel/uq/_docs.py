"""Docstring text the estimators share, written once and filled in at import (the pattern of
SciPy's ``scipy._lib.doccer``).

A docstring line that holds only ``%(name)s`` is replaced by the block ``name`` of
:data:`BLOCKS`, each line indented as the placeholder was; numpydoc, Sphinx and ``help()`` see
the filled text. An unknown name fails at import with the names allowed.
"""

from __future__ import annotations

import re

BLOCKS = {
    "executor": """\
n_jobs : int, default 1
    Parallel workers: an integer >= 1, or -1 for all cores (all Dask workers); a local pool
    has at most one worker per core and per chunk of samples.
backend : {"loky", "dask", "sequential"}, default "loky"
    Where the model runs (:func:`mechrel.uq.evaluate`); the numbers do not depend on it.
cache : path or None
    SQLite cache of finished evaluations (an interrupted run resumes), or None.
progress : bool, default True
    Show a progress bar.
chunk_size : int, optional
    Samples per task (default: about 64 chunks; never depends on ``n_jobs``).""",
}
"""The shared blocks by name: ``executor`` documents the arguments an estimator passes on to
:func:`mechrel.uq.evaluate`."""

_PLACEHOLDER = re.compile(r"^(?P<indent>[ ]*)%\((?P<name>\w+)\)s[ ]*$", re.MULTILINE)


def fill_doc(func):
    """``func`` with each placeholder line of its docstring replaced by its block (module
    docstring).

    Parameters
    ----------
    func : callable
        A function whose docstring holds ``%(name)s`` lines.

    Returns
    -------
    callable
        ``func`` itself, its ``__doc__`` filled.

    Raises
    ------
    KeyError
        A placeholder names no block (the message lists the blocks).

    Examples
    --------
    >>> @fill_doc
    ... def f(n_jobs=1, backend="loky", cache=None, progress=True, chunk_size=None):
    ...     '''Do it.
    ...
    ...     Parameters
    ...     ----------
    ...     %(executor)s
    ...     '''
    >>> f.__doc__.splitlines()[4]
    '    n_jobs : int, default 1'
    """

    def block(m: re.Match) -> str:
        name = m.group("name")
        if name not in BLOCKS:
            raise KeyError(f"{func.__qualname__}: docstring placeholder %({name})s: no such block; "
                           f"allowed: {sorted(BLOCKS)}")
        return "\n".join(m.group("indent") + line if line else line
                         for line in BLOCKS[name].splitlines())

    if func.__doc__:
        func.__doc__ = _PLACEHOLDER.sub(block, func.__doc__)
    return func
