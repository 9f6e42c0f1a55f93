"""Every public function and class carries a numpydoc docstring with the sections it owes.

"Public" is what the API reference renders, made precise: every module of the public
packages (:data:`PACKAGES` and their sub-modules, except those with a leading underscore in
any part of their name and those under :data:`EXCLUDED_PACKAGES`); in each, the names of its
``__all__``, or, without one, every function and class defined in it whose name has no
leading underscore; and the public methods and properties a public class defines itself.
A compiled function (``numba.njit``) is checked through its Python function (``py_func``).

Each item is validated by :func:`numpydoc.validate.validate` with the checks of
:data:`CHECKS`: GL08 (a docstring exists), SS01/SS03 (a summary, ending with a period),
PR01/PR02 (every parameter documented, none extra), RT01 (a Returns section when the function
returns) and EX01 (an Examples section; tests/test_docs.py runs the examples as doctests);
and a function that raises a :class:`~mechrel.errors.MechrelError` subclass in its own body
must have a Raises section (a check of this file: numpydoc has none).

Examples are owed by the API users call (:data:`EXAMPLE_PACKAGES`: the top-level names, the
scene, the simulation, the uncertainty layer, the force laws and the output kinds); the
integrators' kernels, the mechanics, the I/O, the study runner and the command line owe the
other sections (a summary and their parameters is what an internal needs). Text several
docstrings share is written once (``mechrel.uq._docs``: ``%(name)s`` placeholders filled at
import), so what is checked here is the filled text.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
import re
import textwrap
from pathlib import Path

import numba.core.dispatcher
import numpydoc.validate
import pytest
from numpydoc.docscrape import FunctionDoc

import mechrel.errors

PACKAGES = ("mechrel", "mechrel.scene", "mechrel.forces", "mechrel.integrate", "mechrel.io",
            "mechrel.mechanics", "mechrel.simulation", "mechrel.outputs", "mechrel.uq",
            "mechrel.study", "mechrel.cli")

# Packages left out of this test (none: the uncertainty layer is checked like the rest).
EXCLUDED_PACKAGES: tuple[str, ...] = ()

# Modules left out of this test (none).
EXCLUDED_MODULES: tuple[str, ...] = ()

CHECKS = frozenset({"GL08", "SS01", "SS03", "PR01", "PR02", "RT01", "EX01"})

# The packages whose items owe an Examples section (EX01); "mechrel" alone: the names the
# top-level package lists.
EXAMPLE_PACKAGES = ("mechrel.scene", "mechrel.simulation", "mechrel.uq", "mechrel.forces",
                    "mechrel.outputs")


def owes_examples(name: str) -> bool:
    """Whether the item ``name`` (a key of :data:`ITEMS`) must carry Examples."""
    module = name.rsplit(".", 1)[0]
    while module and module not in MODULES:  # a method: its class's module
        module = module.rsplit(".", 1)[0] if "." in module else ""
    return module == "mechrel" or module.startswith(EXAMPLE_PACKAGES)


def _excluded(module_name: str) -> bool:
    return (any(module_name == p or module_name.startswith(p + ".") for p in EXCLUDED_PACKAGES)
            or module_name in EXCLUDED_MODULES)


def public_modules() -> list[str]:
    """The public modules of :data:`PACKAGES`, without the excluded ones."""
    names = set()
    for package in PACKAGES:
        module = importlib.import_module(package)
        names.add(package)
        if hasattr(module, "__path__"):
            names.update(m.name for m in pkgutil.walk_packages(module.__path__, package + "."))
    return sorted(n for n in names if not any(part.startswith("_") for part in n.split("."))
                  and not _excluded(n))


def _unwrap(obj):
    return obj.py_func if isinstance(obj, numba.core.dispatcher.Dispatcher) else obj


def _documentable(obj) -> bool:
    return inspect.isclass(obj) or inspect.isfunction(obj)


def public_items() -> dict[str, object]:
    """``{dotted name: object}`` of every public function, class and method (see above)."""
    items: dict[str, object] = {}
    seen: set[int] = set()

    def add(name, obj):
        if id(obj) not in seen:
            seen.add(id(obj))
            items[name] = obj

    for module_name in public_modules():
        module = importlib.import_module(module_name)
        if hasattr(module, "__all__"):
            names = list(module.__all__)
        else:
            names = [n for n, o in vars(module).items() if not n.startswith("_")
                     and _documentable(_unwrap(o))
                     and getattr(_unwrap(o), "__module__", None) == module_name]
        for name in names:
            obj = _unwrap(getattr(module, name))
            # re-exported names are checked where they are defined (a package's __init__ lists
            # what its modules define), unless that module is excluded from this test
            if not _documentable(obj) or _excluded(obj.__module__):
                continue
            add(f"{module_name}.{name}", obj)
            if inspect.isclass(obj):
                for attr, value in vars(obj).items():
                    if attr.startswith("_"):
                        continue
                    if isinstance(value, (staticmethod, classmethod)):
                        value = value.__func__
                    if isinstance(value, property):
                        value = value.fget
                    if inspect.isfunction(value):
                        add(f"{module_name}.{name}.{attr}", value)
    return items


MECHREL_ERRORS = frozenset(name for name, cls in vars(mechrel.errors).items()
                           if inspect.isclass(cls) and issubclass(cls, mechrel.errors.MechrelError))


def raised_errors(func) -> set[str]:
    """The :class:`~mechrel.errors.MechrelError` subclasses ``func``'s own source raises."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(func)))
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Raise) and node.exc is not None:
            target = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            name = target.id if isinstance(target, ast.Name) else getattr(target, "attr", None)
            if name in MECHREL_ERRORS:
                out.add(name)
    return out


def problems(obj, examples: bool = True) -> list[str]:
    """The failed :data:`CHECKS` of ``obj``'s docstring (EX01 only with ``examples``), as
    ``"CODE: message"``; and for a function that raises a ``MechrelError`` subclass itself, a
    missing Raises section (``"RS: ..."``; numpydoc has no check for it)."""
    checks = CHECKS if examples else CHECKS - {"EX01"}
    result = numpydoc.validate.validate(numpydoc.validate.get_doc_object(obj))
    out = [f"{code}: {message}" for code, message in result["errors"] if code in checks]
    if inspect.isfunction(obj) and raised_errors(obj) and not FunctionDoc(obj)["Raises"]:
        out.append(f"RS: raises {', '.join(sorted(raised_errors(obj)))} but has no Raises "
                   "section")
    return out


ITEMS = public_items()
MODULES = frozenset(public_modules())


def test_the_enumeration_covers_the_api():
    # the items the API reference and the issue name, and none of the excluded modules
    for name in ("mechrel.scene.load_scene", "mechrel.scene.Contact", "mechrel.scene.Joint",
                 "mechrel.simulation.scene_kind", "mechrel.simulation.SimulationResult.to_frame",
                 "mechrel.integrate.events.all_finite", "mechrel.forces.ln_normal_force",
                 "mechrel.io.write_table", "mechrel.io.drawing.draw_scene",
                 "mechrel.cli.main", "mechrel.uq.UncertainInputs.sample",
                 "mechrel.uq.Evaluations.to_frame", "mechrel.uq.LimitState.exceedance",
                 "mechrel.uq.estimators.Method.validate", "mechrel.uq.plots.plot_sobol",
                 "mechrel.study.study.load_study", "mechrel.study.runner.run_reliability",
                 "mechrel.study.presenters.Presenter.verdict",
                 "mechrel.cli.studies.split_overrides"):
        assert name in ITEMS, name
    assert not [n for n in ITEMS if n.startswith(EXCLUDED_MODULES)]
    assert len(ITEMS) > 350


def test_the_api_reference_renders_every_public_item():
    # "public" is what docs/api.md renders: each function and class is there by name
    # (autofunction/autoclass) or through an automodule directive of the module it is listed
    # in or defined in (its methods come with it)
    api = (Path(__file__).resolve().parents[1] / "docs" / "api.md").read_text(encoding="utf-8")
    targets = set(re.findall(r"^\.\. auto\w+:: (\S+)", api, flags=re.MULTILINE))
    modules = set(public_modules())
    missing = [name for name, obj in ITEMS.items()
               if name.rsplit(".", 1)[0] in modules  # not a method
               and not {name, name.rsplit(".", 1)[0], obj.__module__,
                        f"{obj.__module__}.{obj.__name__}"} & targets]
    assert missing == []


@pytest.mark.parametrize("name", sorted(ITEMS))
def test_numpydoc_docstring(name):
    assert problems(ITEMS[name], examples=owes_examples(name)) == []


def test_examples_are_owed_by_the_public_api_only():
    owed = {n for n in ITEMS if owes_examples(n)}
    for name in ("mechrel.scene.load_scene", "mechrel.uq.UncertainInputs.sample",
                 "mechrel.simulation.SimulationResult.to_frame", "mechrel.forces.ln_normal_force"):
        assert name in owed, name
    for name in ("mechrel.cli.main", "mechrel.integrate.events.all_finite",
                 "mechrel.study.runner.run_reliability", "mechrel.io.write_table"):
        assert name in ITEMS and name not in owed, name
    # a prose-only docstring of an internal still owes its parameters and its Returns
    assert sorted(p[:4] for p in problems(_prose_only, examples=False)) == ["PR01", "RT01"]


def test_shared_docstring_text_is_filled_in():
    # the estimators' executor arguments are written once (mechrel.uq._docs) and documented
    # in each, in place of the placeholder; a wrong placeholder fails with the names allowed
    from mechrel.uq import fosm, monte_carlo, polynomial_chaos, sobol_indices
    from mechrel.uq._docs import BLOCKS, fill_doc

    for f in (fosm, monte_carlo, sobol_indices, polynomial_chaos):
        assert "%(" not in f.__doc__
        assert "    chunk_size : int, optional\n" in f.__doc__
    assert BLOCKS["executor"].splitlines()[0] == "n_jobs : int, default 1"

    def wrong():
        """Do it.

        %(executors)s
        """

    with pytest.raises(KeyError, match=r"%\(executors\)s: no such block; allowed: \['executor'\]"):
        fill_doc(wrong)


def _bare(x, y):
    return x + y


def _prose_only(x, y):
    """Add two numbers, say x and y, and return the sum."""
    return x + y


def _documented(x, y):
    """Add two numbers.

    Parameters
    ----------
    x, y : float
        The numbers (m).

    Returns
    -------
    float
        Their sum (m).

    Examples
    --------
    >>> _documented(1.0, 2.0)
    3.0
    """
    return x + y


def test_the_check_fails_on_bad_docstrings():
    # the check is not vacuous: a missing docstring, a prose-only one and an extra parameter
    # are each reported, a complete one passes
    assert [p[:4] for p in problems(_bare)] == ["GL08"]
    assert sorted(p[:4] for p in problems(_prose_only)) == ["EX01", "PR01", "RT01"]
    assert problems(_documented) == []

    def extra(x):
        """Return x.

        Parameters
        ----------
        x : float
            A number.
        y : float
            Not a parameter.

        Returns
        -------
        float
            x.

        Examples
        --------
        >>> extra(1.0)
        1.0
        """
        return x

    assert [p[:4] for p in problems(extra)] == ["PR02"]

    def raising(x):
        """Check x.

        Parameters
        ----------
        x : float
            A length (m).

        Examples
        --------
        >>> raising(1.0)
        """
        if not x > 0:
            raise mechrel.errors.SceneError(f"x = {x}: must be > 0; allowed: > 0 (m)")

    assert [p[:3] for p in problems(raising)] == ["RS:"]
