"""The problem interface the integrator kernels call, for either formulation.

A kernel receives the problem as a tuple of arrays: a :class:`~mechrel.mechanics.system.System`
(absolute coordinates, :mod:`mechrel.mechanics.problem`) or a
:class:`~mechrel.mechanics.reduced.ReducedSystem` (the clearance joints' relative coordinates,
:mod:`mechrel.mechanics.reduced`). Each operation below is one function whose implementation
numba picks at compile time from the type of that tuple (``numba.extending.overload``), so one
kernel source serves both formulations, each specialisation is cached on disk like any other
(passing compiled functions as arguments would recompile in every process,
docs/architecture.md), and the absolute path compiles to the code it compiled to before.

``new_workspace``: :func:`~.problem.make_workspace` or
:func:`~.reduced.make_reduced_workspace`; ``rhs`` (inlined for the absolute formulation) and
``rhs_call``: :func:`~.problem.rhs_inline` / :func:`~.problem.rhs_into` or
:func:`~.reduced.reduced_rhs_into`; ``gaps``: :func:`~.problem.gaps_into` or
:func:`~.reduced.reduced_gaps_into` (straight from ``z``); ``floors``: the contact floors of the
System (of ``ReducedSystem.dyn``); ``record``: max |Φ|, |Φ̇| of the evaluated state, or the
Newton and velocity residuals; ``n_coordinates``: ``n`` (3 per body) or ``2 nc``.

The state is ``y = (coordinates, their rates, W_in, W_cl)`` in both, so the kernels'
second-order structure (``dy/dt``'s first half is the second) holds for either.
"""

from __future__ import annotations

from numba import njit, types
from numba.extending import overload

from ..integrate.events import S_VIOL_POS, S_VIOL_VEL, contact_floors as _floors_of
from .problem import gaps_into, make_workspace, rhs_inline, rhs_into
from .reduced import (ReducedSystem, make_reduced_workspace, reduced_gaps_into,
                      reduced_rhs_into)


def _is_reduced(sys_type) -> bool:
    return (isinstance(sys_type, types.BaseNamedTuple)
            and sys_type.instance_class is ReducedSystem)


def new_workspace(sys):  # pragma: no cover - compiled only
    """The right-hand side's workspace for ``sys``."""
    raise NotImplementedError("called from compiled code only")


@overload(new_workspace)
def _ov_new_workspace(sys):
    if _is_reduced(sys):
        return lambda sys: make_reduced_workspace(sys)
    return lambda sys: make_workspace(sys)


def rhs(t, y, hist, sys, ws, out):  # pragma: no cover - compiled only
    """``dy/dt`` into ``out`` (inlined for the absolute formulation: one call site per
    kernel, as :func:`~mechrel.mechanics.problem.rhs_inline`)."""
    raise NotImplementedError("called from compiled code only")


@overload(rhs, inline='always')
def _ov_rhs(t, y, hist, sys, ws, out):
    if _is_reduced(sys):
        def impl(t, y, hist, sys, ws, out):
            reduced_rhs_into(t, y, hist, sys, ws, out)
        return impl

    def impl(t, y, hist, sys, ws, out):
        rhs_inline(t, y, hist, sys, ws, out)
    return impl


def rhs_call(t, y, hist, sys, ws, out):  # pragma: no cover - compiled only
    """``dy/dt`` into ``out``, as a call (for the sites that are not the hot loop)."""
    raise NotImplementedError("called from compiled code only")


@overload(rhs_call)
def _ov_rhs_call(t, y, hist, sys, ws, out):
    if _is_reduced(sys):
        def impl(t, y, hist, sys, ws, out):
            reduced_rhs_into(t, y, hist, sys, ws, out)
        return impl

    def impl(t, y, hist, sys, ws, out):
        rhs_into(t, y, hist, sys, ws, out)
    return impl


def gaps(t, y, sys, g, gd):  # pragma: no cover - compiled only
    """Penetration (m) and its rate (m/s) of the contact-capable joints into ``g``, ``gd``."""
    raise NotImplementedError("called from compiled code only")


@overload(gaps)
def _ov_gaps(t, y, sys, g, gd):
    if _is_reduced(sys):
        return lambda t, y, sys, g, gd: reduced_gaps_into(t, y, sys, g, gd)
    return lambda t, y, sys, g, gd: gaps_into(t, y, sys, g, gd)


def floors(sys):  # pragma: no cover - compiled only
    """Impact-speed floor (m/s) of each contact joint."""
    raise NotImplementedError("called from compiled code only")


@overload(floors)
def _ov_floors(sys):
    if _is_reduced(sys):
        return lambda sys: _floors_of(sys.dyn)
    return lambda sys: _floors_of(sys)


def n_coordinates(sys):  # pragma: no cover - compiled only
    """Number of coordinates (half the state without the two work integrals)."""
    raise NotImplementedError("called from compiled code only")


@overload(n_coordinates)
def _ov_n_coordinates(sys):
    if _is_reduced(sys):
        return lambda sys: 2 * sys.cl_row.shape[0]
    return lambda sys: sys.mass.shape[0]


def record(ws, stats):  # pragma: no cover - compiled only
    """Track the largest position and velocity constraint violation of the state evaluated
    last in ``ws`` (for the reduced formulation: the Newton residual and the residual of the
    velocity solve)."""
    raise NotImplementedError("called from compiled code only")


@njit(cache=True)
def _record_reduced(ws, stats):
    if ws.res[0] > stats[S_VIOL_POS]:
        stats[S_VIOL_POS] = ws.res[0]
    if ws.res[1] > stats[S_VIOL_VEL]:
        stats[S_VIOL_VEL] = ws.res[1]


@overload(record)
def _ov_record(ws, stats):
    from ..integrate.events import record_violation
    from .reduced import ReducedWorkspace
    if isinstance(ws, types.BaseNamedTuple) and ws.instance_class is ReducedWorkspace:
        return lambda ws, stats: _record_reduced(ws, stats)
    return lambda ws, stats: record_violation(ws, stats)
