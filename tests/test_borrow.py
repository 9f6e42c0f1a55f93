"""``mechrel.mechanics.borrow.borrowed``: the same arrays without reference counting.

The kernels rely on three facts, each checked here: a borrowed array is the same memory as its
owner (reads and writes go through), the value keeps its (named, nested) tuple type so the
kernels' code does not change, and the meminfo pointer, which Numba's reference counting
follows, is null (the point of it: see the module docstring and docs/performance.md).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pytest
from numba import njit, types
from numba.core import cgutils
from numba.core.errors import TypingError
from numba.core.typing import signature
from numba.extending import intrinsic
from numba.np.arrayobj import make_array

from mechrel.mechanics.borrow import borrowed


@intrinsic
def _meminfo_is_null(typingctx, arr):
    """True if ``arr``'s NRT meminfo pointer is null (test-only probe)."""
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, sig, args):
        a = make_array(sig.args[0])(context, builder, value=args[0])
        return builder.icmp_unsigned("==", a.meminfo, cgutils.get_null_value(a.meminfo.type))

    return signature(types.boolean, arr), codegen


class Pair(NamedTuple):
    a: np.ndarray
    b: np.ndarray
    scale: float


@njit
def _null_flags(pair, c):
    """Meminfo-null flags of the owners and of the borrowed copies."""
    p, (c2, k) = borrowed((pair, (c, 3)))
    return (_meminfo_is_null(pair.a), _meminfo_is_null(c),
            _meminfo_is_null(p.a), _meminfo_is_null(p.b), _meminfo_is_null(c2), k, p.scale)


@njit
def _write_through(pair, c):
    """Writes through borrowed arrays and a borrowed slice; returns a sum read through them."""
    p, c2 = borrowed((pair, c))
    row = c2[1]  # a view of a borrowed array is borrowed too
    for i in range(p.a.shape[0]):
        p.a[i] = 2.0 * p.b[i] * p.scale
        row[i] = -1.0
    s = 0.0
    for i in range(p.a.shape[0]):
        s += p.a[i]
    return s, _meminfo_is_null(row)


def test_owners_are_counted_and_borrowed_copies_are_not():
    pair = Pair(np.zeros(3), np.arange(3.0), 0.5)
    c = np.zeros((2, 3))
    own_a, own_c, a, b, c2, k, scale = _null_flags(pair, c)
    assert (own_a, own_c) == (False, False)  # the probe can tell: arrays from Python are counted
    assert (a, b, c2) == (True, True, True)
    assert (k, scale) == (3, 0.5)  # scalars pass unchanged


def test_borrowed_arrays_are_the_same_memory():
    pair = Pair(np.zeros(4), np.arange(4.0), 0.5)
    c = np.zeros((2, 4))
    s, row_null = _write_through(pair, c)
    np.testing.assert_array_equal(pair.a, np.arange(4.0))  # 2 b · 0.5, written through
    assert s == 6.0
    np.testing.assert_array_equal(c, [[0.0] * 4, [-1.0] * 4])
    assert row_null


def test_borrowed_keeps_the_type():
    @njit
    def same(pair):
        return borrowed(pair).scale + borrowed(pair.a)[0]

    assert same(Pair(np.ones(2), np.ones(2), 2.0)) == 3.0
    assert same.nopython_signatures[0].args[0].name.startswith("Pair(")


def test_borrowed_refuses_what_has_no_arrays_to_borrow():
    @njit
    def scalar(x):
        return borrowed(x)

    with pytest.raises(TypingError, match="borrowed"):
        scalar(1.0)
