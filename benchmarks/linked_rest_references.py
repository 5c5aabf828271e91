"""The Richardson references of tests/test_sensitivities_linked_rest.py (tests/linked_rest_richardson.json).

For each scene of that file and each parameter it checks: Richardson-extrapolated central differences of whole runs,
(4 D(h/2) − D(h)) / 3 with D(h) = (y(p + h) − y(p − h)) / 2h, h = STEP |p|, every probe's rows; the perturbed runs
keep ``solve.sensitivities`` (a run without them takes other steps at the events) and must log the same events as
the checked run; PUT_BACK's land to 1e-14 (:data:`TIGHT_LANDING`). Prints, per scene and parameter, the spread of the two differences and the error of the forward
method's sensitivities against the reference, each relative to the probe's largest.

``python benchmarks/linked_rest_references.py [--write]`` (about 20 runs; not run by the suite)."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import latdyn  # noqa: E402
import latdyn.timeloop.landing as landing  # noqa: E402
from tests import test_sensitivities_linked_rest as checked  # noqa: E402

#: the relative perturbation of the larger difference
STEP = 1e-4
#: the landing tolerance of the perturbed runs where the package's (latdyn.timeloop.landing.LANDING, 1e-12) shows in
#: the differences: PUT_BACK's second landing grazes the stop (−6.4e-3 rad/s), where the landed angle's 1e-12 rad,
#: moving with p, moves the landed time by 5.2e-6 of its derivative and the probes by 4.6e-7 (2.2e-9 at 1e-14); the
#: derivative is that of the event landed exactly
TIGHT_LANDING = {"PUT_BACK": 1e-14}
#: the package's landing tolerance
PACKAGE_LANDING = landing.LANDING


def richardson(name: str, parameter: str, result) -> tuple[dict, float]:
    """({probe: Richardson's rows}, the largest spread of the two differences relative to each probe's largest)."""
    p0 = checked.scene(name)["parameters"][parameter]
    differences = []
    landing.LANDING = TIGHT_LANDING.get(name, PACKAGE_LANDING)
    try:
        for h in (STEP * abs(p0), STEP * abs(p0) / 2):
            moved = []
            for value in (p0 + h, p0 - h):
                data = checked.scene(name)
                data["parameters"][parameter] = value
                run = latdyn.run(latdyn.load_scene(data))
                assert [e["kind"] for e in run.summary["events"]] == [e["kind"] for e in result.summary["events"]]
                moved.append(run)
            differences.append({k: (moved[0].probes[k] - moved[1].probes[k]) / (2 * h) for k in result.probes})
    finally:
        landing.LANDING = PACKAGE_LANDING
    reference = {k: (4 * differences[1][k] - differences[0][k]) / 3 for k in result.probes}
    spread = max(np.abs(differences[1][k] - differences[0][k]).max() / np.abs(reference[k]).max() for k in reference)
    return reference, spread


def main(argv=None) -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--write", action="store_true", help="write tests/linked_rest_richardson.json")
    args = parser.parse_args(argv)
    stored = {}
    for name, parameters in checked.CHECKED.items():
        result = latdyn.run(latdyn.load_scene(checked.scene(name)))
        stored[name] = {}
        for parameter in parameters:
            reference, spread = richardson(name, parameter, result)
            error = max(np.abs(result.sensitivities[(k, parameter)] - reference[k]).max() / np.abs(reference[k]).max()
                        for k in reference)
            print(f"{name} by {parameter}: error {error:.2e}, spread {spread:.2e}", flush=True)
            stored[name][parameter] = {k: [float(f"{x:.12e}") for x in v] for k, v in reference.items()}
    if args.write:
        checked.REFERENCES.write_text(json.dumps(stored, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
