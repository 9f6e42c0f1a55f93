"""Holding Ctrl-C and SIGTERM for a few milliseconds of work that must not be cut in two (the
renames that put a set of results in place, the end of the worker pool)."""

from __future__ import annotations

import contextlib
import signal
import threading


@contextlib.contextmanager
def signals_held(*, deliver: bool = True):
    """Hold Ctrl-C and SIGTERM for the ``with`` block: a signal that arrives meanwhile is
    recorded, and (``deliver``) acts with its own handler right after the block. Elsewhere
    than on the main thread (where no handler can be set) the block runs as it is.

    Parameters
    ----------
    deliver : bool, default True
        Deliver the held signals after the block; False: drop them (the block is the end of
        the process's work).

    Yields
    ------
    list of int
        The signals that arrived during the block (filled as they arrive).

    Examples
    --------
    >>> import os
    >>> with signals_held(deliver=False) as caught:
    ...     os.kill(os.getpid(), signal.SIGTERM)   # held: the process is not ended
    >>> caught == [signal.SIGTERM]
    True
    """
    caught: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield caught
        return
    signums = (signal.SIGINT, signal.SIGTERM)
    old = {s: signal.getsignal(s) for s in signums}
    held = [s for s in signums if old[s] not in (signal.SIG_IGN, None)]
    for s in held:
        signal.signal(s, lambda signum, frame: caught.append(signum))
    try:
        yield caught
    finally:
        for s in held:
            signal.signal(s, old[s])
        if deliver:
            for s in dict.fromkeys(caught):
                signal.raise_signal(s)
