"""What the omitted inertia tangent ∂(M v̇ + g)/∂q costs in Newton iterations.

    python benchmarks/newton_tangent.py

The generated kernels give ∂F_i/∂q and ∂g/∂q̇ exactly; the derivative of the inertia
forces with respect to the configuration is left out of the iteration matrix (it needs
third derivatives of the kinematics).  Here the same runs are repeated with the full
∂r/∂q from central differences of the residual (all terms included), and the Newton
iterations per step are compared.  The converged solutions agree to the Newton tolerance:
only the iteration count can change.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

import latdyn.assembly.prepare as prepare_module
import latdyn.solve as solve_module
from latdyn.assembly.assembler import Assembler
from latdyn.errors import SolverError

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "spinup.yaml"


class FiniteDifferenceTangent(Assembler):
    """Replaces K by central differences of the whole residual (v and v̇ held)."""

    def evaluate(self, state, matrices=True, load_factor=1.0, inertia=True):
        ev = super().evaluate(state, matrices, load_factor, inertia)
        if not matrices or self.model.n_dofs == 0:
            return ev
        n, h = self.model.n_dofs, 1e-7
        K = np.zeros((n, n))
        for j in range(n):
            step = np.zeros(n)
            step[j] = h
            plus = super().evaluate(self.advance(state, step), False, load_factor, inertia).residual
            minus = super().evaluate(self.advance(state, -step), False, load_factor, inertia).residual
            K[:, j] = (plus - minus) / (2 * h)
        exact_parts = ev.combined

        def combined(cm, cc, ck, dense=None):
            return exact_parts(cm, cc, 0.0, dense=True) + ck * K

        ev.combined = combined
        return ev


def spinup(t_start_fast: bool, dt: float, t_end: float):
    raw = yaml.safe_load(EXAMPLE.read_text())
    raw["sections"]["arm"] = {k: float(v) for k, v in raw["sections"]["arm"].items()}
    if t_start_fast:  # already spinning at 6 rad/s: strongest centrifugal/Coriolis coupling
        raw["bodies"]["hub"]["motion"]["rotation"]["angle"] = "6*t"
        raw["initial_velocity"] = {"angular": [0, 0, 6.0]}
    raw["solve"].update(t_end=t_end, dt=dt)
    return raw


def main():
    print(f"{'case':34s} {'dt':>7s} {'iter/step (K omits inertia)':>28s} {'iter/step (full FD tangent)':>28s} "
          f"{'max |Δtip|':>11s}")
    for fast in (False, True):
        for dt in (0.005, 0.02, 0.05):
            rows = []
            for assembler in (Assembler, FiniteDifferenceTangent):
                prepare_module.Assembler = assembler
                try:
                    rows.append(solve_module.run(spinup(fast, dt, 1.0)))
                except SolverError as error:
                    rows.append(str(error).splitlines()[1].strip())
            prepare_module.Assembler = Assembler
            name = "spin-up from rest" if not fast else "spinning at 6 rad/s from t = 0"
            cells = [f"{r.summary['newton_iterations'] / r.summary['steps']:.2f}" if not isinstance(r, str)
                     else "failed" for r in rows]
            diff = (np.max(np.abs(rows[0].probes["tip_v"] - rows[1].probes["tip_v"]))
                    if not any(isinstance(r, str) for r in rows) else float("nan"))
            print(f"{name:34s} {dt:7.3f} {cells[0]:>28s} {cells[1]:>28s} {diff:11.2e}")


if __name__ == "__main__":
    main()
