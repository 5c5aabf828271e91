"""The emission stage on toy kernels: printers agree with SymPy, C is warning-free, CSE is
deterministic, bad specs are refused with a one-line message."""
from __future__ import annotations

import ctypes
import importlib.util
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from codegen import emit
from codegen.conventions import GEOMETRY, SECTION
from codegen.ir import KernelSpec, Output

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import toy_kernels  # noqa: E402

CC = os.environ.get("CC", "cc")
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic"]
needs_cc = pytest.mark.skipif(shutil.which(CC.split()[0]) is None, reason=f"no C compiler {CC!r}")


@pytest.fixture(scope="module")
def toy_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("toy_generated")
    files, _ = emit.generate(toy_kernels.build_kernels, toy_kernels.VARIANTS,
                             joint_kernels=toy_kernels.build_joint_kernels)
    emit.write_files(files, out)
    return out


def _inputs(spec, n, seed=0):
    rng = np.random.default_rng(seed)
    return [rng.uniform(0.5, 2.0, size=(n, argument.width)) for argument in spec.inputs]


def _direct(spec, arrays):
    """Evaluate the un-CSE'd expressions with sympy.lambdify, element by element."""
    symbols = [s for argument in spec.inputs for s in argument.symbols()]
    flat_inputs = np.concatenate(arrays, axis=1)
    results = []
    for out in spec.outputs:
        function = sp.lambdify(symbols, out.expressions, modules="numpy", cse=False)
        values = np.array([function(*row) for row in flat_inputs], dtype=float)
        results.append(values.reshape((len(flat_inputs), *out.shape)))
    return results


def _import(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _compile(c_file: Path, flags: list[str]) -> ctypes.CDLL:
    library = c_file.with_suffix(".so")
    subprocess.run([*CC.split(), *flags, "-O2", "-fPIC", "-shared", str(c_file), "-o", str(library), "-lm"],
                   check=True, capture_output=True, text=True)
    return ctypes.CDLL(str(library))


def _call_c(library, spec, arrays):
    n = arrays[0].shape[0]
    outputs = [np.empty((n, *out.shape)) for out in spec.outputs]
    pointer = ctypes.POINTER(ctypes.c_double)
    function = getattr(library, spec.name)
    function.restype = None
    function(ctypes.c_int64(n), *[a.ctypes.data_as(pointer) for a in arrays + outputs])
    return outputs


def _assert_close(actual, expected, what):
    for k, (a, e) in enumerate(zip(actual, expected)):
        assert a.shape == e.shape, f"{what}[{k}]: shape {a.shape} != {e.shape}"
        scale = max(np.linalg.norm(e), 1e-300)
        assert np.linalg.norm(a - e) <= 1e-10 * scale or np.linalg.norm(e) == 0 and not a.any(), \
            f"{what}[{k}]: relative error {np.linalg.norm(a - e) / scale:.3e}"


@pytest.mark.parametrize("variant", list(toy_kernels.VARIANTS))
def test_numpy_matches_sympy(toy_dir, variant):
    module = _import(toy_dir / f"beam_{variant}.py", f"toy_beam_{variant}")
    assert module.VARIANT == variant
    for spec in toy_kernels.build_kernels(variant):
        arrays = _inputs(spec, 7)
        result = getattr(module, spec.name)(*arrays)
        assert isinstance(result, tuple) and len(result) == len(spec.outputs)
        assert list(module.KERNELS[spec.name]["outputs"]) == [(o.name, o.shape) for o in spec.outputs]
        _assert_close(result, _direct(spec, arrays), f"numpy {spec.name}")
        empty = getattr(module, spec.name)(*[a[:0] for a in arrays])
        assert [e.shape for e in empty] == [(0, *o.shape) for o in spec.outputs]


def test_numpy_blocks(toy_dir):
    """More elements than one block of the generated loop."""
    module = _import(toy_dir / "beam_default.py", "toy_beam_default_blocks")
    spec = toy_kernels.build_kernels("default")[1]
    arrays = _inputs(spec, emit.NUMPY_BLOCK + 3, seed=3)
    result = getattr(module, spec.name)(*arrays)
    few = getattr(module, spec.name)(*[a[-5:] for a in arrays])
    for full, tail in zip(result, few):
        np.testing.assert_allclose(full[-5:], tail, rtol=1e-14)


@needs_cc
@pytest.mark.parametrize("variant", list(toy_kernels.VARIANTS))
def test_c_matches_sympy_and_compiles_strictly(toy_dir, variant):
    library = _compile(toy_dir / f"beam_{variant}.c", STRICT)
    subprocess.run([*CC.split(), *STRICT, "-fsyntax-only", "-x", "c", str(toy_dir / f"beam_{variant}.h")],
                   check=True, capture_output=True)
    for spec in toy_kernels.build_kernels(variant):
        arrays = _inputs(spec, 6, seed=1)
        _assert_close(_call_c(library, spec, arrays), _direct(spec, arrays), f"C {spec.name}")


def test_no_pow_for_integer_powers(toy_dir):
    text = (toy_dir / "beam_default.c").read_text()
    calls = re.findall(r"pow\(([^;]*?)\)", text)
    assert all(not re.search(r",\s*-?\d+(\.0)?\s*$", c) for c in calls), calls
    assert "latdyn_sqrt(" in text and "*latdyn_sqrt(" in text and "(1.0/" in text  # lane-wise (batched) sqrt


def test_power_printing():
    x = sp.Symbol("x", real=True)
    c = emit.CPrinter()
    assert c.doprint(x**2) == "(x*x)"
    assert c.doprint(x**3) == "(x*x*x)"
    assert c.doprint(x**-1) == "(1.0/x)"
    assert c.doprint(1 / x**2).replace(" ", "") in ("(1.0/(x*x))", "1.0/(x*x)", "1/(x*x)")
    assert c.doprint(sp.sqrt(x)) == "sqrt(x)"
    assert c.doprint(1 / sp.sqrt(x)) in ("(1.0/sqrt(x))", "1/sqrt(x)")
    assert c.doprint(x ** sp.Rational(3, 2)) == "(x*sqrt(x))"
    assert "pow(x, 2.0/3.0)" == c.doprint(x ** sp.Rational(2, 3))


def test_files_are_stamped(toy_dir):
    for path in sorted(p for p in toy_dir.iterdir() if p.suffix in (".py", ".c", ".h")):
        text = path.read_text(encoding="utf-8")
        head = "\n".join(text.splitlines()[:8])
        assert emit.MARKER in head and "latdyn-codegen" in head, path.name
        assert "sympy " in head and "symengine " in head and "jinja2 " in head
        assert emit.formulation_hash() in head
        assert str(HERE.parent) not in text and not re.search(r"20\d\d-\d\d-\d\d", text)
    header = (toy_dir / "beam_default.py").read_text()
    assert "beam_internal_force:" in header and "Eq. 30" in header and " ops" in header


def test_stray_symbol_refused():
    g = GEOMETRY.symbols()
    stray = sp.Symbol("bogus_7", real=True)
    spec = KernelSpec("beam_bad", "bad", [GEOMETRY, SECTION], [Output("x", (1,), [g[0] + stray])])
    with pytest.raises(emit.EmitError, match="bogus_7") as info:
        emit.lower(spec)
    assert "\n" not in str(info.value)


def test_intermediates():
    g = GEOMETRY.symbols()
    a, b = sp.symbols("a_len b_unused", real=True)
    spec = KernelSpec("beam_inter", "with intermediates", [GEOMETRY], [
        Output("y", (2,), [a**2 + 1, sp.sqrt(a) * g[1]])],
        intermediates=[(a, g[0] ** 2 + g[1] ** 2), (b, g[2])])
    lowered = emit.lower(spec)
    names = [s.name for s, _ in lowered.temporaries]
    assert "a_len" in names and "b_unused" not in names
    text = emit.c_function(lowered)
    assert "const latdyn_vec a_len =" in text


DETERMINISM_SCRIPT = r"""
import sys, hashlib
sys.path.insert(0, {tests!r})
import toy_kernels
from codegen import emit
specs = toy_kernels.build_kernels("default") + toy_kernels.big_kernels()[:0]
files, _ = emit.generate(toy_kernels.build_kernels, toy_kernels.VARIANTS,
                         joint_kernels=toy_kernels.build_joint_kernels)
big = emit.print_kernel(emit.lower(toy_kernels.medium_kernel()))
digest = hashlib.sha256()
for name in sorted(files):
    digest.update(files[name].encode())
digest.update(big.c_source.encode() + big.numpy_source.encode())
print(digest.hexdigest())
"""


def test_cse_deterministic_across_hash_seeds():
    script = DETERMINISM_SCRIPT.format(tests=str(HERE))
    digests = []
    for seed in ("0", "1", "12345"):
        env = dict(os.environ, PYTHONHASHSEED=seed)
        result = subprocess.run([sys.executable, "-c", script], env=env, cwd=HERE.parent,
                                capture_output=True, text=True, check=True)
        digests.append(result.stdout.strip())
    assert len(set(digests)) == 1, digests
