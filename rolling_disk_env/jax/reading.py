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
  :func:`rolling_disk_env.trig.nearest` (an IEEE trick for doubles) ``jnp.rint``, exact in float32 as in float64;
* an iteration ``for _ in range(n):`` whose body assigns names and leaves by ``if c: break`` (the Newton solve of
  :func:`rolling_disk_env.engine.steady_circle`, which the ``circle`` task's reset calls) becomes its ``n`` copies
  (unrolled when JAX traces it), each holding the names bound before the loop (``where``) once a ``c`` has held:
  the same values as the loop that breaks, from a fixed count of steps, ``n`` of them every time.

A kernel the JAX reading calls (a numba dispatcher, or a function of a module it reads through an attribute, as
``kernels.diagnostics``) is read in turn, on first use. Kernels with other loops (the batch loops, dopri5's
adaptive control, the Coulomb hybrid's event location: loops whose bodies branch, or of data-dependent length) have
no JAX reading: :func:`traced` raises ``NotImplementedError`` naming them. Float constants stay Python floats
(weakly typed in JAX), so a kernel computes in the precision of its arguments: float64 where ``jax_enable_x64`` is
on, float32 otherwise.
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
    """The expression rewrites of the module docstring."""

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


def _assigned(statements: list[ast.stmt]) -> set[str]:
    """The names that ``statements`` (assignments among others) bind at their own level."""
    names = set()
    for statement in statements:
        targets = statement.targets if isinstance(statement, ast.Assign) else [getattr(statement, "target", None)]
        for target in targets:
            elements = target.elts if isinstance(target, ast.Tuple) else [target]
            names |= {element.id for element in elements if isinstance(element, ast.Name)}
    return names


def _loops(definition: ast.FunctionDef, name: str) -> None:
    """Rewrites the loops of ``definition``'s body into their unrolled form (:func:`_unrolled`), in place; raises
    ``NotImplementedError`` for any other loop."""
    bound = {argument.arg for argument in definition.args.args}
    body = definition.body
    top = {id(statement) for statement in body}
    for node in ast.walk(definition):
        if isinstance(node, ast.While) or (isinstance(node, ast.For) and id(node) not in top):
            raise _loop_error(name, node)
    definition.body = []
    for index, statement in enumerate(body):
        unrolled = isinstance(statement, ast.For)
        definition.body += _unrolled(statement, bound, body[index + 1 :], name, index) if unrolled else [statement]
        bound |= _assigned([statement])


def _unrolled(loop: ast.For, bound: set[str], after: list[ast.stmt], name: str, index: int) -> list[ast.stmt]:
    """``for _ in range(n):`` over assignments and ``if c: break`` as ``n`` copies of its body (a Python loop, which
    JAX's trace unrolls): a flag ``_done<index>`` records that a ``c`` has held, from which point every assignment to
    a name of ``bound`` (bound before the loop) keeps the name's value. The loop's own names must not be read
    ``after`` it (they would hold the last copy's values, not those of the copy that broke)."""
    done = f"_done{index}"
    counted = isinstance(loop.iter, ast.Call) and getattr(loop.iter.func, "id", None) == "range"
    if not (counted and len(loop.iter.args) == 1 and not loop.orelse):
        raise _loop_error(name, loop)
    body = []
    for statement in loop.body:
        breaks = isinstance(statement, ast.If) and [type(node) for node in statement.body] == [ast.Break]
        if breaks and not statement.orelse:
            body.append(_assign(done, _call("_or", ast.Name(id=done, ctx=ast.Load()), statement.test)))
        elif isinstance(statement, ast.AugAssign) and isinstance(statement.target, ast.Name):
            left = ast.Name(id=statement.target.id, ctx=ast.Load())
            value = ast.BinOp(left=left, op=statement.op, right=statement.value)
            body.append(_held(statement.target, value, done, bound, name))
        elif isinstance(statement, ast.Assign) and len(statement.targets) == 1:
            body.append(_held(statement.targets[0], statement.value, done, bound, name))
        else:
            raise _loop_error(name, loop)
    read_after = {node.id for statement in after for node in ast.walk(statement) if isinstance(node, ast.Name)}
    if (_assigned(loop.body) - bound) & read_after:
        raise NotImplementedError(f"kernel {name!r}: names first bound in the loop (line {loop.lineno}) are read later")
    return [_assign(done, ast.Constant(value=False)), ast.For(target=loop.target, iter=loop.iter, body=body, orelse=[])]


def _held(target: ast.expr, value: ast.expr, done: str, bound: set[str], name: str) -> ast.Assign:
    """``target = value``, or ``target = where(done, target, value)`` where the target (a name, or a tuple of names)
    is bound before the loop."""
    elements = target.elts if isinstance(target, ast.Tuple) else [target]
    if not all(isinstance(element, ast.Name) for element in elements):
        raise NotImplementedError(f"kernel {name!r}: a loop assigns to other than names (line {target.lineno})")
    names = [element.id for element in elements]
    if not set(names) & bound:
        return ast.Assign(targets=[target], value=value)
    if not set(names) <= bound:
        raise NotImplementedError(f"kernel {name!r}: a loop assigns names bound before it and its own together")
    kept = [ast.Name(id=kept_name, ctx=ast.Load()) for kept_name in names]
    kept = ast.Tuple(elts=kept, ctx=ast.Load()) if isinstance(target, ast.Tuple) else kept[0]
    return ast.Assign(targets=[target], value=_call("_where", ast.Name(id=done, ctx=ast.Load()), kept, value))


def _assign(name: str, value: ast.expr) -> ast.Assign:
    return ast.Assign(targets=[ast.Name(id=name, ctx=ast.Store())], value=value)


def _loop_error(name: str, node: ast.stmt) -> NotImplementedError:
    return NotImplementedError(
        f"kernel {name!r} has a loop (line {node.lineno}) other than 'for _ in range(n):' over assignments and "
        "'if c: break': it has no JAX reading"
    )


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
    if value is trig.nearest:
        return jnp.rint
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
    _loops(definition, name)
    tree = ast.fix_missing_locations(_Rewrite().visit(tree))
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
