"""Which iteration matrix and Newton should the transient step use? Issue 31 item 6, measured.

    python benchmarks/newton_iteration_matrix.py [--repeats 3] [--problems truss cantilever]
    python benchmarks/newton_iteration_matrix.py --sweep

For the 260-member truss (``benchmarks/linear_solvers.py lattice_for(260)``: 125 joint bodies, 260
one-element members, Newmark dt 0.01 to 1 s) and the 16-element right-angle cantilever
(``examples/benchmarks/D2_right_angle_cantilever.yaml`` with 8 elements a leg, 30 s at dt 0.01: the
two scenes of ``kernel_throughput.py --whole-solver``), each run in process with ``solve.newton``

- ``full``: full Newton, S = β′M + γ′C + K (the default; no inertia tangent, so it converges
  linearly where the inertia forces turn with the rotations);
- ``exact``: full Newton with the elements' generated inertia tangent ∂(M v̇ + g)/∂q in S
  (``beam_inertia_tangent``, ``inertia_tangent`` of ``csrc/evaluate.c``);
- ``modified``: the factorization kept while the increments contract (``contraction``, 0.5).

Every run records a row every step (``output.every: dt``) of a few probes (displacements of two
points, a rotation where the scene has one, the total energy); the reference is the same scene at
dt/4 with full Newton and ``tol`` 1e-12, its rows taken at the run's times. ``error``: the largest
difference over the run of each probe from the reference, divided by the reference probe's range
(max − min; an energy, nearly constant, by its largest size), the largest over the probes;
``error_vs_full``: the same against the ``full`` run (what the choice moves). Times: the medians of
``--repeats`` runs (after one untimed) of ``solver_s`` (wall, inside the steps) and of the process CPU
time of the whole ``latdyn.run``; the 1-minute load average before and after. Results:
``benchmarks/results/newton_iteration_matrix.json`` and a Markdown table on stdout (docs/performance.md,
"Sixth pass").

``--sweep``: how full Newton converges on the truss, 0.1 s of it: the iterations a step at ``tol``
1e-6, 1e-8, 1e-10, 1e-12 with and without the elements' inertia tangent (``full``, ``exact``), at rest,
with the joint bodies' rotary inertia or their mass taken away, and at other step
sizes h and spin rates ω (the scene's ``initial_velocity.angular``). Iterations growing by one for every
factor 100 of the tolerance are linear convergence with a contraction ≈ 1e-2; quadratic convergence
would add at most one iteration over the whole range.
"""
from __future__ import annotations

import argparse
import copy
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT))

import latdyn  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "newton_iteration_matrix.json"
NEWTONS = ("full", "exact", "modified")


def problems() -> dict:
    """The two scenes, with their probes, as dictionaries."""
    from linear_solvers import lattice_for

    truss = lattice_for(260)
    truss["output"] = {"probes": {
        "top_x": {"point": "j4_4_4", "quantity": "displacement", "frame": "global", "component": "x"},
        "top_y": {"point": "j4_4_4", "quantity": "displacement", "frame": "global", "component": "y"},
        "top_z": {"point": "j4_4_4", "quantity": "displacement", "frame": "global", "component": "z"},
        "middle_x": {"point": "j2_2_2", "quantity": "displacement", "frame": "global", "component": "x"},
        "energy": {"energy": "total"}}}
    cantilever = yaml.safe_load((ROOT / "examples" / "benchmarks" / "D2_right_angle_cantilever.yaml").read_text())
    cantilever["beams"]["leg1"]["elements"] = cantilever["beams"]["leg2"]["elements"] = 8
    cantilever["solve"].update(t_end=30.0, dt=0.01)
    cantilever["output"]["probes"].pop("work", None)  # the external work of a load that ends is 0 after it
    return {"truss": truss, "cantilever": cantilever}


def run(raw: dict, newton: str, dt_divisor: int = 1, tol: float | None = None) -> dict:
    scene = copy.deepcopy(raw)
    solve = scene["solve"]
    solve["newton"] = newton
    solve["dt"] = float(solve["dt"]) / dt_divisor
    if tol is not None:
        solve["tol"] = tol
    scene.setdefault("output", {})["every"] = float(raw["solve"]["dt"])
    cpu = time.process_time()
    result = latdyn.run(latdyn.load_scene(scene))
    cpu = time.process_time() - cpu
    s = result.summary
    return {"solver_s": s["solver_s"], "cpu_s": cpu, "steps": s["steps"], "newton_iterations": s["newton_iterations"],
            "factorizations": s["factorizations"], "elements": s["elements"], "t": np.asarray(result.t),
            "probes": {k: np.asarray(v) for k, v in result.probes.items()}}


def difference(run_: dict, reference: dict) -> dict:
    """Each probe's largest difference from the reference's at the same times, over its range."""
    out = {}
    for name, values in run_["probes"].items():
        ref = reference["probes"][name]
        at = np.searchsorted(reference["t"], run_["t"] - 1e-12)
        assert np.allclose(reference["t"][at], run_["t"], atol=1e-9), "the rows' times differ"
        # a displacement over its range; an energy (nearly constant) over its size
        scale = float(np.max(np.abs(ref))) if name.startswith("energy") else float(np.ptp(ref))
        out[name] = float(np.max(np.abs(values - ref[at]))) / scale
    return out


TOLERANCES = (1e-6, 1e-8, 1e-10, 1e-12)


def sweep() -> list[dict]:
    """The iterations a step of 0.1 s of the truss at each tolerance, for the cases of ``--sweep``."""
    base = problems()["truss"]
    base["solve"]["t_end"] = 0.1
    base.pop("output")

    def case(label, newton="full", dt=0.01, omega=0.5, inertia=None, mass=None):
        scene = copy.deepcopy(base)
        scene["solve"].update(newton=newton, dt=dt)
        scene["initial_velocity"]["angular"] = [0.0, 0.0, omega]
        for body in scene["bodies"].values():
            if inertia is not None:
                body["inertia"] = [inertia] * 3
            if mass is not None:
                body["mass"] = mass
        per_step = []
        for tol in TOLERANCES:
            scene["solve"]["tol"] = tol
            per_step.append(latdyn.run(latdyn.load_scene(copy.deepcopy(scene))).summary["newton_iterations_per_step"])
        return {"case": label, "newton": newton, "h": dt, "omega": omega, "iterations_per_step": per_step}

    rows = [case("as is"), case("as is", newton="exact"), case("at rest", omega=0.0),
            case("bodies without rotary inertia", inertia=1e-9),
            case("bodies nearly massless", inertia=1e-9, mass=1e-6),
            case("h/4", dt=0.0025), case("ω/4", omega=0.125), case("4ω", omega=2.0)]
    print("| case | newton | h | ω | iterations a step at tol " + " / ".join(f"{t:g}" for t in TOLERANCES) + " |")
    print("|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['case']} | {r['newton']} | {r['h']:g} | {r['omega']:g} | "
              + " / ".join(f"{x:.1f}" for x in r["iterations_per_step"]) + " |")
    return rows


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--problems", nargs="*", default=["truss", "cantilever"])
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--sweep", action="store_true", help="the truss's iterations a step against the tolerance")
    parser.add_argument("--newtons", nargs="*", default=list(NEWTONS), choices=NEWTONS,
                        help="the variants run (full always, the others' reference)")
    args = parser.parse_args(argv)
    if args.sweep:
        return {"sweep": sweep()}
    load = [os.getloadavg()[0]]
    doc = {"machine": os.uname().machine, "repeats": args.repeats, "problems": {}}
    scenes = problems()
    for name in args.problems:
        raw = scenes[name]
        reference = run(raw, "full", 4, 1e-12)
        rows = {}
        newtons = ["full"] + [v for v in args.newtons if v != "full"]
        for newton in newtons:
            runs = [run(raw, newton) for _ in range(args.repeats + 1)][1:]
            first = runs[0]
            rows[newton] = {k: first[k] for k in ("steps", "newton_iterations", "factorizations", "elements")}
            rows[newton].update(solver_s=statistics.median(r["solver_s"] for r in runs),
                                cpu_s=statistics.median(r["cpu_s"] for r in runs),
                                us_per_element_iteration=1e6 * statistics.median(r["solver_s"] for r in runs)
                                / (first["newton_iterations"] * first["elements"]),
                                probe_error=difference(first, reference), _run=first)
        for newton in newtons:
            rows[newton]["error"] = max(rows[newton]["probe_error"].values())
            rows[newton]["error_vs_full"] = max(difference(rows[newton]["_run"], rows["full"]["_run"]).values())
        for newton in newtons:
            del rows[newton]["_run"]
        doc["problems"][name] = rows
    load.append(os.getloadavg()[0])
    doc["load_average"] = load
    args.out.write_text(json.dumps(doc, indent=1) + "\n")
    print(markdown(doc))
    return doc


def markdown(doc: dict) -> str:
    lines = [f"load {doc['load_average'][0]:.1f} → {doc['load_average'][1]:.1f}, medians of {doc['repeats']}", "",
             "| scene | newton | iterations / factorizations | solver_s | CPU s | µs per element-iteration "
             "| error against dt/4 | against full |", "|---|---|---|---|---|---|---|---|"]
    for name, rows in doc["problems"].items():
        for newton, r in rows.items():
            lines.append(f"| {name} | {newton} | {r['newton_iterations']} / {r['factorizations']} "
                         f"| {r['solver_s']:.3f} | {r['cpu_s']:.3f} | {r['us_per_element_iteration']:.2f} "
                         f"| {r['error']:.2e} | {r['error_vs_full']:.1e} |")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
