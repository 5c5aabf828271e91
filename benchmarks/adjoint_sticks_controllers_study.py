"""The adjoint through friction sticks beside a controller with states or a sampled one on the stuck joint: the study
behind tests/test_adjoint_held_beside_controllers.py and docs/parameters.md, "Friction by the adjoint" (issue 34).

    python benchmarks/adjoint_sticks_controllers_study.py [--scene pi|pd] [--step 1e-4]

For the scene (the 3D boom slewing on a skew friction hinge under τ = A sin 6t and a PI, or a sampled PD at 25 Hz, on
that hinge): the adjoint against the forward method (every probe's end, max and min, of each output's largest); for
each parameter the forward method against Richardson-extrapolated central differences of whole runs (relative steps
``--step`` and half of it, the time step fixed; each probe's largest error over the rows, relative to its largest
reference), and the same with the sensors' held angle switched off (the stuck joint's held δθ left out of a state's
and a sample's δs: ``owner.held`` None in ``ControllerStates._sensed`` and ``SampledTerms.sample``), which shows
whether that term matters on the scene; and the adjoint with its transpose switched off
(``_held_sensed_transposed``) against the forward method with and without it.
"""
from __future__ import annotations

import argparse
from contextlib import contextmanager

import numpy as np
import yaml

from latdyn.analyses import adjoint_controller_states, sensitivities
from tests.test_adjoint_held_beside_controllers import BOOM_PD, BOOM_PI, _run as run
from tests.test_sensitivities_adjoint import _disagreement


@contextmanager
def sensors_without_held_angles():
    """Both methods with the sensors' held angle left out (module docstring)."""
    sample, sensed = sensitivities.SampledTerms.sample, sensitivities.ControllerStates._sensed
    transposed = adjoint_controller_states._held_sensed_transposed

    def without(method):
        def call(self, *args, **kwargs):
            owner = self.terms.owner
            held, owner.held = owner.held, None
            try:
                return method(self, *args, **kwargs)
            finally:
                owner.held = held
        return call

    sensitivities.SampledTerms.sample = without(sample)
    sensitivities.ControllerStates._sensed = without(sensed)
    adjoint_controller_states._held_sensed_transposed = lambda *args: None
    try:
        yield
    finally:
        sensitivities.SampledTerms.sample, sensitivities.ControllerStates._sensed = sample, sensed
        adjoint_controller_states._held_sensed_transposed = transposed


def richardson(text: str, name: str, step: float) -> dict:
    """{probe: Richardson-extrapolated central differences by ``name`` at each row} (relative step ``step``)."""
    p0 = yaml.safe_load(text)["parameters"][name]
    central = []
    for h in (step * abs(p0), step * abs(p0) / 2):
        up, down = run(text, only=name, **{name: p0 + h}), run(text, only=name, **{name: p0 - h})
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * h) for k in up.probes})
    return {k: (4 * central[1][k] - central[0][k]) / 3 for k in central[0]}


def largest_error(result, expected: dict, name: str) -> float:
    return max(float(np.abs(result.sensitivities[(k, name)] - e).max() / np.abs(e).max())
               for k, e in expected.items() if np.abs(e).max() > 0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", choices=["pi", "pd"], default="pd")
    parser.add_argument("--step", type=float, default=1e-4)
    args = parser.parse_args()
    text = {"pi": BOOM_PI, "pd": BOOM_PD}[args.scene]
    forward, adjoint = run(text), run(text, "adjoint")
    print(f"adjoint against the forward method: "
          f"{_disagreement(forward.summary['probe_sensitivities'], adjoint.summary['probe_sensitivities']):.2e}")
    with sensors_without_held_angles():
        forward_off, adjoint_off = run(text), run(text, "adjoint")
    print(f"without the held angle: adjoint against the forward method with it "
          f"{_disagreement(forward.summary['probe_sensitivities'], adjoint_off.summary['probe_sensitivities']):.2e}, "
          f"without it {_disagreement(forward_off.summary['probe_sensitivities'], adjoint_off.summary['probe_sensitivities']):.2e}")
    for name in yaml.safe_load(text)["solve"]["sensitivities"]:
        expected = richardson(text, name, args.step)
        print(f"{name}: the forward method off Richardson {largest_error(forward, expected, name):.2e}, "
              f"without the held angle {largest_error(forward_off, expected, name):.2e}", flush=True)


if __name__ == "__main__":
    main()
