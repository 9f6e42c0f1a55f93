"""The one result type of a simulation: :class:`SimulationResult` (frozen, ``.to_frame()``),
and its provenance record."""

from __future__ import annotations

import platform
from dataclasses import dataclass, field
from collections.abc import Mapping

import numpy as np

from ..errors import SimulationError
from ..scene.model import Scene

from .extremes import EXTREME_FIELDS

@dataclass(frozen=True)
class SimulationResult:
    """The outcome of :func:`simulate`.

    Parameters
    ----------
    scene : Scene
        The scene simulated.
    time : ndarray
        Output instants (s).
    crank_angle : ndarray or None
        Rotation of the cycle driver since t = 0 (degrees), when the analysis has one.
    outputs : dict
        ``outputs[name][quantity]`` of the simulated mechanism, in SI units; the quantities
        of each output are those of its kind (:data:`mechrel.outputs.OUTPUT_KINDS`).
    ideal : dict or None
        The same for the ideal counterpart: the scene's own mechanism with all joints ideal
        (scenes with clearance joints), or the ideal mechanism of the ``reference`` design
        given to :func:`simulate`.
    q, v, a : ndarray, shape (n_times, n)
        Coordinates (m, rad) and their first and second derivatives.
    orbits : dict
        Per clearance joint: eccentricity components ``ex``, ``ey`` (m) and ratio ``eps``.
    energy : dict
        ``kinetic``, ``potential``, ``elastic``, ``input_work``, ``clearance_work`` (J) and
        ``balance`` = ΔT + ΔV − W_in − W_cl (J), which integration and Baumgarte errors alone
        make non-zero.
    method : str
        ``"kinematics"`` or ``"dynamics"``.
    stats : dict
        Solver statistics (:class:`~mechrel.integrate.SolverStats` as a dict) or those of the
        kinematic analysis; always includes ``max_position_violation`` and ``wall_time``.
    provenance : dict
        Scene name and hash, reference name and hash (if any), versions of mechrel, NumPy,
        SciPy, Numba and Python, and the wall time (s).
    extremes : dict or None
        With ``simulate(..., extremes=True)``: ``extremes[output][quantity][field]`` for the
        fields of :data:`EXTREME_FIELDS`: the largest (``max``) and smallest (``min``) signed
        error and the largest magnitude (``max_abs``) over the analysis window (the last cycle
        of the cycle driver, or the whole span), each with the instant (``*_time``, s) and
        the cycle driver's rotation since t = 0 (``*_angle``, degrees; NaN without a cycle
        driver) where it occurs. Found on the integrator's solution (every accepted step's end
        and ``dense_points`` points of its continuous extension inside it, plus the output
        instants), not on the output grid (docs/mechanics.md, "Cycle extremes"). And
        ``closure``: |error at the window's end − error at its start| over the error's span
        in the window when the window is one whole cycle (NaN otherwise); above
        :data:`~mechrel.simulation.extremes.CLOSURE_LIMIT` the cycle does not repeat (the
        start transient, or a response that is not periodic).
    sector_extremes : dict or None
        With ``simulate(..., extremes=True, sectors=step)``: ``sector_extremes[output][quantity]``
        = ``(max, min)``, arrays of the largest and smallest signed error over each closed
        sector [k·step, (k + 1)·step] of the analysed cycle's crank angle (degrees from its
        start), found on the same points as the cycle extremes: the members of the whole cycle's
        series system (docs/uq.md, "The whole cycle as a series system").
    warnings : tuple of str
        Why the numbers may be wrong without the run having failed, each also issued by
        :func:`simulate` as a :class:`~mechrel.errors.SimulationWarning`: the ideal joints
        drifted apart by at least :data:`~mechrel.simulation.run.DRIFT_LIMIT` of the smallest
        clearance (docs/mechanics.md, "Drift of the ideal joints"). Empty for a sound run.

    See Also
    --------
    simulate : Makes it.

    Examples
    --------
    >>> from mechrel.simulation import simulate
    >>> from mechrel.scene import load_scene
    >>> r = simulate(load_scene("slider-crank"))
    >>> sorted(r.outputs["slider"])
    ['acceleration', 'displacement', 'velocity']
    >>> r.q.shape == (r.time.size, 9)
    True
    """

    scene: Scene
    time: np.ndarray
    crank_angle: np.ndarray | None
    outputs: Mapping[str, Mapping[str, np.ndarray]]
    ideal: Mapping[str, Mapping[str, np.ndarray]] | None
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    method: str
    stats: Mapping
    provenance: Mapping
    orbits: Mapping[str, Mapping[str, np.ndarray]] = field(default_factory=dict)
    energy: Mapping[str, np.ndarray] = field(default_factory=dict)
    extremes: Mapping[str, Mapping[str, Mapping[str, float]]] | None = None
    sector_extremes: Mapping[str, Mapping[str, tuple]] | None = None
    warnings: tuple[str, ...] = ()

    def extremes_frame(self):
        """The cycle extremes as a :class:`pandas.DataFrame`: one row per ``(output,
        quantity)``, the columns of :data:`EXTREME_FIELDS` (values in SI units, times in s,
        angles in degrees of the cycle driver's rotation since t = 0).

        Returns
        -------
        pandas.DataFrame
            The extremes, with the provenance in ``frame.attrs["provenance"]``.

        Raises
        ------
        mechrel.errors.SimulationError
            The result was simulated without ``extremes=True``.

        Examples
        --------
        A crank 0.1 mm longer than the nominal one moves the slider by 0.1 mm at its dead
        centres:

        >>> from mechrel.simulation import simulate
        >>> from mechrel.scene import load_scene
        >>> nominal = load_scene("slider-crank")
        >>> longer = load_scene("slider-crank", overrides=["bodies.crank.length(O,A)=0.0501"])
        >>> r = simulate(longer, reference=nominal, extremes=True)
        >>> round(float(r.extremes_frame().loc[("slider", "displacement"), "max_abs"]), 9)
        0.0001
        """
        import pandas as pd

        if self.extremes is None:
            raise SimulationError("this result has no cycle extremes; simulate(scene, "
                                  "extremes=True) computes them")
        rows = {(name, qty): d for name, qs in self.extremes.items() for qty, d in qs.items()}
        frame = pd.DataFrame.from_dict(rows, orient="index", columns=list(EXTREME_FIELDS))
        frame.index = pd.MultiIndex.from_tuples(frame.index, names=["output", "quantity"])
        frame.attrs["provenance"] = dict(self.provenance)
        return frame

    def error(self, output: str, quantity: str) -> np.ndarray:
        """Simulated minus ideal ``quantity`` of ``output``.

        Parameters
        ----------
        output : str
            An output name of the scene.
        quantity : str
            One of the output's quantities (e.g. ``"displacement"``).

        Returns
        -------
        numpy.ndarray
            The error at each output instant (SI units).

        Raises
        ------
        mechrel.errors.SimulationError
            The result has no ideal counterpart (no clearance joint and no reference).

        Examples
        --------
        A crank 0.1 mm longer than the nominal one: at t = 0 (crank along the slider's line)
        the slider is 0.1 mm further out:

        >>> from mechrel.simulation import simulate
        >>> from mechrel.scene import load_scene
        >>> nominal = load_scene("slider-crank")
        >>> longer = load_scene("slider-crank", overrides=["bodies.crank.length(O,A)=0.0501"])
        >>> e = simulate(longer, reference=nominal).error("slider", "displacement")
        >>> round(float(e[0]), 9)   # m
        0.0001
        """
        if self.ideal is None:
            raise SimulationError("this scene has no clearance joints: there is no response "
                                  "error (the mechanism is its own ideal counterpart)")
        return self.outputs[output][quantity] - self.ideal[output][quantity]

    def to_frame(self):
        """A :class:`pandas.DataFrame` with columns ``time``, ``crank_angle`` (when defined),
        ``<output>.<quantity>`` and, for scenes with clearance joints,
        ``<output>.<quantity>.ideal`` and ``<output>.<quantity>.error``.

        Returns
        -------
        pandas.DataFrame
            One row per output instant (SI units; ``crank_angle`` in degrees), with the
            provenance in ``frame.attrs["provenance"]`` and the result's ``warnings`` in
            ``frame.attrs["warnings"]``.

        Examples
        --------
        >>> from mechrel.simulation import simulate
        >>> from mechrel.scene import load_scene
        >>> frame = simulate(load_scene("slider-crank")).to_frame()
        >>> frame.columns.tolist()
        ['time', 'crank_angle', 'slider.displacement', 'slider.velocity', 'slider.acceleration']
        >>> len(frame)   # one cycle sampled every degree
        361
        """
        import pandas as pd

        cols: dict[str, np.ndarray] = {"time": self.time}
        if self.crank_angle is not None:
            cols["crank_angle"] = self.crank_angle
        for name, quantities in self.outputs.items():
            for qty in quantities:
                cols[f"{name}.{qty}"] = quantities[qty]
                if self.ideal is not None:
                    cols[f"{name}.{qty}.ideal"] = self.ideal[name][qty]
                    cols[f"{name}.{qty}.error"] = quantities[qty] - self.ideal[name][qty]
        frame = pd.DataFrame(cols)
        frame.attrs["provenance"] = dict(self.provenance)
        frame.attrs["warnings"] = list(self.warnings)
        return frame

    def orbits_frame(self):
        """Journal orbits: ``time``, ``<joint>.ex``, ``<joint>.ey`` (m), ``<joint>.eps``.

        Returns
        -------
        pandas.DataFrame
            One row per output instant; only ``time`` for a scene without clearance joints.

        Examples
        --------
        >>> from mechrel.simulation import simulate
        >>> from mechrel.scene import load_scene
        >>> simulate(load_scene("slider-crank")).orbits_frame().columns.tolist()
        ['time']
        """
        import pandas as pd

        cols = {"time": self.time}
        for joint, d in self.orbits.items():
            for key, values in d.items():
                cols[f"{joint}.{key}"] = values
        return pd.DataFrame(cols)


def _provenance(scene: Scene, wall: float, reference: Scene | None = None) -> dict:
    from .. import __version__
    from ..scene import scene_hash

    import numba
    import scipy

    out = {"scene": scene.name, "scene_hash": scene_hash(scene), "mechrel": __version__,
           "numpy": np.__version__, "scipy": scipy.__version__, "numba": numba.__version__,
           "python": platform.python_version(), "wall_time": wall}
    if reference is not None:
        out["reference"] = reference.name
        out["reference_hash"] = scene_hash(reference)
    return out
