"""The compiled problem: constraints, their Jacobian and γ terms, the forward-dynamics
right-hand side, contact gaps and energy.

Every function is ``@njit(cache=True)`` and reads the scene only through a
:class:`~mechrel.mechanics.system.System`. The integrator kernels in :mod:`mechrel.integrate`
call these functions by module-global reference (see docs/architecture.md for why).

Formulation (Nikravesh 1988, *Computer-Aided Analysis of Mechanical Systems*, ch. 6 and 13;
Baumgarte 1972): with ``q`` the absolute coordinates, ``Φ(q, t) = 0`` the constraints,

    [ M    Φ_qᵀ ] [ q̈ ]   [ Q                        ]
    [ Φ_q  0    ] [ λ  ] = [ γ − 2α Φ̇ − β² Φ          ]     (paper eq. 24, corrected)

with ``γ = −(Φ_q q̇)_q q̇ − 2 Φ_qt q̇ − Φ_tt`` and ``Φ̇ = Φ_q q̇ + Φ_t``. ``M`` is diagonal, so the
system is solved through the Schur complement ``S = Φ_q M⁻¹ Φ_qᵀ`` (m × m, symmetric positive
definite while the constraints are independent):
``S λ = Φ_q M⁻¹ Q − c``, ``q̈ = M⁻¹ (Q − Φ_qᵀ λ)``.

State vector ``y = [q (n), q̇ (n), W_in, W_cl]``: the last two entries integrate the power of the
drivers (input work, J) and of the clearance-joint forces (J), for energy balances.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..forces.joint import clearance_force
from ..forces.params import P_C
from .system import (D_ACCEL, D_AMPLITUDE, D_ANGLE0, D_FREQUENCY, D_PHASE, D_RAMP, D_SPEED,
                     LAW_CONSTANT_ACCELERATION, LAW_CONSTANT_SPEED, LAW_HARMONIC)

N_WORK = 2  # extra states: driver work, clearance-force work


@njit(cache=True)
def driver_law(law, par, t):
    """Angle (rad), angular velocity (rad/s) and angular acceleration (rad/s²) of a driver."""
    th0 = par[D_ANGLE0]
    w = par[D_SPEED]
    if law == LAW_CONSTANT_SPEED:
        return th0 + w * t, w, 0.0
    if law == LAW_CONSTANT_ACCELERATION:
        a = par[D_ACCEL]
        return th0 + w * t + 0.5 * a * t * t, w + a * t, a
    if law == LAW_HARMONIC:
        amp = par[D_AMPLITUDE]
        om = par[D_FREQUENCY]
        ph = om * t + par[D_PHASE]
        return th0 + amp * math.sin(ph), amp * om * math.cos(ph), -amp * om * om * math.sin(ph)
    # smooth start: the speed follows w * s(t/T), s the quintic smoothstep 10τ³ − 15τ⁴ + 6τ⁵,
    # so the acceleration is zero at both ends of the ramp.
    T = par[D_RAMP]
    if t >= T:
        return th0 + w * (t - 0.5 * T), w, 0.0
    tau = t / T
    t2 = tau * tau
    t3 = t2 * tau
    S = t2 * t2 * (2.5 - 3.0 * tau + t2)  # ∫ s dτ
    s = t3 * (10.0 - 15.0 * tau + 6.0 * t2)
    ds = 30.0 * t2 * (1.0 - 2.0 * tau + t2)
    return th0 + w * T * S, w * s, w * ds / T


@njit(cache=True)
def _rot(th, sx, sy):
    """A(θ) s and B(θ) s = dA/dθ s."""
    c = math.cos(th)
    s = math.sin(th)
    return c * sx - s * sy, s * sx + c * sy, -s * sx - c * sy, c * sx - s * sy


@njit(cache=True)
def point_state(q, v, i, sx, sy):
    """Global position and velocity of the body-frame point s on body i (i = −1: ground point)."""
    if i < 0:
        return sx, sy, 0.0, 0.0
    th = q[3 * i + 2]
    ax, ay, bx, by = _rot(th, sx, sy)
    w = v[3 * i + 2]
    return (q[3 * i] + ax, q[3 * i + 1] + ay,
            v[3 * i] + bx * w, v[3 * i + 1] + by * w)


@njit(cache=True)
def n_constraints(sys):
    return (2 * sys.rev_i.shape[0] + 2 * sys.tr_i.shape[0] + sys.fa_i.shape[0]
            + sys.dr_i.shape[0])


@njit(cache=True)
def constraints(q, t, sys):
    """Φ(q, t) (m), Φ_t (m/s) and the Jacobian Φ_q."""
    m = n_constraints(sys)
    n = q.shape[0]
    phi = np.zeros(m)
    phit = np.zeros(m)
    J = np.zeros((m, n))
    r = 0
    for k in range(sys.rev_i.shape[0]):
        i = sys.rev_i[k]
        j = sys.rev_j[k]
        th = q[3 * i + 2]
        axi, ayi, bxi, byi = _rot(th, sys.rev_si[k, 0], sys.rev_si[k, 1])
        phi[r] = q[3 * i] + axi - sys.rev_off[k, 0]
        phi[r + 1] = q[3 * i + 1] + ayi - sys.rev_off[k, 1]
        phit[r] = -sys.rev_offdot[k, 0]
        phit[r + 1] = -sys.rev_offdot[k, 1]
        J[r, 3 * i] = 1.0
        J[r + 1, 3 * i + 1] = 1.0
        J[r, 3 * i + 2] = bxi
        J[r + 1, 3 * i + 2] = byi
        if j < 0:
            phi[r] -= sys.rev_sj[k, 0]
            phi[r + 1] -= sys.rev_sj[k, 1]
        else:
            axj, ayj, bxj, byj = _rot(q[3 * j + 2], sys.rev_sj[k, 0], sys.rev_sj[k, 1])
            phi[r] -= q[3 * j] + axj
            phi[r + 1] -= q[3 * j + 1] + ayj
            J[r, 3 * j] = -1.0
            J[r + 1, 3 * j + 1] = -1.0
            J[r, 3 * j + 2] = -bxj
            J[r + 1, 3 * j + 2] = -byj
        r += 2
    for k in range(sys.tr_i.shape[0]):
        i = sys.tr_i[k]
        nx = sys.tr_n[k, 0]
        ny = sys.tr_n[k, 1]
        ax, ay, bx, by = _rot(q[3 * i + 2], sys.tr_si[k, 0], sys.tr_si[k, 1])
        phi[r] = nx * (q[3 * i] + ax - sys.tr_p0[k, 0]) + ny * (q[3 * i + 1] + ay - sys.tr_p0[k, 1])
        J[r, 3 * i] = nx
        J[r, 3 * i + 1] = ny
        J[r, 3 * i + 2] = nx * bx + ny * by
        phi[r + 1] = q[3 * i + 2] - sys.tr_angle[k]
        J[r + 1, 3 * i + 2] = 1.0
        r += 2
    for k in range(sys.fa_i.shape[0]):
        i = sys.fa_i[k]
        phi[r] = q[3 * i + 2] - sys.fa_angle[k]
        J[r, 3 * i + 2] = 1.0
        r += 1
    for k in range(sys.dr_i.shape[0]):
        i = sys.dr_i[k]
        th, w, _ = driver_law(sys.dr_law[k], sys.dr_par[k], t)
        phi[r] = q[3 * i + 2] - th
        phit[r] = -w
        J[r, 3 * i + 2] = 1.0
        r += 1
    return phi, phit, J


@njit(cache=True)
def gamma(q, v, t, sys):
    """γ = −(Φ_q q̇)_q q̇ − 2Φ_qt q̇ − Φ_tt, the right-hand side of Φ_q q̈ = γ (m/s²)."""
    m = n_constraints(sys)
    g = np.zeros(m)
    r = 0
    for k in range(sys.rev_i.shape[0]):
        i = sys.rev_i[k]
        j = sys.rev_j[k]
        ax, ay, _, _ = _rot(q[3 * i + 2], sys.rev_si[k, 0], sys.rev_si[k, 1])
        w2 = v[3 * i + 2] ** 2
        g[r] = ax * w2
        g[r + 1] = ay * w2
        if j >= 0:
            ax, ay, _, _ = _rot(q[3 * j + 2], sys.rev_sj[k, 0], sys.rev_sj[k, 1])
            w2 = v[3 * j + 2] ** 2
            g[r] -= ax * w2
            g[r + 1] -= ay * w2
        r += 2
    for k in range(sys.tr_i.shape[0]):
        i = sys.tr_i[k]
        ax, ay, _, _ = _rot(q[3 * i + 2], sys.tr_si[k, 0], sys.tr_si[k, 1])
        g[r] = (sys.tr_n[k, 0] * ax + sys.tr_n[k, 1] * ay) * v[3 * i + 2] ** 2
        r += 2
    r += sys.fa_i.shape[0]
    for k in range(sys.dr_i.shape[0]):
        _, _, acc = driver_law(sys.dr_law[k], sys.dr_par[k], t)
        g[r] = acc
        r += 1
    return g


@njit(cache=True)
def applied_forces(t, q, v, hist, sys, Q):
    """Add gravity and clearance-joint forces to Q (N, N m); return (clearance power W,
    elastic contact energy J)."""
    nb = q.shape[0] // 3
    for b in range(nb):
        Q[3 * b] += sys.mass[3 * b] * sys.gravity[0]
        Q[3 * b + 1] += sys.mass[3 * b] * sys.gravity[1]
    power = 0.0
    elastic = 0.0
    for k in range(sys.cl_b.shape[0]):
        b = sys.cl_b[k]
        j = sys.cl_j[k]
        bx, by, bvx, bvy = point_state(q, v, b, sys.cl_sb[k, 0], sys.cl_sb[k, 1])
        jx, jy, jvx, jvy = point_state(q, v, j, sys.cl_sj[k, 0], sys.cl_sj[k, 1])
        wb = v[3 * b + 2] if b >= 0 else 0.0
        wj = v[3 * j + 2] if j >= 0 else 0.0
        h = sys.cl_hist[k]
        impact = hist[h] if h >= 0 else 0.0
        ex = jx - bx
        ey = jy - by
        evx = jvx - bvx
        evy = jvy - bvy
        fx, fy, ms, mb, eel = clearance_force(ex, ey, evx, evy, wb, wj, impact, sys.cl_p[k])
        power += fx * evx + fy * evy + ms * wj + mb * wb
        elastic += eel
        if j >= 0:
            rx = jx - q[3 * j]
            ry = jy - q[3 * j + 1]
            Q[3 * j] += fx
            Q[3 * j + 1] += fy
            Q[3 * j + 2] += rx * fy - ry * fx + ms
        if b >= 0:
            rx = bx - q[3 * b]
            ry = by - q[3 * b + 1]
            Q[3 * b] -= fx
            Q[3 * b + 1] -= fy
            Q[3 * b + 2] += -(rx * fy - ry * fx) + mb
    return power, elastic


@njit(cache=True)
def spd_solve(S, b):
    """Solve S x = b for a small symmetric positive definite S by Cholesky (S = L Lᵀ), in
    place on a copy. For the m ≤ ~30 Schur complements here, plain loops beat a LAPACK call,
    whose fixed overhead dominated the right-hand side (measured: docs/performance.md).
    A non-positive pivot (dependent constraints) raises, like ``np.linalg.solve``'s
    LinAlgError for a singular matrix."""
    m = b.shape[0]
    L = S.copy()
    for j in range(m):
        d = L[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            raise np.linalg.LinAlgError("constraint Jacobian is rank deficient")
        d = math.sqrt(d)
        L[j, j] = d
        for i in range(j + 1, m):
            s = L[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / d
    x = b.copy()
    for i in range(m):  # forward: L z = b
        s = x[i]
        for k in range(i):
            s -= L[i, k] * x[k]
        x[i] = s / L[i, i]
    for i in range(m - 1, -1, -1):  # backward: Lᵀ x = z
        s = x[i]
        for k in range(i + 1, m):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]
    return x


@njit(cache=True)
def accelerations(t, y, hist, sys):
    """q̈ (n), Lagrange multipliers λ (m), driver power (W), clearance power (W)."""
    n = sys.mass.shape[0]
    q = y[:n]
    v = y[n:2 * n]
    Q = np.zeros(n)
    pcl, _ = applied_forces(t, q, v, hist, sys, Q)
    phi, phit, J = constraints(q, t, sys)
    m = phi.shape[0]
    alpha = sys.baumgarte[0]
    beta = sys.baumgarte[1]
    # c = γ − 2α Φ̇ − β² Φ with Φ̇ = Φ_q q̇ + Φ_t (loops: a BLAS call costs more than the work)
    c = gamma(q, v, t, sys)
    n = Q.shape[0]
    for i in range(m):
        phidot = phit[i]
        for k in range(n):
            phidot += J[i, k] * v[k]
        c[i] -= 2.0 * alpha * phidot + beta * beta * phi[i]
    minv = 1.0 / sys.mass
    if m == 0:
        lam = np.zeros(0)
        a = Q * minv
    else:
        # S = Φ_q M⁻¹ Φ_qᵀ and Φ_q M⁻¹ Q by loops that skip the zeros of Φ_q (each row has at
        # most six non-zeros): cheaper than dense BLAS calls at these sizes.
        S = np.zeros((m, m))
        rhs_l = -c
        for i in range(m):
            for k in range(n):
                jik = J[i, k]
                if jik != 0.0:
                    w = jik * minv[k]
                    rhs_l[i] += w * Q[k]
                    for j in range(i + 1):
                        S[i, j] += w * J[j, k]
        for i in range(m):
            for j in range(i):
                S[j, i] = S[i, j]
        lam = spd_solve(S, rhs_l)
        a = Q.copy()
        for i in range(m):
            li = lam[i]
            for k in range(n):
                a[k] -= J[i, k] * li
        a *= minv
    # Input power of the drivers: their generalized force is −Φ_q,dᵀ λ_d.
    pin = 0.0
    r = m - sys.dr_i.shape[0]
    for k in range(sys.dr_i.shape[0]):
        pin -= lam[r + k] * v[3 * sys.dr_i[k] + 2]
    return a, lam, pin, pcl


@njit(cache=True)
def rhs(t, y, hist, sys):
    """dy/dt for y = [q, q̇, W_in, W_cl]."""
    n = sys.mass.shape[0]
    a, _, pin, pcl = accelerations(t, y, hist, sys)
    out = np.empty_like(y)
    out[:n] = y[n:2 * n]
    out[n:2 * n] = a
    out[2 * n] = pin
    out[2 * n + 1] = pcl
    return out


@njit(cache=True)
def gaps(t, y, sys):
    """Penetration δ = |e| − c (m) and its rate (m/s) of every contact-capable joint."""
    n = sys.mass.shape[0]
    q = y[:n]
    v = y[n:2 * n]
    nh = 0
    for k in range(sys.cl_hist.shape[0]):
        if sys.cl_hist[k] >= 0:
            nh += 1
    g = np.empty(nh)
    gd = np.empty(nh)
    for k in range(sys.cl_b.shape[0]):
        h = sys.cl_hist[k]
        if h < 0:
            continue
        bx, by, bvx, bvy = point_state(q, v, sys.cl_b[k], sys.cl_sb[k, 0], sys.cl_sb[k, 1])
        jx, jy, jvx, jvy = point_state(q, v, sys.cl_j[k], sys.cl_sj[k, 0], sys.cl_sj[k, 1])
        ex = jx - bx
        ey = jy - by
        e = math.hypot(ex, ey)
        g[h] = e - sys.cl_p[k, P_C]
        # δ̇ = n·ė; at e = 0 the direction is undefined and the joint is far from contact.
        gd[h] = ((jvx - bvx) * ex + (jvy - bvy) * ey) / e if e > 0.0 else 0.0
    return g, gd


@njit(cache=True)
def constraint_violation(t, y, sys):
    """max |Φ| (m or rad) and max |Φ_q q̇ + Φ_t| (m/s or rad/s)."""
    n = sys.mass.shape[0]
    phi, phit, J = constraints(y[:n], t, sys)
    if phi.shape[0] == 0:
        return 0.0, 0.0
    vmax = 0.0
    for i in range(phi.shape[0]):
        r = phit[i]
        for k in range(n):
            r += J[i, k] * y[n + k]
        vmax = max(vmax, abs(r))
    return np.max(np.abs(phi)), vmax


@njit(cache=True)
def mechanical_energy(y, sys):
    """Kinetic energy ½ q̇ᵀ M q̇ and gravitational potential −Σ m g·r (J)."""
    n = sys.mass.shape[0]
    T = 0.0
    V = 0.0
    for k in range(n):
        T += 0.5 * sys.mass[k] * y[n + k] ** 2
    for b in range(n // 3):
        V -= sys.mass[3 * b] * (sys.gravity[0] * y[3 * b] + sys.gravity[1] * y[3 * b + 1])
    return T, V


@njit(cache=True)
def elastic_energy(t, y, hist, sys):
    """Elastic energy stored in the contact springs (J)."""
    n = sys.mass.shape[0]
    Q = np.zeros(n)
    _, eel = applied_forces(t, y[:n], y[n:2 * n], hist, sys, Q)
    return eel


@njit(cache=True)
def post_process(times, Y, sys):
    """Per output instant, in one compiled call: the eccentricity (e_x, e_y) (m) of every
    clearance joint, kinetic and gravitational energy and the elastic contact energy (J).

    Returns (EX, EY, T, V, E) with EX, EY of shape (N, n_clearance)."""
    N = Y.shape[0]
    n = sys.mass.shape[0]
    nc = sys.cl_b.shape[0]
    EX = np.empty((N, nc))
    EY = np.empty((N, nc))
    T = np.empty(N)
    V = np.empty(N)
    E = np.empty(N)
    nh = 0
    for k in range(nc):
        if sys.cl_hist[k] >= 0:
            nh += 1
    no_hist = np.zeros(nh)  # the stored elastic energy does not depend on history
    Q = np.zeros(n)
    for r in range(N):
        y = Y[r]
        q = y[:n]
        v = y[n:2 * n]
        for k in range(nc):
            bx, by, _, _ = point_state(q, v, sys.cl_b[k], sys.cl_sb[k, 0], sys.cl_sb[k, 1])
            jx, jy, _, _ = point_state(q, v, sys.cl_j[k], sys.cl_sj[k, 0], sys.cl_sj[k, 1])
            EX[r, k] = jx - bx
            EY[r, k] = jy - by
        T[r], V[r] = mechanical_energy(y, sys)
        Q[:] = 0.0
        _, E[r] = applied_forces(times[r], q, v, no_hist, sys, Q)
    return EX, EY, T, V, E


@njit(cache=True)
def driver_angles(law, par, times):
    """Angle (rad) of one driver at each instant."""
    out = np.empty(times.shape[0])
    for r in range(times.shape[0]):
        out[r] = driver_law(law, par, times[r])[0]
    return out
