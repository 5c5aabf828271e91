"""A scene typed as YAML, run as a user runs it: ``python -m latdyn run SCENE -o OUT`` in a fresh
process, this checkout first on the path; and what the results folder holds, read back.

One helper for the test files that go through the front door (they kept copies of it)."""
from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def latdyn_run(tmp_path: Path, text: str, *, name: str = "scene.yaml", quiet: bool = False,
               timeout: float | None = 120.0) -> tuple[subprocess.CompletedProcess, Path]:
    """Write ``text`` to ``tmp_path/name`` and run it into ``tmp_path/out``: (the completed
    process, the results folder)."""
    scene, out = tmp_path / name, tmp_path / "out"
    scene.write_text(text)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    command = [sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out)] + (["-q"] if quiet else [])
    completed = subprocess.run(command, env=env, capture_output=True, text=True, cwd=tmp_path,
                               timeout=timeout, check=False)
    return completed, out


def latdyn_run_switched(tmp_path: Path, scene: Path, out: Path, switches: str,
                        timeout: float = 120.0) -> subprocess.CompletedProcess:
    """``latdyn run scene -o out`` in a fresh process that first runs ``switches`` (Python statements setting a
    module's private switch, e.g. ``import latdyn.analyses.adjoint_in_loop as m; m.ADJOINT_IN_LOOP = False``)."""
    code = f"import sys; {switches}; from latdyn.cli import main; sys.exit(main(sys.argv[1:]))"
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-c", code, "run", str(scene), "-o", str(out)], env=env,
                          capture_output=True, text=True, cwd=tmp_path, timeout=timeout, check=False)


def the_loop_off_writes_the_same(tmp_path: Path, out: Path) -> None:
    """The scene ``tmp_path/scene.yaml`` that ``latdyn_run`` ran into ``out`` run again in a fresh process with the
    sensitivities' loop of steps off (latdyn.analyses.sensitivities_in_loop's private ``SENSITIVITIES_IN_LOOP``): no
    step in the loop there, and the same sensitivities.csv and probes.csv byte for byte and summary.json's probe and
    event sensitivities."""
    reference = tmp_path / "python"
    run = latdyn_run_switched(tmp_path, tmp_path / "scene.yaml", reference,
                              "import latdyn.analyses.sensitivities_in_loop as loop; loop.SENSITIVITIES_IN_LOOP = False")
    assert run.returncode == 0, run.stderr
    summary, python = summary_of(out), summary_of(reference)
    assert python["sensitivity_steps_in_loop"] == 0
    for name in ("sensitivities.csv", "probes.csv"):
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name
    assert summary["probe_sensitivities"] == python["probe_sensitivities"]
    assert summary["event_sensitivities"] == python["event_sensitivities"]


def summary_of(out: Path) -> dict | None:
    """summary.json of a results folder, None when there is none."""
    path = out / "summary.json"
    return json.loads(path.read_text()) if path.exists() else None


def probe_columns(out: Path) -> dict[str, np.ndarray]:
    """probes.csv of a results folder, as columns."""
    with open(out / "probes.csv") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}
