"""
Modes of a lattice, and a Campbell diagram
==========================================

**A lattice's modes.** The clamped square truss beam of the lattice benchmark
(``benchmarks/lattice.py``: aluminium tubes, rigid massless joints, six bays of 0.5 m) has
``solve.analysis: modes`` run with 1 and 2 elements per member. The finer mesh holds the
coarser one and the mass matrix is consistent, so the frequencies are Rayleigh–Ritz upper bounds
that can only fall as the mesh is refined: they must. The first bending frequency is set beside
the equivalent cantilever of the benchmark (bending and panel shear combined by Dunkerley's
formula, which the benchmark finds within 7 % of latdyn's first mode).

**A Campbell diagram.** ``examples/rotating_beam_modes.yaml``: a 10 m cantilever clamped to a hub
spinning at Ω, its modes about the steady spin (``solve.about: steady``) seen in the turning frame,
at seven rates. The reference is Wright, Smith, Thresher & Wang (1982): the first flapwise
frequency ω·τ = 3.5160, 6.4495, 11.2023 at γ = Ω·τ = 0, 5, 10 (τ = √(ρA L⁴/EI)), and the first
chordwise one √(ω_flap² − Ω²) (the in-plane motion loses Ω² in the turning frame).
"""
import math
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import latdyn

root = Path.cwd() if Path("benchmarks/lattice.py").exists() else Path("../..")
sys.path.insert(0, str(root / "benchmarks"))
import lattice  # noqa: E402  (benchmarks/lattice.py: the lattice's geometry and sections)

bays = 6
frequencies = {}
for elements in (1, 2):
    scene = lattice.latdyn_scene(bays, elements, 1e-3, analysis="modes")
    scene["solve"]["count"] = 6
    frequencies[elements] = np.sort(np.asarray(latdyn.run(scene).modes))
estimate = 1 / lattice.equivalent_beam(bays)["T"]

# %%
# The lattice's checks: every frequency falls (or stays) as the mesh is refined, and the first is
# within 7 % of the equivalent cantilever.
for elements, f in frequencies.items():
    print(f"{elements} element(s) per member: " + ", ".join(f"{x:.3f}" for x in f) + " Hz")
assert np.all(frequencies[2] <= frequencies[1] * (1 + 1e-9))
first = frequencies[2][0]
print(f"first bending mode {first:.3f} Hz; equivalent cantilever (Dunkerley) {estimate:.3f} Hz, "
      f"{100 * (first / estimate - 1):+.1f} %")
assert abs(first / estimate - 1) < 0.07

fig, ax = plt.subplots(figsize=(7, 3.5))
for k in range(6):
    ax.plot([1, 2], [frequencies[e][k] for e in (1, 2)], "o-", label=f"latdyn: mode {k + 1}")
ax.axhline(estimate, color="k", ls=":", label="equivalent cantilever, mode 1")
ax.set_xticks([1, 2])
ax.set(xlabel="elements per member", ylabel="frequency (Hz)", title=f"Lattice of {bays} bays: mesh refinement")
ax.legend(fontsize=7, ncol=2)
fig.tight_layout()

# %%
# The Campbell diagram: the rotating cantilever at seven rates.
path = root / "examples" / "rotating_beam_modes.yaml"
base = latdyn.load_scene(str(path)).raw
base["solve"].update(mode_shapes=False, count=6)
base["solve"].pop("linear_model", None)
tau = math.sqrt(1.2 * 10.0 ** 4 / 1.4e4)
gammas = [0.0, 2.0, 4.0, 5.0, 6.0, 8.0, 10.0]
rows = []
for gamma in gammas:
    base["bodies"]["hub"]["motion"]["rotation"]["angle"] = f"{gamma / tau!r}*t"
    rows.append(np.sort(np.asarray(latdyn.run(base).modes)) * 2 * math.pi * tau)   # ω·τ
rows = np.array(rows)
WRIGHT_FLAP_1 = {0.0: 3.5160, 5.0: 6.4495, 10.0: 11.2023}
for gamma, flap in WRIGHT_FLAP_1.items():
    got = rows[gammas.index(gamma)]
    # at γ > 0 the chordwise mode is the lowest, the flapwise the next; at γ = 0 both are equal
    chord_got, flap_got = got[0], got[1]
    chord = math.sqrt(flap ** 2 - gamma ** 2)
    print(f"γ = {gamma:4.1f}: flap ωτ latdyn {flap_got:.4f}, Wright {flap:.4f} ({abs(flap_got / flap - 1):.1e}); "
          f"chord latdyn {chord_got:.4f}, √(flap² − γ²) {chord:.4f} ({abs(chord_got / chord - 1):.1e})")
    assert abs(flap_got / flap - 1) < 2e-4 and abs(chord_got / chord - 1) < 2e-4

fig, ax = plt.subplots(figsize=(7, 4.5))
for k in range(rows.shape[1]):
    ax.plot(np.array(gammas) / tau, rows[:, k] / (2 * math.pi * tau), "o-", ms=3, label=f"latdyn: mode {k + 1}")
ax.plot([g / tau for g in WRIGHT_FLAP_1], [f / (2 * math.pi * tau) for f in WRIGHT_FLAP_1.values()], "ks",
        mfc="none", ms=9, label="Wright et al. (1982), flap 1")
ax.set(xlabel="spin rate Ω (rad/s)", ylabel="frequency in the turning frame (Hz)",
       title="Campbell diagram of a rotating cantilever")
ax.legend(fontsize=7)
fig.tight_layout()
