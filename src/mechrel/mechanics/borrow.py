"""Arrays without reference counting inside the compiled kernels: :func:`borrowed`.

Why. Numba counts references to every array through its NRT meminfo with atomic increments and
decrements. A compiled function pays a pair each time it binds an array (taking it out of a
tuple, as ``sys.rev_i``, slicing it, as ``K[s]``, or aliasing it) and when the binding dies, and
Numba's reference-count pruning pass leaves most of these pairs in place across the loops,
branches and calls of the right-hand side. On the dry slider-crank, ``perf`` attributed about
30 % of an RK4 run's samples to ``NRT_incref``/``NRT_decref`` (docs/dev/performance-log.md,
"Where the targets stand"). For an array whose meminfo pointer is null, the same increment and
decrement are a test for null and nothing else.

The rules.

* A *called* kernel function takes its arrays borrowed at entry,
  ``sys, ws, K = borrowed((sys, ws, K))``: the caller's references (the arguments) keep the
  memory alive for the duration of the call, which is exactly how long the borrowed copies are
  used.
* A function compiled with ``inline='always'`` does not borrow its arguments. Numba inlines
  it into its caller's code, where the caller's own reference to an array it allocated dies
  at its last use, which may be the inlined call: Numba frees the array there, and borrowed
  copies made inside the inlined body would point into freed memory. (Measured: Radau's
  Jacobian helper, when it still borrowed, inlined into a wrapper that did not use its work
  arrays after the call, read freed memory and divided by zero; inside Radau's step loop the
  same arrays stayed alive only because the loop used them again.)
* A function that allocates arrays and wants them borrowed keeps the owners alive itself:
  ``owners = (a, b)``, ``a, b = borrowed(owners)``, and :func:`keep_alive` ``(owners)``
  where the borrowed copies are last used (before the return).
* A borrowed array must never outlive its owner: never return it, store it in a container
  that outlives its owner, or box it to Python.
"""

from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.core.typing import signature
from numba.extending import intrinsic
from numba.np.arrayobj import make_array


def _borrow(context, builder, ty, val):
    """``val`` of Numba type ``ty`` with the meminfo and parent of every array in it nulled."""
    if isinstance(ty, types.Array):
        arr = make_array(ty)(context, builder, value=val)
        arr.meminfo = cgutils.get_null_value(arr.meminfo.type)
        arr.parent = cgutils.get_null_value(arr.parent.type)
        return arr._getvalue()
    if isinstance(ty, types.BaseTuple):
        for i, member in enumerate(ty.types):
            val = builder.insert_value(val, _borrow(context, builder, member,
                                                         builder.extract_value(val, i)), i)
    return val


@intrinsic
def borrowed(typingctx, value):
    """``value`` (an array, or a tuple, possibly named and nested, of arrays and scalars) with
    every array's NRT meminfo and parent pointers set to null: the same memory, the same type,
    no reference counting (module docstring). Only inside compiled code; only for as long as
    the caller's own reference keeps ``value`` alive."""
    if not isinstance(value, (types.Array, types.BaseTuple)):
        return None

    def codegen(context, builder, sig, args):
        return _borrow(context, builder, sig.args[0], args[0])

    return signature(value, value), codegen


@intrinsic
def keep_alive(typingctx, value):
    """Use ``value`` here and do nothing else: Numba keeps a variable (and the arrays it owns)
    alive until its last use, so ``keep_alive(owners)`` at the end of a function holds the
    owners of the arrays borrowed from them until that point (module docstring). It
    generates no code and no reference counting."""

    def codegen(context, builder, sig, args):
        return context.get_dummy_value()

    return signature(types.none, value), codegen
