"""SORM: second-order corrections to FORM from the curvatures at the design point.

Around the design point u* (β = ‖u*‖, unit normal α = u*/β pointing into the failure domain)
rotate u to (v, u_n), v in the tangent plane. The limit surface is approximated by the
paraboloid u_n = β + ½ Σ κ_i v_i², whose principal curvatures κ_i are the eigenvalues of
Qᵀ H Q / ‖∇G‖, H the Hessian of G at u*, Q an orthonormal basis of the tangent plane
(κ > 0: the surface bends away from the origin, smaller P_f). The Hessian block Qᵀ H Q is
taken by central second differences along the columns of Q (2(d − 1)² model evaluations, in
one parallel, cached executor call).

P_f of the paraboloid (ψ = φ(β)/Φ(−β)):

Breitung (1984), asymptotic for β → ∞
    P₁ = Φ(−β) Π (1 + β κ_i)^(−1/2)
Hohenbichler & Rackwitz (1988)
    P₂ = Φ(−β) Π (1 + ψ κ_i)^(−1/2)
Tvedt (1990), three terms
    A₁ = P₁,  A₂ = [βΦ(−β) − φ(β)] [Π(1 + βκ_i)^(−1/2) − Π(1 + (β + 1)κ_i)^(−1/2)],
    A₃ = (β + 1)[βΦ(−β) − φ(β)] [Π(1 + βκ_i)^(−1/2) − Re Π(1 + (β + i)κ_i)^(−1/2)],
    P₃ = A₁ + A₂ + A₃.

Each needs its factors positive: 1 + βκ_i > 0 for Breitung (a curvature below −1/β is an
error naming it, not a number: the paraboloid closes around the origin), 1 + ψκ_i > 0 for
Hohenbichler–Rackwitz, 1 + (β + 1)κ_i > 0 for Tvedt. ``formula`` picks the one reported as
``pf`` (default Hohenbichler–Rackwitz, defined for the widest range of curvatures); an
undefined choice is an error naming the formulas that are defined. All three are in
the table, an undefined one as NaN (only possible for negative curvatures).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from scipy import special, stats

from mechrel.errors import StudyError

from ..._checks import ARGS
from ..execution.executor import Evaluations
from ..problem.inputs import seed_record
from .._common import emit_warnings
from ._problem import Problem, RareEventResult, concat_evaluations, refuse_evaluations
from ._system import union_probability
from .form import FORMResult, _form, check_positive

__all__ = ["sorm", "SORMResult", "sorm_probabilities", "FORMULAS"]

FORMULAS = ("hohenbichler", "tvedt", "breitung")


@dataclass(frozen=True, eq=False)
class SORMResult(RareEventResult):
    """SORM result (frozen).

    Parameters
    ----------
    table : DataFrame
        One row: ``pf`` (by ``formula``), ``beta`` (= −Φ⁻¹(pf)), ``beta_form``, ``pf_form``,
        ``pf_breitung``, ``pf_hohenbichler``, ``pf_tvedt``, ``n_evaluations`` (FORM's included).
    curvatures : ndarray
        The principal curvatures κ_i at the (most important) design point.
    form : FORMResult
        The FORM result the curvatures are taken at.
    formula : str
        The formula of ``pf``.
    evaluations : Evaluations or None
        Every model row (FORM's included).
    provenance : dict
        How the result was made.
    warnings : tuple of str, default ()
        Caveats of the estimate (FORM's when FORM ran here, several design points combined,
        a design point represented by its linearisation); also issued as
        :class:`~mechrel.errors.EstimateWarning`.
    modes : DataFrame, optional
        One row per design point of FORM's system: ``member``, ``beta``, ``pf_form``,
        ``pf_sorm`` (by ``formula``) and its ``curvatures``.

    Examples
    --------
    On a linear margin every curvature is zero and SORM is FORM:

    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs, sorm
    >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
    >>> margin = FunctionModel(lambda X: 3.0 - X[:, 0], ["x1", "x2"], ["g"], vectorized=True)
    >>> r = sorm(model=margin, inputs=inputs)
    >>> bool(abs(r.curvatures).max() < 1e-6), round(r.pf / r.form.pf, 6)
    (True, 1.0)
    """

    table: pd.DataFrame
    curvatures: np.ndarray
    form: FORMResult
    formula: str
    evaluations: Evaluations | None
    provenance: dict = field(repr=False)
    warnings: tuple[str, ...] = ()
    modes: pd.DataFrame | None = None


def _member_fn(problem: Problem, m: int):
    """The margin of member m (−1: the system margin) at standard-normal points."""
    def fn(U):
        Gm, ok, reasons, _Y, _A = problem.members(U)
        return (problem.bound.system_from_members(Gm) if m < 0 else Gm[:, m]), ok, reasons
    return fn


def sorm_probabilities(beta: float, kappa: Any) -> dict:
    """The second-order failure probabilities of a paraboloid.

    P_f of the paraboloid with main curvatures ``kappa`` at distance ``beta`` from the origin of
    the standard-normal space, by the three formulas of the module docstring. Breitung needs
    1 + βκ_i > 0 (else no second-order estimate exists), Hohenbichler–Rackwitz 1 + ψκ_i > 0
    and Tvedt 1 + (β + 1)κ_i > 0; a formula whose condition fails (only possible for negative
    curvatures) is None.

    Parameters
    ----------
    beta : float
        The reliability index of the design point (dimensionless).
    kappa : array_like
        The main curvatures at the design point (1/standard-normal unit; positive: the failure
        domain curves away from the origin).

    Returns
    -------
    dict
        ``{"breitung": p, "hohenbichler": p, "tvedt": p}``, each a float or None.

    Raises
    ------
    StudyError
        If 1 + βκ_i <= 0 for a curvature (Breitung's condition).

    Examples
    --------
    With zero curvatures every formula gives FORM's Φ(−β):

    >>> p = sorm_probabilities(3.0, [0.0, 0.0])
    >>> [round(p[k] / 1.3498980316e-3, 9) for k in ("breitung", "hohenbichler", "tvedt")]
    [1.0, 1.0, 1.0]
    """
    k = np.asarray(kappa, dtype=float).reshape(-1)
    if np.any(1.0 + beta * k <= 0):
        bad = k[1.0 + beta * k <= 0]
        raise StudyError(
            f"sorm: curvature κ = {bad.tolist()} at β = {beta:.4g}: 1 + βκ ≤ 0, the second-order approximation "
            "is undefined (the failure domain curls around the origin); allowed: κ > −1/β; use "
            "importance_sampling or subset_simulation"
        )
    pf1 = special.ndtr(-beta)
    phi = stats.norm.pdf(beta)
    psi = phi / pf1 if pf1 > 0 else beta
    P_b = float(np.prod((1.0 + beta * k) ** -0.5))
    breitung = float(pf1 * P_b)
    hr = float(pf1 * np.prod((1.0 + psi * k) ** -0.5)) if np.all(1.0 + psi * k > 0) else None
    tvedt = None
    if np.all(1.0 + (beta + 1.0) * k > 0):
        c = beta * pf1 - phi
        a2 = c * (P_b - float(np.prod((1.0 + (beta + 1.0) * k) ** -0.5)))
        a3 = (beta + 1.0) * c * (P_b - float(np.real(np.prod((1.0 + (beta + 1j) * k) ** -0.5))))
        tvedt = float(breitung + a2 + a3)
    return {"breitung": breitung, "hohenbichler": hr, "tvedt": tvedt}


def curvatures(fn, u: np.ndarray, dG: np.ndarray, g_star: float, *, step: float) -> np.ndarray:
    """Principal curvatures at u* of the margin ``fn(U) -> (G, ok, reasons)`` by central second
    differences in the tangent plane."""
    d = u.shape[0]
    if d == 1:
        return np.empty(0)
    n = -dG / np.linalg.norm(dG)
    # orthonormal basis: QR of [n, e_1, ..., e_d] with n first, the other d-1 columns span the plane
    Q, _ = np.linalg.qr(np.column_stack([n, np.eye(d)]))
    T = Q[:, 1:d]
    m = d - 1
    pts = []
    for i in range(m):
        pts += [u + step * T[:, i], u - step * T[:, i]]
    pairs = [(i, j) for i in range(m) for j in range(i + 1, m)]
    for i, j in pairs:
        for si, sj in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
            pts.append(u + step * (si * T[:, i] + sj * T[:, j]))
    G, ok, reasons = fn(np.array(pts))
    if not ok.all():
        bad = [reasons[i] for i in np.flatnonzero(~ok)][:3]
        raise StudyError(f"sorm: {int((~ok).sum())} of the {len(pts)} curvature points failed ({bad}); "
                         "allowed: a smaller curvature_step, or a sampling method")
    Hm = np.empty((m, m))
    for i in range(m):
        Hm[i, i] = (G[2 * i] - 2.0 * g_star + G[2 * i + 1]) / step**2
    base = 2 * m
    for k, (i, j) in enumerate(pairs):
        gpp, gpm, gmp, gmm = G[base + 4 * k : base + 4 * k + 4]
        Hm[i, j] = Hm[j, i] = (gpp - gpm - gmp + gmm) / (4.0 * step**2)
    # G ≈ ‖∇G‖(β − u_n) + ½ vᵀ H v  →  u_n = β + vᵀ H v / (2‖∇G‖)
    return np.sort(np.linalg.eigvalsh(Hm / np.linalg.norm(dG)))


def sorm(
    *,
    model: Any,
    inputs: Any,
    evaluations: Any = None,
    limit_state: Any = None,
    seed: Any = None,
    design_point: FORMResult | None = None,
    formula: str = "hohenbichler",
    curvature_step: float = 1e-2,
    step: float = 1e-4,
    scheme: str = "central",
    tol: float = 1e-6,
    max_iter: int = 100,
    search: str = "system",
    max_design_points: int = 8,
    contribution: float = 0.01,
    n_jobs: int = 1,
    backend: str = "loky",
    cache: Any = None,
    progress: bool = False,
    chunk_size: int | None = None,
) -> SORMResult:
    """Second-order reliability from the curvatures at FORM's design point.

    Parameters
    ----------
    model, inputs, limit_state
        The model, its uncertain inputs and the limit state (default: the model's only output is
        the margin g; failure g ≤ 0).
    evaluations : None
        Precomputed evaluations cannot be used (the method chooses its points as it goes);
        anything but None is an error. Accepted so that every estimator shares one interface.
    seed
        Unused (SORM draws nothing); accepted so that every estimator shares one interface.
    design_point : FORMResult, optional
        FORM's result for the same model, inputs and limit state (else FORM runs here with
        ``step``, ``scheme``, ``tol``, ``max_iter``).
    formula : {"hohenbichler", "tvedt", "breitung"}, default "hohenbichler"
        Which estimate is ``pf``: Hohenbichler–Rackwitz (defined for the widest range of negative
        curvatures, κ > −1/ψ, ψ ≈ β + 1/β), Tvedt (the most accurate for a true paraboloid, needs
        κ > −1/(β + 1)) or Breitung (the asymptotic form).
    curvature_step : float, default 1e-2
        Second-difference step in standard normal units (its truncation error is O(step²) times
        the fourth derivative; its round-off ≈ ε|G|/step²: enlarge it for a noisy model).
    step, scheme, tol, max_iter, search, max_design_points, contribution
        FORM's settings, when FORM runs here (:func:`form`).
    n_jobs, backend, cache, progress, chunk_size
        Passed to :func:`mechrel.uq.evaluate`.

    Returns
    -------
    SORMResult

    Raises
    ------
    StudyError
        If ``design_point`` is not a FORMResult of the same inputs, or the formula is undefined
        for the curvatures at the design point (a factor 1 + cκ <= 0); the errors of
        :func:`~mechrel.uq.form` when the design point is searched here.

    Examples
    --------
    A parabola g = 3 − u2 + 0.1 u1²: β = 3 and the surface's curvature κ = 0.2 (it bends away
    from the failure domain), so Breitung's formula is Φ(−β)/sqrt(1 + βκ):

    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs, sorm
    >>> inputs = UncertainInputs.from_specs({"u1": Normal(0.0, 1.0), "u2": Normal(0.0, 1.0)})
    >>> parabola = FunctionModel(lambda X: 3.0 - X[:, 1] + 0.1 * X[:, 0] ** 2, ["u1", "u2"],
    ...                          ["g"], vectorized=True)
    >>> r = sorm(model=parabola, inputs=inputs, formula="breitung")
    >>> from scipy.special import ndtr
    >>> round(float(r.pf / (ndtr(-3.0) / (1 + 3 * 0.2) ** 0.5)), 4)
    1.0
    """
    refuse_evaluations(evaluations, "sorm")
    ARGS.choice("formula", formula, FORMULAS)
    curvature_step = check_positive("curvature_step", curvature_step)
    problem = Problem(model=model, inputs=inputs, limit_state=limit_state, n_jobs=n_jobs, backend=backend,
                      cache=cache, progress=progress, chunk_size=chunk_size, what="sorm")
    extra = []
    if design_point is None:
        fr = _form(problem, seed=seed, step=step, scheme=scheme, tol=tol, max_iter=max_iter, start=None,
                   search=search, max_design_points=max_design_points, contribution=contribution)
    else:
        if not isinstance(design_point, FORMResult):
            raise StudyError(f"sorm: design_point = {design_point!r}: not a FORMResult; allowed: None or form(...)")
        if tuple(design_point.design_point.index) != problem.names:
            raise StudyError(f"sorm: design_point inputs {list(design_point.design_point.index)} differ from "
                             f"{list(problem.names)}; allowed: a FORMResult of the same inputs and limit state")
        fr = design_point
        if fr.evaluations is not None:
            extra = [fr.evaluations]
    if fr.system == "parallel":
        raise StudyError(
            "sorm: the limit state is a parallel system; mechrel has no second-order formula for the joint "
            "design point of several components; allowed: form (its first-order parallel estimate), "
            "importance_sampling or subset_simulation")
    dps = fr.design_points
    modes, notes = [], []
    for k, row in dps.iterrows():
        m = int(row["member_index"])
        fn = _member_fn(problem, m)
        pt = fr.points.loc[k]
        u, grad = pt["u"].to_numpy(), pt["dg_du"].to_numpy()
        if row["how"] == "linearised":
            kappa = np.zeros(max(problem.d - 1, 0))
            notes.append(f"sorm: design point {k} ({row['member']}) is a linearisation (its search did not "
                         "converge): its curvatures are taken as 0")
        else:
            g_star = float(fn(u[None, :])[0][0])
            kappa = curvatures(fn, u, grad, g_star, step=curvature_step)
        modes.append((float(row["beta"]), kappa, -grad / np.linalg.norm(grad)))
    per_mode = [sorm_probabilities(b, kap) for b, kap, _a in modes]
    if len(modes) == 1:
        probs = per_mode[0]
    else:
        alphas = np.array([a for _b, _k, a in modes])
        probs = {}
        for f in FORMULAS:
            ps = [pm[f] for pm in per_mode]
            if any(p is None for p in ps):
                probs[f] = None
                continue
            beq = -special.ndtri(np.array(ps))
            probs[f] = union_probability(beq, alphas)[0]
        notes.append(f"sorm: {len(modes)} design points: P_f combines each mode's second-order probability "
                     "as the union of equivalent hyperplanes (β_i = −Φ⁻¹(P_i), FORM's normals; Hohenbichler & "
                     "Rackwitz 1983): compare with a sampling method")
    kappa = modes[0][1]
    beta = float(dps["beta"].iloc[0])
    pf = probs[formula]
    if pf is None:
        defined = [f for f in FORMULAS if probs[f] is not None]
        raise StudyError(
            f"sorm: formula = {formula!r}: undefined for the curvatures κ = {np.round(kappa, 4).tolist()} at "
            f"β = {beta:.4g} (a factor 1 + cκ ≤ 0); allowed here: {defined}")
    probs = {f: (np.nan if v is None else v) for f, v in probs.items()}  # undefined: NaN in the table, documented
    n_ev = problem.n_evaluations + (fr.n_evaluations if design_point is not None else 0)
    table = pd.DataFrame({"pf": [pf], "beta": [float(-special.ndtri(pf))], "beta_form": [fr.beta],
                          "pf_form": [fr.pf], "pf_breitung": [probs["breitung"]],
                          "pf_hohenbichler": [probs["hohenbichler"]], "pf_tvedt": [probs["tvedt"]],
                          "n_design_points": [len(modes)], "n_evaluations": [n_ev]},
                         index=pd.Index([problem.limit_state.name], name="limit_state"))
    mode_table = pd.DataFrame({"member": dps["member"], "beta": [b for b, _k, _a in modes],
                               "pf_form": [float(special.ndtr(-b)) for b, _k, _a in modes],
                               "pf_sorm": [np.nan if pm[formula] is None else pm[formula] for pm in per_mode],
                               "curvatures": [np.round(k_, 6).tolist() for _b, k_, _a in modes]},
                              index=dps.index)
    prov = problem.provenance(method="sorm", seed=seed_record(seed), extra_evaluations=extra,
                              settings={"formula": formula, "curvature_step": curvature_step,
                                        "form": "given" if design_point is not None else
                                        {"step": step, "scheme": scheme, "tol": tol, "max_iter": max_iter,
                                         "search": search, "max_design_points": max_design_points,
                                         "contribution": contribution},
                                        "system": "union of equivalent hyperplanes" if len(modes) > 1 else None})
    kap = np.array(kappa)
    kap.setflags(write=False)
    caveats = emit_warnings(list(fr.warnings if design_point is None else ()) + notes, stacklevel=3)
    return SORMResult(table, kap, fr, formula, concat_evaluations(extra + problem.evaluations), prov, caveats,
                      mode_table)
