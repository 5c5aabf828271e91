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
