"""Mesh convergence of the two local rotation measures: log map (``default``) vs sines (``cr4402``).

    python benchmarks/rotation_measures.py            # S1, S2, D4, D4r, L1; prints Markdown tables
    python benchmarks/rotation_measures.py S1 D4      # only these problems

For each problem and element count, both formulations run the same scene from
examples/benchmarks/ (only ``beams.*.elements`` and ``solve.formulation`` change):

* S1 end-moment circle (static, M = 2πEI/L): |tip − root|/L at the full load, exact 0.
* S2 elastica with a tip force: relative error of v/L at α = PL²/EI = 1 and 4 against
  the elliptic-integral values of benchmarks.json.
* D4 very flexible pendulum (Newmark, dt = 1 ms, t_end = 1 s): the time reached, the energy
  drift max|E − E₀|/max|V| (tolerance 1e-4 in benchmarks.json) and the tip position at the
  last common time against the finest log-map mesh (no published curve exists).  D4r: the same
  with a small rotary inertia (ρI_y = ρI_z = 1e-5), so that no direction is without inertia.
* L1 clamped-free frequencies (modes about the straight beam): relative errors of ω₁…ω₃.
  Both measures agree to first order, so these must coincide.

Numbers are measured by this script; docs/verification.md quotes its output.
"""
from __future__ import annotations

import copy
import math
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
warnings.filterwarnings("ignore", category=RuntimeWarning)

import latdyn  # noqa: E402
from latdyn.errors import SolverError  # noqa: E402
from benchmarks.problems import reference  # noqa: E402

SCENES = ROOT / "examples" / "benchmarks"
FORMULATIONS = ("default", "cr4402")
MEASURE = {"default": "log map", "cr4402": "sines (Eqs. 14–16)"}


def _scene(name: str, beam: str, elements: int, formulation: str) -> dict:
    raw = yaml.safe_load((SCENES / name).read_text())
    raw["beams"][beam]["elements"] = elements
    raw["solve"]["formulation"] = formulation
    return raw


def _run(raw: dict):
    t0 = time.perf_counter()
    try:
        result = latdyn.run(copy.deepcopy(raw), out_dir=None)
        error = None
    except SolverError as exc:
        result, error = getattr(exc, "result", None), str(exc).splitlines()[0]
    return result, error, time.perf_counter() - t0


def s1(elements: int, formulation: str) -> dict:
    """``gap``: |tip − root|/L at M = 2πEI/L; ``worst``: max |tip − exact|/L over the reference load
    factors 1/4, 1/2, 3/4, 1 (tip on the circle of radius L/θ, θ = ML/EI)."""
    result, error, wall = _run(_scene("S1_end_moment_circle.yaml", "beam", elements, formulation))
    if error:
        return {"error": error, "wall": wall}
    gap = math.hypot(result.probes["tip_x"][-1], result.probes["tip_y"][-1])
    lf = np.asarray(result.t)
    worst = 0.0
    for key, val in reference("S1")["reference"].items():
        i = int(np.argmin(abs(lf - float(key))))
        worst = max(worst, math.hypot(result.probes["tip_x"][i] - 1 - val["u_axial_over_L"],
                                      result.probes["tip_y"][i] - val["v_transverse_over_L"]))
    return {"gap": gap, "worst": worst, "wall": wall}


def s2(elements: int, formulation: str, alphas=("1", "4")) -> dict:
    ref = reference("S2")["reference_by_alpha"]
    result, error, wall = _run(_scene("S2_elastica_tip_force.yaml", "beam", elements, formulation))
    if error:
        return {"error": error, "wall": wall}
    lf = np.asarray(result.t)
    out = {"wall": wall}
    for a in alphas:
        i = int(np.argmin(abs(4 * lf - float(a))))
        exact = ref[a]["transverse_over_L"]
        out[a] = abs(result.probes["tip_y"][i] - exact) / exact
    return out


def d4(elements: int, formulation: str, section: dict | None = None) -> dict:
    """Runs into a scratch folder, so that a failed run's probes.csv (closed on failure) still gives the
    time reached and the drift up to it.  ``section`` overrides keys of the scene's section."""
    raw = _scene("D4_flexible_pendulum.yaml", "pendulum", elements, formulation)
    raw["sections"]["s"].update(section or {})
    raw["solve"].update(planar="off", newton="full")  # the tables are of the 3D model (docs/verification.md)
    t0 = time.perf_counter()
    error = None
    with tempfile.TemporaryDirectory(prefix="latdyn-rotation-measures-") as scratch:
        try:
            latdyn.run(copy.deepcopy(raw), out_dir=scratch)
        except SolverError as exc:
            error = str(exc).splitlines()[0]
        table = np.genfromtxt(Path(scratch) / "probes.csv", delimiter=",", names=True)
    wall = time.perf_counter() - t0
    t = np.atleast_1d(table["t"])
    e = np.atleast_1d(table["energy"])
    scale = float(np.max(abs(np.atleast_1d(table["potential"]))))
    return {"t": float(t[-1]), "drift": float(np.max(abs(e - e[0])) / scale), "error": error, "wall": wall,
            "time": t, "tip": np.column_stack([np.atleast_1d(table["tip_x"]), np.atleast_1d(table["tip_y"])])}


def l1(elements: int, formulation: str) -> dict:
    exact = [b ** 2 for b in reference("L1")["reference"]["betaL_clamped_free"][:3]]
    result, error, wall = _run(_scene("L1_clamped_free.yaml", "beam", elements, formulation))
    if error:
        return {"error": error, "wall": wall}
    omega = 2 * np.pi * np.asarray(result.modes)
    return {"errors": [float((omega[np.argmin(abs(omega - w))] - w) / w) for w in exact], "wall": wall}


def _order(prev, cur, n_prev, n_cur):
    if prev is None or cur is None or prev <= 0 or cur <= 0:
        return ""
    return f"{math.log(prev / cur) / math.log(n_cur / n_prev):.2f}"


def table_s1(ns=(2, 4, 8, 16, 32, 64)):
    lines = ["S1 end-moment circle (static, 20 load steps): |tip − root|/L at M = 2πEI/L (exact 0; target 1e-3 "
             "with 8 elements) and the largest tip error /L over M/M₀ = 1/4, 1/2, 3/4, 1", "",
             "| elements | log: gap at 2π | log: worst | order | sines: gap at 2π | sines: worst | order |",
             "|---|---|---|---|---|---|---|"]
    prev = {f: None for f in FORMULATIONS}
    for i, n in enumerate(ns):
        cells = []
        for f in FORMULATIONS:
            r = s1(n, f)
            if "gap" not in r:
                cells += [f"failed ({r['error']})", "-", ""]
                prev[f] = None
                continue
            cells += [f"{r['gap']:.2e}", f"{r['worst']:.2e}", _order(prev[f], r["worst"], ns[i - 1], n) if i else ""]
            prev[f] = r["worst"]
        lines.append(f"| {n} | " + " | ".join(cells) + " |")
    return lines


def table_s2(ns=(2, 4, 8, 16, 32)):
    lines = ["S2 elastica, relative error of the tip deflection v/L at α = PL²/EI = 1 and 4", "",
             "| elements | log α=1 | log α=4 | sines α=1 | sines α=4 |", "|---|---|---|---|---|"]
    for n in ns:
        cells = []
        for f in FORMULATIONS:
            r = s2(n, f)
            cells += [f"{r[a]:.2e}" if a in r else "failed" for a in ("1", "4")]
        lines.append(f"| {n} | " + " | ".join(cells) + " |")
    return lines


#: D4 as published has no rotary inertia (ρI = 0) and GJ = EI: the twist of every node is a direction
#: without inertia.  The second table gives the section a radius of gyration of 1 mm (ρI_y = ρI_z = 1e-5).
D4_ROTARY = {"rhoIy": 1.0e-5, "rhoIz": 1.0e-5}


def table_d4(ns=(2, 4, 8, 16), section=None):
    runs = {(n, f): d4(n, f, section) for n in ns for f in FORMULATIONS}
    finest = runs[(ns[-1], "default")]
    lines = ["D4 very flexible pendulum" + (f" with {section}" if section else " as published")
             + ", Newmark dt = 1 ms to t = 1 s: time reached, energy drift "
             "max|E − E₀|/max|V| (tolerance 1e-4), tip position at t = 1 s against the finest log-map mesh "
             f"({ns[-1]} elements)", "",
             "| elements | log: t reached | log: drift | log: tip gap [m] | sines: t reached | sines: drift "
             "| sines: tip gap [m] |", "|---|---|---|---|---|---|---|"]
    for n in ns:
        cells = []
        for f in FORMULATIONS:
            r = runs[(n, f)]
            done = "tip" in r and abs(r["t"] - 1.0) < 1e-9
            gap = (float(np.linalg.norm(r["tip"][-1] - finest["tip"][-1])) if done and "tip" in finest else None)
            cells += [f"{r['t']:.3f} s" + ("" if done else " (failed)"),
                      f"{r['drift']:.1e}" if "drift" in r else "-",
                      "-" if gap is None else ("(reference)" if (n, f) == (ns[-1], "default") else f"{gap:.1e}")]
        lines.append(f"| {n} | " + " | ".join(cells) + " |")
    return lines


def table_l1(ns=(2, 4, 8, 16)):
    lines = ["L1 clamped-free, relative error of ω₁, ω₂, ω₃ (both measures; they agree to first order)", "",
             "| elements | log ω₁ | log ω₂ | log ω₃ | sines ω₁ | sines ω₂ | sines ω₃ |", "|---|---|---|---|---|---|---|"]
    for n in ns:
        cells = []
        for f in FORMULATIONS:
            r = l1(n, f)
            cells += [f"{e:+.3e}" for e in r["errors"]] if "errors" in r else ["failed"] * 3
        lines.append(f"| {n} | " + " | ".join(cells) + " |")
    return lines


TABLES = {"S1": table_s1, "S2": table_s2, "D4": table_d4, "D4r": lambda: table_d4(section=D4_ROTARY),
          "L1": table_l1}


def main(argv=None):
    names = (argv if argv is not None else sys.argv[1:]) or list(TABLES)
    for name in names:
        t0 = time.perf_counter()
        lines = TABLES[name]()
        print("\n".join(lines))
        print(f"\n({name}: {time.perf_counter() - t0:.0f} s)\n", flush=True)


if __name__ == "__main__":
    main()
