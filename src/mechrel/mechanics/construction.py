"""Closed-form kinematics of a fully driven mechanism: the bodies placed one after another.

Most machines are built from the cranks their motors turn and, added one after another,
groups of two links whose two outer joints are already placed: Assur groups of class II
(Artobolevsky 1977, ch. 2). Such a group's inner joint is where two circles meet (the RRR
dyad: two links pinned to placed points and to each other), where a circle meets a line (the
RRP dyad: a link and a slider on a fixed guide), or it is a slider on a turning link (the RPR
dyad: a link pivoted at a placed point whose line must pass through a placed pin or a block
pinned at a placed point: a Whitworth quick-return, a slotted lever, a hydraulic cylinder).
Its position is then a closed form with one square root, and its velocity and acceleration
two linear equations each, so the kinematic analysis needs no Newton iteration and no
factorisation of Φ_q (Hartenberg & Denavit 1964, ch. 8; Nikravesh 1988, §5.5 calls these
"kinematic modules").

:func:`construction` reads a :class:`~mechrel.mechanics.system.System` as a graph of *nodes*
(the points where revolute joints pin bodies together: a body point and every point pinned to
it, transitively, are one node; the ground's points are placed) and finds an order of steps
that places every body, or returns None when the mechanism is not built that way (a class-III
group, a slider on a moving body other than the RPR dyad's, a prescribed offset in a revolute
joint). The steps:

``POSE_ANGLE``
    a body whose angle is known (a driver, a fixed angle) and one of whose nodes is placed;
    or, where no other step can go on, an undriven body one of whose nodes is placed, whose
    angle then becomes a **free angle**: a coordinate of the mechanism's own (a pendulum's
    swing, the crank of a machine turned by a torque rather than a prescribed motion);
``SLIDE``
    where no other step (and no free angle) can go on, a slider none of whose nodes is placed
    (a cart on a rail, a block on an incline): one of its nodes at a **free position**
    ``N = P₀ + s u`` along the line, ``s`` a coordinate of the mechanism's own like a free
    angle, the slider then posed at its fixed angle. A slider that carries no revolute joint
    gets a node at its sliding point for this. Free angles and free positions together are
    the plan's *free coordinates*;
``POSE_TWO``
    a body two of whose nodes are placed (the angle from the line through them);
``LOCATE``
    the other nodes of a placed body;
``CIRCLES``
    a node that two unplaced bodies share, each with one other node placed: the two circles
    around those nodes meet at ``N = N₁ + (a/L) D ± (h/L) D⊥`` with ``D = N₂ − N₁``,
    ``a = (d₁² − d₂² + L²)/(2L)``, ``h = √(d₁² − a²)``;
``CIRCLE_LINE``
    a node that an unplaced body (one other node placed) shares with a slider on a fixed line,
    or the pin of a pin-in-slot joint in a ground slot:
    ``N = P₀ + (w·u ± √(d₁² − (u × w)²)) u`` with ``w = N₁ − P₀``;
``TURN``
    an unplaced body *j* with one placed node ``N₁`` whose line (a translational or pin-in-slot
    joint's, unit normal ``n = A_j n̄``) must pass through a placed pin ``N₂`` (pin in slot),
    or through the sliding point of a block with one placed node ``N₂`` whose angle is *j*'s
    plus the joint's (translational): ``n·w = h`` with ``w = N₂ − N₁`` and ``h`` constant
    (the line's offset from ``N₁``, less the sliding point's from ``N₂``), so
    ``n = (h w ± √(|w|² − h²) w⊥)/|w|²``; the block is then posed by ``POSE_ANGLE`` with its
    angle ``ANGLE_RELATIVE`` to *j*'s. Velocity ``ω = −n·ẇ/(n × w)``, acceleration
    ``α = −(n·ẅ + 2 ω n × ẇ − ω² n·w)/(n × w)`` (docs/mechanics.md).

Each step that builds a node is followed by placing the bodies it used, so every constraint
equation is used exactly once. A free coordinate is taken only when the construction is
stuck, one body at a time (a free angle before a free position), and the plan is refused if a
body later receives more placed nodes than its freedom allows; the free coordinates are then as
many as the mechanism's undriven degrees of freedom (a kinematic analysis has none: it needs a
fully driven mechanism). The sign of each square root
(the assembly branch) is the one of the first guess. Velocities and accelerations follow the
steps in the same order: a node where two circles meet has ``(N − N_i)·(Ṅ − Ṅ_i) = 0`` for
i = 1, 2, and ``(N − N_i)·(N̈ − N̈_i) + |Ṅ − Ṅ_i|² = 0``; a body through two nodes turns at
``ω = (d × ḋ)/|d|²``, ``α = (d × d̈)/|d|²`` with ``d = N₂ − N₁`` (a rigid ``d`` has
``ḋ = ω d⊥`` and ``d̈ = α d⊥ − ω² d``).

:func:`_construct` reports an instant where a square root has no real value, two circles are
tangent (a toggle) or a value overflowed (a driver speed of 1e300 rad/s) as not done, and
:func:`~mechrel.mechanics.kinematics.kinematic_analysis` continues from there with
Newton–Raphson; :func:`_construct` also returns the constraint residual Φ of the first and the
last instant built, and the analysis solves every instant by Newton where that exceeds the
tolerance. Each step satisfies the equations it uses to round-off, wherever it has a real
solution, so a residual can only come from a construction that leaves some equation unused,
which would show at any instant.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .borrow import borrowed
from .constraints import violations_at
from .drivers import driver_law

__all__ = ["Construction", "construction"]

# Step codes (column 0 of Construction.op).
POSE_ANGLE, POSE_TWO, LOCATE, CIRCLES, CIRCLE_LINE, OFFSET, SLIDE, TURN = range(8)
# Where a POSE_ANGLE step's angle comes from (its op[:, 3]).
ANGLE_DRIVER, ANGLE_CONSTANT, ANGLE_FREE, ANGLE_RELATIVE = 0, 1, 2, 3


class Construction(NamedTuple):
    """The steps that place a mechanism's bodies one after another (:func:`construction`).

    Parameters
    ----------
    op : ndarray of int, shape (n_steps, 9)
        One row per step, ``(code, a, b, c, d, j1, s1, j2, s2)``:

        - ``POSE_ANGLE``: body, node, angle source (``ANGLE_DRIVER``, ``ANGLE_CONSTANT``,
          ``ANGLE_FREE`` or ``ANGLE_RELATIVE``), the row of the angle in the passes' ``drv``
          array (the drivers first, then the free coordinates) or, for ``ANGLE_RELATIVE``,
          the body whose angle it adds to, and for ``ANGLE_FREE`` the free coordinate's
          index (in column 5);
        - ``TURN``: body, its placed node, the placed pin or block node, branch slot;
        - ``POSE_TWO``: body, node 1, node 2;
        - ``LOCATE``: node, body;
        - ``OFFSET``: node, node 1, clearance joint, sign: the node is node 1 plus sign × the
          joint's eccentricity (a journal is its bearing + e, a bearing its journal − e);
        - ``CIRCLES``: node, node 1, node 2, branch slot;
        - ``CIRCLE_LINE``: node, node 1, –, branch slot;
        - ``SLIDE``: node, body, –, the row of the free position in ``drv``, the free
          coordinate's index.

        ``(j1, s1)`` and ``(j2, s2)``: the circles around node 1 and node 2 are centred
        ``s`` × clearance joint ``j``'s eccentricity away from them (``s = 0``: not moved),
        where the node being placed is the far end of a clearance joint from the link
        that makes the circle.
    par : ndarray, shape (n_steps, 5)
        The step's numbers (m, rad; unused entries zero): ``POSE_ANGLE`` the node in the
        body's frame and the constant (or relative) angle; ``POSE_TWO`` node 1 in the body's
        frame and the angle φ₀ of node 1 → node 2 in it; ``LOCATE`` the node in the body's
        frame; ``CIRCLES`` the radii d₁, d₂ around nodes 1 and 2; ``CIRCLE_LINE`` the radius
        d₁, a point P₀ of the line and its unit direction u; ``SLIDE`` the node's position P₀
        at ``s = 0`` and the line's unit direction u (columns 0–3); ``TURN`` the placed node
        in the body's frame, h and the line's unit normal n̄ in the body's frame.
    node_body : ndarray of int, shape (n_nodes,)
        A body each node is a point of (−1: the ground).
    node_s : ndarray, shape (n_nodes, 2)
        The node in that body's frame, a ground node's global position (m): the kernel reads
        the first guess's nodes from them, for the branch of each square root.
    cl_nodes : ndarray of int, shape (nc, 2)
        Each clearance joint's bearing node and journal node (a mechanism with clearance
        joints as force elements, ``compiled.dynamic``; empty for an ideal one).
    n_branches : int
        The number of square roots (``CIRCLES``, ``CIRCLE_LINE`` and ``TURN`` steps).
    n_free : int
        The number of free coordinates: free angles (``POSE_ANGLE`` steps with
        ``ANGLE_FREE``) and free positions (``SLIDE`` steps), the mechanism's undriven
        degrees of freedom; zero for a fully driven one.

    Examples
    --------
    The nine-bar's fourteen steps; the first circles are rod 3 (0.326 m) and rod 4
    (0.497 m) around the crank pins:

    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> plan = construction(compile_scene(load_scene("nine-bar")).ideal)
    >>> plan.op.shape, plan.n_branches, plan.par[4, :2].round(3).tolist()
    ((14, 9), 3, [0.326, 0.497])
    """

    op: np.ndarray  # (n_steps, 9) int64
    par: np.ndarray  # (n_steps, 5) float64
    node_body: np.ndarray  # (n_nodes,) int64
    node_s: np.ndarray  # (n_nodes, 2) float64
    cl_nodes: np.ndarray  # (nc, 2) int64: each clearance joint's bearing and journal node
    n_branches: int
    n_free: int


class _Refuse(Exception):
    """The mechanism is not built of the steps above (internal to :func:`construction`)."""


def _plan(nb, rev_i, rev_j, rev_si, rev_sj, tr_i, tr_si, tr_p0, tr_n, tr_angle, fa_i,
          fa_angle, ln_i, ln_si, ln_j, ln_sj, ln_n, ra_i, ra_j, ra_angle, dr_i, cl_b, cl_sb,
          cl_j, cl_sj):
    # Nodes: the revolute joints' end points, keyed by (body, x, y) (ground: global x, y),
    # joined transitively by union-find.
    keys: dict[tuple, int] = {}
    parent: list[int] = []

    def key_of(body, s):
        k = (int(body), float(s[0]), float(s[1]))
        if k not in keys:
            keys[k] = len(parent)
            parent.append(len(parent))
        return keys[k]

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for j in range(rev_i.shape[0]):
        a = find(key_of(rev_i[j], rev_si[j]))
        b = find(key_of(rev_j[j], rev_sj[j]))
        parent[max(a, b)] = min(a, b)
    # a slider that carries no revolute joint: a node at its sliding point (for SLIDE)
    pinned = {int(b) for b in (*rev_i, *rev_j, *cl_b, *cl_j)}
    for t, b in enumerate(tr_i):
        if int(b) not in pinned:
            key_of(b, tr_si[t])
    # the pin of a pin-in-slot joint (a point on a line, no relative angle): a node
    pins = {int(k): key_of(ln_i[k], ln_si[k]) for k in range(len(ln_i))
            if not any(int(ra_i[a]) == int(ln_i[k]) and int(ra_j[a]) == int(ln_j[k])
                       for a in range(len(ra_i)))}
    # a clearance joint's bearing and journal points: two nodes, e = journal − bearing apart
    ends = [(key_of(cl_b[c], cl_sb[c]), key_of(cl_j[c], cl_sj[c])) for c in range(len(cl_b))]
    roots = sorted({find(k) for k in keys.values()})
    node_of = {r: n for n, r in enumerate(roots)}
    ends = [(node_of[find(kb)], node_of[find(kj)]) for kb, kj in ends]
    pins = {k: node_of[find(key)] for k, key in pins.items()}
    if any(nb_ == nj_ for nb_, nj_ in ends):
        raise _Refuse  # the joint's two points pinned together by revolute joints
    n_nodes = len(roots)
    # body -> {node: local point}; a node holding two points of one body (or two ground
    # points) pins them together: not a mechanism this builds
    on_body: list[dict[int, tuple[float, float]]] = [dict() for _ in range(nb)]
    ground: dict[int, tuple[float, float]] = {}
    node_body = np.full(n_nodes, -2, dtype=np.int64)
    node_s = np.zeros((n_nodes, 2))
    for (body, x, y), k in keys.items():
        n = node_of[find(k)]
        where = ground if body < 0 else on_body[body]
        if n in where and where[n] != (x, y):
            raise _Refuse
        where[n] = (x, y)
        if node_body[n] == -2 or body < 0:
            node_body[n] = body
            node_s[n] = (x, y)
    # the angle of a body, where a constraint states it: (source, driver, constant)
    angle: dict[int, tuple[int, int, float]] = {}
    line: dict[int, int] = {}
    for d, b in enumerate(dr_i):
        if b in angle:
            raise _Refuse
        angle[int(b)] = (ANGLE_DRIVER, d, 0.0)
    for f, b in enumerate(fa_i):
        if b in angle:
            raise _Refuse
        angle[int(b)] = (ANGLE_CONSTANT, 0, float(fa_angle[f]))
    for t, b in enumerate(tr_i):
        if b in angle:
            raise _Refuse
        angle[int(b)] = (ANGLE_CONSTANT, 0, float(tr_angle[t]))
        line[int(b)] = t
    # points on lines: (point body, point, line body, line point, unit normal, relative angle
    # or None for a pin in a slot); a pin in a ground slot is a line for CIRCLE_LINE
    rides = {}
    for k in range(len(ln_i)):
        rel = [float(ra_angle[a]) for a in range(len(ra_i))
               if int(ra_i[a]) == int(ln_i[k]) and int(ra_j[a]) == int(ln_j[k])]
        rides[k] = (int(ln_i[k]), tuple(map(float, ln_si[k])), int(ln_j[k]),
                    tuple(map(float, ln_sj[k])), tuple(map(float, ln_n[k])),
                    rel[0] if rel else None)
    if len(ra_i) != sum(r[5] is not None for r in rides.values()):
        raise _Refuse  # a relative angle without its line (not a joint this builds)
    slots: dict[int, list[int]] = {}  # pin node -> the ground slots it rides in
    for k, (i, _, j, _, _, rel) in rides.items():
        if j < 0 and rel is None and i >= 0:
            slots.setdefault(pins[k], []).append(k)

    placed = set(ground)
    posed: set[int] = set()
    used_offsets: set[int] = set()
    op: list[tuple] = []
    par: list[tuple] = []
    n_branches = 0
    free: list[int] = []  # the bodies with a free coordinate (angle or position), in order
    turns = [k for k, r in rides.items() if r[2] >= 0]  # rides on moving lines, not placed yet

    def riding():
        """The bodies whose angle a ride still to be placed sets: its line body, and the
        block of a translational one."""
        return {rides[k][2] for k in turns} | {rides[k][0] for k in turns
                                               if rides[k][5] is not None}

    def locate_rest(b, used):
        for n, s in on_body[b].items():
            if n in used:
                continue
            if n in placed:  # a closed loop that this order does not solve
                raise _Refuse
            op.append((LOCATE, n, b, 0, 0, -1, 0, -1, 0))
            par.append((s[0], s[1], 0.0, 0.0, 0.0))
            placed.add(n)

    def pose_two(b, n1, n2):
        s1, s2 = on_body[b][n1], on_body[b][n2]
        op.append((POSE_TWO, b, n1, n2, 0, -1, 0, -1, 0))
        par.append((s1[0], s1[1], math.atan2(s2[1] - s1[1], s2[0] - s1[0]), 0.0, 0.0))
        posed.add(b)
        locate_rest(b, (n1, n2))

    def pose_angle(b, n):
        src, d, th = angle[b]
        s = on_body[b][n]
        op.append((POSE_ANGLE, b, n, src, d, -1, 0, -1, 0))
        par.append((s[0], s[1], th, 0.0, 0.0))
        posed.add(b)
        locate_rest(b, (n,))

    def pose_free(b, n):
        s = on_body[b][n]
        op.append((POSE_ANGLE, b, n, ANGLE_FREE, len(dr_i) + len(free), len(free), 0, -1, 0))
        par.append((s[0], s[1], 0.0, 0.0, 0.0))
        free.append(b)
        posed.add(b)
        locate_rest(b, (n,))

    def rail(b, n):
        """The line slider b's node n moves on: its point P0 (the node with the slider at
        the joint's point of the line) and the joint's unit direction u (from its normal
        n = (−u_y, u_x))."""
        t = line[b]
        th = float(tr_angle[t])
        c, s = math.cos(th), math.sin(th)
        ds = np.subtract(on_body[b][n], tr_si[t])  # the node's offset from the sliding point
        p0 = tr_p0[t] + (c * ds[0] - s * ds[1], s * ds[0] + c * ds[1])
        return p0, (tr_n[t][1], -tr_n[t][0])

    def slide_free(b, n):
        p0, u = rail(b, n)
        op.append((SLIDE, n, b, 0, len(dr_i) + len(free), len(free), 0, -1, 0))
        par.append((p0[0], p0[1], u[0], u[1], 0.0))  # s counts along the joint's direction
        free.append(b)
        placed.add(n)
        pose_angle(b, n)

    def dist(b, n1, n2):
        s1, s2 = on_body[b][n1], on_body[b][n2]
        return math.hypot(s2[0] - s1[0], s2[1] - s1[1])

    def one_placed(b):
        """Body b's placed node, if it has exactly one (else None)."""
        here = [n for n in on_body[b] if n in placed]
        return here[0] if len(here) == 1 else None

    def turn(k):
        """The RPR group of ride k, if it can be placed now: its line body j turns about
        its one placed node N₁ until the line passes through the placed pin (pin in slot)
        or through the sliding point of a block with one placed node N₂ (translational),
        ``n·(N₂ − N₁) = h`` with ``n = A_j n̄``; then the block is posed at θ_j + angle.
        True when the steps were added."""
        i, si, j, sj, nbar, rel = rides[k]
        if j < 0 or j in posed or j in angle or j == i:
            return False
        n1 = one_placed(j)
        if n1 is None:
            return False
        s1 = on_body[j][n1]
        h = nbar[0] * (sj[0] - s1[0]) + nbar[1] * (sj[1] - s1[1])  # n̄·(s_Q − s₁)
        if rel is None:
            n2 = pins[k]
            if n2 not in placed or (i >= 0 and i not in posed):
                return False
        else:
            if i < 0 or i in posed or i in angle:
                return False
            n2 = one_placed(i)
            if n2 is None:
                return False
            s2 = on_body[i][n2]
            c, sn_ = math.cos(rel), math.sin(rel)
            dx, dy = si[0] - s2[0], si[1] - s2[1]  # the sliding point from N₂, block frame
            h -= nbar[0] * (c * dx - sn_ * dy) + nbar[1] * (sn_ * dx + c * dy)
        op.append((TURN, j, n1, n2, n_branches, -1, 0, -1, 0))
        par.append((s1[0], s1[1], h, nbar[0], nbar[1]))
        posed.add(j)
        locate_rest(j, (n1,))
        if rel is not None:  # the block, at the line body's angle plus the joint's
            op.append((POSE_ANGLE, i, n2, ANGLE_RELATIVE, j, -1, 0, -1, 0))
            par.append((s2[0], s2[1], rel, 0.0, 0.0))
            posed.add(i)
            locate_rest(i, (n2,))
        return True

    while len(posed) < nb:
        progress = False
        for b in range(nb):
            if b in posed:
                continue
            here = [n for n in on_body[b] if n in placed]
            if b in angle and b not in line and len(here) == 1:
                pose_angle(b, here[0])
                progress = True
            elif len(here) >= 2 or (b in angle and len(here) >= 1):
                raise _Refuse  # more placed nodes than the body has freedom for
        for n in range(n_nodes):
            if n in placed:
                continue
            offset = [(c, other, sg) for c, (n_b, n_j) in enumerate(ends)
                      for end, other, sg in ((n_b, n_j, -1), (n_j, n_b, 1))
                      if end == n and other in placed]
            if offset:  # bearing = journal − e, journal = bearing + e
                c, other, sg = offset[0]
                op.append((OFFSET, n, other, c, sg, -1, 0, -1, 0))
                par.append((0.0, 0.0, 0.0, 0.0, 0.0))
                placed.add(n)
                used_offsets.add(c)
                progress = True
                continue
            # circles for n: bodies holding n, or holding the far end m of a clearance joint
            # at n (n = m + sg e: that body's circle for n is centred sg e away)
            holders = [(n, -1, 0)] + [(other, c, sg) for c, (n_b, n_j) in enumerate(ends)
                                      for end, other, sg in ((n_b, n_j, -1), (n_j, n_b, 1))
                                      if end == n and other not in placed]
            circles, lines = [], []
            for m, c, sg in holders:
                for b in range(nb):
                    if b in posed or m not in on_body[b]:
                        continue
                    here = [k for k in on_body[b] if k in placed]
                    if b in line and not here and c < 0:
                        lines.append(b)
                    elif b not in angle and len(here) == 1 and b not in riding():
                        circles.append((b, here[0], m, c, sg))
            slider = -1  # the body on a line, if a circle meets its line
            slot = slots.get(n, [])  # ground slots the pin node n rides in
            if len(circles) >= 2:
                (b1, n1, m1, c1, s1), (b2, n2, m2, c2, s2) = circles[:2]
                op.append((CIRCLES, n, n1, n2, n_branches, c1, s1, c2, s2))
                par.append((dist(b1, n1, m1), dist(b2, n2, m2), 0.0, 0.0, 0.0))
                used = ((b1, n1, m1, c1, s1), (b2, n2, m2, c2, s2))
            elif circles and lines:
                (b1, n1, m1, c1, s1), b2 = circles[0], lines[0]
                p0, u = rail(b2, n)
                op.append((CIRCLE_LINE, n, n1, 0, n_branches, c1, s1, -1, 0))
                par.append((dist(b1, n1, m1), p0[0], p0[1], u[0], u[1]))
                used = ((b1, n1, m1, c1, s1),)
                slider = b2
            elif circles and slot:  # a pin in a ground slot: N = P0 + s u, u ⊥ the normal
                (b1, n1, m1, c1, s1), (_, _, _, p0, nrm, _) = circles[0], rides[slot[0]]
                op.append((CIRCLE_LINE, n, n1, 0, n_branches, c1, s1, -1, 0))
                par.append((dist(b1, n1, m1), p0[0], p0[1], nrm[1], -nrm[0]))
                used = ((b1, n1, m1, c1, s1),)
                del slots[n]
            else:
                continue
            n_branches += 1
            placed.add(n)
            for b, k, m, c, sg in used:
                if m != n:  # the clearance joint's far end: m = n − sg e
                    op.append((OFFSET, m, n, c, -sg, -1, 0, -1, 0))
                    par.append((0.0, 0.0, 0.0, 0.0, 0.0))
                    placed.add(m)
                    used_offsets.add(c)
                pose_two(b, k, m)
            if slider >= 0:
                pose_angle(slider, n)
            progress = True
        for k in list(turns):
            if turn(k):
                turns.remove(k)
                n_branches += 1
                progress = True
        if not progress:  # stuck: the first undriven body pinned at one placed node swings
            # freely (a free angle: module docstring), one whose angle no ride sets first
            for b in sorted(range(nb), key=lambda b: b in riding()):
                here = [n for n in on_body[b] if n in placed]
                if b not in posed and b not in angle and len(here) == 1:
                    pose_free(b, here[0])
                    progress = True
                    break
        if not progress:  # still stuck: the first slider with no placed node slides freely
            for b in range(nb):  # (a free position: module docstring)
                if b not in posed and b in line and on_body[b] \
                        and not any(n in placed for n in on_body[b]):
                    slide_free(b, min(on_body[b]))
                    progress = True
                    break
        if not progress:
            raise _Refuse
    if len(placed) < n_nodes or len(used_offsets) < len(ends) or turns or slots:
        raise _Refuse  # a node, a clearance joint's offset or a ride on a line left over
    return Construction(np.array(op, dtype=np.int64).reshape(-1, 9),
                        np.array(par, dtype=float).reshape(-1, 5), node_body, node_s,
                        np.array(ends, dtype=np.int64).reshape(-1, 2), n_branches, len(free))


_PLANS: dict[tuple, Construction | None] = {}


def construction(system) -> Construction | None:
    """The steps that place ``system``'s bodies in closed form, or None.

    Parameters
    ----------
    system : System
        A compiled mechanism (:class:`~mechrel.mechanics.system.System`): a fully driven one
        (``compiled.ideal``), or one whose clearance joints are force elements
        (``compiled.dynamic``), placed for given eccentricities of those joints.

    Returns
    -------
    Construction or None
        None when the mechanism is not built of driven or fixed-angle bodies and class-II
        groups (two circles, a circle and a fixed line, a line turning through a placed pin
        or block), when a revolute joint holds a
        prescribed offset, when some constraint would be left unused (a closed loop the
        order does not solve, a redundant constraint), when a clearance joint's
        eccentricity is not free (both its points placed by other joints), or when the
        eccentricities and free coordinates would not be as many as the mechanism's degrees
        of freedom.

    Examples
    --------
    The slider-crank: the crank is placed by its driver, then the crank pin and the slider's
    pin meet where a circle (the rod) crosses the slider's line:

    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> plan = construction(compile_scene(load_scene("slider-crank")).ideal)
    >>> names = ("POSE_ANGLE", "POSE_TWO", "LOCATE", "CIRCLES", "CIRCLE_LINE", "OFFSET",
    ...          "SLIDE", "TURN")
    >>> [names[c] for c in plan.op[:, 0]]
    ['POSE_ANGLE', 'LOCATE', 'CIRCLE_LINE', 'POSE_TWO', 'POSE_ANGLE']

    With its rod–slider joint as a lubricated bearing, the slider's pin is where the rod's
    circle, centred e away from the crank pin, crosses the line; the rod's eye is e from it:

    >>> plan = construction(compile_scene(load_scene("slider-crank-lubricated")).dynamic)
    >>> [names[c] for c in plan.op[:, 0]]
    ['POSE_ANGLE', 'LOCATE', 'CIRCLE_LINE', 'OFFSET', 'POSE_TWO', 'POSE_ANGLE']

    The double pendulum is not driven: each link swings about the node already placed, so
    each gets a free angle (rows 0 and 1 of the passes' ``drv``, there being no driver):

    >>> plan = construction(compile_scene(load_scene("double-pendulum")).ideal)
    >>> [names[c] for c in plan.op[:, 0]], plan.n_free, plan.op[[0, 2], 3:6].tolist()
    (['POSE_ANGLE', 'LOCATE', 'POSE_ANGLE'], 2, [[2, 0, 0], [2, 1, 1]])

    The Whitworth: the crank, then its pin; the lever turns about its pivot until its slot
    passes through the block on the pin (the block at the lever's angle); the ram where the
    rod's circle meets its guide:

    >>> plan = construction(compile_scene(load_scene("whitworth")).ideal)
    >>> [names[c] for c in plan.op[:, 0]]  # doctest: +NORMALIZE_WHITESPACE
    ['POSE_ANGLE', 'LOCATE', 'TURN', 'LOCATE', 'POSE_ANGLE', 'CIRCLE_LINE', 'POSE_TWO',
     'POSE_ANGLE']
    """
    s = system
    parts = (s.rev_i, s.rev_j, s.rev_si, s.rev_sj, s.tr_i, s.tr_si, s.tr_p0, s.tr_n,
             s.tr_angle, s.fa_i, s.fa_angle, s.ln_i, s.ln_si, s.ln_j, s.ln_sj, s.ln_n,
             s.ra_i, s.ra_j, s.ra_angle, s.dr_i, s.cl_b, s.cl_sb, s.cl_j, s.cl_sj)
    # the plan is a function of these arrays' contents and of the offsets, and the key is
    # looked up on every run of a sample: a tuple of each array's bytes (whose length gives its
    # shape, each field having its own dtype and trailing dimensions) hashes three times faster
    # than their shapes with one joined string
    key = (s.mass.shape[0], *[a.tobytes() for a in parts], s.rev_off.tobytes(),
           s.rev_offdot.tobytes())
    try:
        return _PLANS[key]
    except KeyError:
        pass
    if len(_PLANS) >= 256:
        _PLANS.clear()
    plan: Construction | None = None
    if not (s.rev_off.any() or s.rev_offdot.any()):  # a nonzero (or NaN) offset: none
        try:
            plan = _plan(s.mass.shape[0] // 3, *parts)
        except _Refuse:
            pass
    # a plan that uses every constraint equation once leaves the mechanism's degrees of
    # freedom n − m to the eccentricities and the free coordinates; anything else would be
    # a constraint used twice or not at all (the steps are built so that it cannot be:
    # this is the check that they were)
    if plan is not None and (s.mass.shape[0] - s.n_constraints
                             != 2 * plan.cl_nodes.shape[0] + plan.n_free):
        plan = None
    _PLANS[key] = plan
    return plan


@njit(cache=True, inline='always')
def _at(X, k, E, c, sg):
    """``X[k] + sg E[c]``: node k's position, velocity or acceleration (``X``), moved by
    ``sg`` times clearance joint c's eccentricity or its rate (``E``); ``sg = 0``: no move."""
    if sg == 0:
        return X[k, 0], X[k, 1]
    return X[k, 0] + sg * E[c, 0], X[k, 1] + sg * E[c, 1]


@njit(cache=True, inline='always')
def _offset(op, o, X, E):
    """``OFFSET`` step ``o`` on positions, velocities or accelerations: node ``op[o, 1]`` is
    node ``op[o, 2]`` plus ``op[o, 4]`` times clearance joint ``op[o, 3]``'s eccentricity
    (``X``: the nodes' positions or derivatives, ``E``: the eccentricities' or theirs)."""
    k = op[o, 1]
    k1 = op[o, 2]
    c = op[o, 3]
    sg = float(op[o, 4])
    X[k, 0] = X[k1, 0] + sg * E[c, 0]
    X[k, 1] = X[k1, 1] + sg * E[c, 1]


@njit(cache=True, inline='always')
def _branch_signs(q0, con):
    """The sign of each square root on the assembly branch of the configuration ``q0``."""
    op = con.op
    par = con.par
    node_body = con.node_body
    node_s = con.node_s
    nn = node_body.shape[0]
    G = np.empty((nn, 2))  # the nodes of q0
    for k in range(nn):
        b = node_body[k]
        if b < 0:
            G[k, 0] = node_s[k, 0]
            G[k, 1] = node_s[k, 1]
        else:
            c = math.cos(q0[3 * b + 2])
            s = math.sin(q0[3 * b + 2])
            G[k, 0] = q0[3 * b] + c * node_s[k, 0] - s * node_s[k, 1]
            G[k, 1] = q0[3 * b + 1] + s * node_s[k, 0] + c * node_s[k, 1]
    ends = con.cl_nodes
    E = np.empty((ends.shape[0], 2))  # the guess's eccentricities, journal − bearing
    for c in range(ends.shape[0]):
        E[c, 0] = G[ends[c, 1], 0] - G[ends[c, 0], 0]
        E[c, 1] = G[ends[c, 1], 1] - G[ends[c, 0], 1]
    sign = np.ones(con.n_branches)
    for o in range(op.shape[0]):
        k = op[o, 1]
        if op[o, 0] == CIRCLES:
            x1, y1 = _at(G, op[o, 2], E, op[o, 5], op[o, 6])
            x2, y2 = _at(G, op[o, 3], E, op[o, 7], op[o, 8])
            if (x2 - x1) * (G[k, 1] - y1) - (y2 - y1) * (G[k, 0] - x1) < 0.0:
                sign[op[o, 4]] = -1.0
        elif op[o, 0] == CIRCLE_LINE:
            x1, y1 = _at(G, op[o, 2], E, op[o, 5], op[o, 6])
            if (G[k, 0] - x1) * par[o, 3] + (G[k, 1] - y1) * par[o, 4] < 0.0:
                sign[op[o, 4]] = -1.0
        elif op[o, 0] == TURN:  # the root's sign is −sign(n × w), n the guess's normal
            b = op[o, 1]
            k = op[o, 2]
            c = math.cos(q0[3 * b + 2])
            s = math.sin(q0[3 * b + 2])
            nx = c * par[o, 3] - s * par[o, 4]
            ny = s * par[o, 3] + c * par[o, 4]
            wx = G[op[o, 3], 0] - G[k, 0]
            wy = G[op[o, 3], 1] - G[k, 1]
            if nx * wy - ny * wx > 0.0:
                sign[op[o, 4]] = -1.0
    return sign


@njit(cache=True, inline='always')
def _normal(con, o, b, q):
    """The unit normal ``n = A_j n̄`` of ``TURN`` step ``o``'s line, on its body ``b`` at ``q``."""
    c = math.cos(q[3 * b + 2])
    s = math.sin(q[3 * b + 2])
    return (c * con.par[o, 3] - s * con.par[o, 4], s * con.par[o, 3] + c * con.par[o, 4])


@njit(cache=True, inline='always')
def _ground_nodes(con, N):
    """The ground's nodes into ``N`` (they never move)."""
    for k in range(con.node_body.shape[0]):
        if con.node_body[k] < 0:
            N[k, 0] = con.node_s[k, 0]
            N[k, 1] = con.node_s[k, 1]


@njit(cache=True, inline='always')
def _place(con, sign, sys, t, e, N, q, cs, sn, drv, th_prev):
    """Positions: every step's node or body at time ``t``, the clearance joints at the
    eccentricities ``e`` (nc × 2, m), with each body's cos θ and sin θ into ``cs``, ``sn``
    and each driver's ``(θ, θ̇, θ̈)`` into the first rows of ``drv`` (for :func:`_velocities`
    and :func:`_accelerations`). The free coordinates' rows of ``drv``, after the drivers',
    are read: the caller writes each free angle's or free position's value, rate and
    acceleration there.

    Each body angle found from two nodes continues its previous value ``th_prev`` (updated).
    Returns False where a square root has no real value (the group cannot be assembled). Each
    body's cosine and sine are those of its angle in ``q`` (not the unit vector between its
    nodes, which differs in the last bit): a stiff film's force moves by 1e-10 N for such a
    bit, and the forces must see the body that ``q`` describes."""
    op = con.op
    par = con.par
    twopi = 2.0 * math.pi
    for d in range(sys.dr_law.shape[0]):  # the free coordinates' rows are the caller's
        th, w, al = driver_law(sys.dr_law[d], sys.dr_par[d], t)
        drv[d, 0] = th
        drv[d, 1] = w
        drv[d, 2] = al
    for o in range(op.shape[0]):
        code = op[o, 0]
        if code == POSE_ANGLE or code == POSE_TWO or code == TURN:
            b = op[o, 1]
            k = op[o, 2]
            if code == POSE_TWO:
                k2 = op[o, 3]
                dx = N[k2, 0] - N[k, 0]
                dy = N[k2, 1] - N[k, 1]
                th = math.atan2(dy, dx) - par[o, 2]
                th += twopi * round((th_prev[b] - th) / twopi)  # the branch of the angle
                th_prev[b] = th                                # nearest the last one
            elif code == TURN:  # the unit n with n·w = h: n = (h w ± √(|w|² − h²) w⊥)/|w|²
                k2 = op[o, 3]
                wx = N[k2, 0] - N[k, 0]
                wy = N[k2, 1] - N[k, 1]
                w2 = wx * wx + wy * wy
                h = par[o, 2]
                disc = w2 - h * h
                if not (disc >= 0.0 and w2 > 0.0):  # the line cannot reach the point
                    return False
                root = sign[op[o, 4]] * math.sqrt(disc)
                nx = (h * wx - root * wy) / w2
                ny = (h * wy + root * wx) / w2
                th = math.atan2(par[o, 3] * ny - par[o, 4] * nx, par[o, 3] * nx + par[o, 4] * ny)
                th += twopi * round((th_prev[b] - th) / twopi)
                th_prev[b] = th
            elif op[o, 3] == ANGLE_CONSTANT:
                th = par[o, 2]
            elif op[o, 3] == ANGLE_RELATIVE:  # the line body's angle and the joint's
                th = q[3 * op[o, 4] + 2] + par[o, 2]
            else:  # a driver's or a free angle
                th = drv[op[o, 4], 0]
            # the orientation from the angle itself, as every consumer of q computes it
            # (body_trig): the force laws then see the same body as q describes, to the bit
            c = math.cos(th)
            s = math.sin(th)
            cs[b] = c
            sn[b] = s
            q[3 * b] = N[k, 0] - (c * par[o, 0] - s * par[o, 1])
            q[3 * b + 1] = N[k, 1] - (s * par[o, 0] + c * par[o, 1])
            q[3 * b + 2] = th
        elif code == LOCATE:
            k = op[o, 1]
            b = op[o, 2]
            c = cs[b]
            s = sn[b]
            N[k, 0] = q[3 * b] + c * par[o, 0] - s * par[o, 1]
            N[k, 1] = q[3 * b + 1] + s * par[o, 0] + c * par[o, 1]
        elif code == OFFSET:
            _offset(op, o, N, e)
        elif code == CIRCLES:
            k = op[o, 1]
            x1, y1 = _at(N, op[o, 2], e, op[o, 5], op[o, 6])  # the circles' centres
            x2, y2 = _at(N, op[o, 3], e, op[o, 7], op[o, 8])
            d1 = par[o, 0]
            d2 = par[o, 1]
            dx = x2 - x1
            dy = y2 - y1
            L = math.hypot(dx, dy)
            along = (d1 * d1 - d2 * d2 + L * L) / (2.0 * L)
            h2 = d1 * d1 - along * along
            if not h2 >= 0.0:  # the circles do not meet (NaN: a node at infinity)
                return False
            h = sign[op[o, 4]] * math.sqrt(h2)
            N[k, 0] = x1 + (along * dx - h * dy) / L
            N[k, 1] = y1 + (along * dy + h * dx) / L
        elif code == SLIDE:  # N = P0 + s u, s a free position
            k = op[o, 1]
            sl = drv[op[o, 4], 0]
            N[k, 0] = par[o, 0] + sl * par[o, 2]
            N[k, 1] = par[o, 1] + sl * par[o, 3]
        else:  # CIRCLE_LINE: N = P0 + s u
            k = op[o, 1]
            x1, y1 = _at(N, op[o, 2], e, op[o, 5], op[o, 6])
            d1 = par[o, 0]
            ux = par[o, 3]
            uy = par[o, 4]
            wx = x1 - par[o, 1]
            wy = y1 - par[o, 2]
            off = ux * wy - uy * wx  # the centre's distance from the line
            h2 = d1 * d1 - off * off
            if not h2 >= 0.0:
                return False
            sl = ux * wx + uy * wy + sign[op[o, 4]] * math.sqrt(h2)
            N[k, 0] = par[o, 1] + sl * ux
            N[k, 1] = par[o, 2] + sl * uy
    return True


@njit(cache=True)
def _velocities(con, drv, e, N, q, X, x):
    """The velocity pass for several motions at once, at the placed positions (``N``, ``q``).

    Column ``c`` of ``X`` (``m × nn × 2``: every node's velocity) and ``x`` (``m × n``: every
    body's) is, for ``c < 2 nc``, the motion at a unit rate of eccentricity component ``c``
    (clearance joint ``c // 2``, axis ``c % 2``) with the drivers at rest; for
    ``2 nc ≤ c < m − 1``, at a unit rate of free coordinate ``c − 2 nc`` (a free angle or a
    free position): a column of ``∂q/∂z``; the last column (``c = m − 1``) is the drivers'
    motion at their rates (``drv``) with the eccentricities and free coordinates fixed,
    ``q̇₀``. The velocity for rates ``ż`` is then
    ``x[m − 1] + Σ_c ż_c x[c]`` (the pass is linear in the rates). Each step's
    position equation differentiated once: for a node where two circles around ``C_j`` meet,
    ``(N − C_j)·Ṅ = (N − C_j)·Ċ_j``; a body through two nodes turns at ``(d × ḋ)/|d|²``; a
    point ``p = A s`` of a body moves at ``ṙ + ω × p``. The geometry of each step is computed
    once for all columns. Returns False at a toggle (two tangent circles, a rod square to its
    slider's line), where the velocities are not defined."""
    op = con.op
    par = con.par
    m = x.shape[0]
    dr = m - 1  # the drivers' column
    for o in range(op.shape[0]):
        code = op[o, 0]
        if code == POSE_ANGLE or code == POSE_TWO or code == TURN:
            b = op[o, 1]
            k = op[o, 2]
            px = N[k, 0] - q[3 * b]  # A s: from the body's centre to the node
            py = N[k, 1] - q[3 * b + 1]
            if code == POSE_TWO:
                k2 = op[o, 3]
                dx = N[k2, 0] - N[k, 0]
                dy = N[k2, 1] - N[k, 1]
                d2 = dx * dx + dy * dy
            elif code == TURN:  # n·w = h differentiated: ω (n × w) + n·ẇ = 0
                k2 = op[o, 3]
                nx, ny = _normal(con, o, b, q)
                nw = nx * (N[k2, 1] - N[k, 1]) - ny * (N[k2, 0] - N[k, 0])
                if not abs(nw) > 0.0:  # the line square to the pivot's reach: a dead centre
                    return False
            for c in range(m):
                if code == POSE_TWO:
                    wa = (dx * (X[c, k2, 1] - X[c, k, 1]) - dy * (X[c, k2, 0] - X[c, k, 0])) / d2
                elif code == TURN:
                    wa = -(nx * (X[c, k2, 0] - X[c, k, 0]) + ny * (X[c, k2, 1] - X[c, k, 1])) / nw
                elif op[o, 3] == ANGLE_RELATIVE:
                    wa = x[c, 3 * op[o, 4] + 2]
                elif op[o, 3] == ANGLE_DRIVER and c == dr:
                    wa = drv[op[o, 4], 1]
                elif op[o, 3] == ANGLE_FREE and c == 2 * e.shape[0] + op[o, 5]:
                    wa = 1.0  # the free angle's own column
                else:
                    wa = 0.0
                x[c, 3 * b] = X[c, k, 0] + wa * py
                x[c, 3 * b + 1] = X[c, k, 1] - wa * px
                x[c, 3 * b + 2] = wa
        elif code == LOCATE:
            k = op[o, 1]
            b = op[o, 2]
            px = N[k, 0] - q[3 * b]
            py = N[k, 1] - q[3 * b + 1]
            for c in range(m):
                wa = x[c, 3 * b + 2]
                X[c, k, 0] = x[c, 3 * b] - wa * py
                X[c, k, 1] = x[c, 3 * b + 1] + wa * px
        elif code == OFFSET:
            k = op[o, 1]
            k1 = op[o, 2]
            u = 2 * op[o, 3]  # the columns of this joint's two components
            sg = float(op[o, 4])
            for c in range(m):
                X[c, k, 0] = X[c, k1, 0] + (sg if c == u else 0.0)
                X[c, k, 1] = X[c, k1, 1] + (sg if c == u + 1 else 0.0)
        elif code == SLIDE:  # Ṅ = ṡ u: the free position's own column
            k = op[o, 1]
            f = 2 * e.shape[0] + op[o, 5]
            for c in range(m):
                X[c, k, 0] = par[o, 2] if c == f else 0.0
                X[c, k, 1] = par[o, 3] if c == f else 0.0
        elif code == CIRCLES:
            k = op[o, 1]
            x1, y1 = _at(N, op[o, 2], e, op[o, 5], op[o, 6])  # the centres C_j
            x2, y2 = _at(N, op[o, 3], e, op[o, 7], op[o, 8])
            e1x = N[k, 0] - x1
            e1y = N[k, 1] - y1
            e2x = N[k, 0] - x2
            e2y = N[k, 1] - y2
            det = e1x * e2y - e1y * e2x
            if not abs(det) > 0.0:  # tangent circles: a toggle position
                return False
            k1 = op[o, 2]
            k2 = op[o, 3]
            u1 = 2 * op[o, 5]  # the columns that move the centres (sg = 0: none)
            s1 = float(op[o, 6])
            u2 = 2 * op[o, 7]
            s2 = float(op[o, 8])
            for c in range(m):
                d1x = X[c, k1, 0] + (s1 if c == u1 else 0.0)
                d1y = X[c, k1, 1] + (s1 if c == u1 + 1 else 0.0)
                d2x = X[c, k2, 0] + (s2 if c == u2 else 0.0)
                d2y = X[c, k2, 1] + (s2 if c == u2 + 1 else 0.0)
                r1 = e1x * d1x + e1y * d1y
                r2 = e2x * d2x + e2y * d2y
                X[c, k, 0] = (r1 * e2y - r2 * e1y) / det
                X[c, k, 1] = (r2 * e1x - r1 * e2x) / det
        else:  # CIRCLE_LINE: N = P0 + s u
            k = op[o, 1]
            x1, y1 = _at(N, op[o, 2], e, op[o, 5], op[o, 6])
            ux = par[o, 3]
            uy = par[o, 4]
            e1x = N[k, 0] - x1
            e1y = N[k, 1] - y1
            den = e1x * ux + e1y * uy
            if not abs(den) > 0.0:  # the rod square to the line: a dead centre
                return False
            k1 = op[o, 2]
            u1 = 2 * op[o, 5]
            s1 = float(op[o, 6])
            for c in range(m):
                d1x = X[c, k1, 0] + (s1 if c == u1 else 0.0)
                d1y = X[c, k1, 1] + (s1 if c == u1 + 1 else 0.0)
                sd = (e1x * d1x + e1y * d1y) / den
                X[c, k, 0] = sd * ux
                X[c, k, 1] = sd * uy
    return True


@njit(cache=True)
def _accelerations(con, drv, e, edot, dE, N, q, Nv, v, X, x):
    """The acceleration pass at the placed positions (``N``, ``q``) and velocities (``Nv``,
    ``v``, from :func:`_velocities`): every node's acceleration into ``X`` and every body's
    into ``x``, the clearance joints' eccentricities ``e`` (m) moving at ``edot`` (m/s) and
    accelerating at ``dE`` (m/s²), the drivers and the free coordinates at the accelerations
    in ``drv``.

    The position equations differentiated twice: the velocity pass's equations with
    velocity-quadratic terms added. For a node where two circles around the centres ``C_j``
    meet, ``(N − C_j)·N̈ = (N − C_j)·C̈_j − |Ṅ − Ċ_j|²``; a body through two nodes accelerates
    at ``(d × d̈)/|d|²``; a point ``p = A s`` of a body at ``r̈ + α × p − ω² p``; a free
    position's node at ``s̈ u``. With ``dE = 0`` and the free coordinates' accelerations zero
    the result is ``q̈₀``, the acceleration of the drivers and the velocities alone.
    Returns False at a toggle (two tangent circles, a rod square to its slider's line)."""
    op = con.op
    par = con.par
    for o in range(op.shape[0]):
        code = op[o, 0]
        if code == POSE_ANGLE or code == POSE_TWO or code == TURN:
            b = op[o, 1]
            k = op[o, 2]
            if code == POSE_TWO:
                k2 = op[o, 3]
                dx = N[k2, 0] - N[k, 0]
                dy = N[k2, 1] - N[k, 1]
                wa = (dx * (X[k2, 1] - X[k, 1]) - dy * (X[k2, 0] - X[k, 0])) / (
                    dx * dx + dy * dy)
            elif code == TURN:  # twice: α (n × w) + n·ẅ + 2 ω n × ẇ − ω² n·w = 0
                k2 = op[o, 3]
                nx, ny = _normal(con, o, b, q)
                wx = N[k2, 0] - N[k, 0]
                wy = N[k2, 1] - N[k, 1]
                vx = Nv[k2, 0] - Nv[k, 0]
                vy = Nv[k2, 1] - Nv[k, 1]
                nw = nx * wy - ny * wx
                if not abs(nw) > 0.0:
                    return False
                w = v[3 * b + 2]
                wa = -(nx * (X[k2, 0] - X[k, 0]) + ny * (X[k2, 1] - X[k, 1])
                       + 2.0 * w * (nx * vy - ny * vx) - w * w * (nx * wx + ny * wy)) / nw
            elif op[o, 3] == ANGLE_CONSTANT:
                wa = 0.0
            elif op[o, 3] == ANGLE_RELATIVE:
                wa = x[3 * op[o, 4] + 2]
            else:  # a driver's or a free angle's acceleration
                wa = drv[op[o, 4], 2]
            w2 = v[3 * b + 2] * v[3 * b + 2]
            px = N[k, 0] - q[3 * b]  # A s: from the body's centre to the node
            py = N[k, 1] - q[3 * b + 1]
            x[3 * b] = X[k, 0] + wa * py + w2 * px
            x[3 * b + 1] = X[k, 1] - wa * px + w2 * py
            x[3 * b + 2] = wa
        elif code == LOCATE:
            k = op[o, 1]
            b = op[o, 2]
            wa = x[3 * b + 2]
            w2 = v[3 * b + 2] * v[3 * b + 2]
            px = N[k, 0] - q[3 * b]
            py = N[k, 1] - q[3 * b + 1]
            X[k, 0] = x[3 * b] - wa * py - w2 * px
            X[k, 1] = x[3 * b + 1] + wa * px - w2 * py
        elif code == OFFSET:
            _offset(op, o, X, dE)
        elif code == SLIDE:
            k = op[o, 1]
            sa = drv[op[o, 4], 2]
            X[k, 0] = sa * par[o, 2]
            X[k, 1] = sa * par[o, 3]
        elif code == CIRCLES:
            k = op[o, 1]
            x1, y1 = _at(N, op[o, 2], e, op[o, 5], op[o, 6])  # the centres C_j …
            x2, y2 = _at(N, op[o, 3], e, op[o, 7], op[o, 8])
            d1x, d1y = _at(X, op[o, 2], dE, op[o, 5], op[o, 6])  # … and their derivatives
            d2x, d2y = _at(X, op[o, 3], dE, op[o, 7], op[o, 8])
            e1x = N[k, 0] - x1
            e1y = N[k, 1] - y1
            e2x = N[k, 0] - x2
            e2y = N[k, 1] - y2
            det = e1x * e2y - e1y * e2x
            if not abs(det) > 0.0:  # tangent circles: a toggle position
                return False
            r1 = e1x * d1x + e1y * d1y
            r2 = e2x * d2x + e2y * d2y
            c1x, c1y = _at(Nv, op[o, 2], edot, op[o, 5], op[o, 6])  # − |Ṅ − Ċ_j|²
            c2x, c2y = _at(Nv, op[o, 3], edot, op[o, 7], op[o, 8])
            g1x = Nv[k, 0] - c1x
            g1y = Nv[k, 1] - c1y
            g2x = Nv[k, 0] - c2x
            g2y = Nv[k, 1] - c2y
            r1 -= g1x * g1x + g1y * g1y
            r2 -= g2x * g2x + g2y * g2y
            X[k, 0] = (r1 * e2y - r2 * e1y) / det
            X[k, 1] = (r2 * e1x - r1 * e2x) / det
        else:  # CIRCLE_LINE: N = P0 + s u
            k = op[o, 1]
            x1, y1 = _at(N, op[o, 2], e, op[o, 5], op[o, 6])
            d1x, d1y = _at(X, op[o, 2], dE, op[o, 5], op[o, 6])
            ux = par[o, 3]
            uy = par[o, 4]
            e1x = N[k, 0] - x1
            e1y = N[k, 1] - y1
            den = e1x * ux + e1y * uy
            if not abs(den) > 0.0:  # the rod square to the line: a dead centre
                return False
            r1 = e1x * d1x + e1y * d1y
            c1x, c1y = _at(Nv, op[o, 2], edot, op[o, 5], op[o, 6])
            gx = Nv[k, 0] - c1x
            gy = Nv[k, 1] - c1y
            r1 -= gx * gx + gy * gy
            sd = r1 / den
            X[k, 0] = sd * ux
            X[k, 1] = sd * uy
    return True


@njit(cache=True)
def _construct(q0, times, sys, con):
    """Positions, velocities and accelerations at ``times`` by the steps of ``con``.

    Returns ``Q, V, A, done, viol``: ``done < len(times)`` when the instant ``times[done]``
    could not be built (no real intersection, tangent circles, a velocity or acceleration
    that is not finite); the arrays then hold the instants before it. ``viol`` is max |Φ| of
    the first and last instant built, 0 with none
    (:func:`~mechrel.mechanics.constraints.violations_at`), which
    :func:`~mechrel.mechanics.kinematics.kinematic_analysis` compares with its tolerance
    (module docstring): computed here, it costs no compiled call of its own.
    """
    nt = times.shape[0]
    n = q0.shape[0]
    Q = np.empty((nt, n))
    V = np.empty((nt, n))
    A = np.empty((nt, n))
    sys, con = borrowed((sys, con))  # the arguments keep them alive (mechanics/borrow.py)
    nn = con.node_body.shape[0]
    N = np.zeros((nn, 2))
    Na = np.zeros((nn, 2))
    _ground_nodes(con, N)
    sign = _branch_signs(q0, con)
    none = np.zeros((0, 2))  # no clearance joint: no eccentricity
    q = np.empty(n)
    a = np.empty(n)
    Vc = np.zeros((1, nn, 2))  # the velocity pass's one column: the drivers' motion
    vc = np.empty((1, n))
    Nv = Vc[0]
    v = vc[0]
    cs = np.empty(n // 3)
    sn = np.empty(n // 3)
    drv = np.empty((sys.dr_i.shape[0], 3))
    th_prev = np.empty(n // 3)
    for b in range(n // 3):
        th_prev[b] = q0[3 * b + 2]
    for i in range(nt):
        t = times[i]
        if not _place(con, sign, sys, t, none, N, q, cs, sn, drv, th_prev):
            return _built(Q, V, A, times, i, sys)
        if not _velocities(con, drv, none, N, q, Vc, vc):
            return _built(Q, V, A, times, i, sys)
        _accelerations(con, drv, none, none, none, N, q, Nv, v, Na, a)
        fin = 0.0  # 0 unless a value overflowed (inf − inf is NaN)
        for j in range(n):
            fin += (q[j] - q[j]) + (v[j] - v[j]) + (a[j] - a[j])
        if fin != 0.0:
            return _built(Q, V, A, times, i, sys)
        for j in range(n):
            Q[i, j] = q[j]
            V[i, j] = v[j]
            A[i, j] = a[j]
    return _built(Q, V, A, times, nt, sys)


@njit(cache=True)
def _built(Q, V, A, times, done, sys):
    """:func:`_construct`'s result: the ``done`` instants built, and max |Φ| of the first
    and the last of them."""
    rows = np.empty(2 if done > 0 else 0, dtype=np.int64)
    if done > 0:
        rows[0], rows[1] = 0, done - 1
    return Q[:done], V[:done], A[:done], done, violations_at(Q[:done], times, rows, sys)[0]
