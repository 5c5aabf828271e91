"""A scene's laws, compiled: the C unit of :mod:`codegen.laws` built into the kernel cache.

The compiled time step (:mod:`latdyn.engine`) numbers the scene's functions of time
(prescribed translations and angles, load components, hinge torques of t) and its hinge laws
in θ, θ̇ and t; :func:`compile_laws` emits their C unit, compiles it once per distinct source
(``-O2``, a few tenths of a second on first use, reported as compile time) and returns the
addresses of ``latdyn_time_laws`` and ``latdyn_hinge_laws`` for the step to call.
:class:`LawsUnavailable` says why not (a construct the C printer cannot write, no compiler):
the step then takes the law values from Python, as :class:`latdyn.engine._Laws` computes them.
"""
from __future__ import annotations

import ctypes
import hashlib
import sys
import time

from .expressions import HingeLaw, TimeFunction


class LawsUnavailable(Exception):
    """The laws cannot be compiled; the message says why."""


def time_law(function: TimeFunction | HingeLaw):
    """The plain description of a function of time that :mod:`codegen.laws` prints (a
    :class:`HingeLaw` of t alone is a hinge torque: only its value is read)."""
    from codegen.laws import TimeLaw

    text = str(function.source)
    if isinstance(function, HingeLaw):
        if function.time_function is not None:
            return time_law(function.time_function)
        variables, (value, _, _) = function.expressions
        return TimeLaw("expression", text, variable=variables[2], expressions=(value, 0, 0))
    if function.kind == "table":
        times, values = function.table
        return TimeLaw("table", text, times=tuple(times), values=tuple(values))
    found = function.expressions
    if found is None:  # a number, or an expression without t
        return TimeLaw("constant", text, value=float(function.value(0.0)))
    variable, expressions = found
    return TimeLaw("expression", text, variable=variable, expressions=tuple(expressions))


def hinge_law(law: HingeLaw):
    """The plain description of a hinge law that :mod:`codegen.laws` prints."""
    from codegen.laws import HingeLawC

    found = law.expressions
    if found is None:
        return HingeLawC(str(law.source), time=time_law(law.time_function))
    variables, expressions = found
    return HingeLawC(str(law.source), variables=tuple(variables), expressions=tuple(expressions))


class CompiledLaws:
    """The loaded library of one scene's laws and its two functions' addresses."""

    def __init__(self, library: ctypes.CDLL, path):
        self.library, self.path = library, path
        self.time_laws = ctypes.cast(library.latdyn_time_laws, ctypes.c_void_p).value
        self.hinge_laws = ctypes.cast(library.latdyn_hinge_laws, ctypes.c_void_p).value


#: loaded libraries by the laws' own sources (the C source is a function of them in a process)
_LOADED: dict[str, CompiledLaws] = {}


def compile_laws(time_functions: list, hinge_laws: list[HingeLaw]) -> CompiledLaws:
    """The compiled laws (``time_functions``: :class:`TimeFunction` in the step's numbering;
    ``hinge_laws``: :class:`HingeLaw`), from the cache when this source was built before."""
    from codegen.emit import EmitError
    from codegen.laws import laws_source

    from .kernels import C_FLAGS, COMPILE_SECONDS, _build, _compiler, cache_dir

    # the same laws again (a study's runs, a renumbering after a latch): no printing, no lookup
    key = repr([(type(f).__name__, f.source) for f in time_functions]
               + [(type(h).__name__, h.source) for h in hinge_laws])
    if key in _LOADED:
        return _LOADED[key]
    try:
        source = laws_source([time_law(f) for f in time_functions], [hinge_law(h) for h in hinge_laws]).encode()
    except EmitError as error:
        raise LawsUnavailable(str(error)) from None
    compiler = _compiler()
    digest = hashlib.sha256(source + b"\0" + " ".join([*compiler, *C_FLAGS]).encode()).hexdigest()[:20]
    target = cache_dir() / f"laws-{digest}.so"
    if not target.exists():
        from filelock import FileLock

        try:
            target.parent.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise LawsUnavailable(f"cannot create the kernel cache {target.parent}: {error}") from None
        with FileLock(str(target) + ".lock", timeout=600):
            if not target.exists():
                started = time.perf_counter()
                print(f"latdyn: compiling the scene's laws ({len(time_functions)} of time, {len(hinge_laws)} hinge "
                      f"laws) into {target.parent}", file=sys.stderr, flush=True)
                try:
                    _build(compiler, source, target, "laws", C_FLAGS)
                except RuntimeError as error:
                    raise LawsUnavailable(str(error)) from None
                finally:
                    COMPILE_SECONDS["total"] += time.perf_counter() - started
    try:
        loaded = CompiledLaws(ctypes.CDLL(str(target)), target)
    except OSError as error:
        raise LawsUnavailable(f"cannot load {target.name}: {error}") from None
    _LOADED[key] = loaded
    return loaded
