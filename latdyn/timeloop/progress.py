"""What the time loop carries from one step to the next (checkpointed), and its reports of cut steps."""
from __future__ import annotations

import sys
from dataclasses import dataclass, field

import numpy as np

from latdyn.assembly.assembler import State


@dataclass
class TransientProgress:
    """Everything the time loop carries from one step to the next, besides the model.

    Explicit and picklable, so that a run can be checkpointed and resumed: the
    state of the nodes and hinges, the integrator's algorithmic acceleration, the
    step size, the latched hinges, the work and energy bookkeeping, and counters.
    Times are computed from the grid index, never accumulated: the nominal step
    k lands exactly on t_k = k·dt (the last one on t_end).
    """

    state: State
    algorithmic_acceleration: np.ndarray | None
    locked: np.ndarray  # latched hinges
    h: float  # step size to try next
    grid_index: int = 0  # nominal steps completed
    output_index: int = 1  # next recorded time is output_index · every
    external_work: float = 0.0
    power: float = 0.0  # power of loads and prescribed motion at state.t
    total0: float = 0.0  # kinetic + strain + potential at t = 0
    potential0: float = 0.0
    balance_error: float = 0.0  # max |Δ(total − external_work)|
    energy_scale: float = 0.0  # max of kinetic, strain, |potential change|, |external work|
    steps: int = 0
    newton_iterations: int = 0
    rejected_steps: int = 0  # all rejected attempts: Newton failures and error-control rejections
    newton_cuts: int = 0  # steps halved because Newton did not converge
    factorizations: int = 0  # iteration matrices factorized (modified Newton keeps one over steps)
    solver_s: float = 0.0  # wall time inside the integrator's steps
    cut_times: list = field(default_factory=list)  # the first times at which a step was cut
    inertia_tangent_from: float | None = None  # t from which Newton's matrix holds the inertia tangent


#: Cut steps reported on stderr one by one up to this many, then only counted.
CUTS_REPORTED = 10


def report_cut(progress: TransientProgress, t: float, h: float, iterations: int) -> None:
    progress.newton_cuts += 1
    if len(progress.cut_times) < 100:
        progress.cut_times.append(float(t))
    if progress.newton_cuts <= CUTS_REPORTED:
        tail = "" if progress.newton_cuts < CUTS_REPORTED else " (further cuts are only counted in summary.json)"
        print(f"latdyn: Newton did not converge in {iterations} iterations at t = {t:.9g} with step {h:.3g}; "
              f"step cut to {h / 2:.3g}{tail}", file=sys.stderr)
