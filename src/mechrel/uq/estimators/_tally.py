"""Monte Carlo's counts of samples inside their allowables, in one compiled pass over the
outputs.

:func:`tally` counts, per output, the samples whose output is inside its allowable (the
event |y| ≤ I or y ≤ I), per group of outputs the samples with every output of the group
inside (the whole-cycle events), and the samples with every group inside (the joint event).
The counts are those of the NumPy formulas Monte Carlo used before (a boolean (n, n_out)
array of the event, its column sums and row-wise ``all``): a comparison has one answer, and
a sampled allowable is formed as NumPy forms it, μ + σ·ξ, a product then a sum (the compiled
code contracts no product and sum into a fused multiply-add: ``fastmath`` is off). The pass
makes no (n, n_out) array; in NumPy the column sums of a narrow boolean array alone cost
twice the comparisons.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["tally"]


@numba.njit(cache=True)
def _tally(Y, rows, ok, mu, sd, xi, col, spread, two_sided, member):
    n, k = Y.shape
    n_groups = member.shape[0]
    k_out = np.zeros(k, dtype=np.int64)
    k_group = np.zeros(n_groups, dtype=np.int64)
    k_joint = 0
    inside = np.empty(k, dtype=np.bool_)
    for i in range(n):
        if not rows[i]:
            continue
        for j in range(k):
            I = mu[j] + sd[j] * xi[i, col[j]] if spread else mu[j]
            y = abs(Y[i, j]) if two_sided else Y[i, j]
            inside[j] = ok[i] and y <= I  # NaN: outside
            if inside[j]:
                k_out[j] += 1
        joint = True
        for g in range(n_groups):
            held = True
            for j in range(k):
                if member[g, j] and not inside[j]:
                    held = False
                    break
            if held:
                k_group[g] += 1
            else:
                joint = False
        if joint:
            k_joint += 1
    return k_out, k_group, k_joint


def tally(Y: np.ndarray, rows: np.ndarray, ok: np.ndarray, mu: np.ndarray, sd: np.ndarray,
          xi: np.ndarray | None, col: np.ndarray, two_sided: bool, member: np.ndarray):
    """Counts of the samples inside their allowables.

    Parameters
    ----------
    Y : ndarray, shape (n, k)
        The outputs, one row per sample.
    rows : ndarray of bool, shape (n,)
        The samples counted.
    ok : ndarray of bool, shape (n,)
        The successful samples: a failed one is inside nowhere.
    mu, sd : ndarray, shape (k,)
        Each output's allowable is ``mu + sd * xi[:, col]`` (``mu`` alone when ``xi`` is None).
    xi : ndarray, shape (n, m), or None
        The standard-normal draws of the allowables, ``col`` (k,) each output's column in it.
    two_sided : bool
        The event |y| ≤ I (else y ≤ I).
    member : ndarray of bool, shape (g, k)
        Per group, the outputs whose joint event it counts.

    Returns
    -------
    k_out : ndarray of int, shape (k,)
        Per output, the counted samples inside.
    k_group : ndarray of int, shape (g,)
        Per group, the counted samples with each of its outputs inside.
    k_joint : int
        The counted samples with every group's event.
    """
    spread = xi is not None
    k = Y.shape[1]
    xi = xi if spread else np.zeros((1, 1))
    col = col if spread else np.zeros(k, dtype=np.int64)
    k_out, k_group, k_joint = _tally(
        _frozen(Y, float), _frozen(rows, np.bool_), _frozen(ok, np.bool_), _frozen(mu, float),
        _frozen(sd, float), _frozen(xi, float), _frozen(col, np.int64), spread, bool(two_sided),
        _frozen(np.reshape(member, (-1, k)), np.bool_))
    return k_out, k_group, int(k_joint)


def _frozen(a, dtype) -> np.ndarray:
    """A read-only C-ordered view of ``a`` (a copy only when its type or layout differ): one
    compiled specialisation of :func:`_tally` for whatever arrays the callers hold."""
    v = np.ascontiguousarray(a, dtype=dtype).view()
    v.setflags(write=False)
    return v
