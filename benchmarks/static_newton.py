"""One Newton (issue 31, item 4; docs/performance.md, "One Newton"): static paths before and after.

    python benchmarks/static_newton.py [--rounds 3] [--repeat 3] [--trees TREE ...]

Each TREE is a checkout (a folder with ``latdyn/`` and its ``latdyn_generated``) run in fresh
processes with it first on the path, the trees taking turns round by round; each scene is warmed
once, then run ``--repeat`` times in process through ``latdyn.run`` (no results folder). Prints per
tree and scene the median time, the path steps and Newton iterations, the limit points and the last
row's probes (which must agree between trees), then, in this checkout, one Newton iteration as the
Python loop took it (two ``Assembler.evaluate``, ``solve_linear`` of [−r, q_ref], NumPy
``increment_size``) against ``latdyn_static_iteration``, interleaved, at a converged state at λ = 0.1.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

CANTILEVER_3D = """\
title: 3D cantilever, out-of-plane and in-plane tip force, 48 elements
sections:
  s: {EA: 1.0e7, EIy: 1.0, EIz: 2.0, GJ: 1.5, rhoA: 1.0, rhoIy: 1.0, rhoIz: 1.0}
bodies:
  root: {at: [0, 0, 0], fixed: true}
beams:
  beam: {from: root, to: [1, 0, 0], section: s, elements: 48}
loads:
  - {at: beam.end, force: [0, 2.0, 3.0]}
solve: {analysis: static, steps: 10}
output:
  probes:
    tip_z: {point: beam.end, quantity: position, component: z}
"""


def scenes() -> dict[str, str]:
    import test_path_following as paths

    gallery = (ROOT / "examples" / "gallery" / "plot_06_snap_through.py").read_text()
    von_mises = gallery.split('SCENE = """\\\n')[1].split('"""')[0]
    return {"lee_arc": paths.LEE, "von_mises_arc": von_mises,
            "elastica_load": paths.ELASTICA.replace("SOLVE", "{analysis: static, steps: 20}"),
            "elastica_disp": paths.ELASTICA.replace(
                "SOLVE", "{analysis: static, method: displacement-control, steps: 20, "
                         "control: {point: beam.end, direction: [0, 1, 0], to: 0.6}}"),
            "cantilever3d_load": CANTILEVER_3D}


def whole_paths(folder: Path, repeat: int) -> None:
    """In this process (the tree on the path): each scene warmed, then timed; one JSON line each."""
    import latdyn

    for name, text in scenes().items():
        path = folder / f"{name}.yaml"
        path.write_text(text)
        result = latdyn.run(latdyn.load_scene(str(path)))
        times = []
        for _ in range(repeat):
            start = time.perf_counter()
            result = latdyn.run(latdyn.load_scene(str(path)))
            times.append(time.perf_counter() - start)
        s = result.summary
        print(json.dumps({"scene": name, "times": times, "iterations": s["newton_iterations"], "steps": s["steps"],
                          "limit_points": [p["load_factor"] for p in s.get("limit_points", [])],
                          "probes_last": {k: float(v[-1]) for k, v in result.probes.items()}}), flush=True)


def one_iteration(folder: Path) -> None:
    """One Newton iteration, the Python loop's against the native one, interleaved (this checkout)."""
    import numpy as np

    import latdyn
    from latdyn.analyses.continuation import Path as StaticPath
    from latdyn.assembly.factorization import solve_linear
    from latdyn.assembly.prepare import length_scale, prepare
    from latdyn.step.integrators import increment_size

    class Writer:
        summary: dict = {}

    for name in ("lee_arc", "von_mises_arc", "elastica_load", "cantilever3d_load"):
        prepared = prepare(latdyn.load_scene(str(folder / f"{name}.yaml")))
        path = StaticPath(prepared, None, Writer(), length_scale(prepared.model))
        lam, a = 0.1, prepared.assembler
        state, _, _, converged = path.newton.newton(prepared.state, lam)
        assert converged

        def python():
            ev = a.evaluate(state, matrices=True, load_factor=lam, inertia=False)
            shifted = a.evaluate(state, matrices=False, load_factor=lam + 1.0, inertia=False)
            x = solve_linear(ev.stiffness, np.column_stack([-ev.residual, ev.residual - shifted.residual]))
            return x[:, 0], x[:, 1], increment_size(a, x[:, 0], path.length_scale)

        def native():
            step = path.iterate(state, lam)
            return step.dq_r, step.dq_lambda, step.size

        same = all(np.array_equal(x, y) for x, y in zip(python()[:2], native()[:2]))
        times = {"python": [], "native": []}
        for _ in range(7):
            for key, call in (("python", python), ("native", native)):
                start = time.perf_counter()
                for _ in range(50):
                    call()
                times[key].append((time.perf_counter() - start) / 50)
        print(f"{name}: {path.model.n_dofs} coordinates ({path.newton.factorization.kind}), one iteration "
              f"python {1e3 * statistics.median(times['python']):.3f} ms, native "
              f"{1e3 * statistics.median(times['native']):.3f} ms, solutions bit for bit: {same}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--trees", nargs="*", default=[str(ROOT)])
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        whole_paths(Path(args.child), args.repeat)
        return
    folder = Path(tempfile.mkdtemp())
    runs: dict = {}
    for round_ in range(args.rounds):
        for tree in args.trees:
            load = os.getloadavg()[0]
            env = dict(os.environ, PYTHONPATH=tree)
            out = subprocess.run([sys.executable, __file__, "--child", str(folder), "--repeat", str(args.repeat)],
                                 env=env, capture_output=True, text=True, check=True, cwd=folder).stdout
            print(f"round {round_ + 1}, {tree}, load {load:.1f}", flush=True)
            for line in out.splitlines():
                row = json.loads(line)
                runs.setdefault((tree, row["scene"]), []).append(row)
    for (tree, scene), rows in runs.items():
        times = [t for row in rows for t in row["times"]]
        last = rows[-1]
        print(f"{tree} {scene}: median {statistics.median(times):.3f} s of {len(times)}, steps {last['steps']}, "
              f"iterations {last['iterations']}, limit points {last['limit_points']}, last row {last['probes_last']}")
    one_iteration(folder)


if __name__ == "__main__":
    main()
