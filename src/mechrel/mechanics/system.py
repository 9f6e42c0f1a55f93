"""Compile a :class:`~mechrel.scene.model.Scene` into a :class:`System`: plain arrays that the
compiled kernels read.

One compiled kernel serves every scene because the scene enters only as data. The arrays are
grouped per element type (revolute, translational, fixed angle, driver, clearance joint), so a
loop over an empty group costs nothing; each clearance joint's force law branches once on its
model code, so a dry joint never enters film code and a lubricated one never enters contact
code (see docs/mechanics.md).

Coordinates: ``q = (x_1, y_1, θ_1, …, x_nb, y_nb, θ_nb)``, body frames at the centre of mass.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np

from ..errors import SceneError
from ..scene.model import GROUND, Joint, Scene

# Driver laws, in the order of the ``dr_law`` codes.
LAW_CONSTANT_SPEED = 0
LAW_CONSTANT_ACCELERATION = 1
LAW_HARMONIC = 2
LAW_SMOOTH_START = 3
_LAW_CODES = {
    "constant-speed": LAW_CONSTANT_SPEED,
    "constant-acceleration": LAW_CONSTANT_ACCELERATION,
    "harmonic": LAW_HARMONIC,
    "smooth-start": LAW_SMOOTH_START,
}
# Columns of ``dr_par``.
D_ANGLE0, D_SPEED, D_ACCEL, D_AMPLITUDE, D_FREQUENCY, D_PHASE, D_RAMP = range(7)
N_DRIVER_PARAMS = 7


class System(NamedTuple):
    """The mechanism as arrays (SI units). Body index −1 means the ground.

    Revolute joints (2 equations each): ``r_i + A_i s_i − r_j − A_j s_j − off = 0``; for a
    ground point ``s_j`` is its global position. ``off`` is zero except when a clearance joint
    is assembled at a prescribed eccentricity.
    Translational joints on a ground line (2 equations): ``n·(r_i + A_i s_i − p0) = 0`` with
    ``n`` the line's normal, and ``θ_i − angle = 0``. Fixed angles (1 equation). Points on the
    line of a moving body, or a pin in a ground slot (1 equation each, ``ln_*``):
    ``(A_j n̄)·(r_i + A_i s_i − r_j) − n̄·s_j = 0``, the point s_i of body i on the line through
    s_j of body j with unit normal n̄ (body j's frame; i or j −1: the ground, its point then
    global): the on-line equation of a translational joint between moving bodies and of a
    pin-in-slot joint. Relative angles (1 equation each, ``ra_*``): ``θ_i − θ_j − angle = 0``,
    the second equation of such a translational joint. Drivers (1 equation:
    ``θ_i − f(t) = 0``), always the last rows.
    Clearance joints (force elements): bearing body ``cl_b`` with point ``cl_sb``, journal body
    ``cl_j`` with point ``cl_sj``, packed force-law parameters ``cl_p``
    (:mod:`mechrel.forces.params`). ``cl_hist`` gives the clearance joints that can touch
    (dry, transition) their index into ``hist``.

    Parameters
    ----------
    mass : ndarray, shape (n,)
        Diagonal of the mass matrix: m, m, J per body (kg, kg, kg m²).
    gravity : ndarray, shape (2,)
        Gravitational acceleration (m/s²).
    rev_i, rev_j : ndarray of int
        Bodies of each revolute joint (−1: ground).
    rev_si, rev_sj : ndarray, shape (nr, 2)
        Joint points in the body frames (m); a ground point's global position.
    rev_off, rev_offdot : ndarray, shape (nr, 2)
        Prescribed offset (m) and its rate (m/s) of each revolute equation.
    tr_i : ndarray of int
        Body of each translational joint.
    tr_si, tr_p0, tr_n : ndarray, shape (nt, 2)
        Sliding point in the body frame (m), a point of the line (m), the line's unit normal.
    tr_angle : ndarray
        Body angle held by each translational joint (rad).
    fa_i : ndarray of int
        Body of each fixed-angle constraint.
    fa_angle : ndarray
        The angle it holds (rad).
    ln_i, ln_j : ndarray of int
        Body of the point and body of the line of each point-on-a-line equation (−1: ground).
    ln_si, ln_sj, ln_n : ndarray, shape (nl, 2)
        The point in its body's frame, a point of the line and the line's unit normal in the
        line body's frame (global for the ground; m, m, –).
    ra_i, ra_j : ndarray of int
        The two bodies of each relative-angle equation (−1: ground).
    ra_angle : ndarray
        The angle θ_i − θ_j it holds (rad).
    dr_i, dr_law : ndarray of int
        Driven body and driver law code (``LAW_*``) of each driver.
    dr_par : ndarray, shape (nd, N_DRIVER_PARAMS)
        Driver parameters by the ``D_*`` columns: θ0 (rad), ω (rad/s), α (rad/s²),
        A (rad), Ω (rad/s), φ (rad), ramp time (s).
    cl_b, cl_j : ndarray of int
        Bearing body and journal body of each clearance joint.
    cl_sb, cl_sj : ndarray, shape (nc, 2)
        Bearing and journal points in their body frames (m).
    cl_p : ndarray, shape (nc, N_PARAMS)
        Packed force-law parameters of each clearance joint.
    cl_hist : ndarray of int
        Index into ``hist`` of each clearance joint, −1 for joints that cannot touch.
    baumgarte : ndarray, shape (2,)
        Baumgarte stabilisation α, β (1/s).
    row_body : ndarray of int, shape (m, 2)
        The (at most two) bodies each constraint row acts on, −1: none.
    ch_perm, sc_idx, ch_ent, ch_ptr, ch_kk, ch_row_ptr, ch_row_idx : ndarray of int
        Symbolic Cholesky factorisation of S = Φ_q M⁻¹ Φ_qᵀ (:func:`schur_structure`).

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> system = compile_scene(load_scene("slider-crank-dry")).dynamic
    >>> system.n_coordinates, system.n_constraints, system.n_contacts
    (9, 7, 1)
    """

    mass: np.ndarray  # (n,) diagonal of M: m, m, J per body
    gravity: np.ndarray  # (2,)
    rev_i: np.ndarray
    rev_j: np.ndarray
    rev_si: np.ndarray
    rev_sj: np.ndarray
    rev_off: np.ndarray
    rev_offdot: np.ndarray
    tr_i: np.ndarray
    tr_si: np.ndarray
    tr_p0: np.ndarray
    tr_n: np.ndarray
    tr_angle: np.ndarray
    fa_i: np.ndarray
    fa_angle: np.ndarray
    ln_i: np.ndarray
    ln_si: np.ndarray
    ln_j: np.ndarray
    ln_sj: np.ndarray
    ln_n: np.ndarray
    ra_i: np.ndarray
    ra_j: np.ndarray
    ra_angle: np.ndarray
    dr_i: np.ndarray
    dr_law: np.ndarray
    dr_par: np.ndarray
    cl_b: np.ndarray
    cl_j: np.ndarray
    cl_sb: np.ndarray
    cl_sj: np.ndarray
    cl_p: np.ndarray
    cl_hist: np.ndarray  # (nc,) index into hist, −1 for joints that cannot touch (lubricated)
    baumgarte: np.ndarray  # (2,) alpha, beta (1/s)
    # Sparsity of the constraint Jacobian and of the Cholesky factor of S = Φ_q M⁻¹ Φ_qᵀ, fixed
    # by the topology (see :func:`schur_structure`).
    row_body: np.ndarray  # (m, 2) the (at most two) bodies a constraint row acts on, −1: none
    ch_perm: np.ndarray  # (m,) constraint row at each position of the permuted S
    sc_idx: np.ndarray  # (ns, 4) contributions to S: flat L index, flat coef indices of the
    #                     two rows' blocks for the shared body, 3 × that body
    ch_ent: np.ndarray  # (ne, 2) structural entries of L in computation order: flat index,
    #                     column j (the entry is diagonal when flat index == j (m + 1))
    ch_ptr: np.ndarray  # (ne + 1,) entry e subtracts L[a] L[b] for (a, b) in ch_kk[ch_ptr[e]:…]
    ch_kk: np.ndarray  # (nk, 2) flat indices
    ch_row_ptr: np.ndarray  # (m + 1,) row pattern of L below the diagonal: columns
    ch_row_idx: np.ndarray  # ch_row_idx[ch_row_ptr[i]:ch_row_ptr[i + 1]] (ascending)

    @property
    def n_coordinates(self) -> int:
        """Number of coordinates, three per body.

        Returns
        -------
        int
            n = 3 × bodies.

        Examples
        --------
        >>> from mechrel.scene import load_scene
        >>> compile_scene(load_scene("slider-crank")).dynamic.n_coordinates   # three bodies
        9
        """
        return self.mass.shape[0]

    @property
    def n_constraints(self) -> int:
        """Number of constraint equations (rows of Φ), drivers included.

        Returns
        -------
        int
            2 per revolute and translational joint, 1 per fixed angle, pin-in-slot joint and
            driver.

        Examples
        --------
        The slider-crank: three revolutes, a translational joint and a driver; its dry
        clearance joint C is a force element in the dynamic system, a constraint in the ideal:

        >>> from mechrel.scene import load_scene
        >>> compiled = compile_scene(load_scene("slider-crank-dry"))
        >>> compiled.dynamic.n_constraints, compiled.ideal.n_constraints
        (7, 9)
        """
        return (2 * self.rev_i.shape[0] + 2 * self.tr_i.shape[0] + self.fa_i.shape[0]
                + self.ln_i.shape[0] + self.ra_i.shape[0] + self.dr_i.shape[0])

    @property
    def n_contacts(self) -> int:
        """Number of clearance joints that can touch (the length of ``hist``).

        Returns
        -------
        int
            Dry and transition joints; a lubricated joint has no contact.

        Examples
        --------
        >>> from mechrel.scene import load_scene
        >>> compile_scene(load_scene("slider-crank-dry")).dynamic.n_contacts
        1
        >>> compile_scene(load_scene("slider-crank-lubricated")).dynamic.n_contacts
        0
        """
        return int(np.count_nonzero(self.cl_hist >= 0))  # a fifth of .sum()'s time


class CompiledScene(NamedTuple):
    """Everything the simulation needs from a scene, resolved to indices and arrays.

    ``dynamic`` treats clearance joints as force elements; ``assembly`` replaces each of them by
    a revolute constraint held at the joint's initial eccentricity; ``ideal`` replaces them by
    ideal revolutes (the ideal counterpart of the mechanism).

    Parameters
    ----------
    dynamic, assembly, ideal : System
        The three systems described above.
    labels : dict
        ``{"dynamic" | "assembly" | "ideal": one label per constraint row}``.
    body_names : tuple of str
        Bodies in coordinate order.
    body_index : dict
        ``{body name: index}``.
    q_guess : ndarray, shape (n,)
        The scene's body positions and angles, the assembly's first guess (m, rad).
    clearance_names, contact_names, driver_names, output_names : tuple of str
        Clearance joints, those of them that can touch, drivers and outputs, in order.
    out_body : ndarray of int
        Body index of each point output (kind "point", in order).
    out_s : ndarray, shape (no, 2)
        Point of each point output in its body frame (m).
    out_axis : ndarray, shape (no, 2)
        Unit axis of each point output.
    cycle_driver : int
        Index of the cycle driver into the drivers, −1 if none.
    period : float or None
        Cycle period of the cycle driver (s).

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> compiled = compile_scene(load_scene("slider-crank-dry"))
    >>> compiled.body_names, compiled.clearance_names, compiled.period   # 5000 rpm
    (('crank', 'rod', 'slider'), ('C',), 0.012)
    """

    dynamic: System
    assembly: System
    ideal: System
    labels: dict  # {"dynamic" | "assembly" | "ideal": one label per constraint row}
    body_names: tuple[str, ...]
    body_index: dict
    q_guess: np.ndarray
    clearance_names: tuple[str, ...]
    contact_names: tuple[str, ...]
    driver_names: tuple[str, ...]
    output_names: tuple[str, ...]
    out_body: np.ndarray  # (no,) body index of each point output (kind "point", in order)
    out_s: np.ndarray  # (no, 2) point in the body frame
    out_axis: np.ndarray  # (no, 2) unit axis
    cycle_driver: int  # index into drivers, −1 if none
    period: float | None  # s, cycle period of the cycle driver


def _point(scene: Scene, ref, index):
    """(body index or −1, local or global coordinates) of a point reference."""
    if ref.body == GROUND:
        return -1, np.asarray(scene.ground[ref.point], dtype=float)
    return index[ref.body], np.asarray(scene.bodies[ref.body].points[ref.point], dtype=float)


def _line_direction(scene: Scene, joint: Joint) -> np.ndarray:
    """The unit direction of a translational or pin-in-slot joint's line in the frame of its
    line body (``points[1]``'s): ``direction`` is written as that body's points are, so for a
    body written by ``global_points`` it is in ground axes at the initial configuration and
    turns into the body frame by A(angle)ᵀ (exactly itself for angle 0)."""
    u = np.asarray(joint.direction, dtype=float)
    u = u / math.hypot(*u)
    ref = joint.points[1]
    if ref.body == GROUND or scene.bodies[ref.body].global_points is None:
        return u
    th = scene.bodies[ref.body].angle
    c, s = math.cos(th), math.sin(th)
    return np.array([c * u[0] + s * u[1], -s * u[0] + c * u[1]])


def _driver_row(d) -> np.ndarray:
    row = np.zeros(N_DRIVER_PARAMS)
    row[D_ANGLE0] = d.angle0
    row[D_SPEED] = d.speed
    row[D_ACCEL] = d.acceleration
    row[D_AMPLITUDE] = d.amplitude
    row[D_FREQUENCY] = d.frequency
    row[D_PHASE] = d.phase
    row[D_RAMP] = d.ramp_time
    return row


def clearance_parameters(joint: Joint) -> np.ndarray:
    """Pack a clearance joint's force-law parameters by its model's row of the table of
    models (:func:`mechrel.forces.packing.pack_joint`).

    Parameters
    ----------
    joint : mechrel.scene.model.Joint
        A clearance joint.

    Returns
    -------
    numpy.ndarray
        Its parameter vector (:data:`mechrel.forces.params.N_PARAMS` floats).

    Examples
    --------
    >>> from mechrel.forces.params import P_C
    >>> from mechrel.scene import load_scene
    >>> float(clearance_parameters(load_scene("slider-crank-dry").joints["C"])[P_C])   # m
    0.0005
    """
    from ..forces.packing import pack_joint

    return pack_joint(joint)


def _system(scene: Scene, index, clearance_as: str) -> tuple[System, tuple[str, ...]]:
    """Build one System and a label per constraint row; ``clearance_as`` in
    {"force", "offset", "ideal"}."""
    from ..forces.params import N_PARAMS

    nb = len(index)
    mass = np.empty(3 * nb)
    for name, k in index.items():
        b = scene.bodies[name]
        mass[3 * k:3 * k + 3] = (b.mass, b.mass, b.inertia)

    rev_i, rev_j, rev_si, rev_sj, rev_off, rev_offdot = [], [], [], [], [], []
    tr_i, tr_si, tr_p0, tr_n, tr_angle = [], [], [], [], []
    fa_i, fa_angle = [], []
    ln_i, ln_si, ln_j, ln_sj, ln_n = [], [], [], [], []
    ra_i, ra_j, ra_angle = [], [], []
    rev_labels, tr_labels, fa_labels, ln_labels, ra_labels = [], [], [], [], []
    cl_b, cl_j, cl_sb, cl_sj, cl_p, cl_hist = [], [], [], [], [], []
    n_contact = 0
    for joint in scene.joints.values():
        if joint.type == "revolute":
            if joint.is_clearance and clearance_as == "force":
                b, sb = _point(scene, joint.points[0], index)
                j, sj = _point(scene, joint.points[1], index)
                p = clearance_parameters(joint)
                cl_b.append(b); cl_sb.append(sb); cl_j.append(j); cl_sj.append(sj)
                cl_p.append(p)
                if joint.clearance_model.has_contact:
                    cl_hist.append(n_contact)
                    n_contact += 1
                else:
                    cl_hist.append(-1)
                continue
            # Revolute equation written journal-side minus bearing-side, so that a clearance
            # joint assembled at eccentricity e0 reads r_S - r_B - e0 = 0.
            i, si = _point(scene, joint.points[1], index)
            j, sj = _point(scene, joint.points[0], index)
            if i < 0:  # keep the moving body first
                i, si, j, sj = j, sj, i, si
                sign = -1.0
            else:
                sign = 1.0
            off = np.zeros(2)
            offdot = np.zeros(2)
            if joint.is_clearance and clearance_as == "offset":
                off = sign * np.asarray(joint.initial_eccentricity, dtype=float)
                offdot = sign * np.asarray(joint.initial_eccentricity_rate, dtype=float)
            rev_i.append(i); rev_j.append(j); rev_si.append(si); rev_sj.append(sj)
            rev_off.append(off); rev_offdot.append(offdot)
            rev_labels += [f"joints.{joint.name} (x)", f"joints.{joint.name} (y)"]
        elif (joint.type == "translational" and joint.points[0].body != GROUND
              and joint.points[1].body == GROUND):  # a slider on a ground line
            i, si = _point(scene, joint.points[0], index)
            _, p0 = _point(scene, joint.points[1], index)
            u = np.asarray(joint.direction, dtype=float)
            u = u / math.hypot(*u)
            tr_i.append(i); tr_si.append(si); tr_p0.append(p0)
            tr_n.append(np.array([-u[1], u[0]])); tr_angle.append(joint.angle)
            tr_labels += [f"joints.{joint.name} (on line)", f"joints.{joint.name} (angle)"]
        elif joint.type in ("translational", "pin-in-slot"):  # a point on another body's line
            i, si = _point(scene, joint.points[0], index)
            j, sj = _point(scene, joint.points[1], index)
            u = _line_direction(scene, joint)
            ln_i.append(i); ln_si.append(si); ln_j.append(j); ln_sj.append(sj)
            ln_n.append(np.array([-u[1], u[0]]))
            ln_labels.append(f"joints.{joint.name} (on line)")
            if joint.type == "translational":
                ra_i.append(i); ra_j.append(j); ra_angle.append(joint.angle)
                ra_labels.append(f"joints.{joint.name} (angle)")
        elif joint.type == "fixed-angle":
            i, _ = _point(scene, joint.points[0], index)
            fa_i.append(i); fa_angle.append(joint.angle)
            fa_labels.append(f"joints.{joint.name} (angle)")
        else:  # pragma: no cover - the loader rejects other types
            raise SceneError(f"joints.{joint.name}.type: unknown joint type {joint.type!r}")

    dr_i = [index[d.body] for d in scene.drivers.values()]
    dr_law = [_LAW_CODES[d.law] for d in scene.drivers.values()]
    dr_par = [_driver_row(d) for d in scene.drivers.values()]

    def ints(x):
        return np.asarray(x, dtype=np.int64).reshape(-1)

    def vecs(x, width=2):
        return np.asarray(x, dtype=float).reshape(-1, width)

    labels = tuple(rev_labels + tr_labels + fa_labels + ln_labels + ra_labels
                   + [f"drivers.{name}" for name in scene.drivers])
    # Bodies of each constraint row, in the row order of mechrel.mechanics.constraints: revolute
    # x and y rows (i, j), translational (i) twice, fixed angles (i), points on lines and
    # relative angles (i, j; the moving one first when i is the ground), drivers (i).
    row_body = ([(i, j) for i, j in zip(rev_i, rev_j) for _ in range(2)]
                + [(i, -1) for i in tr_i for _ in range(2)]
                + [(i, -1) for i in fa_i]
                + [(i, j) if i >= 0 else (j, -1) for i, j in zip(ln_i, ln_j)]
                + [(i, j) if i >= 0 else (j, -1) for i, j in zip(ra_i, ra_j)]
                + [(i, -1) for i in dr_i])
    row_body = np.asarray(row_body, dtype=np.int64).reshape(-1, 2)
    return System(
        mass=mass, gravity=np.asarray(scene.gravity, dtype=float),
        rev_i=ints(rev_i), rev_j=ints(rev_j), rev_si=vecs(rev_si), rev_sj=vecs(rev_sj),
        rev_off=vecs(rev_off), rev_offdot=vecs(rev_offdot),
        tr_i=ints(tr_i), tr_si=vecs(tr_si), tr_p0=vecs(tr_p0), tr_n=vecs(tr_n),
        tr_angle=np.asarray(tr_angle, dtype=float).reshape(-1),
        fa_i=ints(fa_i), fa_angle=np.asarray(fa_angle, dtype=float).reshape(-1),
        ln_i=ints(ln_i), ln_si=vecs(ln_si), ln_j=ints(ln_j), ln_sj=vecs(ln_sj),
        ln_n=vecs(ln_n), ra_i=ints(ra_i), ra_j=ints(ra_j),
        ra_angle=np.asarray(ra_angle, dtype=float).reshape(-1),
        dr_i=ints(dr_i), dr_law=ints(dr_law), dr_par=vecs(dr_par, N_DRIVER_PARAMS),
        cl_b=ints(cl_b), cl_j=ints(cl_j), cl_sb=vecs(cl_sb), cl_sj=vecs(cl_sj),
        cl_p=vecs(cl_p, N_PARAMS), cl_hist=ints(cl_hist),
        baumgarte=np.array([scene.solver.baumgarte_alpha, scene.solver.baumgarte_beta]),
        row_body=row_body, **schur_structure(row_body),
    ), labels


def without_clearance_forces(system: System) -> System:
    """The same mechanism with every clearance-joint force switched off (film viscosity and
    contact stiffness zero: both force laws are proportional to them), for the smooth part of
    the stiff integrator's Jacobian (:mod:`mechrel.integrate.radau`).

    Parameters
    ----------
    system : System
        A compiled mechanism.

    Returns
    -------
    System
        A copy with ``cl_p[:, P_MU]`` and ``cl_p[:, P_K]`` zero (the same object when it has
        no clearance joint).

    Examples
    --------
    >>> from mechrel.forces.params import P_K
    >>> from mechrel.scene import load_scene
    >>> system = compile_scene(load_scene("slider-crank-dry")).dynamic
    >>> bool(system.cl_p[0, P_K] > 0), float(without_clearance_forces(system).cl_p[0, P_K])
    (True, 0.0)
    """
    from ..forces.params import P_K, P_MU

    if system.cl_p.shape[0] == 0:
        return system
    p = system.cl_p.copy()
    p[:, P_MU] = 0.0
    p[:, P_K] = 0.0
    return system._replace(cl_p=p)


def schur_structure(row_body: np.ndarray) -> dict:
    """Symbolic factorisation of the Schur complement ``S = Φ_q M⁻¹ Φ_qᵀ``.

    ``S[r, s]`` is structurally non-zero only when constraint rows r and s act on a common body
    (``M`` is diagonal), so S is sparse: on the nine-bar 110 of 400 entries. The rows are
    ordered by greedy minimum degree (fewest fill-ins first; Tinney & Walker 1967, the classic
    heuristic) and the fill of the Cholesky factor
    ``L`` is computed once here, so that the compiled solve visits only structural entries:
    on the lubricated nine-bar 136 multiply-adds instead of m³/6 = 1333 for a dense
    factorisation (docs/performance.md).

    Parameters
    ----------
    row_body : ndarray of int, shape (m, 2)
        Bodies of each constraint row (−1: none).

    Returns
    -------
    dict
        The ``ch_*`` and ``sc_*`` fields of :class:`System`.

    Examples
    --------
    Three rows on a chain of two bodies (row 1 couples body 0 and body 1): S is tridiagonal,
    its factor has no fill-in, two entries below the diagonal:

    >>> s = schur_structure(np.array([[0, -1], [0, 1], [1, -1]]))
    >>> s["ch_perm"].tolist(), s["ch_row_idx"].tolist()
    ([0, 1, 2], [0, 1])
    """
    return dict(_schur_structure(row_body.shape[0], row_body.tobytes()))


@functools.lru_cache(maxsize=64)
def _schur_structure(m: int, key: bytes) -> tuple:
    """:func:`schur_structure` by topology (cached: every sample of a study, and the dynamic,
    assembly and ideal systems of a scene without clearance joints, share it)."""
    rb = np.frombuffer(key, dtype=np.int64).reshape(m, 2)
    same = (rb[:, None, :, None] == rb[None, :, None, :]) & (rb[:, None, :, None] >= 0)
    share = same.any(axis=(2, 3))
    # greedy minimum degree on the graph of S, with fill-in edges added as nodes are eliminated
    adj = share.copy()
    np.fill_diagonal(adj, False)
    alive = np.ones(m, dtype=bool)
    perm = []
    for _ in range(m):
        deg = np.where(alive, (adj & alive).sum(axis=1), m + 1)
        r = int(np.argmin(deg))  # the first of the smallest degrees
        nb = np.nonzero(adj[r] & alive)[0]
        adj[np.ix_(nb, nb)] = True
        adj[nb, nb] = False
        alive[r] = False
        perm.append(r)
    perm = np.asarray(perm, dtype=np.int64)
    # contributions to S at permuted positions (p ≥ q), one per shared body, as flat indices
    # into the row-major L (m × m) and coefficient (m × 6) arrays of the workspace
    sp = same[np.ix_(perm, perm)]
    lower = (np.arange(m)[:, None] >= np.arange(m)[None, :])[:, :, None, None]
    p_, q_, a_, b_ = np.nonzero(sp & lower)
    sc = np.stack([p_ * m + q_, 6 * perm[p_] + 3 * a_, 6 * perm[q_] + 3 * b_,
                   3 * rb[perm[p_], a_]], axis=1)
    # symbolic Cholesky: pattern of L (lower, with fill) in the permuted order
    pat = share[np.ix_(perm, perm)].copy()
    for j in range(m):
        below = j + 1 + np.nonzero(pat[j + 1:, j])[0]
        pat[np.ix_(below, below)] = True
    pat = np.tril(pat, -1)
    rows = [np.nonzero(pat[i])[0].tolist() for i in range(m)]
    cols = [np.nonzero(pat[:, j])[0].tolist() for j in range(m)]
    ent, ptr, kk = [], [0], []
    for j in range(m):
        for i in [j] + cols[j]:
            ent.append((i * m + j, j))
            kk += [(i * m + k, j * m + k) for k in rows[j] if i == j or pat[i, k]]
            ptr.append(len(kk))
    row_ptr = np.cumsum([0] + [len(r) for r in rows]).astype(np.int64)
    out = dict(
        ch_perm=perm,
        sc_idx=np.asarray(sc, dtype=np.int64).reshape(-1, 4),
        ch_ent=np.asarray(ent, dtype=np.int64).reshape(-1, 2),
        ch_ptr=np.asarray(ptr, dtype=np.int64),
        ch_kk=np.asarray(kk, dtype=np.int64).reshape(-1, 2),
        ch_row_ptr=row_ptr,
        ch_row_idx=np.asarray([k for r in rows for k in r], dtype=np.int64),
    )
    for v in out.values():
        v.flags.writeable = False  # shared between systems by the cache
    return tuple(out.items())


def compile_scene(scene: Scene) -> CompiledScene:
    """Resolve names to indices and build the dynamic, assembly and ideal systems.

    Parameters
    ----------
    scene : mechrel.scene.model.Scene
        A validated scene.

    Returns
    -------
    CompiledScene
        The scene as arrays.

    Raises
    ------
    mechrel.errors.SceneError
        A point output sits on the ground.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> compiled = compile_scene(load_scene("slider-crank-dry"))
    >>> compiled.labels["ideal"][-3:]
    ('joints.G (on line)', 'joints.G (angle)', 'drivers.crank')
    """
    names = tuple(scene.bodies)
    index = {name: k for k, name in enumerate(names)}
    q_guess = np.empty(3 * len(names))
    for name, k in index.items():
        b = scene.bodies[name]
        q_guess[3 * k:3 * k + 3] = (b.position[0], b.position[1], b.angle)

    out_body, out_s, out_axis = [], [], []  # the point outputs (the numpy baseline reads them)
    for out in scene.outputs.values():
        if out.kind != "point":
            continue
        i, s = _point(scene, out.point, index)
        if i < 0:
            raise SceneError(f"outputs.{out.name}.point: {out.point} is a ground point; an "
                             "output must be on a moving body", path=f"outputs.{out.name}.point")
        a = np.asarray(out.axis, dtype=float)
        out_body.append(i); out_s.append(s); out_axis.append(a / math.hypot(*a))

    driver_names = tuple(scene.drivers)
    cycle = -1
    period = None
    if scene.analysis.cycle_driver is not None:
        cycle = driver_names.index(scene.analysis.cycle_driver)
        period = 2.0 * math.pi / abs(scene.drivers[scene.analysis.cycle_driver].speed)

    clearance = scene.clearance_joints
    systems = {kind: _system(scene, index, how) for kind, how in
               (("dynamic", "force"), ("assembly", "offset"), ("ideal", "ideal"))}
    return CompiledScene(
        dynamic=systems["dynamic"][0], assembly=systems["assembly"][0],
        ideal=systems["ideal"][0], labels={k: v[1] for k, v in systems.items()},
        body_names=names, body_index=index, q_guess=q_guess,
        clearance_names=tuple(j.name for j in clearance),
        contact_names=tuple(j.name for j in clearance if j.clearance_model.has_contact),
        driver_names=driver_names, output_names=tuple(scene.outputs),
        out_body=np.asarray(out_body, dtype=np.int64).reshape(-1),
        out_s=np.asarray(out_s, dtype=float).reshape(-1, 2),
        out_axis=np.asarray(out_axis, dtype=float).reshape(-1, 2),
        cycle_driver=cycle, period=period,
    )
