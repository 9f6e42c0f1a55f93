"""The two formulations the integrators run, behind one set of compiled functions.

A compiled integrator kernel takes a *system* and a *work* object and only ever calls the
functions below on them. Each is resolved when numba compiles the kernel, from the system's
type (``numba.extending.overload``), so one kernel source serves both formulations and each
compiled version contains only its own code. For a
:class:`~mechrel.mechanics.system.System` (the absolute formulation):

* state ``(q, q̇, W_in, W_cl)``, ``2 n + 2`` entries; work arrays
  :func:`~mechrel.mechanics.dynamics.make_workspace`;
* right-hand side :func:`~mechrel.mechanics.dynamics.rhs_into`, contact gaps
  :func:`~mechrel.mechanics.joints.gaps_into`;
* the constraint violation of the last evaluation is recorded;
* fast part of the Jacobian :func:`~mechrel.mechanics.jacobian.clearance_jacobian`.

For a :class:`~mechrel.mechanics.reduced.ReducedSystem` (the reduced formulation):

* state ``(z, ż, W_in, W_cl)``, ``2 nz + 2`` entries (``nz = 2 nc + nf``: the
  eccentricities and the free coordinates); work arrays
  :func:`~mechrel.mechanics.reduced.make_reduced_work`;
* right-hand side :func:`~mechrel.mechanics.reduced.reduced_rhs_into`, contact gaps
  :func:`~mechrel.mechanics.reduced.reduced_gaps_into`;
* nothing is recorded: the constraints hold by construction;
* fast part of the Jacobian :func:`~mechrel.mechanics.reduced.reduced_fast_jacobian`;
* output rows in the absolute layout :func:`~mechrel.mechanics.reduced.output_row`, from what
  the evaluation at the output instant left in the work arrays.

Both states are ``(coordinates, velocities, two work integrals)``, so the integrators'
structure (the exact rows ``d(coordinates)/dt = velocities``, Radau's condensed iteration
matrices) is the same; :func:`n_coordinates` says how many coordinates there are. Adding a
formulation is a system type plus one branch in each function here. The pure-Python functions
only name and document the operations: they raise outside compiled code.

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
from .reduced import (ReducedSystem, ReducedWork, make_reduced_work, n_reduced, output_row,
                      reduced_fast_jacobian, reduced_gaps_into, reduced_rhs_into)

__all__ = ["contact_system", "evaluate", "evaluate_inline", "fast_jacobian", "gaps",
           "has_fast_part", "make_work", "n_coordinates", "output_width", "violation",
           "write_output"]


def _reduced(sys) -> bool:
    """Whether the numba type ``sys`` is a :class:`ReducedSystem`."""
    return isinstance(sys, types.NamedTuple) and sys.instance_class is ReducedSystem


def n_coordinates(sys):
    """The number of coordinates of the state: ``n`` absolute, ``2 nc + nf`` reduced (the
    eccentricities and the free coordinates).

    Parameters
    ----------
    sys : System or ReducedSystem
        The mechanism in its formulation.

    Returns
    -------
    int

    Examples
    --------
    >>> from numba import njit
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> njit(lambda s: n_coordinates(s))(compile_scene(load_scene("slider-crank")).dynamic)
    9
    """
    raise NotImplementedError("compiled only (numba)")


def make_work(sys):
    """The work arrays of one evaluation.

    Parameters
    ----------
    sys : System or ReducedSystem
        The mechanism in its formulation.

    Returns
    -------
    Workspace or ReducedWork

    Examples
    --------
    >>> from numba import njit
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> ws = njit(lambda s: make_work(s))(compile_scene(load_scene("slider-crank")).dynamic)
    >>> type(ws).__name__
    'Workspace'
    """
    raise NotImplementedError("compiled only (numba)")


def contact_system(sys):
    """The :class:`~mechrel.mechanics.system.System` whose joints carry the contact data.

    Parameters
    ----------
    sys : System or ReducedSystem
        The mechanism in its formulation.

    Returns
    -------
    System

    Examples
    --------
    >>> from numba import njit
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> dyn = compile_scene(load_scene("slider-crank-dry")).dynamic
    >>> njit(lambda s: contact_system(s).cl_hist.shape[0])(dyn)
    1
    """
    raise NotImplementedError("compiled only (numba)")


def evaluate(t, y, hist, sys, ws, out):
    """``dy/dt`` into ``out``, as a call (:func:`~mechrel.mechanics.dynamics.rhs_into`,
    :func:`~mechrel.mechanics.reduced.reduced_rhs_into`).

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray
        The state (SI units; module docstring).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s).
    sys : System or ReducedSystem
        The mechanism in its formulation.
    ws : Workspace or ReducedWork
        Its work arrays (:func:`make_work`).
    out : ndarray
        Receives ``dy/dt`` (SI units).

    Examples
    --------
    >>> import numpy as np
    >>> from numba import njit
    >>> from mechrel.mechanics.dynamics import make_workspace, rhs
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> y, out = np.concatenate([q, v, np.zeros(2)]), np.empty(20)
    >>> njit(lambda *a: evaluate(*a))(0.0, y, np.zeros(0), c.dynamic,
    ...                               make_workspace(c.dynamic), out)
    >>> bool(np.array_equal(out, rhs(0.0, y, np.zeros(0), c.dynamic)))
    True
    """
    raise NotImplementedError("compiled only (numba)")


def evaluate_inline(t, y, hist, sys, ws, out):
    """:func:`evaluate` inlined at the call site (:func:`~mechrel.mechanics.dynamics.rhs_inline`):
    use it at one site per kernel, each site compiles the whole right-hand side again.

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray
        The state (SI units; module docstring).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s).
    sys : System or ReducedSystem
        The mechanism in its formulation.
    ws : Workspace or ReducedWork
        Its work arrays (:func:`make_work`).
    out : ndarray
        Receives ``dy/dt`` (SI units).

    Examples
    --------
    On the reduced formulation (whose right-hand side is a call even here; inlining the
    absolute one compiles it whole again, about half a minute):

    >>> import numpy as np
    >>> from numba import njit
    >>> from mechrel.mechanics.construction import construction
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.reduced import (ReducedSystem, make_reduced_work,
    ...                                        reduced_rhs_into)
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, _ = assemble(c.assembly, c.q_guess, 0.0)
    >>> red = ReducedSystem(c.dynamic, construction(c.dynamic), q)
    >>> rw = make_reduced_work(c.dynamic, red.con, q)
    >>> y, out, ref = np.array([3e-4, 0, 0, 0.01, 0, 0]), np.empty(6), np.empty(6)
    >>> f = njit(lambda t, y, h, s, w, o: evaluate_inline(t, y, h, s, w, o))
    >>> f(0.0, y, np.zeros(0), red, rw, out)
    >>> _ = reduced_rhs_into(0.0, y, np.zeros(0), c.dynamic, red.con, rw, ref)
    >>> bool(np.array_equal(out, ref))
    True
    """
    raise NotImplementedError("compiled only (numba)")


def gaps(t, y, sys, g, gd):
    """Penetration δ = |e| − c (m) and its rate (m/s) of the contact-capable joints.

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray
        The state (SI units; module docstring).
    sys : System or ReducedSystem
        The mechanism in its formulation.
    g, gd : ndarray, shape (nh,)
        Receive δ (m) and δ̇ (m/s), indexed like ``hist``.

    Examples
    --------
    >>> import numpy as np
    >>> from numba import njit
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-dry"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> g, gd = np.empty(1), np.empty(1)
    >>> njit(lambda *a: gaps(*a))(0.0, np.concatenate([q, v, np.zeros(2)]), c.dynamic, g, gd)
    >>> g.round(12).tolist()
    [-0.0005]
    """
    raise NotImplementedError("compiled only (numba)")


def violation(ws):
    """``(position, velocity)`` constraint violation of the last evaluation in ``ws``
    (m or rad, m/s or rad/s); zero for the reduced formulation, exact by construction.

    Parameters
    ----------
    ws : Workspace or ReducedWork
        The work arrays of the last evaluation.

    Returns
    -------
    tuple of float

    Examples
    --------
    >>> import numpy as np
    >>> from numba import njit
    >>> from mechrel.mechanics.construction import construction
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.reduced import make_reduced_work
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, _ = assemble(c.assembly, c.q_guess, 0.0)
    >>> rw = make_reduced_work(c.dynamic, construction(c.dynamic), q)
    >>> njit(lambda w: violation(w))(rw)
    (0.0, 0.0)
    """
    raise NotImplementedError("compiled only (numba)")


def output_width(sys):
    """The length of an output row: the absolute state's ``2 n + 2`` in either formulation
    (the integrators return their outputs and logs in the absolute layout).

    Parameters
    ----------
    sys : System or ReducedSystem
        The mechanism in its formulation.

    Returns
    -------
    int

    Examples
    --------
    >>> from numba import njit
    >>> from mechrel.mechanics.construction import construction
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.reduced import ReducedSystem
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, _ = assemble(c.assembly, c.q_guess, 0.0)
    >>> width = njit(lambda s: output_width(s))
    >>> width(c.dynamic), width(ReducedSystem(c.dynamic, construction(c.dynamic), q))
    (20, 20)
    """
    raise NotImplementedError("compiled only (numba)")


def write_output(sys, ws, y, f, Ya, YDa):
    """The output row of the state ``y`` and its derivative ``f``, which must be the last
    evaluation into ``ws``: ``y`` and ``f`` themselves (absolute), or the absolute row of a
    reduced state (:func:`~mechrel.mechanics.reduced.output_row`, without placing the
    mechanism again).

    Parameters
    ----------
    sys : System or ReducedSystem
        The mechanism in its formulation.
    ws : Workspace or ReducedWork
        The work arrays of the evaluation of ``f``.
    y, f : ndarray
        The state and ``dy/dt`` (SI units).
    Ya, YDa : ndarray, shape (output_width(sys),)
        Receive the row ``(q, q̇, W_in, W_cl)`` and ``(q̇, q̈, P_in, P_cl)``.

    Examples
    --------
    >>> import numpy as np
    >>> from numba import njit
    >>> from mechrel.mechanics.dynamics import make_workspace
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> y, f, Ya, YDa = np.concatenate([q, v, [0, 0]]), np.ones(20), np.empty(20), np.empty(20)
    >>> ws = make_workspace(c.dynamic)
    >>> write = njit(lambda s, w, y, f, a, b: write_output(s, w, y, f, a, b))
    >>> write(c.dynamic, ws, y, f, Ya, YDa)
    >>> bool(np.array_equal(Ya, y)), bool(np.array_equal(YDa, f))
    (True, True)
    """
    raise NotImplementedError("compiled only (numba)")


def has_fast_part(sys):
    """Whether the Jacobian is split into a smooth rest and a fast clearance part
    (:func:`mechrel.integrate.radau._update_jacobian`): the mechanism has clearance joints.

    Parameters
    ----------
    sys : System or ReducedSystem
        The mechanism in its formulation.

    Returns
    -------
    bool

    Examples
    --------
    >>> from numba import njit
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> f = njit(lambda s: has_fast_part(s))
    >>> f(compile_scene(load_scene("slider-crank")).dynamic)
    False
    >>> f(compile_scene(load_scene("slider-crank-lubricated")).dynamic)
    True
    """
    raise NotImplementedError("compiled only (numba)")


def fast_jacobian(t, y, hist, sys, ws, f, JS):
    """The fast (clearance) part of the Jacobian into ``JS`` and ``f(t, y)`` into ``f``
    (:func:`~mechrel.mechanics.jacobian.clearance_jacobian`,
    :func:`~mechrel.mechanics.reduced.reduced_fast_jacobian`).

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray
        The state (SI units; module docstring).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s).
    sys : System or ReducedSystem
        The mechanism in its formulation.
    ws : Workspace or ReducedWork
        Its work arrays (:func:`make_work`).
    f : ndarray
        Receives ``dy/dt``.
    JS : ndarray, shape (ny, ny)
        Receives the fast part (rows ``n_coordinates …``, columns ``< 2 n_coordinates``).

    Examples
    --------
    >>> import numpy as np
    >>> from numba import njit
    >>> from mechrel.mechanics.construction import construction
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.reduced import ReducedSystem, make_reduced_work
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, _ = assemble(c.assembly, c.q_guess, 0.0)
    >>> red = ReducedSystem(c.dynamic, construction(c.dynamic), q)
    >>> y, f, JS = np.array([3e-4, 0, 0, 0.01, 0, 0]), np.empty(6), np.zeros((6, 6))
    >>> njit(lambda *a: fast_jacobian(*a))(0.0, y, np.zeros(0), red,
    ...                                    make_reduced_work(c.dynamic, red.con, q), f, JS)
    >>> bool(np.abs(JS[2:4, :4]).max() > 1e6)
    True
    """
    raise NotImplementedError("compiled only (numba)")


@overload(n_coordinates, inline='always')
def _n_coordinates(sys):
    if _reduced(sys):
        return lambda sys: n_reduced(sys.con)
    return lambda sys: sys.mass.shape[0]


@overload(output_width, inline='always')
def _output_width(sys):
    if _reduced(sys):
        return lambda sys: 2 * sys.sys.mass.shape[0] + 2
    return lambda sys: 2 * sys.mass.shape[0] + 2


@overload(write_output, inline='always')
def _write_output(sys, ws, y, f, Ya, YDa):
    if _reduced(sys):
        return lambda sys, ws, y, f, Ya, YDa: output_row(y, f, ws, Ya, YDa)

    def impl(sys, ws, y, f, Ya, YDa):
        for i in range(y.shape[0]):
            Ya[i] = y[i]
            YDa[i] = f[i]
    return impl


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
        return lambda sys: sys.sys.cl_b.shape[0] > 0
    return lambda sys: sys.cl_b.shape[0] > 0


@overload(fast_jacobian)
def _fast_jacobian(t, y, hist, sys, ws, f, JS):
    if _reduced(sys):
        def impl(t, y, hist, sys, ws, f, JS):
            reduced_fast_jacobian(t, y, hist, sys.sys, sys.con, ws, f, JS)
        return impl
    return lambda t, y, hist, sys, ws, f, JS: clearance_jacobian(t, y, hist, sys, ws, f, JS)

