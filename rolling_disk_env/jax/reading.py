"""The package's kernels read as JAX functions: one source, the numba engine's and JAX's.

The model's kernels (``_generated/kernels.py``, from the SymPy derivation), the engine's per-disk checks
(:mod:`rolling_disk_env.engine`) and the tasks' formulas (``rolling_disk_env/tasks/*.py``) are plain Python on floats
and tuples of floats, which numba compiles. :func:`traced` reads the same source as a function that JAX can trace
(``jit``, ``vmap``, ``grad``), rewriting only what a tracer cannot do:

* a conditional expression ``a if c else b`` becomes ``where(c, a, b)`` (both sides are evaluated: the kernels are
  written branch-free for the vectorizer already, so they have no side effects to skip);
* ``and``, ``or`` and ``not`` become their element-wise forms (``&``, ``|``, ``~`` on booleans);
* a guard ``if c: return a`` followed by the rest of the body becomes ``where(c, a, <the rest's value>)``;
* ``min``, ``max``, ``math.sqrt``, ``math.isfinite``, ... become ``jax.numpy``'s functions, and
  :func:`rolling_disk_env.trig.floor` (an IEEE trick for doubles) ``jnp.floor``, exact in float32 as in float64.

A kernel the JAX reading calls (a numba dispatcher, or a function of a module it reads through an attribute, as
``kernels.diagnostics``) is read in turn, on first use. Kernels with loops (the batch loops, dopri5's adaptive
control, the Coulomb hybrid's event location) have no JAX reading: :func:`traced` raises ``NotImplementedError``
naming them. Float constants stay Python floats (weakly typed in JAX), so a kernel computes in the precision of its
arguments: float64 where ``jax_enable_x64`` is on, float32 otherwise.
"""

from __future__ import annotations

import ast
import builtins
import functools
import inspect
import math
import textwrap
import types

import jax.numpy as jnp

from rolling_disk_env import trig

_MATH = {
    "sqrt": jnp.sqrt,
    "sin": jnp.sin,
    "cos": jnp.cos,
    "tan": jnp.tan,
    "atan": jnp.arctan,
    "atan2": jnp.arctan2,
    "exp": jnp.exp,
    "log": jnp.log,
    "isfinite": jnp.isfinite,
    "isnan": jnp.isnan,
    "floor": jnp.floor,
}
"""``math``'s functions as the JAX reading calls them (its constants, ``pi``, ``inf``, ``nan``, stay floats)."""
_HELPERS = {"_and": jnp.logical_and, "_or": jnp.logical_or, "_not": jnp.logical_not}
_BUILTINS = {"min": jnp.minimum, "max": jnp.maximum, "abs": jnp.abs}
_REPLACED = {id(getattr(math, name)): function for name, function in _MATH.items()}
"""Functions imported by name (``from math import sqrt``) and what the JAX reading calls instead."""


class _Rewrite(ast.NodeTransformer):
    """The expression rewrites of the module docstring, and a clear error for a loop."""

    def __init__(self, name: str):
        self.name = name

    def visit_IfExp(self, node: ast.IfExp) -> ast.Call:
        self.generic_visit(node)
        return _call("_where", node.test, node.body, node.orelse)

    def visit_BoolOp(self, node: ast.BoolOp) -> ast.Call:
        self.generic_visit(node)
        helper = "_and" if isinstance(node.op, ast.And) else "_or"
        return functools.reduce(lambda left, right: _call(helper, left, right), node.values)

    def visit_UnaryOp(self, node: ast.UnaryOp) -> ast.AST:
        self.generic_visit(node)
        return _call("_not", node.operand) if isinstance(node.op, ast.Not) else node

    def _loop(self, node: ast.AST) -> None:
        raise NotImplementedError(f"kernel {self.name!r} has a loop (line {node.lineno}): it has no JAX reading")

    visit_For = visit_While = _loop


def _call(name: str, *arguments: ast.expr) -> ast.Call:
    return ast.Call(func=ast.Name(id=name, ctx=ast.Load()), args=list(arguments), keywords=[])


def _guards(body: list[ast.stmt], name: str) -> list[ast.stmt]:
    """``body`` with each guard ``if c: return a`` folded into the final return, ``where(c, a, rest)``; the guard's
    condition and value are kept in names of their own where the guard stood, so that the rest cannot change them."""
    for index, statement in enumerate(body):
        if not isinstance(statement, ast.If):
            continue
        returns = len(statement.body) == 1 and isinstance(statement.body[0], ast.Return) and not statement.orelse
        if not returns:
            raise NotImplementedError(f"kernel {name!r}: an if statement other than a guard 'if c: return a'")
        rest = _guards(body[index + 1 :], name)
        if not rest or not isinstance(rest[-1], ast.Return):
            raise NotImplementedError(f"kernel {name!r}: a guard must be followed by a final return")
        condition, value = f"_guard{index}", f"_value{index}"
        kept = [
            ast.Assign(targets=[ast.Name(id=condition, ctx=ast.Store())], value=statement.test),
            ast.Assign(targets=[ast.Name(id=value, ctx=ast.Store())], value=statement.body[0].value),
        ]
        folded = ast.Return(
            value=_call(
                "_where", ast.Name(id=condition, ctx=ast.Load()), ast.Name(id=value, ctx=ast.Load()), rest[-1].value
            )
        )
        return [*body[:index], *kept, *rest[:-1], folded]
    return body


def _where_tree(condition, a, b):
    """``where`` over two values of the same structure (numbers, or tuples of them)."""
    if isinstance(a, tuple):
        return tuple(_where_tree(condition, x, y) for x, y in zip(a, b, strict=True))
    return jnp.where(condition, a, b)


class _Module:
    """A module as a JAX reading sees it: its kernels read on first use, ``math`` JAX's."""

    def __init__(self, module: types.ModuleType):
        self._module = module

    def __getattr__(self, name: str):
        value = _value(getattr(self._module, name))
        setattr(self, name, value)
        return value


def _value(value):
    """What a name a kernel reads stands for in its JAX reading."""
    if value is math:
        return types.SimpleNamespace(**{**vars(math), **_MATH})
    if id(value) in _REPLACED:
        return _REPLACED[id(value)]
    if value is trig.floor:
        return jnp.floor
    if isinstance(value, types.ModuleType):
        return _Module(value)
    if hasattr(value, "py_func") or (inspect.isfunction(value) and value.__module__.startswith("rolling_disk_env.")):
        return traced(value)
    return value


@functools.cache
def traced(kernel):
    """The JAX reading of ``kernel`` (a numba dispatcher of the package, or its plain function): a function of the
    same arguments that JAX traces (see the module docstring for what it rewrites)."""
    function = getattr(kernel, "py_func", kernel)
    name = f"{function.__module__}.{function.__qualname__}"
    tree = ast.parse(textwrap.dedent(inspect.getsource(function)))
    definition = tree.body[0]
    definition.decorator_list = []
    definition.body = _guards(definition.body, name)
    tree = ast.fix_missing_locations(_Rewrite(name).visit(tree))
    used = {node.id for node in ast.walk(tree) if isinstance(node, ast.Name)}
    namespace = {"__builtins__": builtins, **_HELPERS, "_where": _where_tree}
    namespace |= {key: value for key, value in _BUILTINS.items() if key in used}
    for key in used & function.__globals__.keys():
        namespace[key] = _value(function.__globals__[key])
    exec(compile(tree, f"<JAX reading of {inspect.getsourcefile(function)}>", "exec"), namespace)
    reading = namespace[definition.name]
    reading.__doc__ = function.__doc__
    reading.__qualname__ = f"traced({name})"
    return reading
