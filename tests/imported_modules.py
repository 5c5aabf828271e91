"""The modules a fresh ``latdyn run`` imports, as the fresh-process tests read them: a ``sitecustomize`` on
PYTHONPATH writes ``sys.modules`` as JSON to $LATDYN_TEST_MODULES when the process exits, so the command itself
runs unchanged (tests/test_sensitivities_fresh_process.py, test_latch_fresh_process.py,
test_adjoint_fresh_process.py)."""
from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

#: Where the latdyn under test is: this checkout, or site-packages of a wheel's venv (.ci/run).
SOURCE = Path(importlib.util.find_spec("latdyn").origin).resolve().parents[1]

#: Writes the modules a process imported, as JSON, to $LATDYN_TEST_MODULES when it exits.
MODULES_HOOK = """\
import atexit, json, os, sys

def _dump():
    with open(os.environ["LATDYN_TEST_MODULES"], "w") as out:
        json.dump(sorted(sys.modules), out)

atexit.register(_dump)
"""


def listing_environment(tmp_path: Path) -> dict:
    """The environment of a process whose imported modules are listed: the hook in ``tmp_path/hook`` ahead of the
    latdyn under test on PYTHONPATH (the listing's file named by $LATDYN_TEST_MODULES, per run: :func:`run_listed`)."""
    hook = tmp_path / "hook"
    hook.mkdir(exist_ok=True)
    (hook / "sitecustomize.py").write_text(MODULES_HOOK)
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(hook), str(SOURCE)])}


def run_listed(environment: dict, scene: Path, out: Path, listing: Path) -> set[str]:
    """The modules a fresh ``python -m latdyn run scene -o out -q`` imported (``environment``:
    :func:`listing_environment`); asserts that it ended with 0."""
    done = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out), "-q"],
                          capture_output=True, text=True, timeout=900, cwd=scene.parent,
                          env={**environment, "LATDYN_TEST_MODULES": str(listing)})
    assert done.returncode == 0, done.stderr
    return set(json.loads(listing.read_text()))


def sparse_modules(modules: set[str]) -> list[str]:
    """scipy.sparse and its submodules among ``modules``."""
    return sorted(m for m in modules if m == "scipy.sparse" or m.startswith("scipy.sparse."))
