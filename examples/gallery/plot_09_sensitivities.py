"""
Which members matter: exact sensitivities of a lattice's tip response
=====================================================================

A planar lattice cantilever of three bays (top and bottom chords, verticals and diagonals; 13 tubes,
each its own section whose axial stiffness EA is a named parameter ``EA_<member>``) carries a tip
load that grows in 0.05 s and is then held. ``solve.sensitivities`` names all 13: one run gives the
exact derivative of the tip's deflection by every member's EA (the derivative of the computed
trajectory, docs/parameters.md), which ranks the members by how much a stiffer tube would reduce
the deflection. The top one is checked against one central difference of two whole runs.
"""
import numpy as np
import matplotlib.pyplot as plt

import latdyn

BAY, HEIGHT, EA = 0.5, 0.4, 2.0e6
nodes = {f"b{i}": [BAY * i, 0.0, 0.0] for i in range(4)} | {f"t{i}": [BAY * i, HEIGHT, 0.0] for i in range(4)}
members = {}
for i in range(3):
    members[f"bottom{i}"] = (f"b{i}", f"b{i + 1}")
    members[f"top{i}"] = (f"t{i}", f"t{i + 1}")
    members[f"diagonal{i}"] = (f"b{i}", f"t{i + 1}")
for i in range(1, 4):
    members[f"vertical{i}"] = (f"b{i}", f"t{i}")
members["vertical0"] = ("b0", "t0")   # between the two clamped supports: takes no load (its sensitivity is ~0)
names = [f"EA_{m}" for m in members]
scene = {
    "title": "lattice cantilever, tip load held",
    "parameters": {name: EA for name in names},
    "sections": {m: {"EA": f"EA_{m}", "EIy": 40.0, "EIz": 40.0, "GJ": 30.0, "rhoA": 0.8,
                     "rhoIy": 1e-4, "rhoIz": 1e-4} for m in members},
    "bodies": {n: ({"at": at, "fixed": True} if n in ("b0", "t0") else {"at": at, "mass": 0.05})
               for n, at in nodes.items()},
    "beams": {m: {"from": a, "to": b, "section": m, "elements": 1} for m, (a, b) in members.items()},
    "loads": [{"at": "b3", "force": [0, "-400*Min(t/0.05, 1)", 0]}],
    "solve": {"analysis": "transient", "dt": 0.005, "t_end": 0.1, "sensitivities": names},
    "output": {"probes": {"tip_y": {"point": "b3", "quantity": "displacement", "component": "y"}}},
}
result = latdyn.run(latdyn.load_scene(scene))
t, tip = np.asarray(result.t), np.asarray(result.probes["tip_y"])

# %%
# The ranking: EA · ∂(tip deflection)/∂EA at the last row (the change of the deflection, in m, for a
# 100 % stiffer tube, to first order). The chords near the root carry the bending moment and come first.
effect = {m: EA * result.sensitivities[("tip_y", f"EA_{m}")][-1] for m in members}
ranking = sorted(effect, key=lambda m: -abs(effect[m]))
for m in ranking:
    print(f"{m:10s} EA dy/dEA = {effect[m]: .3e} m")
top = ranking[0]
assert top in ("top0", "bottom0"), ranking

# %%
# The check: one central difference of two whole runs with the top member's EA moved by ±0.1 %.
step = 1e-3 * EA
moved = []
for sign in (1, -1):
    data = {**scene, "parameters": {**scene["parameters"], f"EA_{top}": EA + sign * step},
            "solve": {k: v for k, v in scene["solve"].items() if k != "sensitivities"}}
    moved.append(np.asarray(latdyn.run(latdyn.load_scene(data)).probes["tip_y"])[-1])
central = (moved[0] - moved[1]) / (2 * step) * EA
exact = effect[top]
print(f"{top}: exact {exact:.6e} m, central difference {central:.6e} m, relative difference "
      f"{abs(central - exact) / abs(exact):.1e} (the difference's own error: 4e-4 at ±1 %)")
assert abs(central - exact) < 2e-5 * abs(exact)

# %%
# The lattice, each member coloured by its effect, and the tip's deflection over time.
fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 3.8))
scale = max(abs(v) for v in effect.values())
cmap = plt.get_cmap("viridis")
for m, (a, b) in members.items():
    (xa, ya, _), (xb, yb, _) = nodes[a], nodes[b]
    ax.plot([xa, xb], [ya, yb], color=cmap(abs(effect[m]) / scale), lw=2 + 6 * abs(effect[m]) / scale)
ax.plot([0, 0], [0, HEIGHT], "k^", ms=10, label="clamped supports")
ax.annotate("tip load", (3 * BAY, 0), (3 * BAY - 0.25, -0.2), arrowprops={"arrowstyle": "->"})
sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(0, scale * 1e3))
fig.colorbar(sm, ax=ax, label="|EA ∂(tip y)/∂EA| (mm)")
ax.set(xlabel="x (m)", ylabel="y (m)", title="Members by effect on the tip", aspect="equal", ylim=(-0.3, 0.7))
ax.legend(loc="upper right", fontsize=8)
bx.plot(t, tip * 1e3, label="latdyn: tip deflection y")
bx.plot(t, (tip + 0.1 * result.sensitivities[("tip_y", f"EA_{top}")] * EA) * 1e3, "--",
        label=f"first order, {top} 10 % stiffer")
bx.set(xlabel="time t (s)", ylabel="tip deflection y (mm)", title="Tip response")
bx.legend()
fig.tight_layout()
