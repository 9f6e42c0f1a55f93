"""Build the correction table of the finite-length bearing from numerical Reynolds solutions.

The finite-length film (:mod:`mechrel.forces.finite_film`) is the short-bearing force times a
complex correction q(L/D, ε, ϑ) = F_2D / F_short (forces written as F_r + i F_t), where
ϑ = atan2(εw/2, ε̇) is the direction of the equivalent squeeze vector (ε̇, εw/2): the
half-Sommerfeld film force is positively homogeneous of degree 1 in that vector, for the 2-D
problem as for the short bearing, so q depends on its direction only (the reduction of the
dynamic problem to an equivalent pure-squeeze problem, as in the impedance method of Childs,
Moes & van der Helm 1977). Dividing by the short-bearing force factors out its ε → 1
singularity and makes q → 1 as L/D → 0.

Grids (uniform in transformed variables, so the compiled lookup is index arithmetic):

* L/D = 0.25 · 2^(k/2), k = 0..8 (0.25 to 4);
* ε = 1 − (1 − s)², s = 0, 0.05, ..., 0.9 (ε = 0 to 0.99, dense near the wall);
* ϑ = 0, π/12, ..., π (ϑ < 0 by mirror symmetry: q(−ϑ) = conj q(ϑ)).

Each (L/D, ε) needs one sparse factorisation
(:func:`mechrel.forces.reynolds.half_sommerfeld_directions`) on a 720 × 48 grid (grid error
< 0.5 % against 360 × 24 at ε = 0.99, second order).

Run ``python -m mechrel.forces.finite_table`` to rebuild ``forces/data/finite_bearing_hs.npz``
(about a minute on one core), and ``python -m mechrel.forces.finite_table --cavitation
reynolds`` for the Swift–Stieber table ``finite_bearing_rc.npz`` (one complementarity problem
per direction on a 240 × 16 grid; about 20 minutes under load). The compiled kernel bakes
the tables into Numba's cache: after a rebuild, touch ``finite_film.py`` (or clear
``__pycache__``) so that the cache is recompiled.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

__all__ = ["LD_NODES", "S_NODES", "EPS_NODES", "THETA_NODES", "build_table", "TABLE_PATH",
           "TABLE_PATH_RC", "GRID", "GRID_RC"]

LD_NODES = 0.25 * 2.0 ** (np.arange(9) / 2.0)
S_NODES = np.arange(19) * 0.05
EPS_NODES = 1.0 - (1.0 - S_NODES) ** 2
THETA_NODES = np.arange(13) * (math.pi / 12.0)
TABLE_PATH = Path(__file__).resolve().parent / "data" / "finite_bearing_hs.npz"
"""Where the kernel (:mod:`mechrel.forces.finite_film`, same constant) reads the table."""
GRID = (720, 48)
TABLE_PATH_RC = Path(__file__).resolve().parent / "data" / "finite_bearing_rc.npz"
GRID_RC = (240, 16)
"""Grid of the Swift–Stieber table: one complementarity problem per direction costs ~50 times a
half-Sommerfeld direction. Measured: 120 × 16 is within 0.3 % of 240 × 32 in the Sommerfeld
number at L/D = 1/4..1 and ε = 0.2..0.9; the test suite checks the table against 240 × 32."""


def _short_unit(eps: float, theta: float, l_over_d: float) -> complex:
    from .short_film import short_film_forces
    Fr, Ft = short_film_forces(eps, math.cos(theta), 2.0 * math.sin(theta), 1.0, 1.0,
                               2.0 * l_over_d, 1.0, 0.0, 1.0)
    return complex(Fr, Ft)


def build_table(ld_nodes=LD_NODES, eps_nodes=EPS_NODES, theta_nodes=THETA_NODES,
                grid=GRID, progress: bool = False,
                cavitation: str = "half-sommerfeld") -> np.ndarray:
    """Tabulate the correction q(L/D, ε, ϑ) of the finite bearing over the short one.

    q is the 2-D Reynolds force (:mod:`mechrel.forces.reynolds`) with the given cavitation
    condition divided by the half-Sommerfeld short-bearing force, both as complex numbers
    F_r + i F_t. ``python -m mechrel.forces.finite_table`` writes the shipped tables.

    Parameters
    ----------
    ld_nodes, eps_nodes, theta_nodes : array_like
        L/D (-), ε (-) and ϑ (rad) nodes of the table.
    grid : (int, int)
        Cells (n_theta, n_z) of the Reynolds solutions.
    progress : bool, default False
        Print a line per L/D node.
    cavitation : {"half-sommerfeld", "reynolds"}
        Cavitation condition of the 2-D solutions.

    Returns
    -------
    numpy.ndarray
        Shape (n_LD, n_ε, n_ϑ, 2): real and imaginary parts of q (-).

    Examples
    --------
    One node on a coarse grid (the shipped table uses a finer one):

    >>> Q = build_table([1.0], [0.5], np.array([math.pi / 2]), grid=(60, 10))
    >>> Q.shape, [round(float(x), 2) for x in Q[0, 0, 0]]
    ((1, 1, 1, 2), [0.53, -0.09])
    """
    from .reynolds import half_sommerfeld_directions, reynolds_condition_directions

    solve = {"half-sommerfeld": half_sommerfeld_directions,
             "reynolds": reynolds_condition_directions}[cavitation]

    Q = np.empty((len(ld_nodes), len(eps_nodes), len(theta_nodes), 2))
    for i, ld in enumerate(ld_nodes):
        for j, eps in enumerate(eps_nodes):
            F = solve(float(eps), float(ld), theta_nodes, n_theta=grid[0], n_z=grid[1])
            for k, th in enumerate(theta_nodes):
                q = complex(F[k, 0], F[k, 1]) / _short_unit(float(eps), float(th), float(ld))
                Q[i, j, k] = q.real, q.imag
        if progress:
            print(f"L/D = {ld:.4g} done", flush=True)
    return Q


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cavitation", choices=("half-sommerfeld", "reynolds"),
                    default="half-sommerfeld")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    hs = args.cavitation == "half-sommerfeld"
    out = args.out or (TABLE_PATH if hs else TABLE_PATH_RC)
    grid = GRID if hs else GRID_RC
    Q = build_table(grid=grid, progress=True, cavitation=args.cavitation)
    out.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(out, q=Q, ld=LD_NODES, eps=EPS_NODES, theta=THETA_NODES,
                        grid=np.array(grid), cavitation=np.array(args.cavitation))
    args.out = out
    print(f"wrote {args.out}: q of shape {Q.shape}, |q| in [{np.hypot(*Q.T).min():.4g}, "
          f"{np.hypot(*Q.T).max():.4g}]")


if __name__ == "__main__":
    main()
