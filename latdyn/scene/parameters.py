"""Named parameters of a scene (SCENE.md, "Parameters and sensitivities").

``parameters: {NAME: number, …}`` names numbers; any number of the scene may then be an
expression of them (``EIy: "E*I"``, ``at: ["L", 0, 0]``, ``stiffness: "k*(theta - theta0)"``).

How it works, once for every key: :func:`latdyn.scene.loader.load_scene` reads ``parameters``
first and reads the rest of the scene inside :func:`parameter_scope`. While the scope is open,
every expression text the scene's readers hand to :mod:`latdyn.scene.expressions` (a number
written as text, a function of time, a hinge law, and whatever key is added later that goes
through the same parsers) has the parameters' names replaced by their values
(:meth:`Parameters.substitute`: by token, never inside other names, each value written exactly,
``repr`` of the float, in parentheses), before any other check. The expression that is kept, cached,
pickled and compiled therefore holds numbers only: a law compiled for one value of ``k`` is not
reused for another, and nothing downstream knows the parameters exist.

What depends on what is recorded (:attr:`Parameters.uses`): for every key path whose text named a
parameter, the text as written and the parameters it names. :meth:`Parameters.derivative` gives
∂(that number or law)/∂(parameter), symbolically (SymPy), evaluated at the parameters' values — what
sensitivities need. A number written in the scene as a number depends on nothing.

Names: a parameter name is a plain identifier (letters, digits, ``_``; not starting with a digit)
that is not a word of the expression language (:data:`RESERVED`: ``t``, ``pi``, ``e``, ``theta``,
``theta_dot``, ``s``, ``s_dot``, the function names) nor a Python keyword; it may not be the name of a
probe either (probes, inputs, parameters and controllers share one namespace, SCENE.md). A value is a
finite number or a constant expression without names of parameters (``"pi/2"``).
"""
from __future__ import annotations

import contextlib
import functools
import keyword
import math
import re
from dataclasses import field

from latdyn.errors import SceneError, show_value
from latdyn.records import record
from latdyn.scene import expressions
from latdyn.scene.expressions import ALLOWED_NAMES, HINGE_VARIABLES

__all__ = ["Parameters", "RESERVED", "read_parameters", "parameter_scope"]

#: Words of the expression language that a parameter may not be named: the names of
#: expressions (``t``, ``pi``, ``e``, functions), the variables of hinge and guide laws, and the
#: relations the parser writes for comparisons.
RESERVED = tuple(dict.fromkeys(
    ALLOWED_NAMES + HINGE_VARIABLES + ("s", "s_dot") + ("Lt", "Le", "Gt", "Ge", "Eq", "Ne", "And")))
_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


@record
class Parameters:
    """The scene's parameters: ``values`` (name -> float, file order) and ``uses`` (key path ->
    (the text as written, the parameter names it uses)), filled while the scene is read."""
    values: dict[str, float] = field(default_factory=dict)
    uses: dict[str, tuple[str, tuple[str, ...]]] = field(default_factory=dict)
    #: substituted text -> the text as written (for messages about an expression)
    written: dict[str, str] = field(default_factory=dict, repr=False)

    def __bool__(self) -> bool:
        return bool(self.values)

    def substitute(self, text: str, key: str) -> str:
        """``text`` with every parameter name (a whole NAME token) replaced by its value; the use is
        recorded under ``key``. Text that names no parameter comes back unchanged."""
        if not self.values:
            return text
        named = [name for name in _names_in(text) if name in self.values]
        if not named:
            return text
        self.uses[key] = (text, tuple(dict.fromkeys(named)))
        self.__dict__.pop("_keys_by_name", None)   # depending_on's index, made again on use

        def value(match):
            name = match["name"]
            return f"({self.values[name]!r})" if name in self.values else match.group(0)

        substituted = _TOKEN.sub(value, text)
        self.written[substituted] = self.written[" ".join(substituted.split())] = text
        return substituted

    def depending_on(self, name: str) -> list[str]:
        """The key paths whose number or law uses the parameter ``name``, in reading order (an index of
        every name's keys made in one pass over ``uses``: a pass per name cost 0.65 s at 10³ parameters)."""
        index = self.__dict__.get("_keys_by_name")
        if index is None:
            index = {}
            for key, (_, names) in self.uses.items():
                for used in names:
                    index.setdefault(used, []).append(key)
            self._keys_by_name = index
        return list(index.get(name, ()))

    def derivative(self, key: str, name: str, names: tuple = ()) -> str:
        """∂(the expression at ``key``)/∂``name`` at the parameters' values, as expression text
        (in ``t``, ``theta``, ``theta_dot``, ``s``, ``s_dot`` where the law uses them, and ``names``: a
        controller's sensors; ``"0"`` where ``key`` does not depend on ``name``). Symbolic: SymPy
        differentiates the text as written."""
        if key not in self.uses or name not in self.uses[key][1]:
            return "0"
        text, used = self.uses[key]
        # the parameters renamed by their order in the text: texts that differ only in the parameters
        # they name (fifty loads "F<i>*t") are parsed and differentiated once (_renamed_derivative)
        renamed = tuple(f"{_PLACEHOLDER}{i}" for i in range(len(used)))
        if set(renamed) & (set(_names_in(text)) | set(names)):   # a name of the text's own: as written
            renamed = used
        rename = dict(zip(used, renamed))
        template = _TOKEN.sub(lambda m: rename.get(m["name"], m.group(0)) if m["name"] else m.group(0), text)
        values = tuple(self.values[n] for n in used)
        return _derivative_text(template, renamed, rename[name], tuple(names), values)

    def describe(self) -> list[str]:
        """One line per parameter for ``latdyn check``: its value and the keys that use it."""
        lines = []
        for name, value in self.values.items():
            keys = self.depending_on(name)
            used = ", ".join(keys) if keys else "used nowhere"
            lines.append(f"{name} = {value:g}  ({used})")
        return lines


#: A number (so that ``2e5`` is not read as a name ``e5``) or a name, left to right.
_TOKEN = re.compile(r"(?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)|(?P<name>[A-Za-z_][A-Za-z0-9_]*)")


#: the names :meth:`Parameters.derivative` gives a text's parameters (``p__0``, ``p__1``, … in order)
_PLACEHOLDER = "p__"


@functools.lru_cache(maxsize=1024)
def _renamed_derivative(text: str, used: tuple, name: str, names: tuple):
    """∂(``text``)/∂``name`` as SymPy, the names ``used`` (and ``names``, the hinge and guide variables)
    symbols: what :meth:`Parameters.derivative` evaluates at the parameters' values (the text as written
    was checked when the scene was read)."""
    import sympy as sp

    extra = tuple(used) + names + tuple(v for v in HINGE_VARIABLES + ("s", "s_dot") if v != "t")
    _, expr = expressions.parse_symbolic(text, None, "parameters", extra)
    return expressions._drop_deltas(  # noqa: SLF001 (the package's one rule for deltas)
        sp.diff(expr, sp.Symbol(name, real=True)))


@functools.lru_cache(maxsize=4096)
def _derivative_text(text: str, used: tuple, name: str, names: tuple, values: tuple) -> str:
    """:func:`_renamed_derivative` at the values of ``used`` (in order), as expression text; the SymPy
    substitution only where the derivative still names them (10³ sections' "EA: F<i>" differentiate to "1"
    once, fifty loads' "F<i>*t" to "t"). Kept in the expressions' cache (latdyn.scene.expressions ``_store``,
    under the SymPy version and this module's source): a later process reads the text without importing SymPy
    (0.5 s of a fresh ``latdyn run`` with ``solve.sensitivities``)."""
    source = repr((text, used, name, names, tuple(map(float.hex, map(float, values))), _this_module()))
    cached = expressions.cached_entry("derivative", source)   # the package's one expression cache
    if cached is not None and isinstance(cached.get("text"), str):
        return cached["text"]
    import sympy as sp

    derivative = _renamed_derivative(text, used, name, names)
    symbols = {sp.Symbol(r, real=True): value for r, value in zip(used, values)}
    if derivative.free_symbols & set(symbols):
        derivative = derivative.subs(symbols)
    result = re.sub(r"\bAbs\(", "abs(", str(derivative))
    expressions.keep_entry("derivative", source, {"text": result}, {}, ())
    return result


@functools.lru_cache(maxsize=1)
def _this_module() -> str:
    """A digest of this module's source (how its derivative texts are made), for their cache entries."""
    from pathlib import Path

    from latdyn.native import source_digest

    return source_digest(Path(__file__).read_bytes())


def _names_in(text: str) -> list[str]:
    """The names of an expression text, in order."""
    return [m["name"] for m in _TOKEN.finditer(text) if m["name"]]


def read_parameters(value, file: str, probe_names=()) -> Parameters:
    """``parameters: {NAME: number, …}`` checked: names (see the module's docstring) and finite values.
    A problem raises a SceneError naming ``parameters.NAME``."""
    params = Parameters()
    if value is None:
        return params
    if not isinstance(value, dict):
        raise SceneError(file, "parameters", f"expected a mapping of parameter names to numbers "
                                             f"({{k: 2.5, L: 1.0}}), got {show_value(value)}")
    for name, number in value.items():
        key = f"parameters.{name}"
        if not isinstance(name, str) or not _IDENTIFIER.match(name):
            raise SceneError(file, key if isinstance(name, str) else "parameters",
                             "expected a parameter name of letters, digits and _ (not starting with a digit), "
                             f"got {show_value(name)}")
        if name in RESERVED or keyword.iskeyword(name):
            raise SceneError(file, key, f"{name!r} is a word of the expression language (reserved: "
                                        f"{', '.join(RESERVED)}); expected another parameter name")
        if name in probe_names:
            what = probe_names[name] if isinstance(probe_names, dict) else "a probe"
            raise SceneError(file, key, f"{name!r} is also the name of {what} (probes, inputs, controllers and "
                                        "parameters share one namespace); expected another parameter name")
        if isinstance(number, bool) or not isinstance(number, (int, float, str)):
            raise SceneError(file, key, f"expected a number, got {show_value(number)}")
        if isinstance(number, str):
            named = [n for n in _names_in(number) if n in value and n not in RESERVED]
            if named:
                raise SceneError(file, key, f"a parameter's value may not name parameters ({', '.join(named)}); "
                                            "expected a number (write the expression where the number is used), "
                                            f"got {show_value(number)}")
            function = expressions.parse_time_function(number, file, key)   # no scope yet: no parameters
            if not function.is_constant:
                raise SceneError(file, key, f"expected a number or a constant expression (without t), "
                                            f"got {show_value(number)}")
            number = function.value(0.0)
        try:
            number = float(number)
        except OverflowError:
            number = math.inf
        if not math.isfinite(number):
            raise SceneError(file, key, f"expected a finite number, got {show_value(value[name])}")
        params.values[name] = number
    return params


@contextlib.contextmanager
def parameter_scope(params: Parameters):
    """Read a scene's expressions with ``params`` substituted (see the module's docstring)."""
    token = expressions.ACTIVE_PARAMETERS.set(params if params else None)
    try:
        yield params
    finally:
        expressions.ACTIVE_PARAMETERS.reset(token)
