"""The discrete adjoint through controllers with states and sampled controllers: its CPU time against the run without
sensitivities and the forward method, in process (docs/performance.md, "The adjoint with controller states (issue
34)").

    python benchmarks/adjoint_controller_states_cost.py [--repeats 5]

Scenes (tests/test_adjoint_controllers_states.py, more parameters): the slewing boom under a PI of its hub's angle with
the boom cut into five beams of their own sections, whose four values each (EA, EIy = EIz, GJ, rhoA) are parameters
beside the gains (22 parameters); the same with the gains alone (2); the gimbal's two filtered PIDs (5); the sampled PD
on the flexible arm (3); the two-link boom whose elbow's PI latches (5). Each scene warm once per variant, then
``--repeats`` rounds alternating the run without sensitivities, the forward method and the adjoint; medians of
``time.process_time`` and wall. Run under ``chrt -f 10`` on a loaded machine.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def five_beam_boom(with_sections: bool) -> str:
    """The slewing boom (tests/test_adjoint_controllers_states.py SLEW_BOOM) cut into five beams of one element each,
    beam i of section s_i whose EA, EIy = EIz, GJ and rhoA are the parameters ``EA_i``, ``EI_i``, ``GJ_i``, ``rA_i``
    (with ``with_sections``) beside the gains Kp, Ki."""
    import numpy as np

    tip = np.array([0.8, 0.3, 0.25])
    joints = {f"j{i}": (tip * i / 5).tolist() for i in range(1, 5)}
    values = {f"{key}_{i}": value for i in range(1, 6)
              for key, value in (("EA", 1.0e5), ("EI", 60.0), ("GJ", 40.0), ("rA", 1.0))}
    sections = "\n".join(f'  s{i}: {{EA: "EA_{i}", EIy: "EI_{i}", EIz: "EI_{i}", GJ: "GJ_{i}", rhoA: "rA_{i}", '
                         'rhoIy: 0.001, rhoIz: 0.001}' for i in range(1, 6))
    ends = ["hub", *joints, "tip"]
    beams = "\n".join(f"  b{i}: {{from: {ends[i - 1]}, to: {ends[i]}, section: s{i}, elements: 1"
                      + (', start: {hinge: {axis: [0.2, 0.1, 1], damping: 0.8, torque: "slew"}}}' if i == 1 else "}")
                      for i in range(1, 6))
    bodies = "\n".join(f"  {name}: {{at: {at}, mass: 0.05, inertia: [0.001, 0.001, 0.001]}}"
                       for name, at in joints.items())
    names = ["Kp", "Ki"] + (list(values) if with_sections else [])
    parameters = ", ".join(f"{k}: {v}" for k, v in {"Kp": 4.0, "Ki": 3.0, **values}.items())
    return f"""
title: a slewing boom of five beams under a PI of the hub's angle
parameters: {{{parameters}}}
sections:
{sections}
bodies:
  hub: {{at: [0, 0, 0], fixed: true}}
{bodies}
  tip: {{at: {tip.tolist()}, mass: 0.4, inertia: [0.01, 0.01, 0.01]}}
beams:
{beams}
controllers:
  slew: {{output: "Kp*(0.5 - th) + Ki*E", states: {{E: "0.5 - th"}}, initial: {{E: 0.05}}}}
solve: {{analysis: transient, t_end: 0.6, dt: 0.01, sensitivities: [{", ".join(names)}]}}
output:
  every: 0.01
  probes:
    th: {{hinge: b1.start, quantity: angle}}
    tip_z: {{point: tip, quantity: position, component: z}}
    integral: {{controller: slew, state: E}}
"""


def scenes() -> dict:
    """{name: YAML text}."""
    from tests.test_adjoint_controllers_states import BOOM_LATCH, GIMBAL_PID, SAMPLED_PD

    return {"slewing boom, PI (22 p)": five_beam_boom(True), "slewing boom, PI (2 p)": five_beam_boom(False),
            "gimbal, two filtered PIDs (5 p)": GIMBAL_PID, "sampled PD on a flexible arm (3 p)": SAMPLED_PD,
            "two-link boom, PI beside a latch (5 p)": BOOM_LATCH}


def main(chosen=scenes, doc: str = __doc__) -> None:
    """``chosen()``'s scenes compared (``--repeats``; benchmarks/adjoint_linked_cost.py ``compare``), ``doc`` the
    command's help (benchmarks/adjoint_states_rates_cost.py passes its own)."""
    from benchmarks.adjoint_linked_cost import compare

    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    compare(chosen(), parser.parse_args().repeats)


if __name__ == "__main__":
    sys.path.append(str(ROOT))   # after PYTHONPATH: the build compared is the one it names
    main()
