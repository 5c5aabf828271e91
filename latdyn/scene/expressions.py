"""Scalar functions of time read from scene files (SCENE.md, "Expressions").

A scene scalar that may vary in time (a force component, a hinge torque, a
prescribed angle or translation) is one of

- a number: ``3.5``;
- a string in ``t``: ``"Piecewise((0.4*t, t < 15), (6, True))"``;
- a table: ``{table: [[t0, v0], [t1, v1], ...]}``, linear in t between the
  points and constant beyond the ends (``numpy.interp``).

:class:`TimeFunction` evaluates the value and its first and second time
derivatives, vectorised over NumPy arrays of times.

Strings are *parsed, never evaluated as Python*:

1. the text is split into Python tokens (``tokenize``) and every token is
   checked: numbers (decimal, no underscores, not imaginary), the operators
   ``+ - * / ** ( ) , < > <= >= == !=`` and the names in :data:`ALLOWED_NAMES`.
   Anything else (attribute access, brackets, strings, ``lambda``, ``__import__``,
   an unknown name, ...) is refused with a :class:`~latdyn.errors.SceneError`;
2. the checked text is read into a Python AST (``ast.parse``, no evaluation);
   comparisons are rewritten into SymPy relationals (``a == b`` -> ``Eq(a, b)``,
   ``0 < t < 1`` -> ``And(Lt(0, t), Lt(t, 1))``), and powers of constants are
   bounded so that a scene cannot ask SymPy for ``9**9**9``;
3. SymPy's ``parse_expr`` builds the expression with an explicit ``local_dict``
   (the whitelisted names mapped to SymPy objects) and a ``global_dict`` that
   holds only the four classes its token transformations emit and an empty
   ``__builtins__``.

Expressions are bounded so that reading a scene never hangs: at most
:data:`MAX_TEXT` characters, :data:`MAX_DEPTH` levels of nesting (a sum of
*n* terms nests *n* deep), and :data:`MAX_NODES` nodes in the expression, its
first and its second time derivative: derivatives of ``t**t**t**...``, of nested
functions or of a product of many factors grow fast, and SymPy's time grows with
them. A longer function of time is a table.

Derivatives are symbolic (``sympy.diff``); Dirac deltas that come from
differentiating ``Heaviside``/``sign``/``abs`` are dropped (their value is zero
away from the jump). ``Heaviside(0) = 1/2`` (SymPy's convention; a second
argument ``Heaviside(x, h0)`` picks another value). The functions are compiled
with ``sympy.lambdify(..., "numpy")``.

A :class:`TimeFunction` pickles by its source text; the compiled functions are
rebuilt lazily after unpickling.

SymPy runs once per expression text, not once per process: what a scene needs at run time
(the kind, the lambdified NumPy and ``math`` functions' Python source and the NumPy/``math``
names they use) is kept in the cache (``$LATDYN_CACHE_DIR/expressions/<key>.json``, the key a
hash of the text, of this module's source and of the SymPy version). A later process reads
it back with neither SymPy nor the checks, which the same text passed before; the SymPy
expressions (:attr:`TimeFunction.expressions`, what :mod:`codegen.laws` prints) are derived
again only when asked for. A function is cached only when its source rebuilt from the cache
gives its numbers at a few points.

Hinge laws (SCENE.md "Hinge additions"): a hinge's ``stiffness``, ``damping`` and
``torque`` may also depend on the hinge angle ``theta`` and its rate ``theta_dot``.
:class:`HingeLaw` reads them through the same checks (the two names are added to the
whitelist for these keys only) and differentiates symbolically: f, ∂f/∂θ and ∂f/∂θ̇,
so that the hinge force feeds exact entries into the Newton matrix
(:meth:`latdyn.assembly.assembler.Assembler.evaluate`). A number or a table stays a
:class:`TimeFunction` inside it.
"""
from __future__ import annotations

import ast
import contextlib
import contextvars
import io
import math
import re
import tokenize
from typing import Any, Callable

import numpy as np

from latdyn.errors import SceneError, show_value

__all__ = ["TimeFunction", "parse_time_function", "parse_symbolic", "ACTIVE_PARAMETERS", "HingeLaw", "parse_hinge_law", "HINGE_VARIABLES", "ALLOWED_NAMES", "ALLOWED_OPERATORS",
           "MAX_TEXT", "MAX_DEPTH", "MAX_NODES", "cached_entry", "keep_entry"]

#: Names a scene expression may use (SCENE.md), then the documented extension.
ALLOWED_NAMES = (
    "t", "pi", "e",
    "sin", "cos", "tan", "exp", "log", "sqrt", "abs", "sign",
    "Min", "Max", "Piecewise", "Heaviside", "True", "False",
    # extension
    "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh",
)
#: Operators and punctuation a scene expression may use.
ALLOWED_OPERATORS = ("+", "-", "*", "/", "**", "(", ")", ",", "<", ">", "<=", ">=", "==", "!=")

_NUMBER = re.compile(r"^(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?$")
_MAX_EXPONENT = 1.0e4
#: Longest expression text, in characters.
MAX_TEXT = 2000
#: Deepest nesting of an expression (operators, calls, arguments).
MAX_DEPTH = 100
#: Most nodes in the expression tree, in its first and in its second time derivative
#: (the first bounds the time SymPy takes for the second).
MAX_NODES = (200, 1_000, 10_000)
_ALLOWED_TEXT = (
    "a number, a table {table: [[t0, v0], ...]} or an expression in t using numbers, "
    "the operators " + " ".join(ALLOWED_OPERATORS) + " and the names " + " ".join(ALLOWED_NAMES)
)
_ALLOWED_SHORT = "a real scalar expression in t"

# --------------------------------------------------------------------------- inputs
#: The scene's inputs (latdyn.scene.inputs.Inputs) while the loader reads the scene: their names
#: are allowed in every expression read meanwhile (:func:`reading_inputs`).
_READING_INPUTS: contextvars.ContextVar = contextvars.ContextVar("latdyn_reading_inputs", default=None)


@contextlib.contextmanager
def reading_inputs(*holders):
    """Within the block, expressions may name the signals of ``holders`` (each a
    :class:`~latdyn.scene.inputs.Signals`: the scene's inputs, its controllers' outputs; None is
    skipped): a law that names one reads its current value."""
    token = _READING_INPUTS.set(tuple(h for h in holders if h is not None and len(h)) or None)
    try:
        yield
    finally:
        _READING_INPUTS.reset(token)


def _inputs_named(source) -> tuple:
    """(the holder of each signal ``source`` names, their names), in the holders' order; ((), ())
    when it names none."""
    holders = _READING_INPUTS.get()
    if holders is None or not isinstance(source, str):
        return (), ()
    words = _names_read(source)
    used = [(h, name) for h in holders for name in h.names if name in words]
    return tuple(h for h, _ in used), tuple(n for _, n in used)


def _names_read(text: str) -> set:
    """The names the parser reads in ``text``: its NAME tokens, by the tokenizer :func:`_check_tokens` and
    the parser use (``1e2`` is a number, not a signal ``e2``); none when the text cannot be read
    (:func:`_check_tokens` refuses it)."""
    try:
        tokens = list(tokenize.generate_tokens(io.StringIO(" ".join(text.split())).readline))
    except (tokenize.TokenError, IndentationError, SyntaxError):
        return set()
    return {tok.string for tok in tokens if tok.type == tokenize.NAME}


def _allowed_with(allowed_text: str, names: tuple) -> str:
    return allowed_text + (", and the scene's inputs " + " ".join(names) if names else "")


def _sympy_namespace(extra: tuple[str, ...] = ()):
    """The ``local_dict`` and ``global_dict`` handed to ``parse_expr``; ``extra`` names
    further real symbols (``theta``, ``theta_dot`` of a hinge law)."""
    import sympy as sp

    t = sp.Symbol("t", real=True)
    local = {
        **{name: sp.Symbol(name, real=True) for name in extra},
        "t": t, "pi": sp.pi, "e": sp.E,
        "sin": sp.sin, "cos": sp.cos, "tan": sp.tan, "exp": sp.exp, "log": sp.log,
        "sqrt": sp.sqrt, "abs": sp.Abs, "sign": sp.sign, "Min": sp.Min, "Max": sp.Max,
        "Piecewise": sp.Piecewise, "Heaviside": sp.Heaviside, "True": True, "False": False,
        "asin": sp.asin, "acos": sp.acos, "atan": sp.atan, "atan2": sp.atan2,
        "sinh": sp.sinh, "cosh": sp.cosh, "tanh": sp.tanh,
        # emitted by the comparison rewrite below, never accepted from user text
        "Lt": sp.Lt, "Le": sp.Le, "Gt": sp.Gt, "Ge": sp.Ge, "Eq": sp.Eq, "Ne": sp.Ne, "And": sp.And,
    }
    # parse_expr's standard transformations emit Integer(..), Float(..),
    # Rational(..) and Symbol(..); nothing else is reachable.
    glob = {"__builtins__": {}, "Integer": sp.Integer, "Float": sp.Float,
            "Rational": sp.Rational, "Symbol": sp.Symbol}
    return t, local, glob


#: The parameters of the scene being read (:class:`latdyn.scene.parameters.Parameters`, set by
#: :func:`latdyn.scene.parameters.parameter_scope`), or None: while set, every expression text
#: read here has the parameters' names replaced by their values first (:func:`_with_parameters`).
ACTIVE_PARAMETERS: contextvars.ContextVar = contextvars.ContextVar("latdyn_parameters", default=None)


def _with_parameters(text, key):
    """``text`` with the active scene parameters substituted (recorded under ``key``); as is
    when no parameters are active or ``text`` is not text."""
    params = ACTIVE_PARAMETERS.get()
    if params is None or not isinstance(text, str):
        return text
    return params.substitute(text, key)


# --------------------------------------------------------------------------- text checks
def _refuse(file, key, what, expected=_ALLOWED_TEXT):
    raise SceneError(file, key, f"{what}; expected {expected}")


def _check_tokens(text: str, file, key, extra: tuple[str, ...] = (), allowed_text: str = _ALLOWED_TEXT) -> None:
    """Refuse every token that is not a plain number, an allowed operator or name (or one of ``extra``)."""
    try:
        tokens = list(tokenize.generate_tokens(io.StringIO(text).readline))
    except (tokenize.TokenError, IndentationError, SyntaxError) as exc:
        _refuse(file, key, f"cannot read expression {text!r} ({exc.args[0] if exc.args else exc})")
    for tok in tokens:
        kind, s = tok.type, tok.string
        if kind in (tokenize.NEWLINE, tokenize.NL, tokenize.ENDMARKER):
            continue
        if kind == tokenize.NUMBER:
            if not _NUMBER.match(s):
                _refuse(file, key, f"number {s!r} in {text!r} is not a plain decimal number", allowed_text)
        elif kind == tokenize.NAME:
            if s not in ALLOWED_NAMES and s not in extra:
                params = ACTIVE_PARAMETERS.get()
                known = f" (nor a parameter: {', '.join(params.values)})" if params else ""
                shown = params.written.get(text, text) if params else text
                _refuse(file, key, f"name {s!r} in {shown!r} is not allowed{known}", allowed_text)
        elif kind == tokenize.OP:
            if s not in ALLOWED_OPERATORS:
                _refuse(file, key, f"{s!r} in {text!r} is not allowed", allowed_text)
        else:
            _refuse(file, key, f"{s!r} in {text!r} is not allowed", allowed_text)


_COMPARE = {ast.Lt: "Lt", ast.LtE: "Le", ast.Gt: "Gt", ast.GtE: "Ge", ast.Eq: "Eq", ast.NotEq: "Ne"}
_FOLD_FUNCS: dict[str, Callable[..., float]] = {
    "sin": math.sin, "cos": math.cos, "tan": math.tan, "exp": math.exp, "log": math.log,
    "sqrt": math.sqrt, "abs": abs, "asin": math.asin, "acos": math.acos, "atan": math.atan,
    "atan2": math.atan2, "sinh": math.sinh, "cosh": math.cosh, "tanh": math.tanh,
    "Min": min, "Max": max,
}


class _NotFoldable(Exception):
    pass


def _fold(node: ast.AST) -> float:
    """Float value of a subtree made of numbers, pi, e, arithmetic and plain functions."""
    if isinstance(node, ast.Constant) and type(node.value) in (int, float):
        return float(node.value)
    if isinstance(node, ast.Name) and node.id in ("pi", "e"):
        return math.pi if node.id == "pi" else math.e
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        v = _fold(node.operand)
        return -v if isinstance(node.op, ast.USub) else v
    if isinstance(node, ast.BinOp):
        a, b = _fold(node.left), _fold(node.right)
        try:
            if isinstance(node.op, ast.Add):
                return a + b
            if isinstance(node.op, ast.Sub):
                return a - b
            if isinstance(node.op, ast.Mult):
                return a * b
            if isinstance(node.op, ast.Div):
                return a / b
            if isinstance(node.op, ast.Pow):
                return math.pow(abs(a), b)
        except (ZeroDivisionError, ValueError) as exc:
            raise _NotFoldable from exc
    if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
            and node.func.id in _FOLD_FUNCS and not node.keywords):
        args = [_fold(a) for a in node.args]
        try:
            return float(_FOLD_FUNCS[node.func.id](*args))
        except (ValueError, TypeError, ZeroDivisionError) as exc:
            raise _NotFoldable from exc
    raise _NotFoldable


#: The variables an expression may depend on: time, and for hinge laws the hinge angle and rate.
_VARIABLES = ("t", "theta", "theta_dot")


def _uses_t(node: ast.AST, extra: tuple[str, ...] = ()) -> bool:
    """True when the subtree depends on a variable (t, or theta/theta_dot in a hinge law, or an input)."""
    return any(isinstance(n, ast.Name) and (n.id in _VARIABLES or n.id in extra) for n in ast.walk(node))


class _Rewrite(ast.NodeTransformer):
    """Comparisons -> SymPy relationals; bound powers of constants."""

    def __init__(self, text, file, key, extra: tuple[str, ...] = ()):
        self.text, self.file, self.key, self.extra = text, file, key, extra

    def visit_Compare(self, node):
        self.generic_visit(node)
        terms, left = [], node.left
        for op, right in zip(node.ops, node.comparators):
            fn = _COMPARE[type(op)]
            terms.append(ast.Call(ast.Name(fn, ast.Load()), [left, right], []))
            left = right
        if len(terms) == 1:
            return terms[0]
        return ast.Call(ast.Name("And", ast.Load()), terms, [])

    def visit_BinOp(self, node):
        self.generic_visit(node)
        if isinstance(node.op, ast.Pow):
            self._check_power(node)
        return node

    def _check_power(self, node):
        exponent_t, base_t = _uses_t(node.right, self.extra), _uses_t(node.left, self.extra)
        too_big = (f"the power {ast.unparse(node)!r} in {self.text!r} is too large or not a plain number; "
                   "expected powers of constants within the floating-point range and exponents up to 1e4")
        try:
            exponent = None if exponent_t else _fold(node.right)
            if exponent is not None and abs(exponent) > _MAX_EXPONENT:
                raise SceneError(self.file, self.key, too_big)
            if not base_t and exponent is not None:
                value = math.pow(abs(_fold(node.left)), exponent)
                if not math.isfinite(value):
                    raise SceneError(self.file, self.key, too_big)
        except OverflowError:
            raise SceneError(self.file, self.key, too_big) from None
        except ValueError:  # math.pow(0, negative)
            raise SceneError(self.file, self.key, f"the power {ast.unparse(node)!r} in {self.text!r} divides by "
                                                  "zero; expected a finite expression in t") from None
        except _NotFoldable:
            if not (exponent_t or base_t):
                raise SceneError(self.file, self.key, too_big) from None
            if not exponent_t:  # exponent is a constant we cannot bound
                raise SceneError(self.file, self.key, too_big) from None


def _depth(tree: ast.AST) -> int:
    """Nesting depth of an AST, counted without recursion."""
    deepest, stack = 0, [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node))
    return deepest


def _check_size(expr, order: int, text, file, key) -> None:
    """Refuse an expression (order 0) or its derivative (1, 2) with more nodes than :data:`MAX_NODES` allows."""
    import sympy as sp

    limit = MAX_NODES[order]
    for count, _ in enumerate(sp.preorder_traversal(expr), start=1):
        if count > limit:
            what = ("the expression", "its time derivative", "its second time derivative")[order]
            _refuse(file, key, f"{text!r} is too complex: {what} has more than {limit} terms",
                    "a simpler expression in t, or a table {table: [[t0, v0], ...]}")


def _parse_text(text: str, file, key, extra: tuple[str, ...] = (), allowed_text: str = _ALLOWED_TEXT):
    """Checked text -> (symbol t, SymPy expression in ``t`` and the ``extra`` symbols, all real)."""
    import sympy as sp
    from sympy.parsing.sympy_parser import parse_expr, standard_transformations

    text = _with_parameters(text, key)
    if len(text) > MAX_TEXT:
        _refuse(file, key, f"expression of {len(text)} characters {show_value(text)}",
                f"at most {MAX_TEXT} characters (a longer function of time is a table)")
    clean = " ".join(text.split())
    if not clean:
        _refuse(file, key, "empty expression")
    _check_tokens(clean, file, key, extra, allowed_text)
    too_deep = f"at most {MAX_DEPTH} levels of nesting (a longer function of time is a table)"
    try:
        tree = ast.parse(clean, mode="eval")
    except SyntaxError as exc:
        _refuse(file, key, f"{text!r} is not a valid expression ({exc.msg})", allowed_text)
    except (RecursionError, MemoryError):
        _refuse(file, key, f"{text!r} is nested too deeply", too_deep)
    if _depth(tree) > MAX_DEPTH:
        _refuse(file, key, f"{text!r} is nested too deeply", too_deep)
    tree = ast.fix_missing_locations(_Rewrite(text, file, key, extra).visit(tree))
    symbol, local, glob = _sympy_namespace(extra)
    try:
        expr = parse_expr(ast.unparse(tree), local_dict=local, global_dict=glob,
                          transformations=standard_transformations, evaluate=True)
    except SceneError:
        raise
    except Exception as exc:  # SymPy's own complaints (wrong arguments, ...)
        _refuse(file, key, f"{text!r} is not a valid expression ({type(exc).__name__}: {exc})", _ALLOWED_SHORT)
    if isinstance(expr, (bool, int, float)):
        expr = sp.sympify(expr)
    if not isinstance(expr, sp.Expr):
        _refuse(file, key, f"{text!r} is a condition, not a number", _ALLOWED_SHORT)
    if expr.has(sp.I):
        _refuse(file, key, f"{text!r} is not real", _ALLOWED_SHORT)
    if expr.has(sp.zoo, sp.nan, sp.oo, -sp.oo):
        _refuse(file, key, f"{text!r} is infinite or undefined somewhere", "a finite expression in t")
    return symbol, expr


def parse_symbolic(text: str, file, key, extra: tuple[str, ...] = ()):
    """Checked text -> (symbol t, SymPy expression) with ``extra`` names as real symbols and no
    parameters substituted (what :meth:`latdyn.scene.parameters.Parameters.derivative` differentiates)."""
    token = ACTIVE_PARAMETERS.set(None)
    try:
        return _parse_text(text, file, key, extra)
    finally:
        ACTIVE_PARAMETERS.reset(token)


def _scalar_functions(symbol, expressions, vectorised):
    """``math``-module lambdas of ``expressions`` for one float time, or None.

    A law of time is evaluated once a step at one time; through ``numpy.select`` a Piecewise
    costs ~80 µs there, as nested conditional expressions ~3 µs. They are used only where
    they give the NumPy functions' numbers (checked at a few times), else None."""
    import sympy as sp

    try:
        scalar = tuple(sp.lambdify(symbol, e, modules="math") for e in expressions)
        for t in (0.0, 0.37, 1.9, 23.0):
            for fast, reference in zip(scalar, vectorised):
                with np.errstate(all="ignore"):
                    expected = float(np.asarray(reference(np.float64(t)), dtype=float))
                got = float(fast(t))
                if not (got == expected or abs(got - expected) <= 1e-13 * abs(expected)):
                    return None
    except Exception:  # noqa: BLE001 - a construct the math printer cannot write: NumPy only
        return None
    return scalar


def _drop_deltas(expr):
    import sympy as sp

    return expr.replace(lambda e: isinstance(e, sp.DiracDelta), lambda e: sp.S.Zero)


# --------------------------------------------------------------------------- cache of parsed expressions
#: Bumped when what the cache holds changes meaning.
_CACHE_FORMAT = 1
_GENERATOR: list[str] = []  # this module's source hash and the SymPy version, once per process
#: Probe points (t; and θ, θ̇, t of a hinge law) at which functions rebuilt from the cache
#: must give the numbers of the functions they were made from.
_PROBES = (0.0, 0.37, 1.9, 23.0)
_HINGE_PROBES = ((0.0, 0.0, 0.0), (0.3, -1.2, 0.7), (-2.1, 0.4, 9.5))


def sympy_version() -> str:
    """SymPy's version, read from ``sympy/release.py`` without importing SymPy ("none" without it)."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.find_spec("sympy")
    if spec is None or not spec.submodule_search_locations:
        return "none"
    try:
        text = (Path(next(iter(spec.submodule_search_locations))) / "release.py").read_text()
    except OSError:
        return "unknown"
    found = re.search(r"__version__\s*=\s*['\"]([^'\"]+)", text)
    return found.group(1) if found else "unknown"


def _generator() -> str:
    if not _GENERATOR:
        from pathlib import Path

        from latdyn.native import source_digest

        _GENERATOR.append(source_digest(Path(__file__).read_bytes(), sympy_version(), _CACHE_FORMAT))
    return _GENERATOR[0]


def _cache_path(kind: str, source: str):
    from latdyn.native import cache_dir, source_digest

    return cache_dir() / "expressions" / f"{kind}-{source_digest(kind, source, _generator())}.json"


def _namespace_entry(name: str, value):
    """How to find ``value`` (bound to ``name`` in a lambdified function's globals) again:
    ``[module, attribute]`` of numpy, math or functools, ``["float", repr]``; None if not found."""
    import functools

    if isinstance(value, float):
        return ["float", repr(value)]
    for module in (np, math, functools):
        if getattr(module, name, None) is value:
            return [module.__name__, name]
    return None


def _global_names(code) -> set[str]:
    """The global names a code object (and those nested in it) loads; attributes are not names."""
    import dis

    names = {i.argval for i in dis.get_instructions(code) if i.opname in ("LOAD_GLOBAL", "LOAD_NAME")}
    for constant in code.co_consts:
        if hasattr(constant, "co_code"):
            names |= _global_names(constant)
    return names


def _serialise(function) -> dict | None:
    """A lambdified function as its Python source and the names it uses; None if one is unknown."""
    import builtins
    import inspect

    try:
        text = inspect.getsource(function)
    except (OSError, TypeError):
        return None
    names = {}
    for name in _global_names(function.__code__):
        if name in function.__globals__:
            entry = _namespace_entry(name, function.__globals__[name])
            if entry is None:
                return None
            names[name] = entry
        elif not hasattr(builtins, name):
            return None
    return {"text": text, "function": function.__name__, "names": names}


def _rebuild(saved: dict):
    """The function :func:`_serialise` described."""
    import functools

    modules = {"numpy": np, "math": math, "functools": functools}
    namespace = {}
    for name, (where, what) in saved["names"].items():
        namespace[name] = float(what) if where == "float" else getattr(modules[where], what)
    exec(compile(saved["text"], f"<latdyn cached expression {saved['function']}>", "exec"), namespace)  # noqa: S102
    return namespace[saved["function"]]


def _same_numbers(a, b, points) -> bool:
    for point in points:
        with np.errstate(all="ignore"):
            try:
                x, y = float(np.asarray(a(*point), dtype=float)), float(np.asarray(b(*point), dtype=float))
            except (ArithmeticError, ValueError, TypeError):
                return False
        if not (x == y or (math.isnan(x) and math.isnan(y))):
            return False
    return True


def keep_entry(kind: str, source: str, entry: dict, functions: dict, points) -> None:
    """The package's one cache of what was derived from a text (laws compiled here, parameter derivatives in
    latdyn/scene/parameters.py, jump searches in latdyn/timeloop/jumps.py), keyed by ``kind`` and ``source``: keep ``entry`` (plain data) and ``functions`` (name -> tuple of lambdified functions or
    None) for ``source``: only if every function rebuilds to the same numbers at ``points``."""
    import json
    import os
    import tempfile

    for name, group in functions.items():
        if group is None:
            entry[name] = None
            continue
        saved = [_serialise(f) for f in group]
        if any(s is None for s in saved) or not all(
                _same_numbers(f, _rebuild(s), points) for f, s in zip(group, saved)):
            return
        entry[name] = saved
    path = _cache_path(kind, source)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("w", dir=path.parent, suffix=".tmp", delete=False) as file:
            json.dump({"source": source, **entry}, file)
        os.replace(file.name, path)
    except OSError:  # a read-only cache: SymPy again next time
        pass


def cached_entry(kind: str, source: str) -> dict | None:
    """The cached entry of ``source`` with its functions rebuilt, or None."""
    import json

    try:
        entry = json.loads(_cache_path(kind, source).read_text())
        if entry.get("source") != source:
            return None
        for name, value in entry.items():
            if isinstance(value, list) and value and isinstance(value[0], dict):
                entry[name] = tuple(_rebuild(saved) for saved in value)
        return entry
    except (OSError, ValueError, KeyError, TypeError, AttributeError, SyntaxError):
        return None


# --------------------------------------------------------------------------- TimeFunction
def _finite_float(number) -> float | None:
    """``float(number)``, or None when it is not finite (an integer too large for a float included)."""
    try:
        value = float(number)
    except OverflowError:
        return None
    return value if math.isfinite(value) else None


class _BySource:
    """A law known by its source: pickled as the source (compiled again lazily), equal and
    hashed by it, shown as ``ClassName(source)``."""

    _inputs: tuple = ()  # the holder (latdyn.scene.inputs.Signals) of each signal the law names
    _input_names: tuple = ()  # the signals' names (inputs, controller outputs), in the scene's order

    def __getstate__(self):
        return {"source": self._source, "file": self._file, "key": self._key,
                "inputs": self._inputs, "input_names": self._input_names}

    def __setstate__(self, state):
        self._source, self._file, self._key = state["source"], state["file"], state["key"]
        self._inputs, self._input_names = state.get("inputs", ()), state.get("input_names", ())
        self._compiled = None

    def _input_values(self) -> list[float]:
        """The current values of the inputs the law uses (the order of :attr:`input_names`)."""
        return [float(h.values[h.index(n)]) for h, n in zip(self._inputs, self._input_names)]

    @property
    def key(self) -> str:
        """The key path the law was read at (``beams.arm.end.hinge.torque``, ``loads[0].force[1]``): the key
        its parameters are recorded under (:attr:`latdyn.scene.parameters.Parameters.uses`)."""
        return self._key

    @property
    def input_names(self) -> tuple:
        """The scene's signals this law names (inputs, controller outputs: latdyn.scene.inputs), in the scene's order."""
        return self._input_names

    def _input_symbols(self) -> list:
        import sympy as sp

        return [sp.Symbol(n, real=True) for n in self._input_names]

    def __eq__(self, other):
        return type(other) is type(self) and self._source == other._source

    def __hash__(self):
        return hash(repr(self._source))

    def __repr__(self):
        return f"{type(self).__name__}({self._source!r})"


class TimeFunction(_BySource):
    """A scalar function of time: a constant, an expression in ``t`` or a table.

    ``value(t)``, ``rate(t)`` and ``accel(t)`` give f, df/dt and d²f/dt²; each takes
    a float (returns a float) or an array of times (returns a float64 array of the
    same shape).
    """

    _scalar = None  # math-module lambdas of value, rate, acceleration for one float t (expressions)

    def __init__(self, source: Any, file: str | None = None, key: str = "expression"):
        self._file, self._key = file, key
        self._source = self._normalise(source, file, key)
        self._inputs, self._input_names = (source._inputs, source._input_names) \
            if isinstance(source, _BySource) and source._input_names else _inputs_named(self._source)
        self._compiled = None
        self._compile()
        try:
            value0 = self.value(0.0)
        except (ArithmeticError, TypeError, ValueError) as exc:
            raise SceneError(file, key, f"expected a function finite at t = 0, got {source!r} "
                                        f"({type(exc).__name__}: {exc})") from None
        if not math.isfinite(value0):
            raise SceneError(file, key, f"expected a function finite at t = 0, got {source!r} "
                                        f"which is {value0} there")

    # -- construction
    @staticmethod
    def _normalise(source, file, key):
        if isinstance(source, TimeFunction):
            return source._source
        if isinstance(source, bool) or source is None:
            raise SceneError(file, key, f"expected {_ALLOWED_TEXT}, got {show_value(source)}")
        if isinstance(source, (int, float, np.integer, np.floating)):
            value = _finite_float(source)
            if value is None:
                raise SceneError(file, key, f"expected a finite number, got {show_value(source)}")
            return value
        if isinstance(source, str):
            return _with_parameters(source, key)
        if isinstance(source, dict):
            if set(source) != {"table"}:
                raise SceneError(file, key, "expected a table as {table: [[t0, v0], [t1, v1], ...]}, "
                                            f"got keys {show_value(list(source))}")
            rows = source["table"]
            if not isinstance(rows, (list, tuple)) or not rows:
                raise SceneError(file, f"{key}.table", "expected {table: [[t0, v0], [t1, v1], ...]} with at least "
                                                       f"one pair of numbers, got {show_value(rows)}")
            table = []
            for i, row in enumerate(rows):
                if (not isinstance(row, (list, tuple)) or len(row) != 2
                        or any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in row)):
                    raise SceneError(file, f"{key}.table[{i}]",
                                     f"expected a pair of numbers [t, value], got {show_value(row)}")
                pair = [_finite_float(x) for x in row]
                if None in pair:
                    raise SceneError(file, f"{key}.table[{i}]", f"expected finite numbers, got {show_value(row)}")
                if table and not pair[0] > table[-1][0]:
                    raise SceneError(file, f"{key}.table[{i}]",
                                     f"expected times strictly increasing, got t = {row[0]!r} after {table[-1][0]!r}")
                table.append(pair)
            return {"table": table}
        raise SceneError(file, key, f"expected {_ALLOWED_TEXT}, got {show_value(source)}")

    def _compile(self):
        src = self._source
        if isinstance(src, float):
            c = src
            self._kind = "constant"
            self._expr_cache = None
            self._fns = (lambda t: c, lambda t: 0.0, lambda t: 0.0)
        elif isinstance(src, dict):
            self._kind = "table"
            self._expr_cache = None
            ts = np.array([r[0] for r in src["table"]])
            vs = np.array([r[1] for r in src["table"]])
            slopes = np.diff(vs) / np.diff(ts) if len(ts) > 1 else np.zeros(0)

            def rate(t, ts=ts, slopes=slopes):
                i = np.searchsorted(ts, t, side="right") - 1  # segment on the right of t
                inside = (i >= 0) & (i < len(slopes))
                return np.where(inside, slopes[np.clip(i, 0, max(len(slopes) - 1, 0))]
                                if len(slopes) else 0.0, 0.0)

            self._fns = (lambda t: np.interp(t, ts, vs), rate, lambda t: 0.0)
        elif self._input_names:  # names the scene's inputs: parsed each time, never from the cache
            self._symbolic()
        else:
            cached = cached_entry("time", src)
            if cached is not None:  # parsed, checked and lambdified by an earlier process
                self._kind, self._fns, self._scalar = cached["kind"], cached["numpy"], cached["scalar"]
                self._expr_cache = self._derivative_cache = None  # SymPy again on demand (_symbolic)
            else:
                self._symbolic()
                keep_entry("time", src, {"kind": self._kind}, {"numpy": self._fns, "scalar": self._scalar},
                       [(t,) for t in _PROBES])
        self._compiled = True

    def _symbolic(self):
        """Parse, check, differentiate and lambdify the expression text (SymPy)."""
        import sympy as sp

        src = self._source
        symbol, expr = _parse_text(src, self._file, self._key, extra=self._input_names,
                                   allowed_text=_allowed_with(_ALLOWED_TEXT, self._input_names))
        _check_size(expr, 0, src, self._file, self._key)
        d1 = _drop_deltas(sp.diff(expr, symbol))
        _check_size(d1, 1, src, self._file, self._key)
        d2 = _drop_deltas(sp.diff(d1, symbol))
        _check_size(d2, 2, src, self._file, self._key)
        self._kind = "constant" if not expr.free_symbols else "expression"
        self._expr_cache = expr
        self._derivative_cache = (symbol, (expr, d1, d2))
        arguments = [symbol, *self._input_symbols()]
        try:
            self._fns = tuple(sp.lambdify(arguments, e, modules="numpy") for e in (expr, d1, d2))
        except Exception as exc:  # a construct the NumPy printer cannot write
            raise SceneError(self._file, self._key, f"{src!r} cannot be evaluated numerically "
                                                    f"({type(exc).__name__}: {exc}); expected {_ALLOWED_SHORT}")
        self._scalar = _scalar_functions(symbol, (expr, d1, d2), self._fns) \
            if self._kind == "expression" and not self._input_names else None

    # -- evaluation
    def _eval(self, which: int, t):
        if self._compiled is None:
            self._compile()
        if self._scalar is not None and isinstance(t, float):  # one time: the time step's case
            try:
                return float(self._scalar[which](t))
            except (ValueError, ZeroDivisionError, OverflowError):  # math raises where NumPy gives inf/nan
                pass
        tt = np.asarray(t, dtype=float)
        with np.errstate(all="ignore"):
            out = self._fns[which](tt, *self._input_values())
        out = np.broadcast_to(np.asarray(out, dtype=float), tt.shape)
        if tt.ndim == 0:
            return float(out)
        return np.array(out, dtype=float)

    def value(self, t):
        """f(t) for a float (-> float) or an array (-> array of the same shape)."""
        return self._eval(0, t)

    def rate(self, t):
        """df/dt; for a table the slope of the segment that starts at or before t (0 beyond the ends)."""
        return self._eval(1, t)

    def accel(self, t):
        """d²f/dt²; zero for a table."""
        return self._eval(2, t)

    __call__ = value

    # -- description
    @property
    def source(self):
        """What the scene gave: the string, the number (float) or ``{"table": [[t, v], ...]}``."""
        return self._source

    @property
    def kind(self) -> str:
        """``"constant"``, ``"expression"`` or ``"table"``."""
        if self._compiled is None:
            self._compile()
        return self._kind

    @property
    def is_constant(self) -> bool:
        """True when the function does not change with time."""
        if self.kind == "table":
            return len({r[1] for r in self._source["table"]}) == 1
        return self.kind == "constant"

    def _sympy_on_demand(self):
        if self._compiled is None:
            self._compile()
        if isinstance(self._source, str) and self._expr_cache is None:  # read from the cache
            fns, scalar = self._fns, self._scalar
            self._symbolic()
            self._fns, self._scalar = fns, scalar

    @property
    def expr(self):
        """The SymPy expression in ``t`` (None for numbers and tables)."""
        self._sympy_on_demand()
        return self._expr_cache

    @property
    def expressions(self):
        """``(t, (f, df/dt, d²f/dt²))`` as SymPy (deltas dropped) for an expression, else None:
        what :mod:`codegen.laws` compiles."""
        self._sympy_on_demand()
        return self._derivative_cache if self._kind == "expression" else None

    @property
    def table(self) -> tuple[list[float], list[float]] | None:
        """``(times, values)`` of a table, else None."""
        if not isinstance(self._source, dict):
            return None
        rows = self._source["table"]
        return [r[0] for r in rows], [r[1] for r in rows]

    @classmethod
    def constant(cls, value: float) -> "TimeFunction":
        return cls(float(value))

    def __str__(self):
        return str(self._source)


def parse_time_function(value: Any, file: str | None, key: str) -> TimeFunction:
    """A scene value -> :class:`TimeFunction`; :class:`SceneError` naming ``file`` and ``key`` if invalid."""
    if isinstance(value, TimeFunction):
        return value
    return TimeFunction(value, file=file, key=key)


# --------------------------------------------------------------------------- HingeLaw
#: The variables of a hinge law, in the order :class:`HingeLaw` takes them.
HINGE_VARIABLES = ("theta", "theta_dot", "t")
_HINGE_TEXT = (
    "a number, a table {table: [[t0, v0], ...]} or an expression in theta (hinge angle), theta_dot "
    "(its rate) and t using numbers, the operators " + " ".join(ALLOWED_OPERATORS)
    + " and the names " + " ".join(ALLOWED_NAMES)
)


class HingeLaw(_BySource):
    """A hinge coefficient f(θ, θ̇, t): a number, a table in t, or an expression in
    ``theta``, ``theta_dot`` and ``t`` (parsed, never evaluated as Python).

    ``value``, ``d_theta`` (∂f/∂θ) and ``d_rate`` (∂f/∂θ̇) take floats and return floats;
    the derivatives are symbolic (Dirac deltas of ``sign``/``abs``/``Heaviside`` dropped,
    as for time functions). ``depends_on`` tells which of the variables appear.
    """

    def __init__(self, source: Any, file: str | None = None, key: str = "expression", finite_at_zero: bool = True):
        """``finite_at_zero``: check the law is finite at θ = θ̇ = t = 0 (a user's law; a derived slope evaluated
        only at an event's state, :func:`derivative_as_law` of kind "angle_slope", is not checked there: its use
        checks its value, latdyn/analyses/weight_derivative.py ``_hinge_rows``)."""
        self._file, self._key = file, key
        self._source = source._source if isinstance(source, (HingeLaw, TimeFunction)) \
            else _with_parameters(source, key)
        self._inputs, self._input_names = (source._inputs, source._input_names) \
            if isinstance(source, _BySource) and source._input_names else _inputs_named(self._source)
        self._compiled = None
        self._compile()
        if not finite_at_zero:
            return
        try:
            value0 = self.value(0.0, 0.0, 0.0)
        except (ArithmeticError, TypeError, ValueError) as exc:
            raise SceneError(file, key, f"expected a law finite at theta = theta_dot = t = 0, got {source!r} "
                                        f"({type(exc).__name__}: {exc})") from None
        if not math.isfinite(value0):
            raise SceneError(file, key, f"expected a law finite at theta = theta_dot = t = 0, got {source!r} "
                                        f"which is {value0} there")

    def _compile(self):
        src = self._source
        if not isinstance(src, str):  # a number or a table: a function of time
            self._time = TimeFunction(src, self._file, self._key)
            self._source = self._time.source
            self._depends = ("t",) if not self._time.is_constant else ()
            self._constant = self._time.value(0.0) if self._time.is_constant else None
            self._fns = None
        else:
            self._time = None
            cached = None if self._input_names else cached_entry("hinge", src)  # a law naming inputs: never cached
            if cached is not None:  # parsed, checked and lambdified by an earlier process
                self._depends, self._constant = tuple(cached["depends"]), cached["constant"]
                self._fns, self._law_cache = cached["numpy"], None  # SymPy again on demand
            else:
                self._symbolic()
                if not self._input_names:
                    keep_entry("hinge", src, {"depends": list(self._depends), "constant": self._constant},
                           {"numpy": self._fns}, _HINGE_PROBES)
        self._compiled = True

    def _symbolic(self):
        """Parse, check, differentiate and lambdify the law's text (SymPy)."""
        import sympy as sp

        src = self._source
        _, expr = _parse_text(src, self._file, self._key, extra=("theta", "theta_dot", *self._input_names),
                              allowed_text=_allowed_with(_HINGE_TEXT, self._input_names))
        _check_size(expr, 0, src, self._file, self._key)
        names = {s.name: s for s in expr.free_symbols}
        symbols = [names.get(n, sp.Symbol(n, real=True)) for n in HINGE_VARIABLES]
        inputs = self._input_symbols()
        derivatives = []
        for variable in symbols[:2]:
            d = _drop_deltas(sp.diff(expr, variable))
            _check_size(d, 1, src, self._file, self._key)
            derivatives.append(d)
        self._law_cache = (tuple(symbols + inputs), (expr, *derivatives))
        self._depends = tuple(n for n in HINGE_VARIABLES if n in names)
        self._constant = float(expr) if not self._depends and not self._input_names else None
        try:
            self._fns = tuple(sp.lambdify(symbols + inputs, e, modules="numpy") for e in (expr, *derivatives))
        except Exception as exc:  # a construct the NumPy printer cannot write
            raise SceneError(self._file, self._key, f"{src!r} cannot be evaluated numerically "
                                                    f"({type(exc).__name__}: {exc}); expected {_HINGE_TEXT}")

    def _eval(self, which: int, theta: float, rate: float, t: float) -> float:
        if self._compiled is None:
            self._compile()
        if self._constant is not None:
            return self._constant if which == 0 else 0.0
        if self._fns is None:  # a table in t
            return float(self._time.value(t)) if which == 0 else 0.0
        with np.errstate(all="ignore"):
            return float(self._fns[which](float(theta), float(rate), float(t), *self._input_values()))

    def value(self, theta: float, rate: float, t: float) -> float:
        """f(θ, θ̇, t)."""
        return self._eval(0, theta, rate, t)

    def values_in_time(self, theta: float, rate: float, t) -> np.ndarray:
        """f(θ, θ̇, t) at fixed θ, θ̇ over an array of times, in one call (latdyn.timeloop.jumps)."""
        t = np.asarray(t, dtype=float)
        if self._compiled is None:
            self._compile()
        if self._constant is not None:
            return np.full(t.shape, self._constant)
        if self._fns is None:  # a table in t
            return np.asarray(self._time.value(t), dtype=float)
        with np.errstate(all="ignore"):
            out = self._fns[0](float(theta), float(rate), t, *self._input_values())
        return np.array(np.broadcast_to(np.asarray(out, dtype=float), t.shape))

    def d_theta(self, theta: float, rate: float, t: float) -> float:
        """∂f/∂θ at (θ, θ̇, t)."""
        return self._eval(1, theta, rate, t)

    def d_rate(self, theta: float, rate: float, t: float) -> float:
        """∂f/∂θ̇ at (θ, θ̇, t)."""
        return self._eval(2, theta, rate, t)

    @property
    def depends_on(self) -> tuple[str, ...]:
        """The variables among ``theta``, ``theta_dot``, ``t`` the law uses."""
        if self._compiled is None:
            self._compile()
        return self._depends

    @property
    def is_constant(self) -> bool:
        return not self.depends_on and not self._input_names

    @property
    def constant(self) -> float | None:
        """The value of a constant law, else None."""
        if self._compiled is None:
            self._compile()
        return self._constant

    @property
    def source(self):
        return self._source

    @property
    def expressions(self):
        """``((θ, θ̇, t), (f, ∂f/∂θ, ∂f/∂θ̇))`` as SymPy for an expression, else None (a number or
        a table in t: :attr:`time_function`); what :mod:`codegen.laws` compiles."""
        if self._compiled is None:
            self._compile()
        if self._fns is not None and self._law_cache is None:  # read from the cache
            fns = self._fns
            self._symbolic()
            self._fns = fns
        return self._law_cache if self._fns is not None else None

    @property
    def time_function(self):
        """The :class:`TimeFunction` of a number or a table, else None."""
        if self._compiled is None:
            self._compile()
        return self._time



def parse_hinge_law(value: Any, file: str | None, key: str, finite_at_zero: bool = True) -> HingeLaw:
    """A scene value -> :class:`HingeLaw`; :class:`SceneError` naming ``file`` and ``key`` if invalid.
    ``finite_at_zero``: :class:`HingeLaw`'s (False for a derived angle slope, :func:`derivative_as_law`)."""
    if isinstance(value, HingeLaw):
        return value
    return HingeLaw(value, file=file, key=key, finite_at_zero=finite_at_zero)


def derivative_as_law(law, scene, key: str, kind: str, by: str, what: str, derivative):
    """A derivative of a hinge or guide law of the state as a law of the state itself (a :class:`HingeLaw` of
    SymPy's derivative's text), which the laws' compiler or its own first derivatives then take:
    ``derivative(law.expressions)`` is the SymPy expression (∂f/∂t with deltas dropped, ∂f/∂θ), ``by`` names it in the
    expression cache's key (kind ``kind``: "time_rate", "angle_slope"), ``what`` in a message. The text is kept in the
    expression cache, so a later process needs no SymPy for it. None where the law has no SymPy expression or its
    derivative does not parse (latdyn/analyses/transient_sensitivities.py ``_time_rate_law``,
    latdyn/analyses/weight_derivative.py ``_angle_slope_law``). An angle slope is not checked finite at
    θ = θ̇ = t = 0 as a user's law is (``sqrt(abs(theta))``'s slope ``sign(theta)/(2*sqrt(abs(theta)))`` is infinite
    there): it is evaluated at an event's state alone, where its use checks its value."""
    source = repr((str(law.source), by))
    cached = cached_entry(kind, source)
    text = cached.get("text") if cached is not None else None
    if not isinstance(text, str):
        held = law.expressions
        if held is None:
            return None
        text = re.sub(r"\bAbs\(", "abs(", str(derivative(held)))
        keep_entry(kind, source, {"text": text}, {}, ())
    try:
        with reading_inputs(scene.inputs):   # a slope is evaluated at an event's state alone: not checked at zero
            return parse_hinge_law(text, scene.file, f"{key} ({what})", finite_at_zero=kind != "angle_slope")
    except SceneError:
        return None


# --------------------------------------------------------------------------- controller expressions
def parse_named_expression(text: Any, names: tuple[str, ...], file: str | None, key: str, what: str):
    """A controller's expression (SCENE.md ``controllers``): a number or a text in ``t`` and ``names``
    (probes, inputs, earlier controllers, its states), checked as every scene expression is;
    ``what`` says which names are allowed, for the message. Returns ``(symbols, expr)``: the real
    SymPy symbols of ``t`` and of ``names`` in that order, and the expression."""
    import sympy as sp

    allowed = (f"a number or an expression in t and {what}, using numbers, the operators "
               + " ".join(ALLOWED_OPERATORS) + " and the names " + " ".join(ALLOWED_NAMES))
    if isinstance(text, bool) or not isinstance(text, (str, int, float)):
        _refuse(file, key, f"got {show_value(text)}", allowed)
    if not isinstance(text, str):
        value = _finite_float(text)
        if value is None:
            _refuse(file, key, f"got {show_value(text)}", "a finite number or an expression")
        text = repr(value)
    symbol, expr = _parse_text(text, file, key, extra=tuple(names), allowed_text=allowed)
    _check_size(expr, 0, text, file, key)
    return (symbol, *[sp.Symbol(n, real=True) for n in names]), expr
