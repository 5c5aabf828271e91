"""Full Newton's convergence test: |Δx_k| ≤ tol against the error left estimated from the contraction.

    python benchmarks/newton_convergence_test.py [--problems truss cantilever spinup cable]

Issue 31 item 6 ("fewer iterations where they buy nothing"). Full Newton's test as shipped, |Δx_k| ≤ tol,
against the error left estimated from the contraction, ρ/(1 − ρ) |Δx_k| ≤ tol with ρ = |Δx_k| / |Δx_{k−1}|
(``CompiledGeneralizedAlpha.estimate_error`` switched on; models with events keep |Δx_k| ≤ tol either
way): each runs, in a process of its own, the scenes below at their defaults (``tol`` 1e-8, a row every
``dt`` of the run); the references are the same scenes at dt/4 with ``tol`` 1e-12, and at the same dt
with ``tol`` 1e-12 (what Newton's own error is), with the shipped test. Scenes:

- ``truss``: the 260-member spinning truss of ``kernel_throughput.py --whole-solver`` (1 s, dt 0.01)
  with the probes of ``newton_iteration_matrix.py``;
- ``cantilever``: the 16-element right-angle cantilever (30 s, dt 0.01), its probes;
- ``spinup``: the shipped Kane spin-up (``latdyn/examples/spinup.yaml``, 20 s, dt 0.005);
- ``cable``: ``examples/cable_deploying_truss.yaml`` cut to 0.3 s (dt 0.002): its cables go slack
  and taut on the way, events placed from the last iterates.

Each probe's error: its largest difference over the run from the reference's at the same times, over
the reference probe's range (an energy: over its largest size). Printed as a Markdown table and written
to ``benchmarks/results/newton_convergence_test.json`` (docs/performance.md, "Fewer iterations where
they buy nothing").
"""
from __future__ import annotations

import argparse
import copy
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "newton_convergence_test.json"
PROBLEMS = ("truss", "cantilever", "spinup", "cable")


def problems() -> dict:
    """The four scenes, as dictionaries."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from newton_iteration_matrix import problems as truss_and_cantilever

    scenes = truss_and_cantilever()
    scenes["spinup"] = yaml.safe_load((ROOT / "latdyn" / "examples" / "spinup.yaml").read_text())
    cable = yaml.safe_load((ROOT / "examples" / "cable_deploying_truss.yaml").read_text())
    cable["solve"]["t_end"] = 0.3
    scenes["cable"] = cable
    return scenes


def child(scene_file: str, out_file: str, dt_divisor: int, tol: float | None, estimate: bool) -> None:
    """In a process of its own: one run, its probes and counts saved; ``estimate``: full Newton stops on
    the error left estimated from the contraction."""
    import latdyn
    from latdyn.step import compiled

    if estimate:
        made = compiled.CompiledGeneralizedAlpha.__init__

        def with_the_estimate(self, *args, **kwargs):
            made(self, *args, **kwargs)
            self.estimate_error = not self.modified

        compiled.CompiledGeneralizedAlpha.__init__ = with_the_estimate

    raw = json.loads(Path(scene_file).read_text())
    solve = raw["solve"]
    dt = float(solve["dt"])
    solve["dt"] = dt / dt_divisor
    if tol is not None:
        solve["tol"] = tol
    raw.setdefault("output", {})["every"] = dt
    cpu = time.process_time()
    result = latdyn.run(latdyn.load_scene(raw))
    cpu = time.process_time() - cpu
    s = result.summary
    np.savez(out_file, t=np.asarray(result.t), names=np.array(list(result.probes)),
             values=np.array([np.asarray(v) for v in result.probes.values()]),
             counts=np.array([s["steps"], s["newton_iterations"], s["solver_s"], cpu]),
             package=np.array(str(Path(latdyn.__file__).resolve().parents[1])))


def run_in(raw: dict, dt_divisor: int = 1, tol: float | None = None, estimate: bool = False) -> dict:
    with tempfile.TemporaryDirectory() as folder:
        scene, out = Path(folder) / "scene.json", Path(folder) / "run.npz"
        scene.write_text(json.dumps(raw))
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        subprocess.run([sys.executable, str(Path(__file__).resolve()), "--child", str(scene), str(out),
                        str(dt_divisor), "" if tol is None else repr(tol), str(int(estimate))], check=True, env=env,
                       cwd=folder)
        data = np.load(out)
        steps, iterations, solver_s, cpu = data["counts"]
        return {"t": data["t"], "probes": dict(zip(data["names"].tolist(), data["values"])),
                "steps": int(steps), "newton_iterations": int(iterations), "solver_s": float(solver_s),
                "cpu_s": float(cpu), "package": str(data["package"])}


def errors(run_: dict, reference: dict) -> dict:
    """Each probe's largest difference from the reference's at the same times, over its range."""
    out = {}
    at = np.searchsorted(reference["t"], run_["t"] - 1e-12)
    assert np.allclose(reference["t"][at], run_["t"], atol=1e-9), "the rows' times differ"
    for name, values in run_["probes"].items():
        ref = reference["probes"][name][at]
        scale = float(np.max(np.abs(ref))) if name.startswith(("energy", "kinetic")) else float(np.ptp(ref))
        out[name] = float(np.max(np.abs(values - ref))) / scale
    return out


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problems", nargs="*", default=list(PROBLEMS), choices=PROBLEMS)
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    load = [os.getloadavg()[0]]
    doc = {"problems": {}}
    scenes = problems()
    lines = ["| scene | test | iterations | CPU s | error against dt/4, tol 1e-12, per probe | largest | "
             "against tol 1e-12 (Newton's own) | moved |", "|---|---|---|---|---|---|---|---|"]
    for name in args.problems:
        raw = scenes[name]
        reference = run_in(copy.deepcopy(raw), 4, 1e-12)
        tight = run_in(copy.deepcopy(raw), 1, 1e-12)
        runs = {"shipped": run_in(copy.deepcopy(raw)), "estimate": run_in(copy.deepcopy(raw), estimate=True)}
        rows = {}
        for label, r in runs.items():
            e = errors(r, reference)
            rows[label] = {"package": r["package"], "steps": r["steps"], "newton_iterations": r["newton_iterations"],
                           "cpu_s": r["cpu_s"], "error": e, "largest": max(e.values()),
                           "newton_error": max(errors(r, tight).values())}
        rows["estimate"]["moved"] = max(errors(runs["estimate"], runs["shipped"]).values())
        doc["problems"][name] = rows
        for label, test in (("shipped", "‖Δx‖ ≤ tol"), ("estimate", "estimate ≤ tol")):
            r = rows[label]
            per = ", ".join(f"{k} {v:.3g}" for k, v in r["error"].items())
            lines.append(f"| {name} | {test} | {r['newton_iterations']} | {r['cpu_s']:.3f} | {per} | {r['largest']:.3g} | "
                         f"{r['newton_error']:.2g} | {r.get('moved', float('nan')):.2g} |")
    load.append(os.getloadavg()[0])
    doc["load_average"] = load
    args.out.write_text(json.dumps(doc, indent=1) + "\n")
    print("\n".join(lines))
    print(f"load {load[0]:.1f} -> {load[1]:.1f}")
    return doc


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(sys.argv[2], sys.argv[3], int(sys.argv[4]), float(sys.argv[5]) if sys.argv[5] else None,
              sys.argv[6] == "1")
    else:
        main()
