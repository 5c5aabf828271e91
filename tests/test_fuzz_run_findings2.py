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
