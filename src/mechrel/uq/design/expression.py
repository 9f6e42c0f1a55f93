"""The cost of a design: a small, safe expression language in the design variables.

A cost is written as text, in a study file (``[design] cost = "2/crank + 1/rod"``) or in
Python, and is parsed here into a tree that is evaluated by this module alone: no Python code
from a file is ever run (:func:`eval` is not used). The language:

=====================  ===============================================================
numbers                ``2``, ``0.5``, ``1e-3``
names                  the design variables (``crank``, ``clearance``), nothing else
operators              ``+ - * /``, powers ``**`` (or ``^``), unary ``-`` and ``+``,
                       parentheses
functions              ``sqrt(x)``, ``log(x)`` (natural), ``exp(x)``, ``abs(x)``,
                       ``min(x, y, ...)``, ``max(x, y, ...)``
=====================  ===============================================================

Anything else (attributes, subscripts, comparisons, strings, keyword arguments, other
functions, an unknown name) is refused when the expression is read, with a message that names
the part refused and lists what is allowed. A cost that is not finite at a design (``1/t`` at
t = 0, ``log`` of a negative number) is not a number there: the optimiser treats such designs
as infinitely costly, and a cost that is not finite at the start design is an error.

The usual forms (the tolerance-allocation literature, e.g. Chase & Greenwood 1988,
"Design issues in mechanical tolerance analysis", Manuf. Rev. 1(1)):

* reciprocal, Σ c_i / t_i: machining cost grows as a tolerance t_i is tightened;
* reciprocal power, Σ c_i / t_i^k;
* exponential, Σ c_i exp(−m_i t_i);
* to *maximise* a quantity (the largest clearance), give it as the cost with
  ``sense = "maximize"``.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mechrel.errors import StudyError

__all__ = ["CostExpression", "FUNCTIONS"]

#: The functions a cost may call, with their number of arguments (None: one or more).
FUNCTIONS: Mapping[str, int | None] = {"sqrt": 1, "log": 1, "exp": 1, "abs": 1, "min": None,
                                       "max": None}

_BINARY = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}
_UNARY = {ast.USub: "neg", ast.UAdd: "pos"}
_ALLOWED = ("numbers, the design variables {names}, + - * / ** (or ^), unary -, parentheses "
            "and the functions " + ", ".join(f"{f}()" for f in FUNCTIONS))


MAX_DEPTH = 200
"""Deepest syntax tree a cost may have (levels): its tree is compiled and evaluated
recursively, within Python's recursion limit (1000)."""


def _depth(node: ast.AST) -> int:
    """Levels of the syntax tree under ``node`` (walked without recursion)."""
    deepest, stack = 0, [(node, 1)]
    while stack:
        n, d = stack.pop()
        deepest = max(deepest, d)
        stack.extend((child, d + 1) for child in ast.iter_child_nodes(n))
    return deepest


def _fail(where: str, text: str, problem: str, names: Sequence[str]) -> StudyError:
    return StudyError(f"{where} = {text!r}: {problem}; allowed: "
                      + _ALLOWED.format(names="(" + ", ".join(names) + ")"))


def _compile(node: ast.AST, names: Sequence[str], where: str, text: str) -> tuple:
    """The tree of ``node`` as nested tuples, refusing anything outside the language."""
    if isinstance(node, ast.Expression):
        return _compile(node.body, names, where, text)
    if isinstance(node, ast.Constant):
        v = node.value
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise _fail(where, text, f"the constant {v!r} is not a number", names)
        return ("num", float(v))
    if isinstance(node, ast.Name):
        if node.id not in names:
            raise _fail(where, text, f"unknown name {node.id!r}", names)
        return ("var", node.id)
    if isinstance(node, ast.BinOp):
        op = _BINARY.get(type(node.op))
        if op is None:
            raise _fail(where, text, f"the operator {type(node.op).__name__} is not part of "
                        "the language", names)
        return ("bin", op, _compile(node.left, names, where, text),
                _compile(node.right, names, where, text))
    if isinstance(node, ast.UnaryOp):
        op = _UNARY.get(type(node.op))
        if op is None:
            raise _fail(where, text, f"the operator {type(node.op).__name__} is not part of "
                        "the language", names)
        return ("un", op, _compile(node.operand, names, where, text))
    if isinstance(node, ast.Call):
        fn = node.func.id if isinstance(node.func, ast.Name) else None
        if fn is None or fn not in FUNCTIONS:
            shown = fn if fn is not None else ast.unparse(node.func)
            raise _fail(where, text, f"the function {shown!r} is not one of the language's",
                        names)
        if node.keywords:
            raise _fail(where, text, f"{fn}() takes no keyword arguments", names)
        arity = FUNCTIONS[fn]
        if (arity is not None and len(node.args) != arity) or not node.args:
            raise _fail(where, text, f"{fn}() takes {arity or 'one or more'} argument"
                        f"{'s' if arity != 1 else ''}, got {len(node.args)}", names)
        return ("call", fn, tuple(_compile(a, names, where, text) for a in node.args))
    raise _fail(where, text, f"{type(node).__name__} ({ast.unparse(node)!r}) is not part of "
                "the language", names)


def _eval(tree: tuple, env: Mapping[str, Any]):
    kind = tree[0]
    if kind == "num":
        return tree[1]
    if kind == "var":
        return env[tree[1]]
    if kind == "un":
        v = _eval(tree[2], env)
        return -v if tree[1] == "neg" else +v
    if kind == "bin":
        a, b = _eval(tree[2], env), _eval(tree[3], env)
        op = tree[1]
        if op == "+":
            return a + b
        if op == "-":
            return a - b
        if op == "*":
            return a * b
        if op == "/":
            return np.divide(a, b)
        return np.power(a, b)
    fn, args = tree[1], [_eval(a, env) for a in tree[2]]
    if fn == "min":
        return np.minimum.reduce(np.broadcast_arrays(*args)) if len(args) > 1 else args[0]
    if fn == "max":
        return np.maximum.reduce(np.broadcast_arrays(*args)) if len(args) > 1 else args[0]
    return {"sqrt": np.sqrt, "log": np.log, "exp": np.exp, "abs": np.abs}[fn](args[0])


def _names_of(tree: tuple) -> set[str]:
    if tree[0] == "var":
        return {tree[1]}
    if tree[0] == "num":
        return set()
    parts = tree[2:] if tree[0] == "bin" else (tree[2],) if tree[0] == "un" else tree[2]
    out: set[str] = set()
    for p in parts:
        out |= _names_of(p)
    return out


@dataclass(frozen=True)
class CostExpression:
    """A cost expression of the design variables, checked when it is made (module docstring).

    Parameters
    ----------
    text : str
        The expression, e.g. ``"2/crank + 1/rod + 0.5/offset"``.
    names : sequence of str
        The design variables it may use.
    where : str, default "cost"
        How the expression is named in error messages (``design.cost`` in a study file).

    Raises
    ------
    StudyError
        A syntax error, or a part outside the language (naming it, with what is allowed).

    Examples
    --------
    >>> c = CostExpression("2/crank + 1/rod**2", ["crank", "rod"])
    >>> float(c({"crank": 0.5, "rod": 2.0})), sorted(c.variables)
    (4.25, ['crank', 'rod'])
    >>> CostExpression("rod^2 - 1", ["rod"])({"rod": 3.0})     # ^ is a power, as in **
    8.0
    >>> CostExpression("__import__('os')", ["t"])
    Traceback (most recent call last):
    ...
    mechrel.errors.StudyError: cost = "__import__('os')": the function '__import__' is not one of the language's; allowed: numbers, the design variables (t), + - * / ** (or ^), unary -, parentheses and the functions sqrt(), log(), exp(), abs(), min(), max()
    """

    text: str
    names: tuple[str, ...]
    where: str = "cost"
    tree: tuple = field(init=False, repr=False, compare=False)

    def __init__(self, text: str, names: Sequence[str], where: str = "cost"):
        names = tuple(str(n) for n in names)
        if not isinstance(text, str) or not text.strip():
            raise StudyError(f"{where} = {text!r}: not an expression; allowed: "
                             + _ALLOWED.format(names="(" + ", ".join(names) + ")"))
        try:
            # ``^`` is read as ``**`` before parsing, so that it binds as a power does
            # (Python's ``^`` would bind below + and −: b^2 − 1 would be b^(2 − 1))
            node = ast.parse(text.strip().replace("^", "**"), mode="eval")
        except SyntaxError as exc:
            raise _fail(where, text, f"not an expression ({exc.msg})", names) from None
        depth = _depth(node)
        if depth > MAX_DEPTH:  # the tree is compiled and evaluated recursively
            shown = text if len(text) <= 60 else text[:57] + "..."
            raise StudyError(
                f"{where} = {shown!r} ({len(text)} characters): nested {depth} levels deep "
                "(each term of a long sum or product is one level more); allowed: at most "
                f"{MAX_DEPTH} levels, e.g. a sum of up to about {MAX_DEPTH - 2} terms")
        object.__setattr__(self, "text", text)
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "where", where)
        object.__setattr__(self, "tree", _compile(node, names, where, text))

    @property
    def variables(self) -> frozenset[str]:
        """The design variables the expression uses.

        Returns
        -------
        frozenset of str

        Examples
        --------
        >>> sorted(CostExpression("max(a, 2) + exp(-b)", ["a", "b", "c"]).variables)
        ['a', 'b']
        """
        return frozenset(_names_of(self.tree))

    def __call__(self, values: Mapping[str, Any] | Sequence[float]):
        """The cost at a design.

        Parameters
        ----------
        values : mapping or sequence
            ``{name: value}`` (numbers or arrays, which broadcast), or the values in the order
            of ``names``.

        Returns
        -------
        float or ndarray
            The cost (NaN or ±inf where the expression is not finite: ``1/0``, ``log(-1)``).

        Examples
        --------
        >>> CostExpression("1/t", ["t"])([0.25])
        4.0
        """
        if not isinstance(values, Mapping):
            values = dict(zip(self.names, values))
        with np.errstate(all="ignore"):
            out = _eval(self.tree, {k: np.asarray(v, dtype=float) for k, v in values.items()})
        out = np.asarray(out, dtype=float)
        return float(out) if out.ndim == 0 else out

    def __reduce__(self):
        return (type(self), (self.text, self.names, self.where))


def check_finite(cost: CostExpression, values: Mapping[str, float], what: str) -> float:
    """The cost at a design that must have one (the start design), else an error.

    Parameters
    ----------
    cost : CostExpression
    values : mapping
        ``{name: value}``.
    what : str
        The design's name in the message.

    Returns
    -------
    float

    Raises
    ------
    StudyError
        The cost is not a finite number there.

    Examples
    --------
    >>> check_finite(CostExpression("1/t", ["t"]), {"t": 0.0}, "the start design")
    Traceback (most recent call last):
    ...
    mechrel.errors.StudyError: cost = '1/t': not finite at the start design (t = 0): inf; allowed: an expression with a finite value at every design within the bounds
    """
    v = cost(values)
    if not math.isfinite(v):
        at = ", ".join(f"{k} = {x:g}" for k, x in values.items())
        raise StudyError(f"{cost.where} = {cost.text!r}: not finite at {what} ({at}): {v!r}; "
                         "allowed: an expression with a finite value at every design within "
                         "the bounds")
    return float(v)
