"""An event's time shift through prescribed motions: the cost of the event's (∂K/∂p) w with a time shift and of the
whole forward run, in process (docs/performance.md, "Prescribed motions' time shift generated (issue 34)").

    python benchmarks/prescribed_time_shift_cost.py [--repeats 30] [--runs 5]

Scenes (tests/test_sensitivities_prescribed_time_shift.py): the 3D boom deployed by a prescribed hinge angle latching
its wheel's hinge, and the 3D arm on a prescribed base translation onto its stop. The event block is
``TransientSensitivities._stiffness_derivative`` at the tests' deformed, moving state (t = 0.7, a random δt_e), median
of ``--repeats`` calls; the whole run (forward method, both parameters' events) median of ``--runs`` after one warm
run; ``time.process_time`` and wall. Run under ``chrt -f 10`` on a loaded machine, the trees compared alternately
(PYTHONPATH names the one measured).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _median_ms(call, repeats: int) -> tuple:
    cpu, wall = [], []
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        call()
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    return 1e3 * float(np.median(cpu)), 1e3 * float(np.median(wall))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=30)
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args(argv)
    import yaml

    import latdyn
    from latdyn.analyses.transient_sensitivities import TransientSensitivities
    from tests.test_sensitivities_prescribed_time_shift import BASE_STOP, HINGE_DEPLOY
    from tests.test_weight_derivative_rest import _boom_state

    for name, text in (("hinge deploy", HINGE_DEPLOY), ("base stop", BASE_STOP)):
        prepared, state, rng = _boom_state(text)
        state.t = 0.7
        owner = TransientSensitivities(prepared)
        w = rng.normal(size=prepared.model.n_dofs)
        owner.time_shift = rng.normal(size=len(owner.names))
        owner._stiffness_derivative(state, w)
        block = _median_ms(lambda: owner._stiffness_derivative(state, w), args.repeats)
        data = yaml.safe_load(text)
        latdyn.run(latdyn.load_scene(data))
        run = _median_ms(lambda: latdyn.run(latdyn.load_scene(data)), args.runs)
        print(f"{name}: event block CPU {block[0]:.3f} ms (wall {block[1]:.3f}); "
              f"run CPU {run[0]:.1f} ms (wall {run[1]:.1f})", flush=True)


if __name__ == "__main__":
    sys.path.append(str(ROOT))   # after PYTHONPATH: the build compared is the one it names
    sys.path.append(str(ROOT / "tests"))   # the tests' helpers import each other by their names too
    main()
