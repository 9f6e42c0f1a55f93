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

from mechrel.mechanics.borrow import borrowed, keep_alive


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


@njit
def _borrow_own_array(n):
    """Borrow an array this function allocated, then allocate more arrays of its size (which
    the allocator places in any block freed meanwhile), and read the borrowed copy after them,
    with the owner held by ``keep_alive`` (the third rule of the module docstring)."""
    a = np.full(n, 3.0)
    owners = (a,)
    (b,) = borrowed(owners)
    s = 0.0
    for _ in range(4):
        c = np.full(n, 7.0)
        s += c[1]
    v = b[0] + b[n - 1]
    keep_alive(owners)
    return v, s


def test_keep_alive_holds_the_owner_of_a_borrowed_array():
    # Without keep_alive the owner ``a`` dies at ``borrowed`` and Numba frees it there: with
    # glibc's allocator the next array of the same size (1000 doubles) takes its block and the
    # borrowed copy reads 7 + 7 = 14 (measured while writing this test; 100 000 doubles, which
    # are unmapped when freed, crashed the process). Held until the read, it reads 3 + 3.
    assert _borrow_own_array(1000) == (6.0, 28.0)
    assert _borrow_own_array(100_000) == (6.0, 28.0)



def _jacobian_wrapper(keep):
    """Radau's Jacobian helper (inlined) called as another kernel would, with work arrays the
    wrapper allocates; with ``keep`` the wrapper returns them too (so they outlive the call),
    without it they die at the call."""
    from mechrel.integrate.events import N_STATS
    from mechrel.integrate.radau import _update_jacobian
    from mechrel.mechanics.formulation import evaluate, has_fast_part, make_work

    def jacobian(t, y, hist, red, smooth):
        ny = y.shape[0]
        nq = (ny - 2) // 2
        ws = make_work(red)
        f0 = np.zeros(ny)
        evaluate(t, y, hist, red, ws, f0)
        J = np.zeros((ny, ny))
        JS = np.zeros((ny, ny))
        Jsm = np.zeros((ny - nq, 2 * nq))
        yp = np.zeros(ny)
        fa = np.zeros(ny)
        fb = np.zeros(ny)
        stats = np.zeros(N_STATS)
        _update_jacobian(t, y, f0, hist, red, smooth, ws, J, JS, Jsm, np.bool_(False),
                         np.int64(0), has_fast_part(red), 1e-3, yp, fa, fb, stats)
        if keep:
            return J, (f0, JS, Jsm, yp, fa, fb, stats)
        return J, None

    return njit(jacobian)


# compiles its own callers of the inlined Radau helpers (20-50 s on two cores)
@pytest.mark.slow
def test_radau_inlined_helpers_work_on_a_callers_own_arrays():
    # Radau's inlined step helpers used to borrow their arguments. Inlined into a caller whose
    # work arrays died at the call, the Jacobian helper read freed memory (the reduced
    # slider-crank's raised ZeroDivisionError). The caller's arrays' lifetime must not change
    # a bit of the result.
    from mechrel.integrate.radau import reduced_system
    from mechrel.mechanics.kinematics import assemble
    from mechrel.mechanics.reduced import reduced_coordinates
    from mechrel.mechanics.system import compile_scene, without_clearance_forces
    from mechrel.scene import load_scene

    c = compile_scene(load_scene("slider-crank-lubricated"))
    q, v = assemble(c.assembly, c.q_guess, 0.0)
    red = reduced_system(c.dynamic, np.concatenate([q, v, np.zeros(2)]))
    smooth = red._replace(sys=without_clearance_forces(c.dynamic))
    y = np.asarray(reduced_coordinates(c.dynamic, red.con, q, v), dtype=float)
    y[:2] = (2e-4, -1e-4)  # off centre: the film carries load, the fast part is not zero
    args = (0.01, y, np.zeros(0), red, smooth)
    J_kept, _ = _jacobian_wrapper(True)(*args)
    J_fresh, _ = _jacobian_wrapper(False)(*args)
    assert np.abs(J_kept[2:4, :4]).max() > 1e3  # a film's stiffness and damping are in it
    np.testing.assert_array_equal(J_fresh, J_kept)
