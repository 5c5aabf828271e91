"""A scene run through the API (``latdyn.run``) gives the bits ``latdyn run`` gives, whatever the threads of the
BLAS that NumPy carries: the command starts OpenBLAS on one thread (latdyn.cli.one_blas_thread), and a product
OpenBLAS splits across threads adds in another order. examples/cable_deploying_truss.yaml's probes.csv differed
in its last bits from its third row on (0.8659922142730094 against …095) where NumPy's OpenBLAS ran two threads
in the calling process (and in ``latdyn run`` under the user's ``OPENBLAS_NUM_THREADS=2``); latdyn.run, which the
command calls too, now holds NumPy's and SciPy's OpenBLAS on one thread while it runs
(latdyn.numerics.linalg.blas_on_one_thread) and gives the caller's count back after it."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: the API run in a process of its own, NumPy's OpenBLAS set to two threads first (threadpoolctl; a machine of one
#: core would otherwise give it one), the count read back after the run
API = """\
import json, sys
import numpy
from threadpoolctl import threadpool_limits, threadpool_info
import latdyn
threadpool_limits(2, user_api="blas")
before = [lib["num_threads"] for lib in threadpool_info() if "numpy" in lib["filepath"]]
latdyn.run(latdyn.load_scene(sys.argv[1]), out_dir=sys.argv[2])
after = [lib["num_threads"] for lib in threadpool_info() if "numpy" in lib["filepath"]]
print(json.dumps({"before": before, "after": after}))
"""


def _environment() -> dict:
    environment = {key: value for key, value in os.environ.items()
                   if key not in ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")}
    environment["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)
    return environment


def test_the_cable_truss_through_the_api_gives_the_commands_bits_and_the_callers_threads_back(tmp_path):
    text = (ROOT / "examples" / "cable_deploying_truss.yaml").read_text().replace("t_end: 4.0", "t_end: 0.06")
    assert "t_end: 0.06" in text
    scene = tmp_path / "truss.yaml"
    scene.write_text(text)
    command = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(tmp_path / "command"), "-q"],
                             env=_environment(), capture_output=True, text=True, timeout=600)
    assert command.returncode == 0, command.stderr
    api = subprocess.run([sys.executable, "-c", API, str(scene), str(tmp_path / "api")], env=_environment(),
                         capture_output=True, text=True, timeout=600)
    assert api.returncode == 0, api.stderr
    threads = json.loads(api.stdout.strip().splitlines()[-1])
    assert threads["before"] == threads["after"] == [2]   # the caller's setting, given back
    assert (tmp_path / "api" / "probes.csv").read_bytes() == (tmp_path / "command" / "probes.csv").read_bytes()
    kept = ("events", "steps", "newton_iterations", "energy_balance_error")
    made = [{key: json.loads((tmp_path / run / "summary.json").read_text()).get(key) for key in kept}
            for run in ("api", "command")]
    assert made[0] == made[1]
    # the command with the user's two threads (which it keeps for the process): the same bits
    chosen = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(tmp_path / "two"), "-q"],
                            env={**_environment(), "OPENBLAS_NUM_THREADS": "2"}, capture_output=True, text=True,
                            timeout=600)
    assert chosen.returncode == 0, chosen.stderr
    assert (tmp_path / "two" / "probes.csv").read_bytes() == (tmp_path / "command" / "probes.csv").read_bytes()
