"""Static Newton under gravity with and without the beams' gravity tangent (beam_gravity_D_q).

    python benchmarks/gravity_tangent_newton.py

Two 3D structures under their own weight, ramped over load steps by load control, each load step
solved by Newton at a fixed load factor (latdyn.analyses.continuation.newton_fixed, the path's own
Newton: K − λ ∂Q/∂q, increments to 1e-10) from the previous step's solution, once with the gravity
tangent in the static matrix and once without it (the native model's ``gravity_load_D_q`` set to
NULL: the matrix the package had before). Printed per structure: Newton iterations per load step,
with and without, and the residual norms of one load step's iterations (linear against quadratic
convergence at the end).
"""
from __future__ import annotations

import numpy as np
import yaml

from latdyn.analyses import continuation
from latdyn.assembly.prepare import length_scale, prepare

FRAME = """
title: 3D frame of five members under its own weight
sections:
  s: {EA: 1.0e6, EIy: 60.0, EIz: 90.0, GJ: 70.0, rhoA: 1.0, rhoIy: 0.001, rhoIz: 0.001}
bodies:
  a: {at: [0, 0, 0], fixed: true}
  b: {at: [2, 0, 0], fixed: true}
  c: {at: [0, 0, 2]}
  d: {at: [2, 1, 2]}
  e: {at: [1, 2.5, 2]}
beams:
  c1: {from: a, to: c, section: s, elements: 6}
  c2: {from: b, to: d, section: s, elements: 6}
  g1: {from: c, to: d, section: s, elements: 6}
  g2: {from: d, to: e, section: s, elements: 6}
  g3: {from: c, to: e, section: s, elements: 6}
gravity: [0, 0, -9.81]
solve: {analysis: static, steps: 10}
"""

#: tests/test_gravity_tangent.py FRAME_3D: a post and a hinged arm, the hinge's axis skew
HINGED = """
title: a post and a hinged arm under a skew gravity
sections:
  s: {EA: 1.0e5, EIy: 20.0, EIz: 30.0, GJ: 25.0, rhoA: 1.0, rhoIy: 0.01, rhoIz: 0.02}
bodies:
  a: {at: [0, 0, 0], fixed: true}
  c: {at: [0, 0, 1.5]}
  e: {at: [1.0, 1.2, 1.7]}
beams:
  post: {from: a, to: c, section: s, elements: 3, y_axis: [0.6, 0.8, 0]}
  arm:
    from: c
    to: e
    section: s
    elements: 4
    y_axis: [0, 0, 1]
    start: {hinge: {axis: [0.3, 0.5, 0.81], stiffness: 40.0}}
gravity: [0.8, -1.1, -9.81]
solve: {analysis: static, steps: 4}
"""


def ramp(text: str, with_tangent: bool) -> tuple[float, list[float]]:
    """(Newton iterations per load step, the residual norms of the last step's iterations)."""
    prepared = prepare(yaml.safe_load(text))
    assembler, steps = prepared.assembler, prepared.scene.solve.steps
    if not with_tangent:
        assembler.native().model.gravity_load_D_q = None
    path = continuation.Path(prepared, None, None, length_scale(prepared.model))
    state = prepared.state
    for k in range(1, steps + 1):
        before = path.iterations
        start = state
        state, _, _, converged = continuation.newton_fixed(path, state, k / steps)
        assert converged, f"load step {k} did not converge"
        last = (start, k / steps, path.iterations - before)
    start, load_factor, count = last
    norms, trial = [], start
    for _ in range(count + 1):
        ev = assembler.evaluate(trial, matrices=True, load_factor=load_factor, inertia=False)
        norms.append(float(np.linalg.norm(ev.residual)))
        trial = path.step_to(trial, path.solve(ev.stiffness, -ev.residual)[0])
    return path.iterations / steps, norms


def main() -> None:
    for name, text in (("3D frame, 30 elements", FRAME), ("3D post and hinged arm, 7 elements", HINGED)):
        for with_tangent in (False, True):
            per_step, norms = ramp(text, with_tangent)
            print(f"{name:36s} {'with' if with_tangent else 'without':7s} gravity tangent: "
                  f"{per_step:5.2f} iterations a load step; last step's |r|: "
                  + " ".join(f"{x:.1e}" for x in norms))


if __name__ == "__main__":
    main()
