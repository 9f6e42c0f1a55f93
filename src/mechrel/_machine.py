"""What this machine has, asked of the operating system once per process."""

from __future__ import annotations

import functools
import os

__all__ = ["physical_memory"]


@functools.cache
def physical_memory() -> int | None:
    """Bytes of physical memory of this machine, or None where the OS does not say (not
    POSIX): the memory checks of output grids and sample counts then let the run go.

    Asked once per process (it does not change while the process runs): a Monte Carlo
    sample's output grid is checked against it at every run.

    Returns
    -------
    int or None
        ``SC_PHYS_PAGES × SC_PAGE_SIZE`` (bytes).

    Examples
    --------
    >>> m = physical_memory()
    >>> m is None or m > 2**20
    True
    """
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):  # pragma: no cover - not POSIX
        return None
