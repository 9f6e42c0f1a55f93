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
    """The right-hand side's workspace for ``sys``.

    Compiled code only: numba picks the implementation for the type of ``sys``
    (``numba.extending.overload``); from Python, call that implementation directly.

    Parameters
    ----------
    sys : System or ReducedSystem
        The problem.

    Returns
    -------
    Workspace or ReducedWorkspace
        :func:`~mechrel.mechanics.problem.make_workspace` or
        :func:`~mechrel.mechanics.reduced.make_reduced_workspace` of ``sys``.

    Examples
    --------
    >>> import numpy as np
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.reduced import initial_state, reduced_system
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, va = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> from mechrel.mechanics.problem import make_workspace
    >>> from mechrel.mechanics.reduced import make_reduced_workspace
    >>> make_workspace(c.dynamic).Q.shape, make_reduced_workspace(rs).fr.shape
    ((9,), (2,))
    """
    raise NotImplementedError("called from compiled code only")


@overload(new_workspace)
def _ov_new_workspace(sys):
    if _is_reduced(sys):
        return lambda sys: make_reduced_workspace(sys)
    return lambda sys: make_workspace(sys)


def rhs(t, y, hist, sys, ws, out):  # pragma: no cover - compiled only
    """``dy/dt`` into ``out``, inlined for the absolute formulation.

    One call site per kernel, as :func:`~mechrel.mechanics.problem.rhs_inline`; the reduced
    formulation calls :func:`~mechrel.mechanics.reduced.reduced_rhs_into`.

    Compiled code only: numba picks the implementation for the type of ``sys``
    (``numba.extending.overload``); from Python, call that implementation directly.

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (ny,)
        The state: ``(q, q̇, W_in, W_cl)`` (m, rad; m/s, rad/s; J) for a ``System``,
        ``(z, ż, W_in, W_cl)`` (m; m/s; J) for a ``ReducedSystem``.
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s).
    sys : System or ReducedSystem
        The problem (:class:`~mechrel.mechanics.system.System`,
        :class:`~mechrel.mechanics.reduced.ReducedSystem`).
    ws : Workspace or ReducedWorkspace
        Its workspace (:func:`new_workspace`).
    out : ndarray, shape (ny,)
        Receives ``dy/dt``.

    Examples
    --------
    The absolute formulation's implementation, on the assembled state:

    >>> import numpy as np
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.reduced import initial_state, reduced_system
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, va = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> from mechrel.mechanics.problem import make_workspace, rhs_into
    >>> y = np.concatenate([qa, va, np.zeros(2)])
    >>> out = np.empty_like(y)
    >>> rhs_into(0.0, y, np.zeros(0), c.dynamic, make_workspace(c.dynamic), out)
    >>> bool(np.array_equal(out[:9], va))
    True
    """
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
    """``dy/dt`` into ``out``, as a call (for the sites that are not the hot loop).

    :func:`~mechrel.mechanics.problem.rhs_into` or
    :func:`~mechrel.mechanics.reduced.reduced_rhs_into`.

    Compiled code only: numba picks the implementation for the type of ``sys``
    (``numba.extending.overload``); from Python, call that implementation directly.

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (ny,)
        The state: ``(q, q̇, W_in, W_cl)`` (m, rad; m/s, rad/s; J) for a ``System``,
        ``(z, ż, W_in, W_cl)`` (m; m/s; J) for a ``ReducedSystem``.
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s).
    sys : System or ReducedSystem
        The problem (:class:`~mechrel.mechanics.system.System`,
        :class:`~mechrel.mechanics.reduced.ReducedSystem`).
    ws : Workspace or ReducedWorkspace
        Its workspace (:func:`new_workspace`).
    out : ndarray, shape (ny,)
        Receives ``dy/dt``.

    Examples
    --------
    The absolute formulation's implementation, on the assembled state:

    >>> import numpy as np
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.reduced import initial_state, reduced_system
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, va = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> from mechrel.mechanics.problem import make_workspace, rhs_into
    >>> y = np.concatenate([qa, va, np.zeros(2)])
    >>> out = np.empty_like(y)
    >>> rhs_into(0.0, y, np.zeros(0), c.dynamic, make_workspace(c.dynamic), out)
    >>> bool(np.array_equal(out[:9], va))
    True
    """
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
    """Penetration (m) and its rate (m/s) of the contact-capable joints into ``g``, ``gd``.

    :func:`~mechrel.mechanics.problem.gaps_into` or
    :func:`~mechrel.mechanics.reduced.reduced_gaps_into` (straight from ``z``).

    Compiled code only: numba picks the implementation for the type of ``sys``
    (``numba.extending.overload``); from Python, call that implementation directly.

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (ny,)
        The state (:func:`rhs`).
    sys : System or ReducedSystem
        The problem.
    g, gd : ndarray, shape (nh,)
        Receive the penetration δ (m) and its rate δ̇ (m/s), in ``hist`` order.

    Examples
    --------
    The reduced formulation's implementation; the lubricated slider-crank has no
    contact-capable joint:

    >>> import numpy as np
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.reduced import initial_state, reduced_system
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, va = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> from mechrel.mechanics.reduced import reduced_gaps_into
    >>> g, gd = np.empty(0), np.empty(0)
    >>> reduced_gaps_into(0.0, initial_state(scene, rs), rs, g, gd)
    >>> g.shape
    (0,)
    """
    raise NotImplementedError("called from compiled code only")


@overload(gaps)
def _ov_gaps(t, y, sys, g, gd):
    if _is_reduced(sys):
        return lambda t, y, sys, g, gd: reduced_gaps_into(t, y, sys, g, gd)
    return lambda t, y, sys, g, gd: gaps_into(t, y, sys, g, gd)


def floors(sys):  # pragma: no cover - compiled only
    """Impact-speed floor (m/s) of each contact joint.

    :func:`~mechrel.integrate.events.contact_floors` of the ``System`` (of
    ``ReducedSystem.dyn``). Compiled code only (``numba.extending.overload``).

    Parameters
    ----------
    sys : System or ReducedSystem
        The problem.

    Returns
    -------
    ndarray, shape (nh,)
        The floors (m/s).

    Examples
    --------
    >>> from numba import njit
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> @njit
    ... def floors_of(sys):
    ...     return floors(sys)
    >>> floors_of(compile_scene(load_scene("slider-crank-dry")).dynamic)
    array([0.001])
    """
    raise NotImplementedError("called from compiled code only")


@overload(floors)
def _ov_floors(sys):
    if _is_reduced(sys):
        return lambda sys: _floors_of(sys.dyn)
    return lambda sys: _floors_of(sys)


def n_coordinates(sys):  # pragma: no cover - compiled only
    """Number of coordinates (half the state without the two work integrals).

    ``n`` (3 per body) for a ``System``, ``2 nc`` for a ``ReducedSystem``. Compiled code only
    (``numba.extending.overload``).

    Parameters
    ----------
    sys : System or ReducedSystem
        The problem.

    Returns
    -------
    int
        The number of coordinates.

    Examples
    --------
    >>> import numpy as np
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.reduced import initial_state, reduced_system
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, va = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> from numba import njit
    >>> @njit
    ... def count(sys):
    ...     return n_coordinates(sys)
    >>> count(c.dynamic), count(rs)
    (9, 2)
    """
    raise NotImplementedError("called from compiled code only")


@overload(n_coordinates)
def _ov_n_coordinates(sys):
    if _is_reduced(sys):
        return lambda sys: 2 * sys.cl_row.shape[0]
    return lambda sys: sys.mass.shape[0]


def record(ws, stats):  # pragma: no cover - compiled only
    """Track the largest constraint violations of the state evaluated last in ``ws``.

    For the absolute formulation max |Φ| and max |Φ̇|
    (:func:`~mechrel.integrate.events.record_violation`); for the reduced formulation the
    Newton residual and the residual of the velocity solve (``ReducedWorkspace.res``).
    Compiled code only (``numba.extending.overload``).

    Parameters
    ----------
    ws : Workspace or ReducedWorkspace
        The workspace of the last right-hand-side evaluation.
    stats : ndarray, shape (N_STATS,)
        The kernel's statistics; ``stats[S_VIOL_POS]`` (m) and ``stats[S_VIOL_VEL]`` (m/s)
        are raised to the new values.

    Examples
    --------
    >>> import numpy as np
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.reduced import initial_state, reduced_system
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, va = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> from numba import njit
    >>> from mechrel.integrate.events import N_STATS
    >>> from mechrel.mechanics.reduced import make_reduced_workspace
    >>> @njit
    ... def track(ws, stats):
    ...     record(ws, stats)
    >>> rw, stats = make_reduced_workspace(rs), np.zeros(N_STATS)
    >>> rw.res[:] = 1e-13, 2e-12
    >>> track(rw, stats)
    >>> float(stats[S_VIOL_POS]), float(stats[S_VIOL_VEL])
    (1e-13, 2e-12)
    """
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
