"""The verification manual, computed at every docs build (issue 35 item 2).

Each case runs a scene with an exact or published reference and writes one table row per checked
quantity: the problem, the reference, latdyn's result, the error, the tolerance and the wall time
of the run. The rows come from the same functions the test suite and
benchmarks/verification_report.py use (benchmarks/problems.py), and from the closed forms below;
nothing on the page is typed in by hand. A case whose error is above its tolerance makes the build
fail (a Sphinx warning under ``-W``).

``python docs/_ext/verification_manual.py`` writes the page alone (docs/_generated/).
"""
from __future__ import annotations

import math
import os
import platform
import sys
import tempfile
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
OUT = Path(__file__).resolve().parents[1] / "_generated" / "verification_manual.md"

#: Euler's cantilever column (tests/test_linearise.py): P_cr = π²EI/(4L²) under a dead tip load.
COLUMN = """\
title: cantilever column, dead tip load
sections:
  col: {EA: 1.0e6, EIy: 100, EIz: 200, GJ: 80, rhoA: 1.0}
bodies:
  base: {at: [0, 0, 0], fixed: true}
beams:
  col: {from: base, to: [0, 0, 2], section: col, elements: 8}
loads:
  - {at: col.end, force: [0, 0, -100]}
solve: {analysis: buckling, steps: 4}
"""

#: Beck's column (tests/test_nonconservative.py): a follower tip force flutters at P L²/EI = 20.051.
BECK = """\
title: Beck's column
sections:
  col: {EA: 1.0e5, EIy: 1.0, EIz: 2.0, GJ: 1.0, rhoA: 1.0}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [0, 0, 1]}
beams:
  col: {from: base, to: tip, section: col, elements: 8}
loads:
  - {at: tip, force: [0, 0, -10], frame: tip}
solve: {analysis: buckling}
"""

#: The shallow von Mises truss (tests/test_path_following.py), traced by arc length.
VON_MISES = """\
title: shallow von Mises truss
sections:
  bar: {EA: 1.0e4, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 1.0}
bodies:
  left: {at: [-10, 0, 0], fixed: true}
  apex: {at: [0, 1, 0]}
  right: {at: [10, 0, 0], fixed: true}
beams:
  a: {from: left, to: apex, section: bar, elements: 1, start: {hinge: {axis: [0, 0, 1]}}}
  b: {from: apex, to: right, section: bar, elements: 1, start: {hinge: {axis: [0, 0, 1]}},
      end: {hinge: {axis: [0, 0, 1]}}}
loads:
  - {at: apex, force: [0, -20.0, 0]}
solve: {analysis: static, method: arc-length, steps: 10, max_steps: 300}
output:
  paraview_every: 0
  probes:
    w: {point: apex, quantity: displacement, component: y}
"""


def _run_text(text: str):
    """latdyn.run on a scene given as YAML text (as a user writes it): (result, wall seconds)."""
    import latdyn

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "scene.yaml"
        path.write_text(text, encoding="utf-8")
        started = time.perf_counter()
        result = latdyn.run(latdyn.load_scene(str(path)))
        return result, time.perf_counter() - started


def _rel(got: float, ref: float) -> float:
    return abs(got - ref) / abs(ref)


# ----------------------------------------------------------------------------- the cases
def case_column():
    result, wall = _run_text(COLUMN)
    ref = math.pi ** 2 * 100 / (4 * 2.0 ** 2)
    got = 100 * result.summary["buckling_factor"]
    second = 100 * result.summary["linearised_buckling_factors"][1]
    return ("Euler buckling of a cantilever column (dead load, 8 elements)",
            "P_cr = π²EI/(4L²), EIy = 100, EIz = 200, L = 2 (Euler 1744)",
            [("P_cr, weak plane", ref, got, _rel(got, ref), 2e-4),
             ("P_cr, stiff plane (linearised)", 2 * ref, second, _rel(second, 2 * ref), 3e-4)], wall)


def case_beck():
    result, wall = _run_text(BECK)
    got = 10 * result.summary["flutter_factor"]
    return ("Beck's column: flutter under a follower tip force (8 elements)",
            "P L²/EI = 20.051 (Beck 1952; Bolotin 1963); no divergence",
            [("flutter load P L²/EI", 20.051, got, _rel(got, 20.051), 2e-3)], wall)


def case_von_mises():
    import numpy as np

    result, wall = _run_text(VON_MISES)
    a, h, EA = 10.0, 1.0, 1.0e4
    L0 = math.hypot(a, h)

    def load_of(w):
        L = np.hypot(a, h - w)
        return 2.0 * EA * (L - L0) / L0 * (w - h) / L

    P_max = float(np.max(load_of(np.linspace(0.0, h, 200_001))))
    w, P = -np.asarray(result.probes["w"]), 20.0 * np.asarray(result.t)
    path_error = float(np.max(np.abs(P - load_of(w)))) / P_max
    maximum, minimum = result.summary["limit_points"]
    return ("Snap-through of a shallow von Mises truss (arc length)",
            "closed-form equilibrium path P(w) = 2EA(L − L₀)/L₀ · (w − h)/L, limit loads ±max P",
            [("upper limit load", P_max, 20 * maximum["load_factor"], _rel(20 * maximum["load_factor"], P_max), 2e-3),
             ("lower limit load", -P_max, 20 * minimum["load_factor"], _rel(20 * minimum["load_factor"], -P_max), 2e-3),
             ("largest distance of a path point from P(w), / P_max", 0.0, path_error, path_error, 1e-9)], wall)


def _from_problems(name: str, reference: str, check, **options):
    def case():
        from benchmarks import problems

        out = getattr(problems, check)(**options)
        return name, reference, [tuple(row) for row in out["rows"]], out["wall_s"]
    case.__name__ = check
    return case


CASES = [
    _from_problems("Modes of a uniform beam (clamped-free 8 elements, free-free 16)",
                   "Euler–Bernoulli frequencies, dimensionless: ω√(ρA L⁴/EI) = (βL)², βL = 1.8751, 4.6941, 7.8548 (clamped-free), 4.7300, 7.8532, 10.9956 (free-free)",
                   "check_L1"),
    _from_problems("Spin-up (Kane, Ryan & Banerjee 1987): oscillation at constant 6 rad/s",
                   "period of the tip's oscillation about the steady deflection (benchmarks.json D1)",
                   "check_D1_constant"),
    _from_problems("Flexible pendulum, rigid limit (D4): released horizontal, falls to vertical",
                   "rigid rod pendulum: time to vertical and rate there (elliptic integral)", "check_D4_rigid"),
    _from_problems("Elastica under a dead tip force (S2), 32 elements",
                   "Mattiasson (1981) elliptic-integral solution, P L²/EI = 1 and 4", "check_S2",
                   alphas=("1", "4")),
    _from_problems("Cantilever bent into a circle by an end moment (S1), 96 elements, 20 load steps",
                   "the exact circle: tip at (L sin φ/φ, L (1 − cos φ)/φ), φ = 2π M/M₀", "check_S1"),
    case_column,
    case_beck,
    case_von_mises,
]


def _machine() -> str:
    cpu = "unknown CPU"
    try:
        for line in open("/proc/cpuinfo", encoding="utf-8"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = ", load %.2f" % os.getloadavg()[0] if hasattr(os, "getloadavg") else ""
    return f"{os.cpu_count()} cores, {cpu}, Python {platform.python_version()}{load}"


def manual() -> tuple[str, list[str]]:
    """(the page's Markdown, the rows whose error is above their tolerance)."""
    failed: list[str] = []
    lines = ["# Verification manual", "",
             "Each case below was run when this page was built: the scene, its reference, latdyn's result,",
             "the error (relative, or absolute where the reference is 0) and the tolerance the test suite",
             "holds it to; time is the wall time of the run (the first run of a build also compiles the",
             "element kernels). The cases come from `docs/_ext/verification_manual.py` and",
             "`benchmarks/problems.py`; `docs/verification.md` has the longer benchmark runs and the",
             "convergence studies.", "",
             f"Built on {_machine()}.", ""]
    started = time.perf_counter()
    for case in CASES:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            name, reference, rows, wall = case()
        lines += [f"## {name}", "", f"Reference: {reference}.", "",
                  "| quantity | reference | latdyn | error | tolerance | within |", "|---|---|---|---|---|---|"]
        for quantity, ref, got, error, tol in rows:
            within = float(error) <= float(tol)
            if not within:
                failed.append(f"{name}: {quantity}: error {float(error):.3g} > {float(tol):g}")
            lines.append(f"| {quantity} | {float(ref):.7g} | {float(got):.7g} | {float(error):.2e} | {float(tol):g} | "
                         f"{'yes' if within else '**no**'} |")
        lines += ["", f"Wall time: {wall:.2f} s.", ""]
    lines += [f"All cases: {time.perf_counter() - started:.1f} s.", ""]
    return "\n".join(lines), failed


def write() -> list[str]:
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    text, failed = manual()
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(text, encoding="utf-8")
    return failed


def _on_builder_inited(app):
    from sphinx.util import logging

    for row in write():
        logging.getLogger(__name__).warning("verification manual: %s", row)


def setup(app):
    app.connect("builder-inited", _on_builder_inited)
    return {"version": "1", "parallel_read_safe": True}


if __name__ == "__main__":
    problems = write()
    print(OUT.read_text(encoding="utf-8"))
    sys.exit(1 if problems else 0)
