"""What the outside check of int15 (2026-11-28: random whole runs against main 635b9a2, the kernel cache and
the laws' cache under stress) found, each through the front door and failing before its mend.

A kernel cache that cannot be written (``LATDYN_CACHE_DIR`` on a read-only mount, a shared folder of another
user): a library it lacks stopped the run with ``internal error: OSError: [Errno 30] Read-only file system:
'…/laws-….so.lock'`` (the compile's lock file), where a scene's laws can be evaluated without their C unit and
the element kernels' absence deserves a message that names the cache."""
from __future__ import annotations

import os
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
import yaml

import latdyn
from latdyn import native
from test_law_jumps import PLANAR

ROOT = Path(__file__).resolve().parents[1]

#: tests/test_law_jumps.py's rigid arm (J = 1/3 + 1 + 0.01 about its hinge) under a torque of 2 switched on at
#: T0: at t_end, θ = 2 (t_end − T0)² / 2J exactly; T0 = 0.0131 is a law no other test compiles
ARM = PLANAR.replace("0.013", "0.0131").replace("DT", "0.01").replace(", method: METHOD", "")
EXACT = 2.0 * (0.1 - 0.0131) ** 2 / (2 * (1.0 / 3.0 + 1.0 + 0.01))


@contextmanager
def read_only(folder: Path):
    """``folder`` made read-only for this process (chmod for a user, ``chattr +i`` for root, whom modes do not
    stop); skipped where neither can."""
    if os.geteuid() != 0:
        folder.chmod(0o555)
        undo = ["chmod", "755", str(folder)]
    else:
        made = subprocess.run(["chattr", "+i", str(folder)], capture_output=True)
        if made.returncode != 0:
            pytest.skip(f"cannot make {folder} read-only as root (chattr: {made.stderr.decode().strip()})")
        undo = ["chattr", "-i", str(folder)]
    try:
        yield folder
    finally:
        subprocess.run(undo, check=True)


def _cli(scene: Path, out: Path, cache: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, LATDYN_CACHE_DIR=str(cache), PYTHONPATH=os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]))
    return subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out), "-q"],
                          capture_output=True, text=True, cwd=scene.parent, env=env, timeout=300)


def _angle(out: Path) -> float:
    rows = np.genfromtxt(out / "probes.csv", delimiter=",", names=True)
    return float(rows["angle"][-1])


def test_a_read_only_cache_with_the_kernels_runs_a_new_law_without_its_c_unit(tmp_path, monkeypatch):
    """A read-only kernel cache holding every library of this session's cache (links to them) but not the
    laws' unit of a law it has not seen: the run evaluates the law without it and solves to the exact angle,
    through the CLI and the API. Before, ``internal error: PermissionError`` (OSError: read-only file system on a
    read-only mount) on the lock file of the laws' compile, exit status 1; the API raised it."""
    cache = tmp_path / "cache"
    cache.mkdir()
    for entry in native.cache_dir().iterdir():
        if entry.is_file() and not entry.name.endswith((".lock", ".tmp")):
            (cache / entry.name).symlink_to(entry)
    scene = tmp_path / "arm.yaml"
    scene.write_text(ARM)
    with read_only(cache):
        done = _cli(scene, tmp_path / "out", cache)
        assert done.returncode == 0, done.stderr
        assert "internal error" not in done.stderr
        assert abs(_angle(tmp_path / "out") - EXACT) < 1e-9
        monkeypatch.setenv("LATDYN_CACHE_DIR", str(cache))
        result = latdyn.run(latdyn.load_scene(yaml.safe_load(ARM)))
    assert result.summary["status"] == "solved"
    assert abs(result.probes["angle"][-1] - EXACT) < 1e-9


def test_an_empty_read_only_cache_is_named_in_the_message(tmp_path):
    """An empty read-only kernel cache: the element kernels cannot be compiled there, and the run says so,
    naming the folder and LATDYN_CACHE_DIR (exit status 1, no compiler advice: the compiler is there). Before,
    ``internal error: PermissionError: [Errno 1] Operation not permitted: '…/beam_….so.lock'``."""
    cache = tmp_path / "empty"
    cache.mkdir()
    scene = tmp_path / "arm.yaml"
    scene.write_text(ARM)
    with read_only(cache):
        done = _cli(scene, tmp_path / "out", cache)
    assert done.returncode == 1
    assert "internal error" not in done.stderr and "Traceback" not in done.stderr
    assert f"into the kernel cache {cache}" in done.stderr
    assert "set LATDYN_CACHE_DIR to a folder this process can write" in done.stderr
    assert "install cc" not in done.stderr


#: seed 502's case 57 of ``benchmarks/fuzz_runs.py --extended``, cut down: a 3D two-beam arm whose load and
#: hinge torque are zero at t = 0, where a static analysis takes them
ZERO_LOADS_BUCKLING = """\
sections:
  s0: {EA: 2192811.0, EIy: 817.6, EIz: 817.6, GJ: 654.1, rhoA: 0.649}
  s1: {EA: 1089508.0, EIy: 1956.4, EIz: 1956.4, GJ: 1028.0, rhoA: 1.631}
bodies:
  g: {at: [0, 0, 0], fixed: true}
  b0: {at: [0.0, -1.77, 0.0], mass: 1.093, inertia: [0.0916, 0.0385, 0.0829]}
  b1: {at: [1.93, -1.77, 0.0], mass: 2.485, inertia: [0.0476, 0.0543, 0.0429]}
beams:
  m0:
    from: g
    section: s0
    to: {body: b0, offset: [-0.043, -0.046, 0.112]}
    elements: 3
    end:
      hinge: {axis: [0.0, 0.0, 1.0], stiffness: 198.13*(1 + 0.5*sin(t)), torque: TORQUE}
  m1: {from: b0, section: s1, to: {body: b1, offset: [0.076, -0.014, -0.027]}, elements: 2}
loads:
- at: m1.start
  force: [0, 0, FORCE]
solve: {analysis: buckling, steps: 10}
output:
  probes:
    p0: {hinge: m0.end, quantity: rate}
"""


def test_buckling_under_loads_that_are_zero_at_t0_says_the_loads_move_nothing(tmp_path):
    """The loads of a static analysis are taken at t = 0; a force 14.05*sin(3*t) and a torque
    8.22*Heaviside(t - 0.01) are zero there. The buckling search reported a limit point at λ = 1.89e13
    ("solved", from K₁ of round-off: linearised factors 5.6e7 and up). It now refuses, saying the loads
    move nothing; the same scene with the loads' amplitudes as constants still finds its instability."""
    from latdyn.errors import SolverError

    zero = tmp_path / "zero.yaml"
    zero.write_text(ZERO_LOADS_BUCKLING.replace("TORQUE", "8.22*Heaviside(t - 0.01)")
                    .replace("FORCE", "14.05*sin(3*t)"), encoding="utf-8")
    done = _cli(zero, tmp_path / "out", Path(os.environ.get("LATDYN_CACHE_DIR") or tmp_path / "cache"))
    assert done.returncode == 1, done.stderr
    assert "buckling: the loads move nothing" in done.stderr and "Traceback" not in done.stderr, done.stderr
    with pytest.raises(SolverError, match="the loads move nothing"):
        latdyn.run(latdyn.load_scene(str(zero)))
    loaded = tmp_path / "loaded.yaml"
    loaded.write_text(ZERO_LOADS_BUCKLING.replace("TORQUE", "8.22").replace("FORCE", "14.05"), encoding="utf-8")
    result = latdyn.run(latdyn.load_scene(str(loaded)))
    assert result.summary["instability"] == "buckling"
    assert 1.0 < result.summary["buckling_factor"] < 1e4
