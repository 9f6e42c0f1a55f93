"""Every public function and class of :mod:`mechrel.uq` has a complete numpydoc docstring.

numpydoc's validator (``numpydoc.validate.validate``) on each name of ``mechrel.uq.__all__``
that is a function or a class, for the checks the project requires: GL08 (a docstring exists),
SS01/SS03 (a one-line summary ending in a period), PR01/PR02 (every parameter documented, none
that does not exist), RT01 (a Returns section for a function that returns) and EX01 (an
Examples section). The examples themselves run as doctests in ``tests/test_docs.py``.
"""

from __future__ import annotations

import inspect

import numpydoc.validate as numpydoc_validate  # in the test extra
import pytest

import mechrel.uq as uq

CHECKS = ("GL08", "SS01", "SS03", "PR01", "PR02", "RT01", "EX01")
PUBLIC = [name for name in uq.__all__
          if inspect.isfunction(getattr(uq, name)) or inspect.isclass(getattr(uq, name))]


def test_the_public_names_are_found():
    # the list below must not be vacuous: the estimators, results and models are in it
    for name in ("fosm", "monte_carlo", "polynomial_chaos", "sobol_indices", "form", "sorm",
                 "importance_sampling", "subset_simulation", "FORMResult", "UncertainInputs",
                 "LimitState", "evaluate", "MechanismModel"):
        assert name in PUBLIC


@pytest.mark.parametrize("name", PUBLIC)
def test_public_docstring_passes_numpydoc(name):
    report = numpydoc_validate.validate(f"mechrel.uq.{name}")
    errors = [f"{code}: {msg}" for code, msg in report["errors"] if code in CHECKS]
    assert not errors, f"mechrel.uq.{name}:\n" + "\n".join(errors)


def test_the_validator_reports_a_missing_example():
    # the check can fail: a documented function without an Examples section is reported as
    # EX01, and as nothing else of the checks
    codes = {code for code, _ in numpydoc_validate.validate(f"{__name__}._no_example")["errors"]}
    assert codes & set(CHECKS) == {"EX01"}


def _no_example(x):
    """Return ``x``.

    Parameters
    ----------
    x : float
        Anything.

    Returns
    -------
    float
        ``x``.
    """
    return x
