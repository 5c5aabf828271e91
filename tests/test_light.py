"""A light process: what a run imports, the caches that spare SymPy and the C printer, the
fallback without a C compiler, and the messages of missing extras (issue 18, items 4 and 6).

Each import check runs in a fresh interpreter (``python -c``) and reads ``sys.modules``.
"""
from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
#: Where the latdyn under test is: this checkout, or site-packages of a wheel's venv (.ci/run).
SOURCE = Path(importlib.util.find_spec("latdyn").origin).resolve().parents[1]

#: Scene of a beam on a hub turning by a table in t (no expression text): 0.2 s.
NO_EXPRESSIONS = """\
title: spin-up without expressions
sections:
  arm: {EA: 2.8e7, EIy: 1.4e4, EIz: 1.4e4, GJ: 1.0e4, rhoA: 1.2}
bodies:
  hub:
    at: [0, 0, 0]
    motion:
      rotation: {axis: [0, 0, 1], angle: {table: [[0, 0], [1, 0.5]]}}
beams:
  arm: {from: hub, to: [10, 0, 0], section: arm, elements: 4}
solve: {analysis: transient, t_end: 0.2, dt: 0.01}
output:
  every: 0.05
  probes:
    tip_v: {point: arm.end, quantity: position, frame: hub, component: y}
"""
#: The same with the spin-up's expression for the hub angle.
WITH_EXPRESSIONS = NO_EXPRESSIONS.replace(
    "{table: [[0, 0], [1, 0.5]]}",
    '"Piecewise((6/15*(t**2/2 + (15/(2*pi))**2*(cos(2*pi*t/15) - 1)), t < 15), (6*(t - 7.5), True))"')

#: Never imported by ``import latdyn`` nor by a run of a scene without expressions.
HEAVY = ("sympy", "codegen", "jinja2", "symengine", "matplotlib", "dask", "distributed", "tqdm",
         "pandas", "IPython")


def _python(code: str, cache: Path, **env) -> dict:
    """Run ``code`` in a fresh interpreter (the latdyn under test first on the path); the JSON it prints last."""
    environment = {**os.environ, "PYTHONPATH": str(SOURCE), "LATDYN_CACHE_DIR": str(cache), **env}
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          env=environment, timeout=600, cwd=cache.parent)
    assert done.returncode == 0, done.stderr
    return {**json.loads(done.stdout.strip().splitlines()[-1]), "stderr": done.stderr}


_RUN = """
    import json, sys
    import latdyn
    scene = latdyn.load_scene({path!r})
    result = latdyn.run(scene, out_dir={out!r})
    heavy = sorted({{name.split(".")[0] for name in sys.modules}} & set({heavy!r}))
    print(json.dumps({{"heavy": heavy, "tip": float(result.probes["tip_v"][-1]),
                      "linalg": "scipy.linalg" in sys.modules}}))
"""


def test_import_latdyn_is_light(tmp_path):
    found = _python(f"""
        import json, sys
        import latdyn
        print(json.dumps({{"modules": sorted(sys.modules)}}))
    """, tmp_path / "cache")
    modules = set(found["modules"])
    assert not {m.split(".")[0] for m in modules} & set(HEAVY)
    assert "scipy" not in modules and "numpy" not in modules and "h5py" not in modules


def test_run_without_expressions_imports_neither_sympy_nor_codegen(tmp_path):
    scene = tmp_path / "scene.yaml"
    scene.write_text(NO_EXPRESSIONS)
    code = _RUN.format(path=str(scene), out=str(tmp_path / "out"), heavy=HEAVY)
    # the first process in an empty cache compiles the kernels and prints the laws unit (the
    # table of the hub's angle) with codegen; a later one finds them in the cache
    first = _python(code, tmp_path / "cache")
    assert "sympy" not in first["stderr"]
    second = _python(code, tmp_path / "cache")
    assert second["heavy"] == []
    assert second["tip"] == first["tip"] and np.isfinite(second["tip"])


def test_scene_with_expressions_uses_the_caches_in_a_later_process(tmp_path):
    """The first process parses with SymPy and prints the laws in C; the second finds both
    by the expression's text: neither SymPy nor codegen, the same numbers."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(WITH_EXPRESSIONS)
    cache = tmp_path / "cache"
    first = _python(_RUN.format(path=str(scene), out=str(tmp_path / "a"), heavy=HEAVY), cache)
    assert "sympy" in first["heavy"] and "codegen" in first["heavy"]
    assert list((cache / "expressions").glob("time-*.json"))
    second = _python(_RUN.format(path=str(scene), out=str(tmp_path / "b"), heavy=HEAVY), cache)
    assert second["heavy"] == []
    assert second["tip"] == first["tip"]
    assert "compiling" not in second["stderr"]


#: What ``latdyn run`` of a transient scene that the dense LU serves must not import (issue 31,
#: item 5; docs/performance.md, "First run"): SciPy's sparse and dense packages (its LAPACK comes
#: from the extension ``scipy.linalg.cython_lapack`` alone), the analyses and the studies, and
#: what only they or SciPy's packages pull in (NumPy's random, masked arrays, f2py and testing).
NOT_FOR_A_SMALL_RUN = HEAVY + ("scipy.sparse", "scipy.linalg", "scipy.optimize", "scipy.integrate",
                               "numpy.random", "numpy.ma", "numpy.f2py", "numpy.testing", "unittest",
                               "difflib", "latdyn.analyses", "latdyn.studies",
                               "numpy.polynomial",  # the Gauss points of hinge-law potentials, on use
                               # SciPy's OpenBLAS is found in /proc/self/maps to pin it to one thread
                               # (latdyn.numerics.linalg.openblas_thread_functions); threadpoolctl
                               # inspects every loaded library (8-10 ms) and is left where that fails
                               *(("threadpoolctl",) if sys.platform.startswith("linux") else ()))

#: Writes the modules a process imported, as JSON, to $LATDYN_TEST_MODULES when it exits
#: (a sitecustomize on PYTHONPATH: the command itself runs unchanged).
_MODULES_HOOK = """\
import atexit, json, os, sys

def _dump():
    with open(os.environ["LATDYN_TEST_MODULES"], "w") as out:
        json.dump(sorted(sys.modules), out)

atexit.register(_dump)
"""


def _imported_by_a_run(tmp_path, scene_text: str) -> set[str]:
    """The modules a fresh ``python -m latdyn run`` of ``scene_text`` imports, with the kernels
    and laws already in the cache (a first run puts them there; the second is the one read)."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(scene_text)
    hook = tmp_path / "hook"
    hook.mkdir()
    (hook / "sitecustomize.py").write_text(_MODULES_HOOK)
    listing = tmp_path / "modules.json"
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join([str(hook), str(SOURCE)]),
                   "LATDYN_TEST_MODULES": str(listing)}
    for out in ("first", "second"):
        done = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(tmp_path / out), "-q"],
                              capture_output=True, text=True, env=environment, timeout=600, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
    assert (tmp_path / "second" / "probes.csv").read_text() == (tmp_path / "first" / "probes.csv").read_text()
    return set(json.loads(listing.read_text()))


def test_a_small_transient_run_imports_only_what_it_needs(tmp_path):
    """A beam on a hub (24 coordinates: the dense LU) run through the CLI: no SciPy package but
    its LAPACK extension, no analysis, nothing of NumPy's that only SciPy's packages import."""
    modules = _imported_by_a_run(tmp_path, NO_EXPRESSIONS.replace("t_end: 0.2", "t_end: 0.05"))
    assert {"latdyn.solve", "latdyn.timeloop.transient", "numpy", "latdyn.results.hdf5_writer"} <= modules  # the hook saw the run
    assert not {m for m in modules if m == "h5py" or m.startswith("h5py.")}  # latdyn writes its HDF5 files itself
    assert "scipy.linalg.cython_lapack" in modules  # where the dense LU's LAPACK comes from
    unneeded = sorted(m for m in modules - {"scipy.linalg.cython_lapack"}
                      if m in NOT_FOR_A_SMALL_RUN or m.startswith(tuple(n + "." for n in NOT_FOR_A_SMALL_RUN)))
    assert unneeded == [], f"a small transient run imported {unneeded}"
    # the kernels' metadata and libraries come from the unit index (latdyn.model.kernels._compiled_unit)
    generated = sorted(m for m in modules if m.startswith("latdyn_generated."))
    assert generated == [], f"a run with its kernels cached imported the generated modules {generated}"


def test_a_small_band_model_imports_no_sparse_package(tmp_path):
    """The 3D model of a beam of 8 elements (48 coordinates, bandwidth 11 after RCM) takes the band
    LU (latdyn.numerics.linalg.SMALL_BAND_FRACTION): its order comes from ``small_rcm_band``, not
    from ``scipy.sparse.csgraph``."""
    text = NO_EXPRESSIONS.replace("t_end: 0.2, dt: 0.01}", "t_end: 0.05, dt: 0.01, planar: off}").replace(
        "elements: 4", "elements: 8")
    modules = _imported_by_a_run(tmp_path, text)
    assert {"latdyn.solve", "latdyn.timeloop.transient", "numpy"} <= modules  # the hook saw the run
    summary = json.loads((tmp_path / "second" / "summary.json").read_text())
    assert summary["coordinates"] == 48
    unneeded = sorted(m for m in modules - {"scipy.linalg.cython_lapack"}
                      if m in NOT_FOR_A_SMALL_RUN or m.startswith(tuple(n + "." for n in NOT_FOR_A_SMALL_RUN)))
    assert unneeded == [], f"a small band model's run imported {unneeded}"


def test_scipy_lapack_without_scipy_linalg_is_the_same_lapack(tmp_path):
    """:func:`latdyn.assembly.library.scipy_extension` loads SciPy's LAPACK capsules without
    ``scipy.linalg``: the same routines as the ordinary import, which still works after it."""
    found = _python("""
        import json, sys
        from latdyn.assembly.library import cython_address, lapack_address
        before = {name: lapack_address(name) for name in ("dgetrf", "dgetrs", "dgbtrf", "dgbtrs")}
        alone = "scipy.linalg" not in sys.modules and "scipy.sparse" not in sys.modules
        import numpy as np
        import scipy.linalg
        import scipy.linalg.cython_lapack as lapack
        after = {name: cython_address(lapack, name) for name in before}
        lu, piv = scipy.linalg.lu_factor(np.array([[4.0, 3.0], [6.0, 3.0]]))
        print(json.dumps({"alone": alone, "same": before == after, "lu": lu.tolist()}))
    """, tmp_path / "cache")
    assert found["alone"] and found["same"]
    assert found["lu"] == [[6.0, 3.0], [4.0 / 6.0, 1.0]]



def test_scipy_openblas_is_pinned_though_blas_was_asked_before_it_was_loaded(tmp_path):
    """SciPy's LAPACK is loaded on use, so BLAS may be limited (``single_thread_blas``, e.g. the
    held check of a model of 65–120 coordinates) before SciPy's OpenBLAS is there: the compiled
    step must still pin SciPy's OpenBLAS, not NumPy's."""
    found = _python("""
        import ctypes, json
        from latdyn.numerics import linalg
        with linalg.single_thread_blas():  # BLAS looked up before SciPy's LAPACK is loaded
            pass
        from latdyn.assembly.library import lapack_address
        lapack_address("dgetrf")
        get, put = linalg.openblas_thread_functions()
        own = [lib for lib in linalg._blas_controllers(refresh=True)
               if lib.internal_api == "openblas" and linalg._in_scipy_folder(lib.filepath)]
        expected = None
        if len(own) == 1:
            prefix, suffix = own[0]._find_affixes()
            function = getattr(own[0].dynlib, f"{prefix}openblas_get_num_threads{suffix}")
            expected = ctypes.cast(function, ctypes.c_void_p).value
        print(json.dumps({"get": get, "expected": expected, "scipy_openblas": len(own)}))
    """, tmp_path / "cache")
    if found["scipy_openblas"] != 1:
        pytest.skip("SciPy's LAPACK is not its own OpenBLAS here")
    assert found["get"] == found["expected"] is not None


def test_instruction_set_macros_are_asked_once_per_compiler_and_cpu(monkeypatch, tmp_path):
    """The macros of -march= come from the kernel cache after the first process has asked the
    compiler; another CPU (another /proc/cpuinfo) asks the compiler again, into its own file."""
    from latdyn import native

    if native._cpu_identity() is None:
        pytest.skip("no /proc/cpuinfo: the compiler is asked in every process")
    monkeypatch.setenv("LATDYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(native, "_VECTOR_FLAGS", {})
    asked = []
    real_run = subprocess.run

    def counting_run(command, *args, **kwargs):
        if "-dM" in command:
            asked.append(command)
        return real_run(command, *args, **kwargs)

    monkeypatch.setattr(subprocess, "run", counting_run)  # native imports subprocess where it runs one
    first = native.isa_macros()
    assert first and len(asked) == 1 and len(list((tmp_path / "cache").glob("isa-*.txt"))) == 1
    monkeypatch.setattr(native, "_VECTOR_FLAGS", {})  # a fresh process
    assert native.isa_macros() == first and len(asked) == 1
    monkeypatch.setattr(native, "_VECTOR_FLAGS", {})
    monkeypatch.setattr(native, "_cpu_identity", lambda: b"flags: another cpu")
    assert native.isa_macros() == first and len(asked) == 2  # asked again (same compiler here)
    assert len(list((tmp_path / "cache").glob("isa-*.txt"))) == 2


def _fresh(monkeypatch, tmp_path):
    import latdyn.scene.expressions as expressions

    monkeypatch.setenv("LATDYN_CACHE_DIR", str(tmp_path / "cache"))
    return expressions


@pytest.mark.parametrize("text", [
    "Piecewise((6/15*(t**2/2 + (15/(2*pi))**2*(cos(2*pi*t/15) - 1)), t < 15), (6*(t - 7.5), True))",
    "3*sin(2*t)*exp(-t/4) + Heaviside(t - 1) * atan2(t, 2) + Max(t, 0.5) - abs(sign(t - 2))",
    "sqrt(1 + t**2) - log(2 + t) + tanh(t) * Min(1, t**3)",
    "2*pi",
])
def test_time_function_from_the_cache_equals_sympy(monkeypatch, tmp_path, text):
    expressions = _fresh(monkeypatch, tmp_path)
    made = expressions.TimeFunction(text)  # SymPy: parsed, stored
    assert list((tmp_path / "cache" / "expressions").glob("time-*.json"))
    read = expressions.TimeFunction(text)  # from the cache
    assert read._expr_cache is None and made._expr_cache is not None
    times = np.linspace(-1.0, 30.0, 311)
    for which in ("value", "rate", "accel"):
        np.testing.assert_array_equal(getattr(read, which)(times), getattr(made, which)(times))
        for t in (0.0, 0.37, 1.0, 15.0, 22.5):
            assert getattr(read, which)(t) == getattr(made, which)(t)
    assert read.kind == made.kind
    # SymPy's expressions again on demand (what codegen.laws prints)
    assert read.expressions == made.expressions


def test_hinge_law_from_the_cache_equals_sympy(monkeypatch, tmp_path):
    expressions = _fresh(monkeypatch, tmp_path)
    text = "-50*(1 + theta**2)*Heaviside(theta - 0.1) - 3*sign(theta_dot)*Max(abs(theta_dot), 0.2) + sin(t)"
    made = expressions.HingeLaw(text)
    read = expressions.HingeLaw(text)
    assert read._law_cache is None
    rng = np.random.default_rng(3)
    for theta, rate, t in rng.uniform(-2, 2, size=(50, 3)):
        for which in ("value", "d_theta", "d_rate"):
            assert getattr(read, which)(theta, rate, t) == getattr(made, which)(theta, rate, t)
    assert read.depends_on == made.depends_on
    assert read.expressions == made.expressions


def test_a_tampered_cache_entry_for_another_text_is_not_used(monkeypatch, tmp_path):
    expressions = _fresh(monkeypatch, tmp_path)
    expressions.TimeFunction("t**2")
    (path,) = (tmp_path / "cache" / "expressions").glob("time-*.json")
    entry = json.loads(path.read_text())
    entry["source"] = "t**3"  # not the text the key was made of
    path.write_text(json.dumps(entry))
    assert expressions.TimeFunction("t**2")._expr_cache is not None  # parsed again by SymPy


# ----------------------------------------------------------------------------- no compiler
def test_no_compiler_stops_the_run_and_names_the_fix(tmp_path):
    """The runtime evaluates natively only (latdyn/assembly/native_model.py): without a C compiler a
    run stops before it writes anything, with one line that says why and how to get one."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(NO_EXPRESSIONS)
    environment = {**os.environ, "PYTHONPATH": str(SOURCE), "LATDYN_CACHE_DIR": str(tmp_path / "cache"),
                   "CC": str(tmp_path / "no-such-cc")}
    done = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(tmp_path / "out"), "-q"],
                          capture_output=True, text=True, env=environment, timeout=600, cwd=tmp_path)
    assert done.returncode == 1, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("latdyn: "), done.stderr
    assert "no-such-cc" in lines[0] and 'pip install "latdyn[compiler]"' in lines[0]
    assert "Traceback" not in done.stderr and not (tmp_path / "out").exists()
    assert not list((tmp_path / "cache").glob("*.so"))


@pytest.mark.skipif(importlib.util.find_spec("ziglang") is None, reason="ziglang is not installed")
def test_zig_compiles_when_there_is_no_cc(monkeypatch, tmp_path):
    from latdyn import native

    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))  # no cc on it
    monkeypatch.setenv("LATDYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(native, "_COMPILER", {})
    compiler = native.compiler()
    assert compiler.name == "zig cc"
    path = native.build("twice", b"double twice(double x) { return 2.0 * x; }\n")
    library = native.load(path)
    import ctypes

    library.twice.restype, library.twice.argtypes = ctypes.c_double, [ctypes.c_double]
    assert library.twice(1.25) == 2.5
    assert native.build("twice", b"double twice(double x) { return 2.0 * x; }\n") == path  # cached


# ----------------------------------------------------------------------------- extras
def test_a_study_on_dask_without_dask_names_the_extra(monkeypatch, capsys, tmp_path):
    from latdyn import cli

    monkeypatch.setitem(sys.modules, "dask", None)  # import dask -> ImportError
    monkeypatch.setitem(sys.modules, "distributed", None)
    study = ROOT / "examples" / "studies" / "spinup_work_precision.yaml"
    status = cli.main(["study", str(study), "--scheduler", "local:2", "-q", "-o", str(tmp_path / "study")])
    err = capsys.readouterr().err
    assert status == 1
    assert err.count("\n") == 1 and 'pip install "latdyn[dask]"' in err, err


# ----------------------------------------------------------------------------- caches of a fresh process
def test_the_compiler_is_asked_its_version_once_per_binary(monkeypatch, tmp_path):
    """The ``--version`` that names the compiler in every library digest is kept in the kernel
    cache by the binary's path and file identity (latdyn.native._stored_version): a later process
    starts no compiler to load cached libraries; another binary is asked again."""
    import shutil

    from latdyn import native

    if os.environ.get("CC") or shutil.which("cc") is None:
        pytest.skip("needs cc on PATH and no $CC")
    monkeypatch.setenv("LATDYN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(native, "_COMPILER", {})
    asked = []
    real_run = subprocess.run

    def counting_run(command, *args, **kwargs):
        if "--version" in command:
            asked.append(command)
        return real_run(command, *args, **kwargs)

    monkeypatch.setattr(subprocess, "run", counting_run)  # native imports subprocess where it runs one
    first = native.compiler()
    assert len(asked) == 1 and len(list((tmp_path / "cache").glob("compiler-*.txt"))) == 1
    monkeypatch.setattr(native, "_COMPILER", {})  # a fresh process
    again = native.compiler()
    assert len(asked) == 1 and again.identity() == first.identity()
    real_stat = os.stat
    monkeypatch.setattr(native.os, "stat", lambda path, *a, **k: os.stat_result(
        tuple(real_stat(path, *a, **k))[:6] + (1,) + tuple(real_stat(path, *a, **k))[7:]))  # another size
    monkeypatch.setattr(native, "_COMPILER", {})
    assert native.compiler().identity() == first.identity() and len(asked) == 2


def test_kernels_from_the_unit_index_are_the_ones_made_without_it(monkeypatch, tmp_path):
    """A fresh process reads a generated unit's metadata and library files from its index in the
    kernel cache (latdyn.model.kernels._compiled_unit), without importing the generated module:
    the same metadata and libraries as made from the sources; an unreadable index is made again."""
    from latdyn.model import kernels

    index = tmp_path / "index-{}.marshal"
    monkeypatch.setattr(kernels, "_index", lambda stem: Path(str(index).format(stem)))
    monkeypatch.setattr(kernels, "_LOADED", {})
    made = kernels.load_kernels("c", "default_xy")  # no index yet: from the generated module
    assert Path(str(index).format("beam_default_xy")).is_file() and Path(str(index).format("joints")).is_file()
    real_import = kernels.importlib.import_module

    def no_generated_module(name, *args):
        assert not name.startswith(kernels.PACKAGE + "."), f"imported {name}"
        return real_import(name, *args)

    monkeypatch.setattr(kernels.importlib, "import_module", no_generated_module)
    monkeypatch.setattr(kernels, "_LOADED", {})
    read = kernels.load_kernels("c", "default_xy")
    assert read.info == made.info and read.names == made.names
    assert {n: lib._name for n, lib in read.libraries.items()} == {n: lib._name for n, lib in made.libraries.items()}
    frame = np.random.default_rng(1).standard_normal((3, read.info["so3_exp"]["inputs"][0][1]))
    for a, b in zip(read.so3_exp(frame), made.so3_exp(frame)):
        np.testing.assert_array_equal(a, b)
    monkeypatch.setattr(kernels.importlib, "import_module", real_import)
    Path(str(index).format("joints")).write_bytes(b"not an index")
    monkeypatch.setattr(kernels, "_LOADED", {})
    assert kernels.load_kernels("c", "default_xy").info == made.info
