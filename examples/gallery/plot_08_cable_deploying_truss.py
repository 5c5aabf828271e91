"""
A cable-driven truss deploys and latches: its latch loads
=========================================================

``examples/cable_deploying_truss.yaml``: the hinged truss of ``examples/deploying_truss.yaml`` (three
bays opened by preloaded hinge springs of 1 N·m/rad, each hinge latching with ``lock_at`` when its bay
is in line), its deployment held back by two cables from the root station to the tip station that a
reel pays out (rest length ``Min(3.02, 1.74 + 0.5*t)`` m, EA = 2 kN). The springs pull the cables taut
again and again, so the truss opens at about the reel's pace, and the bays latch one after the other.

A latch is rigid: it locks its hinge with an impulsive jump, and from then on the joint probe
``{hinge: BEAM.start, quantity: torque}`` gives the reaction that holds it (before, the spring's
torque); ``summary.json`` ``joint_peaks`` has the largest of each, with its time. These are the latch
loads that size the hardware. The checks: before its latch each knee's torque is the spring's law
k (θ_rest − θ) exactly; each knee reaches its latch angle and holds it; ``joint_peaks`` is the
largest torque of the recorded rows; a cable never pushes (its tension is zero while it is slack,
between the slack and taut changes of ``cable_events``). The picture of the structure is a side view (x–z) at the latch times, cables
dashed.
"""
import json
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import yaml

import latdyn
from latdyn.results.structure import StructureView, draw_structure, load_structure, make_axes

path = Path("examples/cable_deploying_truss.yaml")
if not path.exists():
    path = Path("../cable_deploying_truss.yaml")
scene = yaml.safe_load(path.read_text())
knees = [name for name, beam in scene["beams"].items() if "hinge" in beam.get("start", {})]
for name in knees:  # the torque and the angle of every knee hinge
    scene["output"]["probes"][f"{name}_torque"] = {"hinge": f"{name}.start", "quantity": "torque"}
    scene["output"]["probes"][f"{name}_angle"] = {"hinge": f"{name}.start", "quantity": "angle"}
# rows at every step: joint_peaks is the largest torque over the recorded rows, and the latched
# truss rings faster than the file's 0.01 s rows would show
scene["output"]["every"] = scene["solve"]["dt"]
out = Path(tempfile.mkdtemp()) / "cable_truss"
result = latdyn.run(latdyn.load_scene(scene), out)
summary = json.loads((out / "summary.json").read_text())
t = np.asarray(result.t)

# %%
# The checks. Each knee's spring (stiffness 1 N·m/rad, rest angle ``rest_angle``) drives it until its
# latch; then the probe is the latch's reaction.
latched_at = {e["joint"]: e["t"] for e in summary["events"] if e["kind"] == "latch"}
assert sorted(latched_at) == sorted(f"{name}.start" for name in knees), latched_at
angle_of = {"pi/3": np.pi / 3, "2*pi/3": 2 * np.pi / 3}
for name in knees:
    hinge = scene["beams"][name]["start"]["hinge"]
    rest = angle_of[hinge["rest_angle"].split(" + ")[0]] + 0.3
    lock = angle_of[hinge["lock_at"]]
    torque, angle = np.asarray(result.probes[f"{name}_torque"]), np.asarray(result.probes[f"{name}_angle"])
    before = t < latched_at[f"{name}.start"]
    law = float(np.abs(torque[before] - 1.0 * (rest - angle[before])).max())
    after = ~before
    held = float(np.abs(angle[after] - lock).max())
    peak = summary["joint_peaks"][f"{name}.start"]
    rows = float(torque[np.argmax(np.abs(torque))])
    print(f"{name}: latched at t = {latched_at[name + '.start']:.4f} s; spring law before it to {law:.1e} N·m; "
          f"on its latch angle to {held:.1e} rad after; latch load (joint_peaks) {peak['peak']:+.1f} N·m "
          f"at t = {peak['t']:.2f} s")
    assert law < 1e-9 and held < 1e-5
    assert peak["peak"] == rows  # the largest torque of the rows, signed
tension = np.asarray(result.probes["pull"])
assert tension.min() >= 0.0  # a cable never pushes
changes = [(e["t"], e["state"]) for e in summary["cable_events"] if e["cable"] == "tie_a"]
assert [s for _, s in changes] == ["taut", "slack"] * (len(changes) // 2) + ["taut"] * (len(changes) % 2)
slack_rows = np.zeros(len(t), bool)
for (t_slack, _), (t_taut, _) in zip(changes[1::2], changes[2::2] + [(np.inf, "taut")]):
    slack_rows |= (t > t_slack + 1e-9) & (t < t_taut - 1e-9)
assert np.all(tension[slack_rows] == 0.0)
print(f"cable tie_a: {len(changes)} slack and taut changes, largest tension {tension.max():.1f} N")

# %%
# The structure, seen from the side (the y axis points into the page: the two longerons of a bay and
# the two cables are drawn over each other), at the start, half-way to the first latch, and at each
# bay's latch.
history = load_structure(out)
points = history.all_points()
margin = 0.1
view = StructureView(plane=(0, 2), lower=points.min(axis=0) - margin, upper=points.max(axis=0) + margin)
bays = {"bay 1": "bay1_a.start", "bay 2": "bay2_a.start", "bay 3": "bay3_a.start"}
moments = [("start", 0.0), ("reel paying out", 0.5 * latched_at["bay1_a.start"])]
moments += [(f"{bay} latched", latched_at[joint]) for bay, joint in bays.items()]
fig = plt.figure(figsize=(8, 4.5))
axes = make_axes(fig, view)
colours = plt.get_cmap("viridis")(np.linspace(0.0, 0.85, len(moments)))
handles = []
for (label, when), colour in zip(moments, colours):
    frame = int(np.argmin(np.abs(np.asarray(history.times) - when)))
    draw_structure(axes, history, frame, view, colour)
    handles.append(plt.Line2D([], [], color=colour, lw=2, label=f"{label}, t = {history.times[frame]:.2f} s"))
handles.append(plt.Line2D([], [], color="grey", lw=1, ls="--", label="cables (reel at the root)"))
axes.legend(handles=handles, loc="upper left", fontsize="small")
axes.set_title("Cable-driven truss, side view: solid beams, dashed cables, squares fixed")
fig.tight_layout()

# %%
# The latch loads: each bay's knee torque (the spring's before the latch, dotted line; the latch's
# reaction after it), and the cable's tension against the reel's rest length.
fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
for bay, joint in bays.items():
    name = joint.split(".")[0]
    line, = top.plot(t, result.probes[f"{name}_torque"], lw=1, label=f"{bay} knee ({name}.start)")
    top.axvline(latched_at[joint], color=line.get_color(), ls=":", lw=1)
top.set(ylabel="hinge torque (N·m)", title="Knee torques: spring law, then the latch's reaction (dotted: latch)")
top.legend(fontsize="small", loc="lower left")
bottom.plot(t, tension, lw=1, color="C3", label="tension of tie_a")
bottom.set(xlabel="time t (s)", ylabel="cable tension (N)")
reel = bottom.twinx()
reel.plot(t, np.minimum(3.02, 1.74 + 0.5 * t), color="grey", ls="--", lw=1, label="rest length (reel)")
reel.set_ylabel("rest length (m)")
bottom.legend(handles=bottom.get_lines() + reel.get_lines(), fontsize="small", loc="upper right")
fig.tight_layout()
