"""
Work-precision: a pendulum at five time steps
==============================================

How much accuracy a second of computing buys, for three of the implicit integrators
(``solve.method``). The problem: the D4 pendulum in its rigid limit
(``examples/benchmarks/D4_rigid_limit.yaml``: a 1.2 m rod so stiff that it swings as a rigid
body) released horizontal under gravity. The reference is the rigid rod's equation of motion,
θ̈ = −(3g / 2L) cos θ, integrated by SciPy to 1e-12; the error is the hinge angle at t = 0.5 s
(just before the rod passes the vertical). Each method is second order: halving the step
quarters the error.
"""
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from scipy.integrate import solve_ivp

import latdyn

path = Path("examples/benchmarks/D4_rigid_limit.yaml")
scene = latdyn.load_scene(path if path.exists() else Path("../benchmarks/D4_rigid_limit.yaml")).raw
scene["solve"]["t_end"] = 0.5
L, g = 1.2, 9.81
exact = solve_ivp(lambda t, y: [y[1], -1.5 * g / L * np.cos(y[0])], (0.0, 0.5), [0.0, 0.0],
                  rtol=1e-12, atol=1e-14).y[0, -1]
# θ: the hinge angle about +z from the horizontal (negative as the rod falls)
steps = [0.02, 0.01, 0.005, 0.0025, 0.00125]
methods = ["generalized-alpha", "hht-alpha", "newmark"]
errors, walls = {}, {}
for method in methods:
    errors[method], walls[method] = [], []
    for dt in steps:
        scene["solve"].update(method=method, dt=dt)
        started = time.perf_counter()
        result = latdyn.run(scene)
        walls[method].append(time.perf_counter() - started)
        errors[method].append(abs(result.probes["angle"][-1] - exact))

# %%
# The checks: second-order convergence (the slope of log error against log dt over the last
# three steps) and the error at the finest step.
print(f"reference angle at t = 0.5 s: {exact:.10f} rad")
for method in methods:
    order = np.polyfit(np.log(steps[-3:]), np.log(errors[method][-3:]), 1)[0]
    print(f"{method:18s} errors {', '.join(f'{e:.2e}' for e in errors[method])} rad; "
          f"observed order {order:.2f}; wall {sum(walls[method]):.2f} s")
    assert 1.8 < order < 2.3 and errors[method][-1] < 1e-4

# %%
# The work-precision chart: error against the wall time of each run (log-log; lower left is
# better), and the same errors against the step.
fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
for method in methods:
    left.loglog(walls[method], errors[method], "o-", label=f"latdyn, {method}")
    right.loglog(steps, errors[method], "o-", label=f"latdyn, {method}")
right.loglog(steps, errors["generalized-alpha"][0] * (np.array(steps) / steps[0]) ** 2, "k:", label="slope 2")
left.set(xlabel="wall time of the run (s)", ylabel="error in the angle at t = 0.5 s (rad)", title="Work-precision")
right.set(xlabel="time step dt (s)", ylabel="error in the angle at t = 0.5 s (rad)", title="Convergence")
left.legend(fontsize=8)
right.legend(fontsize=8)
fig.tight_layout()
