"""The generated C kernels' batches over elements and the units they are compiled in.

A call on n elements writes each element's rows as a call on that element alone does, bit for bit, and
nothing past the n-th row, whatever n is against the lane count (codegen/emit.py: the whole batches on the
caller's rows, a last, partial one on copies, its last element repeated in the unused lanes). The small
kernels of a variant are compiled a few units together (latdyn.model.kernels.BUNDLE_OPS)."""
from __future__ import annotations

import ctypes
import os

import numpy as np
import pytest

from latdyn import native
from latdyn.model.kernels import _kernel_sources

#: rows past the n-th, filled with a pattern no kernel writes, checked untouched
GUARD = 9


def _so3_exp(lanes):
    """The generated so3_exp (joints.c: the rotation matrix of a rotation vector), its unit compiled as the
    kernels are (this machine's instruction set; its own lane count, or ``lanes``)."""
    try:
        using = native.compiler()
        simd = native.vector_flags(using)
    except RuntimeError as error:
        pytest.skip(f"no C compiler: {error}")
    source = _kernel_sources("joints", ["so3_exp"])["so3_exp"]
    defines = () if lanes is None else (f"-DLATDYN_LANES={lanes}",)
    flags = ("-O1", *native.C_FLAGS[1:], *simd, *defines)
    function = native.load(native.build("test_batches_so3_exp", source, flags, using=using)).so3_exp
    function.restype = None
    function.argtypes = [ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p]
    return function


@pytest.mark.parametrize("lanes", [None, 2, 4])
def test_a_call_on_n_elements_writes_their_rows_as_one_element_calls_do_and_nothing_past(lanes):
    so3_exp = _so3_exp(lanes)
    rng = np.random.default_rng(3)
    vectors = rng.normal(size=(19, 3))
    guard = np.frombuffer(np.full(9, 0x7FF4DEADBEEF0001, np.uint64).tobytes(), np.float64)  # a signalling NaN

    def call(n):
        """so3_exp of the first n vectors into n rows followed by GUARD rows of the pattern"""
        out = np.empty((n + GUARD, 9))
        out[:] = guard
        so3_exp(n, np.ascontiguousarray(vectors[:n]).ctypes.data, out.ctypes.data)
        assert np.array_equal(out[n:].view(np.uint64), np.tile(guard, (GUARD, 1)).view(np.uint64)), n
        return out[:n]

    # each element on its own: a batch of one, its other lanes repeating it
    alone = np.concatenate([np.asarray(_alone(so3_exp, vectors[k], guard)) for k in range(19)])
    assert np.allclose(alone[0].reshape(3, 3) @ alone[0].reshape(3, 3).T, np.eye(3), atol=1e-12)
    for n in range(1, 19):
        assert np.array_equal(call(n).view(np.uint64), alone[:n].view(np.uint64)), n


def _alone(so3_exp, vector, guard):
    """so3_exp of one vector, into one row followed by GUARD rows of the pattern, checked untouched"""
    out = np.empty((1 + GUARD, 9))
    out[:] = guard
    so3_exp(1, np.ascontiguousarray(vector[None, :]).ctypes.data, out.ctypes.data)
    assert np.array_equal(out[1:].view(np.uint64), np.tile(guard, (GUARD, 1)).view(np.uint64))
    return out[:1]


def test_small_kernels_are_compiled_together_and_each_is_found_in_its_library(tmp_path, monkeypatch):
    """latdyn.model.kernels._compile: the kernels of at most BUNDLE_OPS operations share a few units (one a
    worker; the compiler's start and the helpers cost each unit about 0.1 s of CPU, as much as a small
    kernel), the larger ones a unit each: joints' small kernels in two units with two workers, each larger one
    (rigid_link_inertia_D_ends, 1519 operations) alone; every kernel's library exports it and computes as the
    kernel's own unit does, to the bit (so3_exp)."""
    import importlib

    from latdyn.model import kernels

    monkeypatch.setenv("LATDYN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(os, "cpu_count", lambda: 2)  # two workers, as on the 2-core machine measured
    unit = importlib.import_module(f"{kernels.PACKAGE}.joints").KERNELS
    ops = {name: int(meta["op_count"]) for name, meta in unit.items()}
    names = [name for name in unit if name not in kernels.ON_DEMAND]
    assert len(names) >= 20
    try:
        paths = kernels._compile("joints", names, ops)
    except RuntimeError as error:
        pytest.skip(f"no C compiler: {error}")
    assert sorted(paths) == sorted(names)
    large = [name for name in names if ops[name] > kernels.BUNDLE_OPS]
    assert len(set(paths.values())) == 2 + len(large)  # the small ones one unit a worker, each larger one alone
    assert all(list(paths.values()).count(paths[name]) == 1 for name in large)
    for name, path in paths.items():
        assert hasattr(native.load(path), name), name
    together = native.load(paths["so3_exp"]).so3_exp
    together.restype, together.argtypes = None, [ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p]
    own_unit = _so3_exp(None)
    vectors = np.random.default_rng(5).normal(size=(13, 3))
    one, two = np.empty((13, 9)), np.empty((13, 9))
    together(13, vectors.ctypes.data, one.ctypes.data)
    own_unit(13, vectors.ctypes.data, two.ctypes.data)
    assert np.array_equal(one.view(np.uint64), two.view(np.uint64))
