"""A scene's laws, compiled: the C unit of :mod:`codegen.laws` built into the kernel cache.

The compiled time step (:mod:`latdyn.step.compiled`) numbers the scene's functions of time
(prescribed translations and angles, load components, hinge torques of t) and its hinge laws
in θ, θ̇ and t; :func:`compile_laws` emits their C unit, compiles it once (``-O2``, a few
tenths of a second on first use, reported as compile time; :mod:`latdyn.native`) and returns
the addresses of ``latdyn_time_laws`` and ``latdyn_hinge_laws`` for the step to call. A law that
names one of the scene's inputs or controllers reads it from the arrays bound with
:meth:`CompiledLaws.bind_inputs` (:attr:`latdyn.scene.inputs.Signals.values`), so that a value set
between steps is the one the next step uses, without compiling again.

The library is found in the cache by the laws' own text (kind and source of each law, in the
step's numbering), the generator's version (:func:`generator_version`: the code generator's
and the expression reader's sources, the SymPy version) and the compiler: a run whose laws
were compiled before neither imports SymPy nor runs the C printer.
:class:`LawsUnavailable` says why not (a construct the C printer cannot write, no compiler):
the step then takes the law values from Python, as :class:`latdyn.step.compiled._Laws` computes them.
"""
from __future__ import annotations

import ctypes

from latdyn.native import source_digest
from latdyn.scene.expressions import HingeLaw, TimeFunction


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


def controller_law(controller, sensors: tuple):
    """The plain description of a continuous controller that :mod:`codegen.laws` prints, the
    arguments a = (s_0 … s_{m−1}, S_0 … S_{p−1}) being the probes ``sensors`` it reads and its states
    (in the order of ``controllers.NAME.states``): its output y and ∂y/∂a, then for each state j its
    rate f_j = dS_j/dt and ∂f_j/∂a, all exact (Dirac deltas dropped); (1 + p)(1 + m + p) values."""
    import sympy as sp
    from codegen.laws import ControllerLawC

    from latdyn.scene.expressions import _drop_deltas

    by_name = {s.name: s for s in controller.symbols}
    arguments = [by_name[n] for n in (*sensors, *controller.states)]
    expressions = []
    for f in (controller.output_expr, *controller.state_exprs):
        expressions += [f, *(_drop_deltas(sp.diff(f, a)) for a in arguments)]
    return ControllerLawC(f"{controller.name}: {controller.output_text}", variables=(by_name["t"], *arguments),
                          expressions=tuple(expressions))


def sampled_law(controller, sensors: tuple):
    """The plain description of a sampled controller that :mod:`codegen.laws` prints, the arguments
    a = (s_0 … s_{m−1}, S_0 … S_{p−1}) being the probes ``sensors`` it reads and its states: its
    output y, then each state's rate EXPR_j (the sample's S_j ← S_j + EXPR_j / rate); 1 + p values.
    The inputs and controllers it names are read from the bound arrays (``latdyn_bind_inputs``)."""
    from codegen.laws import SampledLawC

    by_name = {s.name: s for s in controller.symbols}
    arguments = [by_name[n] for n in (*sensors, *controller.states)]
    return SampledLawC(f"{controller.name}: {controller.output_text}", variables=(by_name["t"], *arguments),
                       expressions=(controller.output_expr, *controller.state_exprs))


class CompiledLaws:
    """The loaded library of one scene's laws and its two functions' addresses."""

    def __init__(self, library: ctypes.CDLL, path):
        self.library, self.path = library, path
        self.time_laws = ctypes.cast(library.latdyn_time_laws, ctypes.c_void_p).value
        self.hinge_laws = ctypes.cast(library.latdyn_hinge_laws, ctypes.c_void_p).value
        self.controller_laws = ctypes.cast(library.latdyn_controller_laws, ctypes.c_void_p).value
        self.sampled_laws = ctypes.cast(library.latdyn_sampled_laws, ctypes.c_void_p).value
        self._bind = library.latdyn_bind_inputs
        self._bind.argtypes, self._bind.restype = [ctypes.c_void_p, ctypes.c_void_p], None

    def bind_inputs(self, inputs, controllers) -> None:
        """Point the laws at ``inputs`` and ``controllers`` (float64, C-contiguous, one entry per input
        and per controller, kept alive by the caller). A library is shared by every model with the
        same laws in a process: the step binds its own arrays before it calls the laws."""
        self._bind(inputs.ctypes.data, controllers.ctypes.data)


#: loaded libraries by the laws' own sources (the C source is a function of them in a process)
_LOADED: dict[str, CompiledLaws] = {}
_VERSION: list[str] = []


def generator_version() -> str:
    """A hash of what turns a law's text into C: ``codegen/*.py``, ``codegen/templates/*.j2``,
    ``latdyn/scene/expressions.py`` and the SymPy version (read without importing codegen or SymPy).
    Found through an index in the kernel cache (:func:`_version_index`) where a process before this one
    digested the same files, else from the files (and the index written)."""
    if not _VERSION:
        import importlib.util
        from pathlib import Path

        from latdyn import native
        from latdyn.scene.expressions import sympy_version

        spec = importlib.util.find_spec("codegen")
        folder = Path(next(iter(spec.submodule_search_locations))) if spec else None
        files = sorted(folder.glob("*.py")) + sorted((folder / "templates").glob("*.j2")) if folder else []
        files.append(Path(__file__).parents[1] / "scene" / "expressions.py")
        sympy = importlib.util.find_spec("sympy")  # its release.py, which sympy_version reads
        release = (Path(next(iter(sympy.submodule_search_locations))) / "release.py"
                   if sympy is not None and sympy.submodule_search_locations else None)
        index = _version_index(files, release)
        version = _indexed_version(index)
        if version is None:
            version = source_digest(*[path.read_bytes() for path in files], sympy_version())
            if index is not None:
                native._store(index, version)
        _VERSION.append(version)
    return _VERSION[0]


def _version_index(files: list, release):
    """Where the kernel cache keeps the :func:`generator_version` of these files: under a digest of their
    identities (path, size, modification time, inode) and of SymPy's ``release.py`` (``release``; None
    without SymPy), as the compiled step's library is found (:func:`latdyn.assembly.library._library_index`).
    Reading and digesting the 0.38 MB took ≈ 1.3 ms of every fresh run (docs/performance.md, "Twelfth
    pass"); an edited file, or another SymPy, changes the digest, so the version is digested from the files
    again. None where a file cannot be read."""
    import os

    from latdyn import native

    identities = []
    try:
        for path in (*files, *(() if release is None else (release,))):
            status = os.stat(path)
            identities += [str(path), status.st_size, status.st_mtime_ns, status.st_ino]
    except OSError:
        return None
    return native.cache_dir() / f"index-laws-generator-{source_digest('laws-generator', *identities)}.txt"


def _indexed_version(index) -> str | None:
    """The generator version an index of :func:`_version_index` holds, where it is in the cache."""
    if index is None:
        return None
    try:
        version = index.read_text().strip()
    except (OSError, ValueError):
        return None
    return version if len(version) == 20 and all(c in "0123456789abcdef" for c in version) else None


def _text_key(time_functions, hinge_laws, signals=((), ()), controllers=(), sampled=()) -> str:
    """What the laws' C unit is a function of. A controller enters by its expressions as read (exactly,
    ``srepr``), not by the text as written: that text names the scene's parameters, whose values the
    loader substituted, so two scenes with other values of a gain share it (and shared one library:
    a run with Kp = 40 stepped with the law compiled for Kp = 4). SymPy is imported only for
    controllers (their expressions are SymPy's already): a key of time functions and hinge laws
    alone is their source text, and importing SymPy for it cost 0.3 s of a run's start."""

    def read(kind, c, sensors):
        from sympy import srepr

        return (kind, c.name, srepr(c.output_expr), tuple(sensors), c.states, tuple(map(srepr, c.state_exprs)))

    return repr([(type(f).__name__, f.source) for f in time_functions]
                + [(type(h).__name__, h.source) for h in hinge_laws] + [("signals", tuple(map(tuple, signals)))]
                + [read("controller", c, sensors) for c, sensors in controllers]
                + [read("sampled", c, sensors) for c, sensors in sampled])


def _print(time_functions, hinge_laws, signals=((), ()), controllers=(), sampled=()) -> bytes:
    """The C unit of the laws (SymPy and the C printer); LawsUnavailable when a law does not print."""
    from codegen.emit import EmitError
    from codegen.laws import laws_source

    try:
        return laws_source([time_law(f) for f in time_functions], [hinge_law(h) for h in hinge_laws],
                           *map(tuple, signals), [controller_law(c, sensors) for c, sensors in controllers],
                           [sampled_law(c, sensors) for c, sensors in sampled]).encode()
    except EmitError as error:
        raise LawsUnavailable(str(error)) from None


def compile_laws(time_functions: list, hinge_laws: list[HingeLaw], signals=((), ()), controllers=(),
                 sampled=()) -> CompiledLaws:
    """The compiled laws (``time_functions``: :class:`TimeFunction` in the step's numbering;
    ``hinge_laws``: :class:`HingeLaw`; ``signals``: the names of the scene's inputs and of its
    controllers, in order; ``controllers``: (continuous controller, the probes it reads) pairs;
    ``sampled``: (sampled controller, the probes it reads) pairs), from the cache when these laws
    were built before."""
    from latdyn import native

    # the same laws again (a study's runs, a renumbering after a latch): no lookup
    key = _text_key(time_functions, hinge_laws, signals, controllers, sampled)
    if key in _LOADED:
        return _LOADED[key]
    try:
        using = native.compiler()
        text = source_digest(key, generator_version()).encode()
        target = native.target("laws", text, native.C_FLAGS, using)
        if not native.intact(target):  # print the unit only now (absent, or cut short)
            announce = (f"latdyn: compiling the scene's laws ({len(time_functions)} of time, {len(hinge_laws)} "
                        f"hinge laws) with {using.name} into {target.parent}")
            target = native.build("laws", _print(time_functions, hinge_laws, signals, controllers, sampled),
                                  native.C_FLAGS, using=using,
                                  key=text, announce=announce)
        loaded = CompiledLaws(native.load(target), target)
    except RuntimeError as error:  # no compiler, a failed build, a library that does not load
        raise LawsUnavailable(str(error)) from None
    _LOADED[key] = loaded
    return loaded


def unprintable(hinge_laws: list[HingeLaw], signals=((), ())) -> str | None:
    """Why these hinge laws cannot be printed in C, or None. A success is remembered in the
    cache by the laws' text (an empty marker file), so that a later run does not print them."""
    from latdyn import native

    marker = native.cache_dir() / f"laws-printable-{source_digest(_text_key([], hinge_laws, signals), generator_version())}"
    if marker.exists():
        return None
    try:
        _print([], hinge_laws, signals)
    except LawsUnavailable as error:
        return str(error)
    try:
        marker.parent.mkdir(parents=True, exist_ok=True)
        marker.touch()
    except OSError:
        pass
    return None
