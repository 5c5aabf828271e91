"""``latdyn-codegen`` (python -m codegen): --check, unknown variants, stale detection."""
from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
HERE = Path(__file__).resolve().parent
has_derivation = importlib.util.find_spec("codegen.derivation") is not None


def _run(*args, toy=False):
    env = dict(os.environ)
    if toy:
        env["PYTHONPATH"] = os.pathsep.join([str(HERE), env.get("PYTHONPATH", "")])
        args = ("--derivation", "toy_kernels", *args)
    return subprocess.run([sys.executable, "-m", "codegen", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=600)


def test_committed_tree_carries_the_generators_stamp():
    """The cheap check, every run: every generated file carries the hash of today's generator
    (codegen/*.py and its templates). A change to the generator without regenerating fails here;
    the full byte-for-byte regeneration (``latdyn-codegen --check``, minutes) runs once in CI,
    in .ci/run, not in the suite."""
    from codegen import emit

    digest = emit.formulation_hash()
    generated = sorted(p for p in (ROOT / "generated").iterdir() if p.suffix in (".py", ".c", ".h"))
    assert len(generated) > 3
    stale = [p.name for p in generated if f"Formulation hash: {digest}" not in p.read_text()[:2000]
             and p.name != "__init__.py"]
    assert not stale, f"generated with another generator than today's {digest}: {stale}; run latdyn-codegen"
    import latdyn_generated

    assert latdyn_generated.FORMULATION_HASH == digest


@pytest.mark.skipif(not has_derivation, reason="codegen/derivation.py not written yet")
def test_unknown_variant_exits_2():
    result = _run("--variant", "nope")
    assert result.returncode == 2
    assert "latdyn-codegen: unknown variant 'nope' (known: default, cr4402, no_stiffening, default_yz," in result.stderr
    assert "no_stiffening_xy)" in result.stderr  # the planar variants of each formulation follow


def test_unknown_variant_toy():
    result = _run("--variant", "x", toy=True)
    assert result.returncode == 2
    assert "unknown variant 'x' (known: default, no_stiffening)" in result.stderr


def test_check_detects_tampering(tmp_path):
    out = tmp_path / "generated"
    made = _run("--out", str(out), toy=True)
    assert made.returncode == 0, made.stderr
    assert "cse" in made.stdout and "ops" in made.stdout
    assert _run("--check", "--out", str(out), toy=True).returncode == 0
    path = out / "beam_no_stiffening.c"
    path.write_text(path.read_text().replace("sqrt(", "sqrtf(", 1))
    stale = _run("--check", "--out", str(out), toy=True)
    assert stale.returncode == 1
    assert "beam_no_stiffening.c" in stale.stdout and "line" in stale.stdout
    (out / "beam_default.h").unlink()
    shutil.copy(out / "beam_default.py", out / "beam_old.py")
    stale = _run("--check", "--out", str(out), toy=True)
    assert stale.returncode == 1
    assert "missing: beam_default.h" in stale.stdout and "extra:   beam_old.py" in stale.stdout
    assert _run("--out", str(out), toy=True).returncode == 0      # regenerating repairs it
    assert not (out / "beam_old.py").exists()
    assert _run("--check", "--out", str(out), toy=True).returncode == 0
