"""A finite-volume solver of the two-dimensional Reynolds equation of a plain journal bearing.

This is the reference against which the closed-form film models (long bearing,
:mod:`mechrel.forces.film`; short bearing, :mod:`mechrel.forces.short_film`) are checked. It is
plain NumPy/SciPy, not compiled, and is not called during a simulation.

Problem
-------
Same conventions as the film models: θ from n = e/|e| toward t, film h = c (1 − ε cos θ),
wedge speed w = ω_S + ω_B − 2γ̇, in the frame turning with the line of centres. With ζ = z/R
(z the axial coordinate, ζ ∈ [−L/D, L/D]) and p = (μ R²/c²) P, Reynolds' equation is

    ∂θ(H³ ∂θ P) + ∂ζ(H³ ∂ζ P) = −12 G(θ),   G = ε̇ cos θ − (ε w / 2) sin θ,   H = 1 − ε cos θ,

periodic in θ, P = 0 at both ends ζ = ±L/D (ambient pressure). The force on the journal is

    F = −(μ R⁴ / c²) ∫∫ P (cos θ n + sin θ t) dθ dζ.

Discretisation: cell-centred finite volumes, ``n_theta`` cells around and ``n_z`` cells along
(by symmetry only the half ζ ≥ 0 is solved, with zero flux at ζ = 0), H³ taken at the cell faces
(exact H there), a 5-point stencil; second order in both spacings. Forces by the midpoint rule
over the cells.

Cavitation conditions
---------------------
``"half-sommerfeld"`` (Gümbel): solve the full-film (Sommerfeld) problem and integrate only
its positive part. Not mass conserving, but it is the condition of the long- and short-bearing
closed forms.

``"reynolds"`` (Swift–Stieber): P ≥ 0 everywhere, Reynolds' equation where P > 0, and
∂P/∂n = 0 on the film-rupture boundary, i.e. the linear complementarity problem
P ≥ 0, K P − f ≥ 0, P·(K P − f) = 0 on the whole periodic domain (K the discrete operator
−∇·(H³∇), f = 12 G). It is solved by a primal–dual active-set iteration, exact on the grid in a
finite number of steps for this M-matrix. This is the "periodic complementarity" reading of the
Reynolds condition for a full 360° bearing; the other reading, restarting the film at the
maximum-film line with ambient pressure, imposes a reformation line the physics does not ask for
and depends on the choice of that line when the squeeze direction turns, so it is not
implemented. Under the Reynolds condition the film runs past the thinnest point until the
pressure falls to zero with zero gradient: a larger positive region than half-Sommerfeld's, a
larger load capacity and a smaller attitude angle (tests/test_forces_short_film.py, docs/forces.md).

Source: Reynolds (1886); Hamrock, Schmid & Jacobson (2004), Fundamentals of Fluid Film
Lubrication, ch. 7 and 10 (Reynolds' equation, the Swift–Stieber condition); the
complementarity formulation as in Giacopini, Fowell, Dini & Strozzi (2010), J. Tribol. 132.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["reynolds_forces", "half_sommerfeld_directions", "reynolds_condition_directions",
           "CAVITATION"]

CAVITATION = ("half-sommerfeld", "reynolds")


def _operator(eps: float, half_length: float, n_theta: int, n_z: int):
    """Sparse K (−∇·H³∇, times cell area) on the half domain ζ ∈ [0, L/D], and the grids."""
    dth = 2.0 * math.pi / n_theta
    dz = half_length / n_z
    th = (np.arange(n_theta) + 0.5) * dth            # cell centres
    th_f = np.arange(n_theta) * dth + dth            # face between cell i and i+1
    H_f3 = (1.0 - eps * np.cos(th_f)) ** 3           # at θ faces
    H_c3 = (1.0 - eps * np.cos(th)) ** 3             # at ζ faces (H does not depend on ζ)
    N = n_theta * n_z
    idx = np.arange(N).reshape(n_z, n_theta)          # row j (ζ), column i (θ)
    rows, cols, vals = [], [], []
    diag = np.zeros(N)
    ax = dz / dth                                      # θ-face coupling factor
    az = dth / dz                                      # ζ-face coupling factor
    # θ faces (periodic): face i couples cells i and i+1
    a = np.tile(H_f3 * ax, n_z)
    left = idx.ravel()
    right = np.roll(idx, -1, axis=1).ravel()
    rows += [left, right]
    cols += [right, left]
    vals += [-a, -a]
    np.add.at(diag, left, a)
    np.add.at(diag, right, a)
    # ζ faces between rows j and j+1
    if n_z > 1:
        b = np.tile(H_c3 * az, n_z - 1)
        lo = idx[:-1].ravel()
        hi = idx[1:].ravel()
        rows += [lo, hi]
        cols += [hi, lo]
        vals += [-b, -b]
        np.add.at(diag, lo, b)
        np.add.at(diag, hi, b)
    # end ζ = L/D: P = 0 half a cell beyond the last centre (Dirichlet, distance dz/2)
    np.add.at(diag, idx[-1], 2.0 * H_c3 * az)
    # ζ = 0: symmetry plane, zero flux (nothing to add)
    rows.append(np.arange(N))
    cols.append(np.arange(N))
    vals.append(diag)
    K = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(N, N))
    return K, th, dth, dz


def reynolds_forces(eps: float, eps_dot: float, eps_w: float, mu: float, R: float, L: float,
                    c: float, *, cavitation: str = "half-sommerfeld", n_theta: int = 240,
                    n_z: int = 40, return_pressure: bool = False):
    """Film force on the journal from a numerical solution of the 2-D Reynolds equation.

    Parameters
    ----------
    eps : float
        ε (-), 0 ≤ ε < 1.
    eps_dot : float
        ε̇ (1/s).
    eps_w : float
        ε·w (rad/s), w = ω_S + ω_B − 2γ̇.
    mu : float
        Viscosity (Pa s).
    R : float
        Journal radius (m); D = 2R.
    L : float
        Bearing length (m).
    c : float
        Radial clearance (m).
    cavitation : {"half-sommerfeld", "reynolds"}
        Cavitation condition (module docstring).
    n_theta, n_z : int
        Cells around the circumference and along the half length.
    return_pressure : bool
        Also return (θ centres, ζ centres, P) of the half domain.

    Returns
    -------
    (F_r, F_t) : (float, float)
        Force on the journal along n and t (N), or ``(F_r, F_t, (theta, zeta, P))``.

    Examples
    --------
    A coarse grid (60 x 10 cells) already lands within 1 % of the tabulated finite bearing of
    :func:`mechrel.forces.finite_film.finite_film_forces` (-0.0515 N, 0.1039 N):

    >>> Fr, Ft = reynolds_forces(0.5, 0.0, 50.0, 0.01, 9.5e-3, 20e-3, 0.5e-3, n_theta=60, n_z=10)
    >>> round(Fr, 3), round(Ft, 3)
    (-0.052, 0.104)
    """
    if cavitation not in CAVITATION:
        raise ValueError(f"cavitation = {cavitation!r}: allowed one of {', '.join(CAVITATION)}")
    if not 0.0 <= eps < 1.0:
        raise ValueError(f"eps = {eps!r}: allowed 0 <= eps < 1")
    half = L / (2.0 * R)                               # ζ extent of the half domain = L/D
    K, th, dth, dz = _operator(eps, half, n_theta, n_z)
    G = eps_dot * np.cos(th) - 0.5 * eps_w * np.sin(th)
    f = np.tile(12.0 * G * dth * dz, n_z)
    if cavitation == "half-sommerfeld":
        P = spla.spsolve(K.tocsc(), f)
        P = np.maximum(P, 0.0)
    else:
        P = _lcp_active_set(K, f)
    Pg = P.reshape(n_z, n_theta)
    Fr, Ft = _force(Pg, th, dth, dz, mu, R, c)
    if return_pressure:
        return Fr, Ft, (th, (np.arange(n_z) + 0.5) * dz, Pg)
    return Fr, Ft


def _force(Pg, th, dth, dz, mu, R, c):
    # both halves of the bearing: twice the half domain
    s_cos = 2.0 * float(np.sum(Pg * np.cos(th))) * dth * dz
    s_sin = 2.0 * float(np.sum(Pg * np.sin(th))) * dth * dz
    k = mu * R ** 4 / (c * c)
    return -k * s_cos, -k * s_sin


def half_sommerfeld_directions(eps: float, l_over_d: float, directions, *, n_theta: int = 240,
                               n_z: int = 40) -> np.ndarray:
    """Half-Sommerfeld forces for unit (ε̇, εw/2) = (cos ϑ, sin ϑ) over many directions ϑ.

    The full-film problem is linear in G = ε̇ cos θ − (εw/2) sin θ, so one factorisation and
    two solves (G = cos θ, G = −sin θ) give the full-film pressure of every direction; each is
    then clipped and integrated. Forces are returned per unit μR²L/c²... precisely: the
    returned (F_r, F_t) are for μ = 1, R = 1, c = 1 and L = 2·l_over_d (so D = 2), to be
    scaled by μ R⁴/c² · A for a physical bearing (A = hypot(ε̇, εw/2) in 1/s).

    Parameters
    ----------
    eps : float
        ε (-), 0 ≤ ε < 1.
    l_over_d : float
        L/D (-).
    directions : array_like
        ϑ values (rad).
    n_theta, n_z : int
        Grid (see :func:`reynolds_forces`).

    Returns
    -------
    numpy.ndarray
        Shape (len(directions), 2): (F_r, F_t) per direction.

    Examples
    --------
    Pure squeeze (ϑ = 0) pushes the journal back along n only: the film is symmetric about
    the line of centres, so F_t vanishes:

    >>> F = half_sommerfeld_directions(0.5, 1.0, [0.0, math.pi / 2], n_theta=60, n_z=10)
    >>> F.shape, bool(F[0, 0] < 0), bool(abs(F[0, 1]) < 1e-9)
    ((2, 2), True, True)
    """
    K, th, dth, dz = _operator(eps, l_over_d, n_theta, n_z)
    lu = spla.splu(K.tocsc())
    Pc = lu.solve(np.tile(12.0 * np.cos(th) * dth * dz, n_z))
    Ps = lu.solve(np.tile(-12.0 * np.sin(th) * dth * dz, n_z))
    out = np.empty((len(directions), 2))
    for i, v in enumerate(directions):
        P = np.maximum(math.cos(v) * Pc + math.sin(v) * Ps, 0.0).reshape(n_z, n_theta)
        out[i] = _force(P, th, dth, dz, 1.0, 1.0, 1.0)
    return out


def reynolds_condition_directions(eps: float, l_over_d: float, directions, *,
                                  n_theta: int = 240, n_z: int = 40) -> np.ndarray:
    """As :func:`half_sommerfeld_directions`, with the Swift–Stieber (Reynolds) condition.

    One complementarity problem per direction; each starts from the previous direction's
    cavitated set, so that neighbouring directions take few active-set steps.

    Parameters
    ----------
    eps : float
        ε (-), 0 ≤ ε < 1.
    l_over_d : float
        L/D (-).
    directions : array_like
        ϑ values (rad).
    n_theta, n_z : int
        Grid (see :func:`reynolds_forces`).

    Returns
    -------
    numpy.ndarray
        Shape (len(directions), 2): (F_r, F_t) per direction, scaled as in
        :func:`half_sommerfeld_directions`.

    Examples
    --------
    The Reynolds condition lets the film end where its pressure gradient vanishes, beyond the
    half-Sommerfeld cut, so it carries more load:

    >>> hs = half_sommerfeld_directions(0.5, 1.0, [0.0], n_theta=60, n_z=10)
    >>> rc = reynolds_condition_directions(0.5, 1.0, [0.0], n_theta=60, n_z=10)
    >>> bool(rc[0, 0] < hs[0, 0] < 0)
    True
    """
    K, th, dth, dz = _operator(eps, l_over_d, n_theta, n_z)
    gc = np.tile(12.0 * np.cos(th) * dth * dz, n_z)
    gs = np.tile(-12.0 * np.sin(th) * dth * dz, n_z)
    out = np.empty((len(directions), 2))
    free = None
    for i, v in enumerate(directions):
        f = math.cos(v) * gc + math.sin(v) * gs
        P, free = _lcp_active_set(K, f, free=free, return_set=True)
        out[i] = _force(P.reshape(n_z, n_theta), th, dth, dz, 1.0, 1.0, 1.0)
    return out


def _lcp_active_set(K, f, max_iter: int = 200, free=None, return_set=False):
    """Solve P ≥ 0, K P − f ≥ 0, P (K P − f) = 0 by a primal–dual active-set iteration
    (``free``: a starting guess of the set where P > 0; default all)."""
    N = f.size
    Kc = K.tocsr()
    free = np.ones(N, dtype=bool) if free is None else free.copy()
    P = np.zeros(N)
    for _ in range(max_iter):
        P = np.zeros(N)
        if free.any():
            Kff = Kc[free][:, free].tocsc()
            P[free] = spla.spsolve(Kff, f[free])
        lam = Kc @ P - f
        new_free = free.copy()
        new_free[free & (P < 0.0)] = False
        new_free[~free & (lam < 0.0)] = True
        if np.array_equal(new_free, free):
            P = np.maximum(P, 0.0)
            return (P, free) if return_set else P
        free = new_free
    raise RuntimeError(f"Reynolds-condition active set did not settle in {max_iter} iterations")
