"""Hydrodynamic film forces of a finite-length journal bearing (0.25 ≤ L/D ≤ 4), rotation and
squeeze, half-Sommerfeld film.

Method
------
Same conventions as :mod:`mechrel.forces.film` (F_r along n = e/|e|, F_t along t, ε, ε̇ and
ε·w with w = ω_S + ω_B − 2γ̇). The half-Sommerfeld film force of the two-dimensional Reynolds
equation depends on the motion only through the equivalent squeeze vector (ε̇, εw/2): the
right-hand side of Reynolds' equation is −12 μ c G with G = ε̇ cos θ − (εw/2) sin θ
(docs/forces.md), so the force is A · f(ε, ϑ; L/D) with A = hypot(ε̇, εw/2) and
ϑ = atan2(εw/2, ε̇). This is the reduction of the dynamic problem to a pure-squeeze problem
that underlies the impedance method (Childs, Moes & van der Helm 1977). We write
f = f_short · q, complex numbers F_r + i F_t, where f_short is the short-bearing (Ocvirk)
force of :mod:`mechrel.forces.short_film` (it carries the ε → 1 singularity, and q → 1 as
L/D → 0), and tabulate the correction q(L/D, ε, ϑ) from our own finite-volume Reynolds
solutions (:mod:`mechrel.forces.finite_table`, data ``forces/data/finite_bearing_hs.npz``):

* one table per cavitation condition: half-Sommerfeld (``finite_bearing_hs.npz``) and
  Swift–Stieber (``finite_bearing_rc.npz``, the 2-D Reynolds-condition force over the
  half-Sommerfeld short one; positively homogeneous in (ε̇, εw/2) as well);
* L/D = 0.25·2^(k/2), k = 0..8; ε = 1 − (1 − s)², s = 0, 0.05, ..., 0.9; ϑ = 0, π/12, ..., π,
  with q(−ϑ) = conj q(ϑ) (mirror symmetry w → −w);
* cubic Lagrange interpolation in each of the three uniform index variables (4×4×4 nodes),
  one-sided at the ends of the L/D and ε ranges; for ε > 0.99 q is held at its ε = 0.99
  value (the force keeps the short bearing's divergence as ε → 1, scaled by q(0.99)).

The result is multiplied by the same small-eccentricity factor as the other films (through
the short-bearing force). Accuracy against the 2-D solution: within 2 % over the tested range
(tests/test_forces_finite_film.py).

Source: Reynolds' equation (Hamrock, Schmid & Jacobson 2004, ch. 7); Childs, D., Moes, H. &
van der Helm, H. (1977), "Petrov's method and the impedance method for dynamically loaded
journal bearings", J. Lubr. Technol. 99, 64–73 (the reduction to an equivalent squeeze).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from pathlib import Path

from mechrel.forces.short_film import short_film_forces

__all__ = ["finite_film_forces", "correction", "LD_MIN", "LD_MAX", "TABLE_PATH",
           "TABLE_PATH_RC", "TABLES_PRESENT"]

TABLE_PATH = Path(__file__).resolve().parent / "data" / "finite_bearing_hs.npz"
"""Half-Sommerfeld correction table (package data, built by :mod:`mechrel.forces.finite_table`)."""
TABLE_PATH_RC = Path(__file__).resolve().parent / "data" / "finite_bearing_rc.npz"
"""Swift–Stieber correction table."""
_SHAPE = (9, 19, 13, 2)  # L/D, ε, ϑ nodes of mechrel.forces.finite_table; real and imaginary


def _load(path: Path) -> np.ndarray:
    # A missing table (e.g. while it is being rebuilt from scratch) leaves NaN in its place;
    # pack_params then refuses the finite film instead of passing NaN on.
    try:
        with np.load(path) as data:
            q = np.ascontiguousarray(data["q"], dtype=np.float64)
    except FileNotFoundError:
        return np.full(_SHAPE, np.nan)
    if q.shape != _SHAPE:
        raise ValueError(f"{path}: table of shape {q.shape}, expected {_SHAPE}")
    return q


_Q = _load(TABLE_PATH)
_Q_RC = _load(TABLE_PATH_RC)
TABLES_PRESENT = {"half-sommerfeld": bool(np.all(np.isfinite(_Q))),
                  "reynolds": bool(np.all(np.isfinite(_Q_RC)))}
"""Whether each correction table was loaded (cavitation condition → bool)."""
_N_LD, _N_S, _N_TH = _SHAPE[0], _SHAPE[1], _SHAPE[2]
LD_MIN = 0.25
"""Smallest L/D of the table (-)."""
LD_MAX = 0.25 * 2.0 ** ((_N_LD - 1) / 2.0)
"""Largest L/D of the table (-), 4."""
_DS = 0.05
_DTH = math.pi / 12.0


@numba.njit(cache=True, fastmath=False)
def _lagrange4(t):
    # weights of the cubic through nodes 0, 1, 2, 3 at t
    a = t
    b = t - 1.0
    c = t - 2.0
    d = t - 3.0
    return (-b * c * d / 6.0, a * c * d / 2.0, -a * b * d / 2.0, a * b * c / 6.0)


@numba.njit(cache=True, fastmath=False)
def _stencil(x, n):
    # first node of a 4-point stencil around x in [0, n − 1], and the local coordinate
    i0 = int(math.floor(x)) - 1
    if i0 < 0:
        i0 = 0
    if i0 > n - 4:
        i0 = n - 4
    return i0, x - i0


@numba.njit(cache=True, fastmath=False)
def correction(l_over_d, eps, theta, reynolds=False):
    """Complex correction q = (Re, Im) of the finite bearing over the short one (-).

    Parameters
    ----------
    l_over_d : float
        L/D (-), in [0.25, 4] (the packer checks it).
    eps : float
        ε (-), ≥ 0; above 0.99 the value at 0.99 is used.
    theta : float
        Direction ϑ = atan2(εw/2, ε̇) (rad), in [−π, π].
    reynolds : bool
        Swift–Stieber table instead of the half-Sommerfeld one.

    Returns
    -------
    (float, float)
        Real and imaginary parts of q.

    Examples
    --------
    >>> q = correction(20e-3 / 19e-3, 0.5, math.pi / 2)   # L/D of a 20 mm x 19 mm bearing
    >>> [round(x, 4) for x in q]
    [0.5007, -0.0878]
    """
    x = 2.0 * math.log2(l_over_d / LD_MIN)
    x = min(max(x, 0.0), _N_LD - 1.0)
    s = (1.0 - math.sqrt(max(1.0 - eps, 0.0))) / _DS
    s = min(max(s, 0.0), _N_S - 1.0)
    conj = theta < 0.0
    y = abs(theta) / _DTH
    y = min(y, _N_TH - 1.0)
    i0, tx = _stencil(x, _N_LD)
    j0, ts = _stencil(s, _N_S)
    # ϑ: the stencil may reach past 0 or π; ghost nodes by mirror symmetry (conjugate)
    k0 = int(math.floor(y)) - 1
    if k0 > _N_TH - 3:
        k0 = _N_TH - 3
    ty = y - k0
    wx = _lagrange4(tx)
    ws = _lagrange4(ts)
    wy = _lagrange4(ty)
    Q = _Q_RC if reynolds else _Q
    qr = 0.0
    qi = 0.0
    for c in range(4):
        k = k0 + c
        sign = 1.0
        if k < 0:
            k = -k
            sign = -1.0
        elif k > _N_TH - 1:
            k = 2 * (_N_TH - 1) - k
            sign = -1.0
        for a in range(4):
            for b in range(4):
                w = wx[a] * ws[b] * wy[c]
                qr += w * Q[i0 + a, j0 + b, k, 0]
                qi += w * sign * Q[i0 + a, j0 + b, k, 1]
    if conj:
        qi = -qi
    return qr, qi


@numba.njit(cache=True, fastmath=False)
def finite_film_forces(eps, eps_dot, eps_w, mu, R_S, L, c, lam, eps0, reynolds=False):
    """Finite-length bearing film forces, half-Sommerfeld, rotation and squeeze (N).

    Parameters
    ----------
    eps : float
        ε = |e|/c (-), 0 ≤ ε < 1 (the caller caps it).
    eps_dot : float
        ε̇ (1/s), > 0 when the journal moves away from the centre.
    eps_w : float
        ε·w (rad/s), w = ω_S + ω_B − 2γ̇.
    mu : float
        Dynamic viscosity (Pa s).
    R_S : float
        Journal radius (m).
    L : float
        Bearing length (m); L/D = L/(2 R_S) must be in [0.25, 4].
    c : float
        Radial clearance (m).
    lam, eps0 : float
        Small-eccentricity correction (see :func:`mechrel.forces.film.small_eccentricity_factor`).
    reynolds : bool, default False
        Swift–Stieber cavitation (its own table) instead of half-Sommerfeld.

    Returns
    -------
    (float, float)
        (F_r, F_t): force on the journal along n and along t (N).

    Examples
    --------
    A finite bearing carries less than the short-bearing formula, which neglects the
    circumferential pressure flow (L/D = 1.05 here):

    >>> from mechrel.forces.short_film import short_film_forces
    >>> args = (0.5, 0.0, 50.0, 0.01, 9.5e-3, 20e-3, 0.5e-3, 0.0, 0.1)
    >>> [round(f, 4) for f in finite_film_forces(*args)]
    [-0.0515, 0.1039]
    >>> [round(f, 4) for f in short_film_forces(*args)]
    [-0.1351, 0.1838]
    """
    Fr, Ft = short_film_forces(eps, eps_dot, eps_w, mu, R_S, L, c, lam, eps0)
    qr, qi = correction(L / (2.0 * R_S), eps, math.atan2(0.5 * eps_w, eps_dot), reynolds)
    return Fr * qr - Ft * qi, Fr * qi + Ft * qr
