"""The two formulations the integrators run, behind one set of compiled functions.

A compiled integrator kernel takes a *system* and a *work* object and only ever calls the
functions below on them. Each is resolved when numba compiles the kernel, from the system's
type (``numba.extending.overload``), so one kernel source serves both formulations and each
compiled version contains only its own code:

================================  ===========================================  ==============================================
system (what the kernel gets)     :class:`~mechrel.mechanics.system.System`    :class:`~mechrel.mechanics.reduced.ReducedSystem`
================================  ===========================================  ==============================================
state ``y``                       ``(q, q̇, W_in, W_cl)``, ``2 n + 2``          ``(z, ż, W_in, W_cl)``, ``4 nc + 2``
work                              :func:`~.dynamics.make_workspace`            :func:`~.reduced.make_reduced_work`
right-hand side                   :func:`~.dynamics.rhs_into`                  :func:`~.reduced.reduced_rhs_into`
contact gaps                      :func:`~.joints.gaps_into`                   :func:`~.reduced.reduced_gaps_into`
constraint violation recorded     from the last evaluation                     none: the constraints hold by construction
fast part of the Jacobian         :func:`~.jacobian.clearance_jacobian`        none: finite differences of ``4 nc`` columns
================================  ===========================================  ==============================================

Both states end with the two work integrals and are ``(coordinates, velocities, W)``, so the
integrators' structure (the exact rows ``d(coordinates)/dt = velocities``, Radau's condensed
iteration matrices) is the same; :func:`n_coordinates` says how many coordinates there are.

Adding a formulation is a system type plus one branch in each function here.

Examples
--------
The same function on the two systems of the lubricated nine-bar:

>>> import numpy as np
>>> from numba import njit
>>> from mechrel.mechanics.construction import construction
>>> from mechrel.mechanics.kinematics import assemble
>>> from mechrel.mechanics.reduced import ReducedSystem
>>> from mechrel.mechanics.system import compile_scene
>>> from mechrel.scene import load_scene
>>> c = compile_scene(load_scene("nine-bar-lubricated"))
>>> q0, _ = assemble(c.assembly, c.q_guess, 0.0)
>>> count = njit(lambda s: n_coordinates(s))
>>> count(c.dynamic), count(ReducedSystem(c.dynamic, construction(c.dynamic), q0))
(24, 4)
"""

from __future__ import annotations

from numba import types
from numba.extending import overload

from .constraints import violation_from
from .dynamics import make_workspace, rhs_inline, rhs_into
from .jacobian import clearance_jacobian
from .joints import gaps_into
from .reduced import (ReducedSystem, ReducedWork, make_reduced_work, reduced_gaps_into,
                      reduced_rhs_into)

__all__ = ["contact_system", "evaluate", "evaluate_inline", "fast_jacobian", "gaps",
           "has_fast_part", "make_work", "n_coordinates", "violation"]


def _reduced(sys) -> bool:
    """Whether the numba type ``sys`` is a :class:`ReducedSystem`."""
    return isinstance(sys, types.NamedTuple) and sys.instance_class is ReducedSystem


# The pure-Python bodies below are what the functions mean; numba compiles the overloads.

def n_coordinates(sys):
    """The number of coordinates of the state (``n`` absolute, ``2 nc`` reduced)."""
    raise NotImplementedError("compiled only (numba)")


def make_work(sys):
    """The work arrays of one evaluation (a Workspace or a ReducedWork)."""
    raise NotImplementedError("compiled only (numba)")


def contact_system(sys):
    """The :class:`~mechrel.mechanics.system.System` whose joints carry the contact data."""
    raise NotImplementedError("compiled only (numba)")


def evaluate(t, y, hist, sys, ws, out):
    """``dy/dt`` into ``out``, a call (:func:`~.dynamics.rhs_into`)."""
    raise NotImplementedError("compiled only (numba)")


def evaluate_inline(t, y, hist, sys, ws, out):
    """``dy/dt`` into ``out``, inlined at the call site (:func:`~.dynamics.rhs_inline`; use
    it at one site per kernel)."""
    raise NotImplementedError("compiled only (numba)")


def gaps(t, y, sys, g, gd):
    """Penetration (m) and its rate (m/s) of the contact-capable joints."""
    raise NotImplementedError("compiled only (numba)")


def violation(ws):
    """``(position, velocity)`` constraint violation of the last evaluation (m, m/s)."""
    raise NotImplementedError("compiled only (numba)")


def has_fast_part(sys):
    """Whether the Jacobian is split into a smooth rest and a fast clearance part."""
    raise NotImplementedError("compiled only (numba)")


def fast_jacobian(t, y, hist, sys, ws, f, JS):
    """The fast (clearance) part of the Jacobian into ``JS`` (:func:`~.jacobian.clearance_jacobian`)."""
    raise NotImplementedError("compiled only (numba)")


@overload(n_coordinates, inline='always')
def _n_coordinates(sys):
    if _reduced(sys):
        return lambda sys: 2 * sys.con.cl_nodes.shape[0]
    return lambda sys: sys.mass.shape[0]


@overload(make_work)
def _make_work(sys):
    if _reduced(sys):
        return lambda sys: make_reduced_work(sys.sys, sys.con, sys.q_ref)
    return lambda sys: make_workspace(sys)


@overload(contact_system, inline='always')
def _contact_system(sys):
    if _reduced(sys):
        return lambda sys: sys.sys
    return lambda sys: sys


@overload(evaluate)
def _evaluate(t, y, hist, sys, ws, out):
    if _reduced(sys):
        def impl(t, y, hist, sys, ws, out):
            reduced_rhs_into(t, y, hist, sys.sys, sys.con, ws, out)
        return impl

    def impl(t, y, hist, sys, ws, out):
        rhs_into(t, y, hist, sys, ws, out)
    return impl


@overload(evaluate_inline, inline='always')
def _evaluate_inline(t, y, hist, sys, ws, out):
    if _reduced(sys):
        def impl(t, y, hist, sys, ws, out):
            reduced_rhs_into(t, y, hist, sys.sys, sys.con, ws, out)
        return impl

    def impl(t, y, hist, sys, ws, out):
        rhs_inline(t, y, hist, sys, ws, out)
    return impl


@overload(gaps)
def _gaps(t, y, sys, g, gd):
    if _reduced(sys):
        return lambda t, y, sys, g, gd: reduced_gaps_into(y, sys.sys, g, gd)
    return lambda t, y, sys, g, gd: gaps_into(t, y, sys, g, gd)


@overload(violation)
def _violation(ws):
    if isinstance(ws, types.NamedTuple) and ws.instance_class is ReducedWork:
        return lambda ws: (0.0, 0.0)
    return lambda ws: violation_from(ws)


@overload(has_fast_part, inline='always')
def _has_fast_part(sys):
    if _reduced(sys):
        return lambda sys: False
    return lambda sys: sys.cl_b.shape[0] > 0


@overload(fast_jacobian)
def _fast_jacobian(t, y, hist, sys, ws, f, JS):
    if _reduced(sys):
        def impl(t, y, hist, sys, ws, f, JS):
            pass
        return impl
    return lambda t, y, hist, sys, ws, f, JS: clearance_jacobian(t, y, hist, sys, ws, f, JS)

