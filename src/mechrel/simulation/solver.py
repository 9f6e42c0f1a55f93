"""The solver a scene asks for: :func:`make_integrator`, the defaults per scene kind.

:func:`scene_kind` names the most demanding effect a scene declares (ideal, or the clearance
model of highest precedence); :data:`DEFAULT_SOLVERS` gives its integrator and tolerances
(each clearance model's from its row of :data:`mechrel.forces.models.MODELS`);
:func:`make_integrator` builds the integrator from the scene's ``solver`` table, checked.
"""

from __future__ import annotations

import inspect


from ..errors import SimulationError
from ..forces.models import MODELS
from ..integrate import INTEGRATORS, get_integrator
from ..scene.model import Scene


# Default integrator per scene kind: "ideal" here, each clearance model's from its row of the
# table of models (mechrel.forces.models.MODELS, where the measurements behind each are cited).
DEFAULT_SOLVERS: dict[str, tuple[str, dict]] = {
    "ideal": ("dopri5", {"rtol": 1e-9, "atol": 1e-12}),
    **{m.name: (m.solver[0], dict(m.solver[1])) for m in MODELS.values()},
}


def scene_kind(scene: Scene) -> str:
    """``ideal`` or the name of a clearance model: the most demanding effect declared.

    A film makes the problem stiff; contact makes it non-smooth; when a scene mixes models the
    one of highest ``precedence`` in the table of models wins (lubricated, then transition,
    then dry: the stiff default wins).

    Parameters
    ----------
    scene : mechrel.scene.model.Scene
        The scene.

    Returns
    -------
    str
        ``"ideal"``, ``"dry"``, ``"lubricated"`` or ``"transition"``.

    Examples
    --------
    The four-bar has a lubricated and a dry joint: the stiff film sets its kind:

    >>> from mechrel.scene import load_scene
    >>> scene_kind(load_scene("slider-crank")), scene_kind(load_scene("four-bar"))
    ('ideal', 'lubricated')
    """
    rows = [j.clearance_model for j in scene.clearance_joints]
    return max(rows, key=lambda m: m.precedence).name if rows else "ideal"


def make_integrator(scene: Scene, integrator: str | None = None, **settings):
    """The integrator a scene asks for (``solver.integrator``; ``"auto"`` → per scene type).

    Parameters
    ----------
    scene : Scene
        Its ``solver`` table gives the integrator, step (s), tolerances, step budget,
        contact-onset tolerance (m) and radau's formulation.
    integrator : str, optional
        Overrides ``scene.solver.integrator``: ``"auto"`` (:data:`DEFAULT_SOLVERS` of the
        scene's kind, :func:`scene_kind`) or a name of :data:`mechrel.integrate.INTEGRATORS`.
    **settings
        ``step`` (s), ``rtol``, ``atol`` and the integrator's own keywords, overriding the
        scene's (None leaves a value as it is).

    Returns
    -------
    Integrator
        Configured, ready for :meth:`~mechrel.integrate.base.Integrator.integrate`.

    Raises
    ------
    SimulationError
        An unknown integrator or setting, a fixed-step method without a step, or a
        ``solver.formulation`` for an integrator other than radau.

    Examples
    --------
    A dry clearance joint makes the problem non-smooth: the default is DOPRI5 at tight
    tolerances.

    >>> from mechrel.scene import load_scene
    >>> solver = make_integrator(load_scene("slider-crank-dry"))
    >>> solver.name, solver.rtol, solver.atol
    ('dopri5', 1e-08, 1e-11)

    A scene may choose the equations radau integrates:

    >>> scene = load_scene("nine-bar-lubricated", overrides={"solver.formulation": "absolute"})
    >>> make_integrator(scene).formulation
    'absolute'
    """
    s = scene.solver
    name = s.integrator if integrator is None else integrator
    if name != "auto" and name not in INTEGRATORS:
        raise SimulationError(f"solver.integrator: unknown integrator {name!r}; allowed: auto, "
                              f"{', '.join(sorted(INTEGRATORS))}")
    chosen: dict = {}
    if name == "auto":
        kind = scene_kind(scene)  # a model registered since import: its row's solver
        name, table = DEFAULT_SOLVERS.get(kind) or MODELS[kind].solver
        chosen = dict(table)
        if name not in INTEGRATORS:  # compiled stiff method not available: SciPy's
            name = "lsoda"
    # step, rtol, atol and the integrator's own keywords (Radau's fixed_step); the step
    # budget and the onset tolerance come from the scene
    own = set(inspect.signature(INTEGRATORS[name]).parameters) - {"kwargs"}
    allowed = sorted(({"step", "rtol", "atol"} | own) - {"max_steps", "onset_tolerance"})
    unknown = sorted(set(settings) - set(allowed))
    if unknown:
        raise SimulationError(f"solver settings of {name!r}: unknown "
                              f"{', '.join(map(repr, unknown))}; allowed: {', '.join(allowed)}")
    for key in ("step", "rtol", "atol"):
        value = getattr(s, key)
        if value is not None:
            chosen[key] = value
    if s.formulation is not None:  # radau's equations (a setting of radau alone)
        if "formulation" not in own:
            raise SimulationError(
                f"solver.formulation = {s.formulation!r}: the equations that 'radau' "
                f"integrates, but this scene runs {name!r} (set solver.integrator = 'radau', "
                "or leave solver.formulation unset)")
        chosen["formulation"] = s.formulation
    chosen.update({k: v for k, v in settings.items() if v is not None})
    if name == "rk4" and chosen.get("step") is None:
        raise SimulationError("solver.step: the fixed-step integrator 'rk4' needs a step (s)")
    if INTEGRATORS.get(name) is not None and not INTEGRATORS[name].adaptive:
        chosen.pop("rtol", None)
        chosen.pop("atol", None)
    return get_integrator(name, max_steps=s.max_steps, onset_tolerance=s.onset_tolerance,
                          **chosen)


def _check_step_budget(solver, times) -> None:
    """Refuse up front a fixed-step run whose steps over the span exceed ``solver.max_steps``
    (it would stop at the budget, after running it all, with "maximum number of steps")."""
    if solver.adaptive or times.size < 2:
        return
    span = float(times[-1] - times[0])
    needed = span / solver.step
    if needed > solver.max_steps:
        raise SimulationError(
            f"solver.step = {solver.step:g} s: the analysis span of {span:g} s needs "
            f"{needed:.3g} steps of {solver.name}, more than solver.max_steps = "
            f"{solver.max_steps}; allowed: solver.step >= {span / solver.max_steps:.3g} s, or "
            "a larger solver.max_steps (each step costs about a microsecond or more)")
