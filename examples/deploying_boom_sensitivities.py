"""The deploying boom's hinge spring and damper chosen with exact gradients through the latch.

    python examples/deploying_boom_sensitivities.py [--plot FILE.png]

A planar two-panel boom (examples/deploying_boom.yaml, coarser: 3 elements a panel, dt = 0.005 and rho_inf = 0.5 (with 0.01 or the default 0.8 some designs
ran unbounded in the first steps, where the folded panel starts), and
rotary inertia on the panels so that every direction has inertia) deploys on its preloaded hinge
spring (stiffness k, rest angle 3.6 rad) with a damper c and latches at π. A stiff spring deploys
fast and latches hard; a damper softens the latch and slows the deployment. The design: minimise the
latch shock seen at the knee — the peak-to-peak of its lateral displacement over the run — subject
to the latch coming by T_MAX, with scipy.optimize.minimize (SLSQP) and the exact gradients of one
run each: ``probe_sensitivities`` (the derivatives of the probe's largest and smallest values) and
``event_sensitivities`` (the latch time's derivatives), docs/parameters.md. Prints the iterations
and the optimum, checks the gradient at the optimum against one central difference of whole runs,
and with ``--plot`` draws the knee's motion at the start and at the optimum.
"""
from __future__ import annotations

import argparse
import copy

import numpy as np
from scipy.optimize import minimize

import latdyn

T_MAX = 1.3025   # s: the latch must come by then (between grid times: an event on a grid time is a kink in p)
SCENE = {
    "title": "deploying two-panel boom, planar, its hinge spring and damper named",
    "parameters": {"k": 2.0, "c": 0.1},
    "sections": {"panel": {"EA": 1.0e6, "EIy": 50.0, "EIz": 50.0, "GJ": 40.0, "rhoA": 1.0,
                           "rhoIy": 0.001, "rhoIz": 0.001}},
    "bodies": {"root": {"at": [0, 0, 0], "fixed": True}, "knee": {"at": [1, 0, 0], "mass": 0.2},
               "tip": {"at": [0, 0.05, 0], "mass": 0.5}},
    "beams": {"inner": {"from": "root", "to": "knee", "section": "panel", "elements": 3},
              "outer": {"from": {"body": "knee", "offset": [0, 0.05, 0]}, "to": "tip", "section": "panel",
                        "elements": 3, "start": {"hinge": {"axis": [0, 0, 1], "stiffness": "k", "damping": "c",
                                                           "rest_angle": 3.6, "lock_at": "pi"}}}},
    "solve": {"analysis": "transient", "t_end": 2.5, "dt": 0.005, "rho_inf": 0.5, "sensitivities": ["k", "c"]},
    "output": {"every": 0.01, "probes": {"knee_y": {"point": "knee", "quantity": "displacement", "component": "y"},
                                         "hinge": {"hinge": "outer.start", "quantity": "angle"}}},
}
NAMES = ("k", "c")


def run(x: np.ndarray, sensitivities: bool = True):
    scene = copy.deepcopy(SCENE)
    scene["parameters"] = dict(zip(NAMES, map(float, x)))
    if not sensitivities:
        del scene["solve"]["sensitivities"]
    return latdyn.run(latdyn.load_scene(scene))


class Design:
    """One run per design point, its objective, constraint and their exact gradients."""

    def __init__(self):
        self.x, self.result, self.history = None, None, []

    def at(self, x):
        if self.x is None or not np.array_equal(x, self.x):
            try:
                self.x, self.result = np.array(x, float), run(x)
            except latdyn.SolverError as failure:
                raise SystemExit(f"the run at k = {x[0]:.6g}, c = {x[1]:.6g} failed: {failure}") from None
            self.history.append((self.x.copy(), self.shock(), self.latch_time()))
            print(f"  k = {x[0]:.4f} N·m/rad, c = {x[1]:.4f} N·m·s/rad: knee peak-to-peak "
                  f"{self.shock() * 1e3:.3f} mm, latch at {self.latch_time():.4f} s")
        return self.result

    def shock(self, x=None):
        r = self.result if x is None else self.at(x)
        return float(np.max(r.probes["knee_y"]) - np.min(r.probes["knee_y"]))

    def shock_gradient(self, x):
        peaks = self.at(x).summary["probe_sensitivities"]["knee_y"]
        return np.array([peaks["max"][n] - peaks["min"][n] for n in NAMES])

    def latch_time(self, x=None):
        r = self.result if x is None else self.at(x)
        (latch,) = [e for e in r.summary["events"] if e["kind"] == "latch"]
        return float(latch["t"])

    def latch_gradient(self, x):
        (latch,) = self.at(x).summary["event_sensitivities"]
        return np.array([latch["dt"][n] for n in NAMES])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", help="a picture of the knee's motion at the start and the optimum")
    args = parser.parse_args()
    design = Design()
    start = np.array([SCENE["parameters"][n] for n in NAMES])
    print("SLSQP iterations (each line one run with its exact gradients):")
    found = minimize(design.shock, start, jac=design.shock_gradient, method="SLSQP",
                     bounds=[(0.5, 6.0), (0.0, 1.0)],
                     constraints=[{"type": "ineq", "fun": lambda x: T_MAX - design.latch_time(x),
                                   "jac": lambda x: -design.latch_gradient(x)}],
                     options={"maxiter": 15, "ftol": 1e-9})
    x = found.x
    print(f"optimum: k = {x[0]:.4f} N·m/rad, c = {x[1]:.4f} N·m·s/rad; knee peak-to-peak "
          f"{design.shock(x) * 1e3:.3f} mm (start {design.history[0][1] * 1e3:.3f} mm); latch at "
          f"{design.latch_time(x):.4f} s (limit {T_MAX} s); {found.nit} iterations, {len(design.history)} runs; "
          f"{found.message}")
    assert found.success and design.latch_time(x) <= T_MAX + 1e-6 and design.shock(x) < 0.7 * design.history[0][1]
    # the gradient at the optimum against one central difference of whole runs (±0.1 %)
    exact = design.shock_gradient(x)
    for i, name in enumerate(NAMES):
        step = 1e-3 * max(abs(x[i]), 1e-2)
        up, down = x.copy(), x.copy()
        up[i] += step
        down[i] -= step
        spread = [float(np.ptp(run(p, sensitivities=True).probes["knee_y"])) for p in (up, down)]
        central = (spread[0] - spread[1]) / (2 * step)
        print(f"d(peak-to-peak)/d{name}: exact {exact[i]:.6e}, central difference {central:.6e}")
        assert abs(central - exact[i]) < 1e-3 * abs(exact[i])   # the difference's own error: 1e-4 at ±0.1 %
    if args.plot:
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(8, 3.5))
        for label, point in (("start", start), ("optimum", x)):
            r = run(point, sensitivities=False)
            ax.plot(r.t, np.asarray(r.probes["knee_y"]) * 1e3,
                    label=f"latdyn, {label}: k = {point[0]:.2f} N·m/rad, c = {point[1]:.2f} N·m·s/rad")
        ax.axvline(T_MAX, color="k", ls=":", lw=1, label="latch time limit")
        ax.set(xlabel="time t (s)", ylabel="knee lateral displacement (mm)", title="Deploying boom: the latch shock")
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=100)


if __name__ == "__main__":
    main()
