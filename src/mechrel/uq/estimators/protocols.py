"""The typing contracts of estimators and their results (structural: nothing to inherit).

:class:`~mechrel.uq.problem.model.Model` is what an estimator evaluates; :class:`Result` is what every
estimator returns (:class:`~mechrel.uq.estimators.fosm.FOSMResult`,
:class:`~mechrel.uq.estimators.monte_carlo.MonteCarloResult`, :class:`~mechrel.uq.surrogates.pce.PCEResult`,
:class:`~mechrel.uq.estimators.sobol.SobolResult`, :class:`~mechrel.uq.estimators.normality.NormalityResult`), and
:class:`Estimator` is the call itself. A new method's result satisfies :class:`Result` when it
is a frozen dataclass with these fields and method; ``docs/contributing.md`` has the recipe.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, Protocol, runtime_checkable

import pandas as pd

__all__ = ["Estimator", "Result"]


@runtime_checkable
class Result(Protocol):
    """What every estimator returns (a structural protocol: nothing to inherit).

    Parameters
    ----------
    *args, **kwargs
        Not used: a protocol is not instantiated; a class satisfies it by its attributes.

    Attributes
    ----------
    provenance : mapping
        How the result was made: method, seed, settings, model evaluations, versions, time
        (``mechrel.uq._common.make_provenance``).
    warnings : tuple of str
        The caveats of the estimate (also issued as
        :class:`~mechrel.errors.EstimateWarning`); empty when there are none.
    n_evaluations : int
        Model evaluations behind the estimate (rows sent to the executor, cache hits
        included).

    Examples
    --------
    >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model, fosm
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    >>> r = fosm(model=linear_model([0.0], [[2.0]], ["x"]), inputs=inputs,
    ...          allowable=Allowable(1.0, 0.1), progress=False)
    >>> isinstance(r, Result)
    True
    """

    @property
    def provenance(self) -> Mapping[str, Any]:
        """How the result was made.

        Returns
        -------
        mapping
            Method, seed, settings, model evaluations, versions, time.

        Examples
        --------
        >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model, fosm
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
        >>> fosm(model=linear_model([0.0], [[2.0]], ["x"]), inputs=inputs,
        ...      allowable=Allowable(1.0, 0.1), progress=False).provenance["method"]
        'fosm'
        """
        ...

    @property
    def warnings(self) -> tuple[str, ...]:
        """The caveats of the estimate.

        Returns
        -------
        tuple of str
            Empty when there are none.

        Examples
        --------
        >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model, fosm
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
        >>> fosm(model=linear_model([0.0], [[2.0]], ["x"]), inputs=inputs,
        ...      allowable=Allowable(1.0, 0.1), progress=False).warnings
        ()
        """
        ...

    @property
    def n_evaluations(self) -> int:
        """The model evaluations behind the estimate.

        Returns
        -------
        int
            Rows sent to the executor, cache hits included.

        Examples
        --------
        >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model, fosm
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
        >>> fosm(model=linear_model([0.0], [[2.0]], ["x"]), inputs=inputs,
        ...      allowable=Allowable(1.0, 0.1), progress=False).n_evaluations
        3
        """
        ...

    def to_frame(self) -> pd.DataFrame:
        """The result as a table, one row per output.

        Returns
        -------
        pandas.DataFrame
            The result's table.

        Examples
        --------
        >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model, fosm
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
        >>> len(fosm(model=linear_model([0.0], [[2.0]], ["x"]), inputs=inputs,
        ...          allowable=Allowable(1.0, 0.1), progress=False).to_frame())
        1
        """
        ...


Estimator = Callable[..., Result]
"""An estimator: called with keyword arguments only (``model=`` or ``evaluations=``,
``inputs=``, its settings, ``seed=`` and the executor's ``n_jobs``/``backend``/``cache``/
``progress``), returning a :class:`Result`. The keywords differ between methods, so the type
fixes only the return (``fosm``, ``monte_carlo``, ``polynomial_chaos``, ``sobol_indices`` are
all :data:`Estimator`)."""
