"""Backend loader for the generated beam kernels: NumPy module or JIT-compiled C99.

``load_kernels(backend, variant)`` returns a :class:`KernelSet` whose attributes are the
kernels of ``generated/beam_<variant>.py`` (package ``latdyn_generated``), all with one
call convention (docs/architecture.md, "Kernel argument convention")::

    ks = load_kernels()                       # C if a compiler works, else NumPy
    force, = ks.beam_internal_force(geometry, section)   # (n, 36), (n, 10) -> ((n, 14),)

Inputs are float arrays of shape ``(n, width)``; outputs a tuple of float64 arrays of
shape ``(n, *shape)``.  The C backend compiles ``beam_<variant>.c`` once per source,
flags and compiler into ``$LATDYN_CACHE_DIR`` (default ``~/.cache/latdyn/kernels``) through
:mod:`latdyn.native` and calls it through ctypes; nothing loops over elements in Python.

This module is runtime code: it imports neither SymPy nor the code generator.
"""
from __future__ import annotations

import ctypes
import importlib
import marshal
import os
import sys
import time
from pathlib import Path
from typing import Callable

import numpy as np

from latdyn.errors import MissingExtra
from latdyn.native import C_FLAGS, NO_COMPILER_ADVICE, CacheNotWritable  # the one compile-and-cache path

BACKENDS = ("auto", "c", "numpy")
PACKAGE = "latdyn_generated"
#: The generated unit of joint bodies and point loads (codegen/joints.py), loaded with every variant.
JOINTS = "joints"

_LOADED: dict[tuple[str, str], "KernelSet"] = {}


class KernelSet:
    """The kernels of one variant on one backend, as attributes; ``info`` is their metadata."""

    def __init__(self, backend: str, variant: str, info: dict, functions: dict[str, Callable],
                 libraries: dict[str, ctypes.CDLL] | None = None,
                 deferred: dict[str, Callable[[], tuple[ctypes.CDLL, Callable]]] | None = None):
        self.backend = backend
        self.libraries = libraries or {}  # C backend: kernel name -> its shared library
        self.variant = variant
        self.info = info
        self._functions = functions
        #: C kernels compiled on first use (ON_DEMAND): name -> () -> (library, function)
        self._deferred = dict(deferred or {})
        for name, function in functions.items():
            setattr(self, name, function)

    def __getattr__(self, name: str):
        """A kernel compiled on first use (ON_DEMAND) is built when it is first asked for."""
        if name in self.__dict__.get("_deferred", {}):
            self._build(name)
            return getattr(self, name)
        raise AttributeError(f"{type(self).__name__} of {self.__dict__.get('variant')!r} has no kernel {name!r}")

    def library(self, name: str) -> ctypes.CDLL:
        """The shared library of C kernel ``name``, compiled now if it is compiled on first use."""
        if name in self._deferred:
            self._build(name)
        return self.libraries[name]

    def address(self, name: str) -> int | None:
        """The address of C kernel ``name``'s function in its library (for a call from C), None where it has none
        (the NumPy backend, or no such kernel)."""
        try:
            return ctypes.cast(getattr(self.library(name), name), ctypes.c_void_p).value
        except (AttributeError, KeyError):
            return None

    def _build(self, name: str) -> None:
        library, function = self._deferred.pop(name)()
        self.libraries[name] = library
        self._functions[name] = function
        setattr(self, name, function)

    @property
    def names(self) -> list[str]:
        return [*self._functions, *self._deferred]

    def __repr__(self) -> str:
        return f"KernelSet(backend={self.backend!r}, variant={self.variant!r}, kernels={len(self._functions)})"


def known_variants() -> dict[str, str]:
    """Variant name → description, from the generated package."""
    return dict(importlib.import_module(PACKAGE).VARIANTS)


def generated_info(variant: str) -> dict:
    """The metadata of ``variant``'s beam kernels as generated (name -> inputs, outputs, …), without compiling
    anything: what a refusal before a run needs to know. From the unit's index in the kernel cache where it is
    there (:func:`_index`, the metadata :func:`_compiled_unit` keeps), else from the generated package, whose
    NumPy module is 0.1–11 MB of source (2 s of a fresh geometry-sensitivity run of the default variant where
    Python writes no bytecode)."""
    index = _index(f"beam_{variant}")
    if index is not None:
        try:
            return dict(marshal.loads(index.read_bytes())["info"])
        except (OSError, ValueError, EOFError, TypeError, KeyError):
            pass   # no index yet, or one not written here: the generated module
    return dict(importlib.import_module(f"{PACKAGE}.beam_{variant}").KERNELS)


#: Suffix of the planar variants (codegen/formulation.py PLANES) by the index of the plane's normal.
PLANE_SUFFIXES = {0: "yz", 1: "zx", 2: "xy"}


def planar_variant(formulation: str, normal: int) -> str:
    """The kernels of ``formulation`` restricted to the coordinate plane normal to axis ``normal``."""
    return f"{formulation}_{PLANE_SUFFIXES[normal]}"


def plane_of(variant: str) -> int | None:
    """The normal axis of a planar variant, None for a 3D one."""
    base, _, suffix = variant.rpartition("_")
    for normal, name in PLANE_SUFFIXES.items():
        if base and suffix == name:
            return normal
    return None


def load_kernels(backend: str = "auto", variant: str = "default") -> KernelSet:
    """Load (once per process) the kernels of ``variant`` on ``backend`` ("auto", "c", "numpy").

    "auto" and "c" use C: "auto" raises :class:`latdyn.errors.MissingExtra` naming the fix
    when no compiler works (the runtime evaluates natively only), "c" raises RuntimeError when
    the C kernels cannot be built. "numpy": the NumPy kernels, for the generator's checks.
    """
    if backend not in BACKENDS:
        raise ValueError(f"unknown kernel backend {backend!r} (known: {', '.join(BACKENDS)})")
    variants = known_variants()
    if variant not in variants:
        raise ValueError(f"unknown kernel variant {variant!r} (known: {', '.join(variants)})")
    if backend == "auto":
        if ("c", variant) in _LOADED:
            return _LOADED[("c", variant)]
        try:
            return load_kernels("c", variant)
        except RuntimeError as error:
            raise _unavailable(error) from None
    key = (backend, variant)
    if key not in _LOADED:
        info, functions, libraries, deferred = {}, {}, {}, {}
        # the beam kernels of the variant, and the joint bodies and point loads every variant shares
        for stem in (f"beam_{variant}", JOINTS):
            if backend == "numpy":
                module = importlib.import_module(f"{PACKAGE}.{stem}")
                unit = module.KERNELS  # the generated kernels
                info.update(unit)
                functions.update({name: _checked(name, meta, getattr(module, name)) for name, meta in unit.items()})
            else:
                unit, built = _compiled_unit(stem)
                info.update(unit)
                ops = {name: int(meta.get("op_count", 0)) for name, meta in unit.items()}
                libraries = built if not libraries else libraries.joined(built)
                parts = {part for used in COMPOSED.values() for part in used}
                functions.update({name: _checked(name, meta, _c_function(built[name], name, meta))
                                  for name, meta in unit.items() if name in built and name in parts})
                # the others' libraries opened when a kernel is first asked for (a model needs 15-28 of 34)
                deferred.update({name: _opened(built, name, meta) for name, meta in unit.items()
                                 if name in built and name not in parts})
                deferred.update({name: _on_demand(stem, name, meta, ops) for name, meta in unit.items()
                                 if name in ON_DEMAND})
        for name, parts in COMPOSED.items():  # not generated: no entry in ``info``
            meta = _composed_meta(name, parts, info)
            functions[name] = _checked(name, meta, _composed(meta, parts, info, functions))
        _LOADED[key] = KernelSet(backend, variant, info, functions, libraries or None, deferred)
    return _LOADED[key]


def joint_kernel(name: str) -> Callable:
    """Kernel ``name`` of the joints unit in C, the function a :class:`KernelSet` of any variant calls, for a caller
    that needs it before the run's kernels are loaded: the model's build takes a rigid link's joint-body block from
    the generated ``rigid_link_inertia`` (latdyn/model/model.py ``rigid_link_inertia``) before it knows its variant.
    From the unit's index in the kernel cache (:func:`_compiled_unit`), not the generated NumPy module, whose import
    is 0.4–0.7 s of a fresh process; without a compiler :class:`MissingExtra` naming the fix, as ``load_kernels``'s
    "auto"."""
    for (backend, _), kernels in _LOADED.items():
        if backend == "c":
            return getattr(kernels, name)
    if name not in _JOINT_KERNELS:
        try:
            info, built = _compiled_unit(JOINTS)
        except RuntimeError as error:
            raise _unavailable(error) from None
        _JOINT_KERNELS[name] = _opened(built, name, info[name])()[1]
    return _JOINT_KERNELS[name]


def _unavailable(error: RuntimeError) -> MissingExtra:
    """What "auto" raises where the C kernels cannot be built: why, and the fix where a compiler is missing."""
    advice = "" if isinstance(error, CacheNotWritable) else f"; {NO_COMPILER_ADVICE}"
    return MissingExtra(f"C kernels unavailable ({error}){advice}")


#: the kernels :func:`joint_kernel` opened, by name (before any KernelSet of the C backend was loaded)
_JOINT_KERNELS: dict[str, Callable] = {}


class LibraryFiles(dict):
    """Kernel name -> its shared library (``ctypes.CDLL``), each opened (``dlopen``) when it is first
    looked up: a run opens the libraries of the kernels its model calls, not all of a variant's
    (34 ``dlopen`` s ≈ 6 ms of CPU at a run's start; docs/performance.md, "Seventh pass"). ``in``,
    ``len``, iteration and ``keys`` count every kernel once, opened or not (a library stored for a name,
    as :meth:`KernelSet._build` does, takes the place of its file); ``get``, ``items`` and ``values``
    (and ``dict(...)``) open those they return; the files were found in the cache when the set was made."""

    def __init__(self, paths: dict):
        super().__init__()
        self._paths = dict(paths)

    def __missing__(self, name: str) -> ctypes.CDLL:
        from latdyn import native

        library = self[name] = native.load(self._paths.pop(name))
        return library

    def __setitem__(self, name: str, library: ctypes.CDLL) -> None:
        self._paths.pop(name, None)
        dict.__setitem__(self, name, library)

    def __contains__(self, name) -> bool:
        return dict.__contains__(self, name) or name in self._paths

    def __iter__(self):
        yield from dict.keys(self)
        yield from list(self._paths)

    def __len__(self) -> int:
        return dict.__len__(self) + len(self._paths)

    def keys(self):
        return list(self)

    def get(self, name, default=None):
        return self[name] if name in self else default

    def items(self):
        """Every kernel's library, opening those not yet open."""
        return [(name, self[name]) for name in list(self)]

    def values(self):
        return [library for _, library in self.items()]

    def joined(self, other: "LibraryFiles") -> "LibraryFiles":
        """This set and ``other``'s, neither opening anything."""
        both = LibraryFiles({**self._paths, **other._paths})
        dict.update(both, dict.items(self))
        dict.update(both, dict.items(other))
        return both


def _opened(libraries: LibraryFiles, name: str, meta: dict) -> Callable[[], tuple[ctypes.CDLL, Callable]]:
    """Kernel ``name`` of a compiled unit, its library opened when it is first asked for."""
    def open_library():
        library = libraries[name]
        return library, _checked(name, meta, _c_function(library, name, meta))
    return open_library


def _on_demand(stem: str, name: str, meta: dict, ops: dict[str, int]) -> Callable[[], tuple[ctypes.CDLL, Callable]]:
    """The compilation of one ON_DEMAND kernel, for when it is first asked for: its library read from its entry
    beside the unit's index (:func:`_on_demand_index`) where that names one in the cache, else compiled (or found)
    from its source and the entry written. Finding it from the source imports the generated module
    (:func:`_kernel_sources`: the kernels' order), 1.8–2.5 s of a fresh process for ``default`` where Python writes
    no bytecode — what a transient run with sensitivities or ``newton: exact`` paid each time for the inertia
    tangent (docs/performance.md, "Forward sensitivities: where a step goes")."""
    def build():
        from latdyn import native

        entry = _on_demand_index(stem, name)
        path = None
        if entry is not None and entry.is_file():
            try:
                path = native.cache_dir() / marshal.loads(entry.read_bytes())
            except (OSError, ValueError, EOFError, TypeError):
                path = None
        if path is None or not native.intact(path):
            path = Path(_compile(stem, [name], ops)[name])
            if entry is not None:
                native._store_bytes(entry, marshal.dumps(path.name))
        library = native.load(path)
        return library, _checked(name, meta, _c_function(library, name, meta))
    return build


def _on_demand_index(stem: str, name: str):
    """The path of ON_DEMAND kernel ``name``'s entry beside the index of unit ``stem`` (:func:`_index`: the same
    digest of the generated files, this module, the compiler and the flags), its library's file name; None where
    the unit has no index."""
    index = _index(stem)
    return None if index is None else index.parent / f"{index.stem}-{name}{index.suffix}"


def _checked(name: str, meta: dict, function: Callable) -> Callable:
    """Wrap a backend function: inputs to C-contiguous float64 (n, width), shapes checked."""
    inputs = [(arg, int(width)) for arg, width in meta["inputs"]]

    def kernel(*arrays):
        if len(arrays) != len(inputs):
            raise TypeError(
                f"{name}() takes {len(inputs)} arrays ({', '.join(a for a, _ in inputs)}), "
                f"got {len(arrays)}"
            )
        converted = []
        for (arg, width), array in zip(inputs, arrays):
            array = np.ascontiguousarray(array, dtype=np.float64)
            if array.ndim != 2 or array.shape[1] != width:
                raise ValueError(
                    f"{name}: argument {arg!r} must have shape (n, {width}), got {array.shape}"
                )
            converted.append(array)
        n = converted[0].shape[0]
        for (arg, _), array in zip(inputs, converted):
            if array.shape[0] != n:
                raise ValueError(
                    f"{name}: argument {arg!r} has {array.shape[0]} rows, "
                    f"{inputs[0][0]!r} has {n}"
                )
        return function(*converted)

    kernel.__name__ = kernel.__qualname__ = name
    kernel.__doc__ = meta.get("doc", "")
    return kernel


def _c_function(library: ctypes.CDLL, name: str, meta: dict) -> Callable:
    """The C kernel ``name`` called on C-contiguous float64 arrays (:func:`_checked` makes them so and keeps them
    alive over the call), their addresses passed as plain pointers: NumPy's ``ndpointer`` checked each array's
    flags and cast its address again per call (≈ 1 µs an array; a sensitivity step calls kernels from Python with
    5–8 arrays each)."""
    function = getattr(library, name)
    function.argtypes = [ctypes.c_int64] + [ctypes.c_void_p] * (len(meta["inputs"]) + len(meta["outputs"]))
    function.restype = None
    shapes = [tuple(shape) for _, shape in meta["outputs"]]

    def call(*arrays):
        n = arrays[0].shape[0]
        outputs = tuple(np.empty((n, *shape)) for shape in shapes)
        if n:
            function(n, *(a.ctypes.data for a in arrays), *(out.ctypes.data for out in outputs))
        return outputs

    return call


def _composed_meta(name: str, parts, kernels: dict) -> dict:
    """Metadata of a composed kernel: the inputs of its widest part (then any other part's),
    and the parts' outputs in turn."""
    widest = max(parts, key=lambda part: len(kernels[part]["inputs"]))  # its argument order
    inputs, outputs = list(kernels[widest]["inputs"]), []
    for part in parts:
        inputs += [arg for arg in kernels[part]["inputs"] if arg not in inputs]
        outputs += list(kernels[part]["outputs"])
    return {"inputs": inputs, "outputs": outputs,
            "doc": "One Newton iteration's element terms: " + ", ".join(out for out, _ in outputs),
            "equations": ", ".join(kernels[part]["equations"] for part in parts),
            "op_count": sum(int(kernels[part].get("op_count", 0)) for part in parts)}


def _composed(meta: dict, parts, kernels: dict, functions: dict) -> Callable:
    """A kernel (metadata ``meta``) whose outputs are those of ``parts`` (by output name), called in turn."""
    inputs = [arg for arg, _ in meta["inputs"]]
    plan = []
    for part in parts:
        args = [inputs.index(arg) for arg, _ in kernels[part]["inputs"]]
        plan.append((functions[part], args, [out for out, _ in kernels[part]["outputs"]]))
    order = [out for out, _ in meta["outputs"]]

    def call(*arrays):
        outputs = {}
        for function, args, names in plan:
            outputs.update(zip(names, function(*(arrays[i] for i in args))))
        return tuple(outputs[out] for out in order)

    return call


# --------------------------------------------------------------------------- compilation
#
# GCC's register allocator is superlinear in the size of one function: a combined kernel
# of everything a Newton iteration needs (40 000 operations, 5 800 temporaries after CSE)
# took 64 s at -O2 and as long at -O1 (LRA hard-register assignment is 60 % of it), while
# its four parts together take 30 s and the longest of them 15 s. So every large kernel is its
# own translation unit and shared object, compiled in parallel on first use (the small ones a
# few units together, BUNDLE_OPS), and
# ``beam_dynamics`` is the composition of its parts (COMPOSED), on both backends: the code
# generator no longer emits it (14 µs per element against 11 µs for the combined function
# in C, measured on the 2-core development machine).

#: The optimisation level of each unit, by its operation count after CSE. The kernels are
#: batched over elements (codegen/templates/c_source.c.j2: one SIMD lane per element, the
#: lane count of native.vector_flags) and derived through small Jacobians (issue 19), so
#: the largest unit of the default element has 25 000 operations: -O1 compiles it in 6 s and
#: runs it 2.3x faster than -O0 (0.81 against 1.88 µs an element with 8 lanes; -O2: 0.84 µs,
#: 8 s; benchmarks/compile_levels.py). Units larger than OPT_LIMIT_OPS stay at -O0, where GCC
#: needs seconds rather than minutes.
OPT_LIMIT_OPS = 40_000


def optimisation(ops: int) -> str:
    """The -O level of a kernel unit of ``ops`` operations (see OPT_LIMIT_OPS), or the one ``$LATDYN_KERNEL_OPT``
    names for every unit (:func:`latdyn.native.kernel_optimisation`: the test suite's -O0)."""
    from latdyn.native import kernel_optimisation

    return kernel_optimisation() or ("-O1" if ops <= OPT_LIMIT_OPS else "-O0")


#: C kernels compiled when first asked for, not with the rest of their variant: the elements' inertia
#: tangent (2.2e5 operations in `default`, the largest unit, at -O0) runs only with ``newton: exact`` or
#: after a Newton failure (latdyn/step/integrators.py), so a run that never needs it does not compile it
#: (docs/performance.md, "The inertia tangent generated by forward mode"); the section forces' derivative
#: only for a controller that reads a section force (latdyn/assembly/control.py SECTION_FORCE) or a section-force
#: probe's sensitivity; the forces' (and the section forces') derivatives along the reference data only with
#: geometry parameters (docs/parameters.md, "Geometry parameters"), and by the section values only with a parameter
#: in a section value (docs/parameters.md, "Section values"); the stiffness's derivative along a direction by the
#: coordinates only at an event's impulse with sensitivities (latdyn/analyses/weight_derivative.py), the point loads'
#: and the cable elements' likewise (codegen/joints.py; the cable's 5 240 operations 0.5 s of the joints unit's first
#: compile, docs/performance.md "The rest of the impulse weight's derivative generated"); the cable's stiffness by its
#: rest length and a compliant stop's by its law only at an event with such a parameter
#: (latdyn/analyses/parameter_stiffness.py); the section forces' and a cable's tension's second derivatives only at an
#: event with a controller reading them (latdyn/analyses/weight_derivative.py ``_sensor_kinematics``), a point's
#: velocity relative to a body's likewise; the stiffness's derivative along the reference data only at an event with a
#: geometry parameter (latdyn/analyses/parameter_stiffness.py ``_geometry``).
ON_DEMAND = ("beam_inertia_tangent", "beam_section_forces_D_q", "beam_internal_force_D_reference",
             "beam_inertia_force_D_reference", "beam_section_forces_D_reference", "beam_internal_force_D_section",
             "beam_inertia_force_D_section", "beam_section_forces_D_section", "beam_energies_D_section",
             "beam_stiffness_D_section", "beam_stiffness_D_q", "point_load_stiffness_D_q", "cable_stiffness_D_q",
             "cable_stiffness_D_rest_length", "contact_stiffness_D_law", "beam_section_forces_D_q_D_q",
             "cable_tension_D_q_D_q", "point_velocity_in_body_D_q_D_q",
             "beam_stiffness_D_reference", "beam_section_forces_D_q_D_section", "cable_tension_D_q_D_section")

#: Kernels composed from their parts in the C backend (see above), name -> parts.
COMPOSED = {
    "beam_dynamics": ("beam_internal_force_D_q", "beam_mass_matrix", "beam_quadratic_velocity_D_qdot"),
}



def _kernel_sources(stem: str, names) -> dict[str, bytes]:
    """The C source of each kernel as a translation unit of its own.

    ``codegen/templates/c_source.c.j2`` writes the includes, then every kernel after a comment
    line ``/* NAME: ...``; the unit is the includes plus that kernel, up to the next kernel of the
    file (whether or not it is asked for: an ON_DEMAND kernel is not compiled with the others)."""
    includes, texts = _kernel_texts(stem, names)
    return {name: (includes + texts[name]).encode() for name in names}


def _kernel_texts(stem: str, names) -> tuple[str, dict[str, str]]:
    """The includes and helpers of the generated C source ``stem``.c, and the text of each kernel of ``names``
    (its comment line up to the next kernel of the file), :func:`_kernel_sources`' parts."""
    from latdyn.native import package_folder

    try:
        source = (package_folder(PACKAGE) / f"{stem}.c").read_text()
    except (FileNotFoundError, OSError) as error:
        raise RuntimeError(f"no C source {stem}.c: {error}") from None
    every = list(dict.fromkeys([*importlib.import_module(f"{PACKAGE}.{stem}").KERNELS, *names]))
    marks = {name: source.find(f"\n/* {name}: ") for name in every}
    missing = [name for name in names if marks[name] < 0]
    if missing:
        raise RuntimeError(f"{stem}.c has no kernel {', '.join(missing)}")
    starts = sorted(at for at in marks.values() if at >= 0)
    includes = source[: starts[0]].split("*/", 1)[-1]  # after the stamp comment
    texts = {}
    for name in names:
        at = marks[name]
        later = [s for s in starts if s > at]
        texts[name] = source[at: later[0] if later else len(source)]
    return includes, texts


#: Kernels of at most this many operations after CSE are compiled together, a few units a variant
#: (:func:`_bundles`), not one unit each: the compiler's start and the includes and helpers of a unit
#: cost about 0.1 s of CPU whatever its kernel, as much as a small kernel itself, and a variant has
#: 25 such kernels in ``joints`` alone (docs/performance.md, "Ninth pass"). The large ones stay a unit
#: each (GCC's register allocator is superlinear in a function's size, not in a unit's).
BUNDLE_OPS = 1_500


def _bundles(names, ops: dict[str, int], workers: int) -> list[list[str]]:
    """``names`` as the units they are compiled in: each kernel of more than BUNDLE_OPS operations alone,
    the smaller ones in at most ``workers`` units of about equal operation counts (the largest first into
    the lightest unit), each unit's kernels in the order of ``names``."""
    large = [[name] for name in names if ops.get(name, 0) > BUNDLE_OPS]
    small = [name for name in names if ops.get(name, 0) <= BUNDLE_OPS]
    groups: list[list[str]] = [[] for _ in range(min(max(1, workers), len(small)))]
    weight = [0] * len(groups)
    for name in sorted(small, key=lambda n: -ops.get(n, 0)):
        lightest = weight.index(min(weight))
        groups[lightest].append(name)
        weight[lightest] += ops.get(name, 0)
    order = {name: k for k, name in enumerate(names)}
    return large + [sorted(group, key=order.get) for group in groups]


def _compiled_unit(stem: str) -> tuple[dict, "LibraryFiles"]:
    """The metadata (``KERNELS``) of the generated unit ``stem`` and its kernels' libraries (each
    opened on first use, :class:`LibraryFiles`), compiled into the cache if need be (:func:`_compile`; not the ON_DEMAND ones, compiled on first use).

    A fresh process with everything cached reads both from the unit's index in the kernel cache
    (:func:`_index`), without importing the generated NumPy module (a 0.1–2.4 MB source) nor
    reading and splitting the C source to digest each kernel (together 40–70 ms of a 5-step run's
    process; docs/performance.md, "First run"); where the index is missing, stale or names a
    library that is not there, they are made as before and the index is written."""
    from latdyn import native

    index = _index(stem)
    if index is not None and index.is_file():
        try:
            entry = marshal.loads(index.read_bytes())
            paths = {name: native.cache_dir() / file for name, file in entry["targets"].items()}
            if all(map(native.intact, set(paths.values()))):   # each there, none cut short
                return entry["info"], LibraryFiles(paths)
        except (OSError, ValueError, EOFError, TypeError, KeyError, AttributeError):
            pass  # made again below
    unit = importlib.import_module(f"{PACKAGE}.{stem}").KERNELS  # the generated kernels
    targets = _compile(stem, [name for name in unit if name not in ON_DEMAND],
                       {name: int(meta.get("op_count", 0)) for name, meta in unit.items()})
    if index is not None:
        native._store_bytes(index, marshal.dumps({"info": unit, "targets": {n: t.name for n, t in targets.items()}}))
    return unit, LibraryFiles(targets)


def _index(stem: str):
    """The path of the index of the generated unit ``stem`` in the kernel cache: its kernels'
    metadata and library files, under a digest of all that names them without reading the sources:
    the generated files' identity (path, size, modification time, inode of ``stem``.c and .py), this
    module's and :mod:`latdyn.native`'s (the flags, the -O levels), ``$LATDYN_KERNEL_OPT``, the compiler's
    identity, the instruction-set flags and the Python version (the index is a ``marshal`` dump). None without a
    compiler or where the generated files are not plain files."""
    from latdyn import native

    try:
        using = native.compiler()
        simd = native.vector_flags(using)
        folder = native.package_folder(PACKAGE)
        identities = []
        for path in (folder / f"{stem}.c", folder / f"{stem}.py", __file__, native.__file__):
            status = os.stat(os.fspath(path))
            identities += [os.path.realpath(os.fspath(path)), status.st_size, status.st_mtime_ns, status.st_ino]
    except (RuntimeError, OSError, TypeError):
        return None
    digest = native.source_digest(stem, sys.version, using.identity(), *simd, *C_FLAGS, OPT_LIMIT_OPS, BUNDLE_OPS,
                                 native.kernel_optimisation() or "", *identities)
    return native.cache_dir() / f"index-{stem}-{digest}.marshal"


def _compile(stem: str, names, ops: dict[str, int] | None = None) -> dict[str, os.PathLike]:
    """Compile the kernels of ``names`` into the cache (:mod:`latdyn.native`: once per source,
    flags and compiler), in parallel, the small ones together (:func:`_bundles`); name -> its
    library's path (the same path for the kernels of one unit)."""
    from latdyn import native

    ops = ops or {}
    workers = max(1, os.cpu_count() or 1)
    includes, texts = _kernel_texts(stem, names)
    using = native.compiler()  # NoCompiler (a RuntimeError) says why not
    simd = native.vector_flags(using)
    units, flags, members = {}, {}, {}
    for group in _bundles(list(names), ops, workers):
        unit = f"{group[0]}-{stem}" if len(group) == 1 else f"{group[0]}-and-{len(group) - 1}-{stem}"
        units[unit] = (includes + "".join(texts[name] for name in group)).encode()
        flags[unit] = (optimisation(max(ops.get(name, 0) for name in group)), *C_FLAGS[1:], *simd)
        members[unit] = group
    paths = {unit: native.target(unit, units[unit], flags[unit], using) for unit in units}
    todo = [unit for unit, path in paths.items() if not native.intact(path)]
    if todo:
        from concurrent.futures import ThreadPoolExecutor

        started = time.perf_counter()
        target_set = f" for -march={native.march()}" if simd else ""
        count = sum(len(members[unit]) for unit in todo)
        print(f"latdyn: compiling {count} C kernels of {stem}.c in {len(todo)} units with {using.name}{target_set} "
              f"into {native.cache_dir()} (first use only; seconds)", file=sys.stderr, flush=True)
        before = native.COMPILE_SECONDS["total"]

        def build(unit):
            native.build(unit, units[unit], flags[unit], using=using)

        # the longest units first, so that the last one to finish started early
        order = sorted(todo, key=lambda unit: -len(units[unit]))
        with ThreadPoolExecutor(max_workers=workers) as pool:
            list(pool.map(build, order))
        elapsed = time.perf_counter() - started
        # the units' own seconds overlap (parallel builds): the wall time counts once
        native.COMPILE_SECONDS["total"] = before + elapsed
        print(f"latdyn: compiled in {elapsed:.1f} s", file=sys.stderr, flush=True)
    return {name: paths[unit] for unit, group in members.items() for name in group}
