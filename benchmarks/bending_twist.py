"""Bending–twist coupling of the beam element (issue 22, item 1): convergence tables.

    PYTHONPATH=. python benchmarks/bending_twist.py [--quick]   # prints, writes results/bending_twist.json

Two cases, each a scene written as YAML text (as a user types it):

* **Lateral-torsional buckling** of a narrow cantilever, L = 1, weak-axis EI = GJ = 1, strong-axis
  EI = 1000, dead tip force at the centroid across the strong axis.  Closed form (Timoshenko & Gere,
  *Theory of Elastic Stability*, 2nd ed., §6.2, cantilever with a concentrated end load at the
  centroid): P_cr = 4.013 √(EI_weak GJ)/L², for EI_strong → ∞; errors are against it, as in the
  issue (the prebuckling curvature of a finite EI_strong = 1000 shifts the limit by about 0.1 %,
  which the Aitken-extrapolated limits printed below show).  The critical load is the load factor
  where the tangent stiffness of the loaded (perfect, planar) equilibrium loses positive
  definiteness, bisected on the smallest eigenvalue of
  ``assembler.evaluate(state, load_factor=λ, inertia=False).stiffness`` (the helper below, not in the
  package).
* **Helix**: a cantilever (isotropic section EI = 1) loaded at its free end by a dead couple
  M = (M_x, M_y, 0) with components along and across its axis.  The internal moment is M everywhere,
  so the tangent turns about M at the rate |M|/EI, t(s) = exp(s skew(M)/EI) e_x, whatever GJ: the
  centreline is a helix independent of GJ.  Error: |x_tip − x_exact|/L for GJ = 0.5, 1, 2.
* **D2 right-angle cantilever** (Simo & Vu-Quoc 1988; examples/benchmarks/), the 3D verification case
  where bending, twist and twist inertia meet: the first maximum of the tip's out-of-plane displacement
  against elements per leg (dt = 0.025, 20 s), for the self-convergence of each formulation.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import latdyn  # noqa: E402
from latdyn.assembly.prepare import prepare  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results" / "bending_twist.json"

#: Timoshenko & Gere §6.2: P_cr L²/√(EI_weak GJ) = 4.013 for the centroid-loaded cantilever
LTB_COEFFICIENT = 4.013
EI_STRONG = 1000.0
LTB_REFERENCE = LTB_COEFFICIENT  # L = EI_weak = GJ = 1

HELIX_MOMENT = (1.0, 2.0)


def ltb_scene(elements: int, formulation: str, load: float = 4.5, lateral: float = 0.0, steps: int = 10) -> str:
    """The LTB cantilever as YAML text: local y = global Y (weak, EIz = 1), local z = global Z (strong)."""
    return f"""\
title: lateral-torsional buckling of a narrow cantilever
sections:
  narrow: {{EA: 1.0e6, EIy: {EI_STRONG}, EIz: 1.0, GJ: 1.0, rhoA: 1.0}}
bodies:
  root: {{at: [0, 0, 0], fixed: true}}
beams:
  cantilever: {{from: root, to: [1, 0, 0], section: narrow, elements: {elements}}}
loads:
  - {{at: cantilever.end, force: [0, {lateral}, {-load}], frame: global}}
solve: {{analysis: static, steps: {steps}, formulation: {formulation}, planar: "off"}}
output:
  probes:
    tip_y: {{point: cantilever.end, quantity: displacement, frame: global, component: y}}
    tip_z: {{point: cantilever.end, quantity: displacement, frame: global, component: z}}
"""


def helix_scene(elements: int, formulation: str, GJ: float, steps: int = 8) -> str:
    mx, my = HELIX_MOMENT
    return f"""\
title: cantilever rolled into a helix by an end couple
sections:
  round: {{EA: 1.0e6, EIy: 1.0, EIz: 1.0, GJ: {GJ}, rhoA: 1.0}}
bodies:
  root: {{at: [0, 0, 0], fixed: true}}
beams:
  rod: {{from: root, to: [1, 0, 0], section: round, elements: {elements}}}
loads:
  - {{at: rod.end, moment: [{mx}, {my}, 0], frame: global}}
solve: {{analysis: static, steps: {steps}, formulation: {formulation}, planar: "off"}}
output:
  probes:
    tip_x: {{point: rod.end, quantity: position, frame: global, component: x}}
    tip_y: {{point: rod.end, quantity: position, frame: global, component: y}}
    tip_z: {{point: rod.end, quantity: position, frame: global, component: z}}
"""


def helix_exact(L: float = 1.0, EI: float = 1.0) -> np.ndarray:
    """x(L) = ∫₀ᴸ exp(s skew(M)/EI) e_x ds, in closed form (rotation about n = M/|M| at rate k = |M|/EI)."""
    M = np.array([*HELIX_MOMENT, 0.0])
    k = np.linalg.norm(M) / EI
    n = M / np.linalg.norm(M)
    e = np.array([1.0, 0.0, 0.0])
    along = n * (n @ e)
    across = e - along
    # ∫ [along + cos(ks) across + sin(ks) n × across] ds
    return along * L + across * math.sin(k * L) / k + np.cross(n, across) * (1 - math.cos(k * L)) / k


def load_yaml(text: str):
    import yaml

    return latdyn.load_scene(yaml.safe_load(text))


# --------------------------------------------------------------------------
# Critical load: the loaded equilibrium's tangent loses positive definiteness
# --------------------------------------------------------------------------
def _equilibrium(prepared, state, load_factor: float, tol: float = 1e-11, max_iter: int = 40):
    assembler = prepared.assembler
    for _ in range(max_iter):
        ev = assembler.evaluate(state, matrices=True, load_factor=load_factor, inertia=False)
        K = ev.combined(0.0, 0.0, 1.0, dense=True)
        dx = np.linalg.solve(K, -ev.residual)
        state = assembler.advance(state, dx)
        assembler.apply_prescribed(state, 0.0)
        if np.linalg.norm(dx) < tol:
            ev = assembler.evaluate(state, matrices=True, load_factor=load_factor, inertia=False)
            return state, ev.combined(0.0, 0.0, 1.0, dense=True)
    raise RuntimeError(f"no equilibrium at load factor {load_factor}")


def smallest_eigenvalue(K: np.ndarray) -> float:
    return float(np.linalg.eigvalsh(0.5 * (K + K.T))[0])


def critical_load_factor(scene, lo: float = 0.5, hi: float = 1.0, rel: float = 1e-7) -> float:
    """Bisect λ in [lo, hi] on the sign of the smallest eigenvalue of the loaded tangent.

    The equilibrium at each λ is followed from the last stable one (the perfect cantilever's
    prebuckling path is planar, so Newton stays on it past the bifurcation as well)."""
    prepared = prepare(scene)
    state = prepared.state
    for lam in np.linspace(0.0, lo, 6)[1:]:
        state, K = _equilibrium(prepared, state, lam)
    assert smallest_eigenvalue(K) > 0, "unstable below the bracket"
    stable = state
    while hi - lo > rel * hi:
        mid = 0.5 * (lo + hi)
        trial, K = _equilibrium(prepared, stable, mid)
        if smallest_eigenvalue(K) > 0:
            lo, stable = mid, trial
        else:
            hi = mid
    return 0.5 * (lo + hi)


def ltb_critical_load(elements: int, formulation: str, load: float = 4.5) -> float:
    return load * critical_load_factor(load_yaml(ltb_scene(elements, formulation, load)))


def helix_tip_error(elements: int, formulation: str, GJ: float) -> float:
    result = latdyn.run(load_yaml(helix_scene(elements, formulation, GJ)))
    tip = np.array([result.probes[f"tip_{c}"][-1] for c in "xyz"])
    return float(np.linalg.norm(tip - helix_exact()))


def d2_tip_maximum(elements: int, formulation: str) -> float:
    from benchmarks import problems

    scene = problems.scene("D2_right_angle_cantilever.yaml")
    scene["beams"]["leg1"]["elements"] = scene["beams"]["leg2"]["elements"] = elements
    scene["solve"].update(dt=0.025, t_end=10.0, formulation=formulation)
    result = latdyn.run(latdyn.load_scene(scene))
    return float(np.max(np.asarray(result.probes["tip_u3"])))


def orders(ns, errors):
    return [None] + [math.log(abs(errors[i - 1] / errors[i])) / math.log(ns[i] / ns[i - 1])
                     for i in range(1, len(ns))]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="16 and 32 elements only")
    parser.add_argument("--formulation", action="append", default=None)
    args = parser.parse_args(argv)
    ns = (16, 32) if args.quick else (16, 32, 64)
    formulations = args.formulation or ["default", "cr4402"]
    out = {"ltb": {"reference": LTB_REFERENCE, "closed_form_coefficient": LTB_COEFFICIENT, "rows": {}},
           "helix": {"exact_tip": helix_exact().tolist(), "moment": HELIX_MOMENT, "rows": {}}}
    print(f"Lateral-torsional buckling, P_ref = 4.013 √(EI GJ)/L² = {LTB_REFERENCE:.5f} (EI_strong = {EI_STRONG:g})")
    print(f"{'formulation':<12} {'n':>4} {'P_cr':>10} {'error':>9} {'order':>6} {'s':>6}")
    for name in formulations:
        loads = []
        for n in ns:
            started = time.perf_counter()
            loads.append(ltb_critical_load(n, name))
            seconds = time.perf_counter() - started
            errors = [p / LTB_REFERENCE - 1 for p in loads]
            order = orders(ns[:len(errors)], errors)[-1]
            print(f"{name:<12} {n:>4} {loads[-1]:>10.5f} {errors[-1]:>+9.3%} "
                  f"{'' if order is None else f'{order:.2f}':>6} {seconds:>6.1f}")
        out["ltb"]["rows"][name] = {"elements": list(ns), "P_cr": loads,
                                    "relative_error": [p / LTB_REFERENCE - 1 for p in loads]}
        if len(loads) == 3:  # Aitken's Δ²: the limit of a sequence converging at a fixed order in h
            a, b, c = loads
            limit = c - (c - b) ** 2 / ((c - b) - (b - a))
            self_order = math.log((b - a) / (c - b)) / math.log(2)
            out["ltb"]["rows"][name].update(extrapolated=limit, self_convergence_order=self_order)
            print(f"{name:<12} {'lim':>4} {limit:>10.5f} {limit / LTB_REFERENCE - 1:>+9.3%}  "
                  f"order from successive differences {self_order:.2f}")
    print(f"\nHelix under an end couple M = {HELIX_MOMENT}: |x_tip − x_exact|/L")
    print(f"{'formulation':<12} {'GJ':>4} " + " ".join(f"{f'n={n}':>10}" for n in ns) + "  orders")
    for name in formulations:
        out["helix"]["rows"][name] = {}
        for GJ in (0.5, 1.0, 2.0):
            errors = [helix_tip_error(n, name, GJ) for n in ns]
            out["helix"]["rows"][name][str(GJ)] = {"elements": list(ns), "tip_error": errors}
            print(f"{name:<12} {GJ:>4} " + " ".join(f"{e:>10.3e}" for e in errors) + "  "
                  + " ".join(f"{o:.2f}" for o in orders(ns, errors)[1:]))
    if not args.quick:
        d2_ns = (5, 10, 20, 40)
        out["d2"] = {"elements_per_leg": list(d2_ns), "rows": {}}
        print("\nD2 right-angle cantilever: first maximum of the tip's out-of-plane displacement (dt 0.025)")
        print(f"{'formulation':<12} " + " ".join(f"{f'n={n}':>10}" for n in d2_ns) + "  successive-difference ratios")
        for name in formulations:
            values = [d2_tip_maximum(n, name) for n in d2_ns]
            out["d2"]["rows"][name] = values
            ratios = [(values[i] - values[i + 1]) / (values[i + 1] - values[i + 2]) for i in range(len(values) - 2)]
            print(f"{name:<12} " + " ".join(f"{v:>10.5f}" for v in values) + "  "
                  + " ".join(f"{r:.1f}" for r in ratios))
        RESULTS.write_text(json.dumps(out, indent=1) + "\n")
        print(f"\nwrote {RESULTS.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
