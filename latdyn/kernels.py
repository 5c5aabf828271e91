"""Backend loader for the generated beam kernels: NumPy module or JIT-compiled C99.

``load_kernels(backend, variant)`` returns a :class:`KernelSet` whose attributes are the
kernels of ``generated/beam_<variant>.py`` (package ``latdyn_generated``), all with one
call convention (docs/architecture.md, "Kernel argument convention")::

    ks = load_kernels()                       # C if a compiler works, else NumPy
    force, = ks.beam_internal_force(geometry, section)   # (n, 36), (n, 8) -> ((n, 14),)

Inputs are float arrays of shape ``(n, width)``; outputs a tuple of float64 arrays of
shape ``(n, *shape)``.  The C backend compiles ``beam_<variant>.c`` once per source,
flags and compiler into ``$LATDYN_CACHE_DIR`` (default ``~/.cache/latdyn/kernels``) and
calls it through ctypes; nothing loops over elements in Python.

This module is runtime code: it imports neither SymPy nor the code generator.
"""
from __future__ import annotations

import ctypes
import hashlib
import importlib
import importlib.resources
import os
import shlex
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path
from typing import Callable

import numpy as np

BACKENDS = ("auto", "c", "numpy")
C_FLAGS = ("-O2", "-std=c99", "-fPIC", "-shared")
PACKAGE = "latdyn_generated"

_LOADED: dict[tuple[str, str], "KernelSet"] = {}


class KernelSet:
    """The kernels of one variant on one backend, as attributes; ``info`` is their metadata."""

    def __init__(self, backend: str, variant: str, info: dict, functions: dict[str, Callable]):
        self.backend = backend
        self.variant = variant
        self.info = info
        self._functions = functions
        for name, function in functions.items():
            setattr(self, name, function)

    @property
    def names(self) -> list[str]:
        return list(self._functions)

    def __repr__(self) -> str:
        return f"KernelSet(backend={self.backend!r}, variant={self.variant!r}, kernels={len(self._functions)})"


def known_variants() -> dict[str, str]:
    """Variant name → description, from the generated package."""
    return dict(importlib.import_module(PACKAGE).VARIANTS)


def load_kernels(backend: str = "auto", variant: str = "default") -> KernelSet:
    """Load (once per process) the kernels of ``variant`` on ``backend`` ("auto", "c", "numpy").

    "auto" uses C when a compiler works and falls back to NumPy with one warning;
    "c" raises RuntimeError when the C kernels cannot be built.
    """
    if backend not in BACKENDS:
        raise ValueError(f"unknown kernel backend {backend!r} (known: {', '.join(BACKENDS)})")
    variants = known_variants()
    if variant not in variants:
        raise ValueError(f"unknown kernel variant {variant!r} (known: {', '.join(variants)})")
    if backend == "auto":
        if ("c", variant) in _LOADED:
            return _LOADED[("c", variant)]
        if ("auto-numpy", variant) in _LOADED:
            return _LOADED[("auto-numpy", variant)]
        try:
            return load_kernels("c", variant)
        except RuntimeError as error:
            warnings.warn(f"latdyn: C kernels unavailable ({error}); using NumPy kernels",
                          RuntimeWarning, stacklevel=2)
            kernels = load_kernels("numpy", variant)
            _LOADED[("auto-numpy", variant)] = kernels
            return kernels
    key = (backend, variant)
    if key not in _LOADED:
        module = importlib.import_module(f"{PACKAGE}.beam_{variant}")
        if backend == "numpy":
            functions = {
                name: _checked(name, meta, getattr(module, name))
                for name, meta in module.KERNELS.items()
            }
        else:
            library = _compile(variant)
            functions = {
                name: _checked(name, meta, _c_function(library, name, meta))
                for name, meta in module.KERNELS.items()
            }
        _LOADED[key] = KernelSet(backend, variant, module.KERNELS, functions)
    return _LOADED[key]


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
    function = getattr(library, name)
    pointer = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
    function.argtypes = [ctypes.c_int64] + [pointer] * (len(meta["inputs"]) + len(meta["outputs"]))
    function.restype = None
    shapes = [tuple(shape) for _, shape in meta["outputs"]]

    def call(*arrays):
        n = arrays[0].shape[0]
        outputs = tuple(np.empty((n, *shape)) for shape in shapes)
        if n:
            function(n, *arrays, *outputs)
        return outputs

    return call


# --------------------------------------------------------------------------- compilation


def cache_dir() -> Path:
    return Path(os.environ.get("LATDYN_CACHE_DIR") or Path.home() / ".cache" / "latdyn" / "kernels")


def _compiler() -> list[str]:
    return shlex.split(os.environ.get("CC") or "cc")


def _compile(variant: str) -> ctypes.CDLL:
    """Compile ``beam_<variant>.c`` into the cache (once per source, flags, compiler); load it."""
    try:
        source = (importlib.resources.files(PACKAGE) / f"beam_{variant}.c").read_bytes()
    except (FileNotFoundError, OSError) as error:
        raise RuntimeError(f"no C source for variant {variant!r}: {error}") from None
    compiler = _compiler()
    try:
        version = subprocess.run(
            [*compiler, "--version"], capture_output=True, timeout=60, check=False
        ).stdout
    except (OSError, subprocess.SubprocessError) as error:
        raise RuntimeError(f"no C compiler {' '.join(compiler)!r}: {error}") from None
    digest = hashlib.sha256()
    for part in (source, " ".join(C_FLAGS).encode(), " ".join(compiler).encode(), version):
        digest.update(part + b"\0")
    suffix = ".dll" if sys.platform == "win32" else ".so"
    folder = cache_dir()
    target = folder / f"beam_{variant}-{digest.hexdigest()[:20]}{suffix}"
    if not target.exists():
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise RuntimeError(f"cannot create the kernel cache {folder}: {error}") from None
        from filelock import FileLock

        with FileLock(str(target) + ".lock", timeout=600):
            if not target.exists():
                _build(compiler, source, target, variant)
    try:
        return ctypes.CDLL(str(target))
    except OSError as error:
        raise RuntimeError(f"cannot load {target.name}: {error}") from None


def _build(compiler: list[str], source: bytes, target: Path, variant: str) -> None:
    folder = target.parent
    with tempfile.TemporaryDirectory(dir=folder, prefix=".build-") as scratch:
        c_file = Path(scratch) / f"beam_{variant}.c"
        c_file.write_bytes(source)
        partial = Path(scratch) / target.name
        command = [*compiler, *C_FLAGS, str(c_file), "-o", str(partial), "-lm"]
        try:
            result = subprocess.run(command, capture_output=True, text=True, timeout=900)
        except (OSError, subprocess.SubprocessError) as error:
            raise RuntimeError(f"{' '.join(compiler)} failed to run: {error}") from None
        if result.returncode != 0:
            lines = (result.stderr or result.stdout).strip().splitlines()
            first = lines[0] if lines else f"exit status {result.returncode}"
            raise RuntimeError(f"{' '.join(compiler)} failed: {first}")
        os.replace(partial, target)
