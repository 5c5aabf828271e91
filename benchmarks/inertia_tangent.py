"""The elements' inertia tangent: its cost per element-iteration, and runs with ``newton: exact``.

    python benchmarks/inertia_tangent.py [--elements 48] [--repeat 200] [--runs OUT.json]

1. Cost: one native evaluation with the matrices (``latdyn_evaluate``) of a free-flying 3D beam
   of ``--elements`` shear-deformable elements (the ``default`` variant, gravity, offsets none) at a
   random large-rotation state with random rates and accelerations, with and without the inertia
   tangent; the difference per element is what the tangent costs an element-iteration (medians
   of ``--repeat`` calls).
2. Runs (``--runs``): scenes that use the inertia tangent (``solve.newton: exact``), their probes
   at every row and the Newton iterations, written to a JSON file; run it on two builds and compare
   the files with ``--compare A.json B.json``.

Runs on whatever ``latdyn`` is imported (PYTHONPATH), so the same script measures two builds: the
central differences of before issue 31 and the generated kernel ``beam_inertia_tangent`` (forward
mode of the lowered force, codegen/forward.py); docs/performance.md has the numbers.
"""
from __future__ import annotations

import argparse
import copy
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

import latdyn

ROOT = Path(__file__).resolve().parents[1]


def free_beam(elements: int) -> dict:
    return {
        "gravity": [0.0, -9.81, -2.0],
        "sections": {"s": {"EA": 5e5, "EIy": 80.0, "EIz": 120.0, "GJ": 60.0, "rhoA": 0.8, "rhoIy": 1e-3,
                           "rhoIz": 2e-3, "GAy": 3.0e4, "GAz": 2.0e4}},
        "beams": {"b": {"from": [0, 0, 0], "to": [3.0, 0.4, 0.2], "section": "s", "elements": elements,
                        "y_axis": [0, 0, 1]}},
        "solve": {"analysis": "transient", "t_end": 0.01, "dt": 0.005},
    }


def cost(elements: int, repeat: int) -> dict:
    from latdyn.assembly.assembler import unpack_free
    from latdyn.assembly.prepare import prepare

    prepared = prepare(latdyn.load_scene(free_beam(elements)))
    model, assembler = prepared.model, prepared.assembler
    rng = np.random.default_rng(1)
    n = model.n_dofs
    state = assembler.advance(prepared.state, 0.3 * rng.standard_normal(n))
    unpack_free(model, rng.standard_normal(n), state.v, state.w, state.theta_dot)
    unpack_free(model, 5 * rng.standard_normal(n), state.a, state.alpha, state.theta_ddot)
    native = assembler.native(True)
    times = {}
    for tangent in (False, True, False, True):
        samples = []
        for _ in range(repeat):
            start = time.perf_counter()
            native.evaluate(state, True, 1.0, True, tangent)
            samples.append(time.perf_counter() - start)
        times[tangent] = float(np.median(samples))
    E = len(model.element_nodes)
    return {"elements": E, "evaluation_us_per_element": 1e6 * times[False] / E,
            "with_tangent_us_per_element": 1e6 * times[True] / E,
            "tangent_us_per_element": 1e6 * (times[True] - times[False]) / E}


def scenes() -> dict[str, dict]:
    sys.path.insert(0, str(ROOT / "tests"))
    from test_engine import loaded_arm

    d4 = yaml.safe_load((ROOT / "examples" / "benchmarks" / "D4_flexible_pendulum.yaml").read_text())
    d4["solve"].update(planar="off", t_end=0.3, newton="exact", method="generalized-alpha", rho_inf=0.8)
    spin = yaml.safe_load((ROOT / "examples" / "spinup.yaml").read_text())
    spin["solve"].update(t_end=2.0, newton="exact")
    arm = loaded_arm(t_end=0.3, newton="exact")
    return {"D4_3d_exact": d4, "spinup_exact": spin, "loaded_arm_exact": arm}


def runs(path: Path) -> None:
    out = {}
    for name, raw in scenes().items():
        folder = Path(tempfile.mkdtemp(prefix=f"it-{name}-"))
        start = time.perf_counter()
        result = latdyn.run(latdyn.load_scene(copy.deepcopy(raw)), folder)
        wall = time.perf_counter() - start
        summary = json.loads((folder / "summary.json").read_text())
        out[name] = {"t": np.asarray(result.t).tolist(),
                     "probes": {k: np.asarray(v).tolist() for k, v in result.probes.items()},
                     "steps": summary.get("steps"), "newton_iterations": summary.get("newton_iterations"),
                     "status": summary.get("status"), "solver_s": summary.get("solver_s"), "wall_s": wall}
        print(f"{name:>18}: {summary.get('status')}, {summary.get('steps')} steps, "
              f"{summary.get('newton_iterations')} iterations, solver {summary.get('solver_s')} s")
    path.write_text(json.dumps(out))


def compare(a: Path, b: Path) -> None:
    A, B = json.loads(a.read_text()), json.loads(b.read_text())
    for name in A:
        x, y = A[name], B[name]
        worst = 0.0
        for key, values in x["probes"].items():
            u, v = np.asarray(values), np.asarray(y["probes"][key])
            if u.shape != v.shape:
                worst = np.inf
                break
            worst = max(worst, float(np.max(np.abs(u - v)) / max(np.max(np.abs(u)), 1e-300)))
        print(f"{name:>18}: iterations {x['newton_iterations']} -> {y['newton_iterations']}, steps {x['steps']} -> "
              f"{y['steps']}, largest probe difference {worst:.2e} of the probe's largest value, "
              f"solver {x['solver_s']} -> {y['solver_s']} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elements", type=int, default=48)
    parser.add_argument("--repeat", type=int, default=200)
    parser.add_argument("--runs", type=Path)
    parser.add_argument("--compare", type=Path, nargs=2)
    args = parser.parse_args()
    if args.compare:
        compare(*args.compare)
        return
    print(json.dumps(cost(args.elements, args.repeat)))
    if args.runs:
        runs(args.runs)


if __name__ == "__main__":
    main()
