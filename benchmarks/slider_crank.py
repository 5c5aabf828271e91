"""The flexible slider-crank: latdyn's mid-span deflection of the connecting rod against a peer's.

Run from the repository root::

    python benchmarks/slider_crank.py              # latdyn at several (elements, dt) against the reference
    python benchmarks/slider_crank.py --reference  # the reference itself, from Exudyn (pip install exudyn)

The problem is the classic flexible connecting rod of a slider-crank in the proportions it is usually
quoted with (after Jasinski, Lee & Sandor 1971 and Simo & Vu-Quoc 1986; taken from public code that
cites them, not checked against the papers): a rigid crank of 0.152 m, a steel rod of 0.304 m
and 6 mm diameter (E = 200 GPa, ρ = 7870 kg/m³; Euler–Bernoulli, no rotary inertia), pinned at both
ends, its far end carrying a slider of half the rod's mass on a frictionless guide through the
crank's pivot. No gravity. The crank is driven through its hinge angle from rest to Ω = 150 rad/s
over T = 0.03 s with a smooth run-up (θ̇ = Ω (1 − cos πt/T)/2, so θ, θ̇ and θ̈ are continuous), then
at Ω: θ(t) = Ω (t − T/2). Both codes start from the same state (everything at rest, the rod
straight along x), so the histories compare without any initial transient of either.

The measured quantity is the rod's mid-span deflection: the distance of its middle node from the
chord through its ends, signed by the plane's normal (positive to the left of the chord as seen from
the pin towards the slider), in metres, over 0 ≤ t ≤ 0.12 s (two and a half turns).

Reference (``benchmarks/references/slider_crank.json``): Exudyn 1.13.6 (installed into a separate
virtual environment, never this project's), 16 ObjectANCFCable2D elements (Euler–Bernoulli,
axial and bending, no rotary inertia: the same physics), the pin prescribed by two
CoordinateConstraints with offset user functions, the slider a MassPoint2D tied to the rod's end and
held at y = 0, generalized-α (spectral radius 0.9, full Newton, constant steps: Exudyn's default
adaptive step cuts steps whose Newton fails, which its default absolute tolerance 1e-10 makes
happen here, and leaves rows off the 0.5 ms grid) at h = 2e-5 s. Its own convergence: ``--reference``
also runs 8 elements at 2e-5 s and 16 elements at 1e-5 and 1e-4 s and records the differences
(measured: 3.6e-7 m, 3.6e-7 m and 8.4e-6 m against a peak of 4.21e-3 m).

No digitised published curve of this problem was available to this project; the peer's converged
history is the reference. The run-up, the slider's mass and the start from rest are this problem's,
so the papers' figures are not this one.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "benchmarks" / "references" / "slider_crank.json"
RESULTS = ROOT / "benchmarks" / "results" / "slider_crank.json"
FIGURE = ROOT / "docs" / "guides_slider_crank.png"

CRANK, ROD, DIAMETER = 0.152, 0.304, 0.006
YOUNG, DENSITY = 2.0e11, 7870.0
OMEGA, RUN_UP, T_END, EVERY = 150.0, 0.03, 0.12, 5.0e-4


def rod_properties() -> dict:
    """EA, EI, GJ, ρA and the slider's mass, rounded to 7 digits: the numbers both codes are given."""
    area, inertia = math.pi * DIAMETER ** 2 / 4.0, math.pi * DIAMETER ** 4 / 64.0
    exact = {"EA": YOUNG * area, "EI": YOUNG * inertia, "GJ": YOUNG / 2.6 * 2.0 * inertia,
             "rhoA": DENSITY * area, "slider": 0.5 * DENSITY * area * ROD}
    return {k: float(f"{v:.7g}") for k, v in exact.items()}


def crank_angle(t: float) -> float:
    """θ(t): the smooth run-up to Ω over T, then Ω (t − T/2)."""
    if t < RUN_UP:
        return 0.5 * OMEGA * (t - RUN_UP / math.pi * math.sin(math.pi * t / RUN_UP))
    return OMEGA * (t - 0.5 * RUN_UP)


CRANK_ANGLE_TEXT = "Piecewise((75*(t - 0.03/pi*sin(pi*t/0.03)), t < 0.03), (150*(t - 0.015), True))"


def scene_text(elements: int = 8, dt: float = 1.0e-4, t_end: float = T_END, rotation=None) -> str:
    """The scene as a user writes it; ``rotation`` (3×3) turns the whole mechanism into another plane."""
    R = np.eye(3) if rotation is None else np.asarray(rotation, float)
    p = rod_properties()

    def vec(v):
        return "[" + ", ".join(f"{x:.16g}" for x in R @ np.asarray(v, float)) + "]"

    z = vec([0, 0, 1])
    return f"""title: flexible slider-crank (Simo & Vu-Quoc's proportions), the crank run up to 150 rad/s
sections:
  crank: {{EA: 1.0e9, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 1.0}}
  rod: {{EA: {p['EA']}, EIy: {p['EI']}, EIz: {p['EI']}, GJ: {p['GJ']}, rhoA: {p['rhoA']}}}
bodies:
  hub: {{at: [0, 0, 0], fixed: true}}
  pin: {{at: {vec([CRANK, 0, 0])}}}
  slider: {{at: {vec([CRANK + ROD, 0, 0])}, mass: {p['slider']}, guide: {{axis: {vec([1, 0, 0])}}}}}
beams:
  crank:
    from: hub
    to: pin
    section: crank
    rigid: true
    start: {{hinge: {{axis: {z}, angle: "{CRANK_ANGLE_TEXT}"}}}}
  rod:
    from: pin
    to: slider
    section: rod
    elements: {elements}
    start: {{hinge: {{axis: {z}}}}}
    end: {{hinge: {{axis: {z}}}}}
solve: {{analysis: transient, t_end: {t_end}, dt: {dt}, rho_inf: 0.9}}
output:
  every: {EVERY}
  probes:
""" + "".join(f"    {name}_{c}: {{point: rod.node[{k}], quantity: position, component: {c}}}\n"
              for name, k in (("pin", 0), ("mid", elements // 2), ("end", elements)) for c in "xyz")


def mid_span_deflection(pin, mid, end, normal=(0.0, 0.0, 1.0)) -> np.ndarray:
    """The middle point's distance from the chord pin → end, signed by ``normal`` (rows of points)."""
    chord, arm = np.asarray(end) - np.asarray(pin), np.asarray(mid) - np.asarray(pin)
    return np.cross(chord, arm) @ np.asarray(normal, float) / np.linalg.norm(chord, axis=1)


def probe_points(probes: dict, name: str) -> np.ndarray:
    return np.column_stack([probes[f"{name}_{c}"] for c in "xyz"])


def latdyn_history(elements: int, dt: float, t_end: float = T_END):
    """(t, deflection, slider x, solver wall time s, steps) of a latdyn run of the scene."""
    import latdyn

    with tempfile.TemporaryDirectory() as tmp:
        scene = Path(tmp) / "slider_crank.yaml"
        scene.write_text(scene_text(elements, dt, t_end))
        result = latdyn.run(latdyn.load_scene(scene), Path(tmp) / "out")
    probes = result.probes
    deflection = mid_span_deflection(*(probe_points(probes, n) for n in ("pin", "mid", "end")))
    return (np.asarray(result.t), deflection, np.asarray(probes["end_x"]), result.summary["wall_time_s"],
            result.summary["steps"])


def exudyn_history(elements: int, dt: float, t_end: float = T_END):
    """(t, deflection, slider x, wall time s) of the same problem in Exudyn (module docstring)."""
    import exudyn as exu
    from exudyn import itemInterface as eii

    p = rod_properties()
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    h = ROD / elements
    nodes = [mbs.AddNode(eii.NodePoint2DSlope1(referenceCoordinates=[CRANK + h * i, 0, 1, 0]))
             for i in range(elements + 1)]
    for i in range(elements):
        mbs.AddObject(eii.ObjectANCFCable2D(nodeNumbers=[nodes[i], nodes[i + 1]], length=h,
                                            massPerLength=p["rhoA"], bendingStiffness=p["EI"],
                                            axialStiffness=p["EA"], useReducedOrderIntegration=0))
    ground = mbs.AddNode(eii.NodePointGround())
    at_ground = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=ground, coordinate=0))
    pin_offsets = (lambda mbs, t, item, offset: CRANK * math.cos(crank_angle(t)) - CRANK,
                   lambda mbs, t, item, offset: CRANK * math.sin(crank_angle(t)))
    for c, offset in enumerate(pin_offsets):
        m = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=nodes[0], coordinate=c))
        mbs.AddObject(eii.CoordinateConstraint(markerNumbers=[at_ground, m], offsetUserFunction=offset))
    slider = mbs.AddNode(eii.NodePoint2D(referenceCoordinates=[CRANK + ROD, 0]))
    mbs.AddObject(eii.MassPoint2D(mass=p["slider"], nodeNumber=slider))
    for c in (0, 1):
        ms = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=slider, coordinate=c))
        me = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=nodes[-1], coordinate=c))
        mbs.AddObject(eii.CoordinateConstraint(markerNumbers=[ms, me]))
    mbs.AddObject(eii.CoordinateConstraint(markerNumbers=[at_ground, ms]))  # ms: the slider's y
    position = exu.OutputVariableType.Position
    sensors = [mbs.AddSensor(eii.SensorNode(nodeNumber=nodes[k], outputVariableType=position,
                                            storeInternal=True, writeToFile=False))
               for k in (0, elements // 2, elements)]
    mbs.Assemble()
    ss = exu.SimulationSettings()
    ti = ss.timeIntegration
    ti.numberOfSteps, ti.endTime, ti.verboseMode = int(round(t_end / dt)), t_end, 0
    ti.generalizedAlpha.spectralRadius = 0.9
    ti.adaptiveStep = False  # constant steps: no step is cut (Exudyn's default halves a step whose Newton fails)
    ti.newton.useModifiedNewton = False
    ti.newton.absoluteTolerance = 1e-6  # N: Exudyn's default 1e-10 is below the round-off of EA ~ 6e6 N
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = dt  # every step: the rows at multiples of EVERY are taken below
    ss.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    start = time.perf_counter()
    mbs.SolveDynamic(ss)
    wall = time.perf_counter() - start
    pin, mid, end = (np.asarray(mbs.GetSensorStoredData(s)) for s in sensors)
    ratio = pin[:, 0] / EVERY
    rows = np.flatnonzero(np.abs(ratio - np.round(ratio)) < 1e-6)
    pin, mid, end = pin[rows], mid[rows], end[rows]
    pad = np.zeros((len(pin), 1))
    points = [np.hstack([a[:, 1:3], pad]) for a in (pin, mid, end)]
    return pin[:, 0], mid_span_deflection(*points), end[:, 1], wall


def write_reference() -> None:
    """The converged Exudyn history and its own convergence, into ``REFERENCE``."""
    import exudyn

    t, deflection, slider, wall = exudyn_history(16, 2.0e-5)
    checks = {}
    for elements, dt in ((8, 2.0e-5), (16, 1.0e-5), (16, 1.0e-4)):
        t_c, d_c, _, wall_c = exudyn_history(elements, dt)
        checks[f"{elements} elements, dt {dt:g}"] = {
            "max_difference_m": float(np.abs(np.interp(t, t_c, d_c) - deflection).max()), "wall_s": wall_c}
    REFERENCE.write_text(json.dumps({
        "problem": "flexible slider-crank, benchmarks/slider_crank.py (module docstring)",
        "code": f"Exudyn {exudyn.__version__}, 16 ObjectANCFCable2D, generalized-alpha rho 0.9, h = 2e-5 s",
        "wall_s": wall, "convergence": checks, "parameters": rod_properties(),
        "t": [round(float(x), 10) for x in t], "deflection_m": [float(f"{x:.9g}") for x in deflection],
        "slider_x_m": [float(f"{x:.12g}") for x in slider]}, indent=1) + "\n")
    print(f"wrote {REFERENCE}: peak |deflection| {np.abs(deflection).max():.6g} m; {checks}")


def load_reference() -> dict:
    data = json.loads(REFERENCE.read_text())
    return {k: np.asarray(v) if isinstance(v, list) else v for k, v in data.items()}


def compare(t, deflection, reference=None) -> dict:
    """Largest |latdyn − reference| of the deflection, in metres and over the reference's peak."""
    reference = reference or load_reference()
    d_ref = np.interp(t, reference["t"], reference["deflection_m"])
    peak = float(np.abs(reference["deflection_m"]).max())
    worst = float(np.abs(deflection - d_ref).max())
    return {"max_difference_m": worst, "relative_to_peak": worst / peak, "reference_peak_m": peak}


def figure(histories: dict, reference: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, low) = plt.subplots(2, 1, figsize=(7.5, 5.4), sharex=True, height_ratios=[2.2, 1])
    ax.plot(1e3 * reference["t"], 1e3 * reference["deflection_m"], "k-", lw=2.2,
            label="Exudyn, 16 ANCF elements, h = 2e-5 s (reference)")
    for label, (t, d) in histories.items():
        ax.plot(1e3 * t, 1e3 * d, "--", lw=1.2, label=f"latdyn, {label}")
        low.plot(1e3 * t, 1e6 * (d - np.interp(t, reference["t"], reference["deflection_m"])), lw=1.0,
                 label=f"latdyn, {label}")
    ax.set_ylabel("mid-span deflection (mm)")
    ax.set_title("Flexible slider-crank: the rod's mid-span deflection (crank to 150 rad/s by 30 ms)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    low.set_xlabel("time t (ms)")
    low.set_ylabel("latdyn − reference (µm)")
    low.grid(True, alpha=0.3)
    low.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(FIGURE, dpi=110)
    plt.close(fig)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference", action="store_true", help="compute the Exudyn reference (needs exudyn)")
    args = parser.parse_args(argv)
    if args.reference:
        write_reference()
        return
    sys.path.insert(0, str(ROOT))  # this checkout's latdyn
    reference = load_reference()
    rows, histories = [], {}
    for elements, dt in ((4, 1.0e-4), (8, 1.0e-4), (8, 2.0e-5), (16, 2.0e-5)):
        start = time.perf_counter()
        t, d, slider, solver_s, steps = latdyn_history(elements, dt)
        run_s = time.perf_counter() - start
        row = {"elements": elements, "dt": dt, "steps": steps, "solver_s": solver_s, "run_s": run_s,
               "peak_m": float(np.abs(d).max()), **compare(t, d, reference)}
        rows.append(row)
        print(row)
        if (elements, dt) in ((4, 1.0e-4), (8, 1.0e-4), (8, 2.0e-5)):
            histories[f"{elements} elements, dt = {dt:g} s"] = (t, d)
    RESULTS.write_text(json.dumps({"load_average": os.getloadavg(), "rows": rows,
                                   "reference": {k: reference[k] for k in ("code", "convergence")}},
                                  indent=1) + "\n")
    figure(histories, reference)
    print(f"wrote {RESULTS} and {FIGURE}")


if __name__ == "__main__":
    main()
