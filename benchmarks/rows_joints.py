"""What a recorded row costs for the scenes whose rows used to need Python per row: joint forces
(probes and ``summary.json`` ``joint_peaks``), law springs' potential, a continuous controller's output
probe (docs/performance.md, "Joints, cables and law springs in the row").

    PYTHONPATH=TREE python benchmarks/rows_joints.py crank|law|stop|pd [--repeats 5]

In process, after one warm-up of each: ``latdyn.run`` with a row every step and with rows at t = 0
and t_end only, the CPU time of the process (``time.process_time``: a loaded machine's other work
left out), medians of the repeats; the rows' cost is the difference, per row. Run it once per tree
(its checkout first on ``PYTHONPATH``) to compare.
"""
from __future__ import annotations

import argparse
import copy
import json
import statistics
import tempfile
import time
from pathlib import Path

import yaml

import latdyn
from latdyn.scene.loader import _yaml_loader

ROOT = Path(__file__).resolve().parents[1]

#: a stiff arm with a bob on a hinge at a fixed pivot (tests/test_hinges.py's pendulum)
PENDULUM = """\
sections: {arm: {EA: 1.0e10, EIy: 1.0e9, EIz: 1.0e9, GJ: 1.0e9, rhoA: 0.01}}
bodies:
  pivot: {at: [0, 0, 0], fixed: true}
  bob: {at: [1, 0, 0], mass: 1.0}
beams:
  arm: {from: pivot, to: bob, section: arm, start: {hinge: HINGE}}
solve: SOLVE
output:
  probes:
    angle: {hinge: arm.start, quantity: angle}
    torque: {hinge: arm.start, quantity: torque}
    total: {energy: total}
"""


#: a rigid link to a tip mass on a hinge slewed by a continuous PD (tests/test_controllers.py's hub)
HUB_PD = """\
inputs: {kp: 40.0, kd: 8.0, ref: 1.0}
controllers:
  ctl: {output: "-kp*(th - ref) - kd*om"}
sections: {s: {EA: 1, EIy: 1, EIz: 1, GJ: 1, rhoA: 0}}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.5, 0, 0], mass: 4.0}
beams:
  arm: {from: hub, to: tip, section: s, rigid: true, start: {hinge: {axis: [0, 0, 1], torque: ctl}}}
solve: {t_end: 1.5, dt: 0.004}
output:
  probes:
    th: {hinge: arm.start, quantity: angle}
    om: {hinge: arm.start, quantity: rate}
    u: {controller: ctl}
"""


def scene(kind: str) -> dict:
    if kind == "pd":
        return yaml.safe_load(HUB_PD)
    if kind == "crank":  # the shipped slider-crank: a rigid link, a guide, a prescribed crank
        raw = yaml.load((ROOT / "examples" / "slider_crank.yaml").read_text(), Loader=_yaml_loader())
        raw["output"].pop("every", None)
        raw["solve"]["t_end"] = 0.6
        return raw
    hinge, solve = {
        "law": ('{axis: [0, 0, 1], stiffness: "10*(1 + theta**2)", rest_angle: 1.0}',
                "{analysis: transient, t_end: 1.5, dt: 0.005}"),
        "stop": ("{axis: [0, 0, 1], stiffness: 10.0, rest_angle: 1.0, limits: [-0.1, 0.5], restitution: 0.0}",
                 "{analysis: transient, t_end: 0.7, dt: 0.001}"),
    }[kind]
    return yaml.safe_load(PENDULUM.replace("HINGE", hinge).replace("SOLVE", solve))


def once(raw: dict) -> tuple[float, int]:
    with tempfile.TemporaryDirectory() as folder:
        started = time.process_time()
        latdyn.run(latdyn.load_scene(copy.deepcopy(raw)), folder)
        spent = time.process_time() - started
        return spent, json.loads((Path(folder) / "summary.json").read_text())["rows"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("kind", choices=("crank", "law", "stop", "pd"))
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    every = scene(args.kind)
    ends = copy.deepcopy(every)
    ends["output"]["every"] = every["solve"]["t_end"]
    once(every), once(ends)
    runs = [(once(every), once(ends)) for _ in range(args.repeats)]
    rows = runs[0][0][1]
    with_rows = statistics.median(r[0][0] for r in runs)
    without = statistics.median(r[1][0] for r in runs)
    print(f"{latdyn.__file__}: {args.kind}, {rows} rows: CPU {with_rows:.3f} s a row every step, "
          f"{without:.3f} s rows at the ends; rows {with_rows - without:.3f} s, "
          f"{1e6 * (with_rows - without) / rows:.0f} µs a row")


if __name__ == "__main__":
    main()
