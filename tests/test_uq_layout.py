"""The layout of :mod:`mechrel.uq`: one list of public names, lazy imports, four folders.

* ``mechrel.uq.__all__`` is the one list of the public API: every name once, each resolving to
  an object of the submodule the list names.
* Importing the package, or the model protocol a worker needs to unpickle a model, loads
  neither scipy.stats, chaospy nor SALib (checked in a fresh interpreter).
* The old flat modules are gone (no compatibility shims before 1.0).
"""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

import mechrel.uq as uq


def test_every_public_name_is_listed_once_and_resolves_to_its_module():
    assert len(uq.__all__) == len(set(uq.__all__))
    for name in uq.__all__:
        module = importlib.import_module(f"mechrel.uq.{uq._WHERE[name]}")
        assert getattr(uq, name) is getattr(module, name), name
    assert set(dir(uq)) >= set(uq.__all__)
    with pytest.raises(AttributeError, match="module 'mechrel.uq' has no attribute 'FORMS'"):
        uq.FORMS  # noqa: B018 - renamed EVENTS


def test_the_package_and_the_model_protocol_import_lazily():
    code = ("import sys, mechrel.uq, mechrel.uq.problem.model; "
            "print(sorted(m for m in ('scipy.stats', 'chaospy', 'SALib') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


@pytest.mark.parametrize("old", ["inputs", "model", "mechanism", "analytic", "reliability",
                                 "protocols", "first_order", "montecarlo", "sobol", "normality",
                                 "pce", "executor", "cache", "_workers",
                                 "estimators.limit_state"])
def test_the_flat_modules_are_gone(old):
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module(f"mechrel.uq.{old}")


def test_every_registered_method_is_exported_with_its_result():
    # the exports of a method come from its registration (one module + one registration)
    from mechrel.uq.estimators import METHODS

    for m in METHODS.values():
        names = m.public_names
        assert names and set(names) <= set(uq.__all__), m.name
        assert getattr(uq, m.function.__name__) is m.function
        assert getattr(uq, m.result_type.__name__) is m.result_type
        for name, module in names.items():
            assert uq._WHERE[name] == module
