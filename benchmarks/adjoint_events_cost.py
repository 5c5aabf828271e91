"""The discrete adjoint through compliant stops' onsets and beside laws in t: its CPU time against the run without
sensitivities and the forward method, in process (docs/performance.md, "The adjoint through compliant stops and beside
laws in t (issue 34)").

    python benchmarks/adjoint_events_cost.py [--repeats 7]

Scenes (tests/test_adjoint_events_more.py): a 3D boom swung into its root hinge's compliant stop (7 parameters), a
gimbal of rigid rings with compliant stops on both hinges (7), a 3D latch beside a tip load of t (7), a slewing hinge
of prescribed angle beside a rigid stop (6), a reel paying out a skew stay that goes taut and slack (4). Each scene
warm once per variant, then ``--repeats`` rounds alternating the run without sensitivities, the forward method and the
adjoint; medians of ``time.process_time`` and wall. Run under ``chrt -f 10`` on a loaded machine.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def scenes() -> dict:
    """{name: YAML text}."""
    from tests.test_adjoint_events_more import BOOM_STOP, CABLE_REEL, GIMBAL_STOPS, LATCH_TIP_LOAD, SLEWING_STOP

    return {"boom_stop": BOOM_STOP, "gimbal_stops": GIMBAL_STOPS, "latch_tip_load": LATCH_TIP_LOAD,
            "slewing_stop": SLEWING_STOP, "reel_stay": CABLE_REEL}


def variants(text: str) -> dict:
    """{without, forward, adjoint}: the scene's mappings."""
    import yaml

    without, forward, adjoint = (yaml.safe_load(text) for _ in range(3))
    without["solve"].pop("sensitivities")
    adjoint["solve"]["sensitivity_method"] = "adjoint"
    return {"without": without, "forward": forward, "adjoint": adjoint}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT))
    import latdyn

    for name, text in scenes().items():
        runs = variants(text)
        for data in runs.values():   # warm: kernels and laws compiled, caches filled
            latdyn.run(latdyn.load_scene(data))
        taken = {key: [] for key in runs}
        for _ in range(args.repeats):
            for key, data in runs.items():
                scene = latdyn.load_scene(data)
                cpu, wall = time.process_time(), time.perf_counter()
                result = latdyn.run(scene)
                taken[key].append((time.process_time() - cpu, time.perf_counter() - wall))
        cpu = {key: statistics.median(c for c, _ in values) for key, values in taken.items()}
        wall = {key: statistics.median(w for _, w in values) for key, values in taken.items()}
        k = len(runs["forward"]["solve"]["sensitivities"])
        print(f"{name}: k = {k}, {result.summary['steps']} steps; CPU (wall) without {1e3 * cpu['without']:.1f} "
              f"({1e3 * wall['without']:.1f}) ms, forward {1e3 * cpu['forward']:.1f} ({1e3 * wall['forward']:.1f}) ms "
              f"= {cpu['forward'] / cpu['without']:.2f} x, adjoint {1e3 * cpu['adjoint']:.1f} "
              f"({1e3 * wall['adjoint']:.1f}) ms = {cpu['adjoint'] / cpu['without']:.2f} x the run without, "
              f"{cpu['adjoint'] / cpu['forward']:.2f} x the forward method", flush=True)


if __name__ == "__main__":
    main()
