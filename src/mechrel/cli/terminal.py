"""What the ``mechrel`` command writes to the terminal: one line per line, with the control
characters of names, keys, values and paths escaped.

A scene, study, input or output name, a ``--set`` key or value, a path: anything a user (or a
file a user was sent) put into a message reaches the terminal through :func:`say`, which writes
each line with its control characters escaped (``\\x1b`` as ``\\x1b``, a newline as ``\\n``,
and the bidirectional-text controls that reorder what a terminal shows). An escape sequence in
a study's name can then not clear the screen or retitle the window, and a newline in a name
cannot forge a ``mechrel: error:`` line of its own.
"""

from __future__ import annotations

import sys

# C0 and C1 controls and DEL (Unicode category Cc), and the bidirectional formatting characters
_BIDI = "\u061c\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069"
_NAMED = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}
_ESCAPES = {c: _NAMED.get(chr(c), f"\\x{c:02x}") for c in (*range(0x20), 0x7f)}
_ESCAPES.update({c: f"\\x{c:02x}" for c in range(0x80, 0xa0)})
_ESCAPES.update({ord(c): f"\\u{ord(c):04x}" for c in _BIDI})


def printable(text: object) -> str:
    """``text`` as one line a terminal shows as it is: control characters escaped.

    Parameters
    ----------
    text : object
        The line (``str()`` of it).

    Returns
    -------
    str
        The line with every C0/C1 control character, DEL and bidirectional formatting character
        written as an escape (``\\n``, ``\\t``, ``\\x1b``, ``\\u202e``); a backslash is left
        as it is.

    Examples
    --------
    >>> printable("study \\x1b[2J\\nmechrel: error: forged")
    'study \\\\x1b[2J\\\\nmechrel: error: forged'
    >>> printable("µ = 0.1 — plain text ±")
    'µ = 0.1 — plain text ±'
    """
    return str(text).translate(_ESCAPES)


def say(*lines: object, file=None) -> None:
    """Write each of ``lines`` as one escaped line (:func:`printable`) to ``file`` (default:
    standard output).

    Parameters
    ----------
    *lines : object
        The lines; each is one line on the terminal, whatever it holds.
    file : file-like, optional
        Where to write (default ``sys.stdout``).

    Examples
    --------
    >>> say("first", "second\\x07")
    first
    second\\x07
    """
    out = sys.stdout if file is None else file
    for line in lines:
        print(printable(line), file=out)
