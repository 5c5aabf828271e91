"""Shear-deformable sections (GAy, GAz): the numbers of docs/verification.md, "Shear-deformable sections".

    python benchmarks/shear_sections.py                 # all tables (the spaghetti grid takes ~7 min on 2 busy cores)
    python benchmarks/shear_sections.py shapes modes    # only these: shapes, modes, cantilever, spaghetti

* shapes: which transverse shapes the ½v_x² stretching term and the inertia should use once the bending +
  shear energy is the IIE one.  The element linearised about the straight state (built here from
  codegen.formulation's own shapes, in-plane DOFs v, θ per node): simply supported Timoshenko frequencies
  with the IIE or the Hermite consistent mass, and the pinned–pinned buckling load with IIE or Hermite
  slopes against Engesser's P_E/(1 + P_E/GA).
* modes: latdyn.run (solve.analysis: modes) of the simply supported beam of tests/test_shear.py against
  the exact Timoshenko frequencies; the shear-rigid limit GA = 1e12 against no GA.
* cantilever: one element, tip force, against PL³/(3EI) + PL/GA.
* spaghetti: D3 (examples/benchmarks/D3_flying_spaghetti.yaml) with GA = EA = 1e4 and without GA:
  total energy after the pulse, elements × dt.
"""
from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
import scipy.linalg as sl
import sympy as sp

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from codegen import formulation as fm  # noqa: E402
from test_shear import (TIMOSHENKO, _cantilever, bending_frequencies, simply_supported_timoshenko,  # noqa: E402
                        spaghetti_energy)


def _linear_element():
    """Stiffness, IIE and Hermite mass, IIE and Hermite geometric stiffness of the straight element, in
    (v1, θ1, v2, θ2): chord rotation β = (v2 − v1)/L, φ_k = θ_k − β (the corotational split, linearised)."""
    xi = fm.xi
    L, EI, GA, rA, rI = sp.symbols("L EI GA rhoA rhoI", positive=True)
    q = sp.symbols("v1 theta1 v2 theta2")
    mu = L**2 / (L**2 + 12 * EI / GA)  # 1/(1 + Φ)
    beta = (q[2] - q[0]) / L
    phi1, phi2 = q[1] - beta, q[3] - beta
    stiffness = sp.hessian(fm.bending_shear_energy(EI, mu, L, phi1, phi2), q)
    (n1, n2), (r1, r2) = fm.interdependent_shapes()
    mass, geometric = {}, {}
    for name, m in (("IIE", mu), ("Hermite", 1)):
        at = {fm.SHEAR_FACTOR: m}
        v = q[0] * (1 - xi) + q[2] * xi + L * (n1.subs(at) * phi1 + n2.subs(at) * phi2)
        rotation = beta + r1.subs(at) * phi1 + r2.subs(at) * phi2
        kinetic = L * sp.integrate(sp.expand(rA * v**2 + rI * rotation**2), (xi, 0, 1)) / 2
        stretching = L * sp.integrate(sp.expand((sp.diff(v, xi) / L) ** 2), (xi, 0, 1)) / 2  # ∫½v_x² dx
        mass[name] = sp.lambdify((L, EI, GA, rA, rI), sp.hessian(kinetic, q))
        geometric[name] = sp.lambdify((L, EI, GA), sp.hessian(stretching, q))
    return sp.lambdify((L, EI, GA), stiffness), mass, geometric


def _assemble(n, element):
    size = 2 * (n + 1)
    out = np.zeros((size, size))
    for e in range(n):
        out[2 * e:2 * e + 4, 2 * e:2 * e + 4] += element
    free = [i for i in range(size) if i not in (0, size - 2)]  # v = 0 at both ends (pinned)
    return out[np.ix_(free, free)]


def table_shapes(meshes=(8, 16, 32)):
    p = TIMOSHENKO
    stiffness, mass, geometric = _linear_element()
    exact = np.array([simply_supported_timoshenko(k) for k in range(1, 5)])
    euler = math.pi**2 * p["EI"] / p["L"] ** 2
    engesser = euler / (1 + euler / p["GA"])  # Engesser (1891); Timoshenko & Gere, Theory of Elastic Stability §2.18
    print("| elements | mass | ω₁ | ω₂ | ω₃ | ω₄ (relative error) |\n|---|---|---|---|---|---|")
    for n in meshes:
        h = p["L"] / n
        K = _assemble(n, np.array(stiffness(h, p["EI"], p["GA"]), float))
        for name in mass:
            M = _assemble(n, np.array(mass[name](h, p["EI"], p["GA"], p["rhoA"], p["rhoI"]), float))
            omega = np.sqrt(sl.eigh(K, M, eigvals_only=True)[:4])
            print(f"| {n} | {name} | " + " | ".join(f"{e:+.2e}" for e in omega / exact - 1) + " |")
    print(f"\nEngesser P_cr = {engesser:.6f} (P_E = {euler:.6f})\n")
    print("| elements | slopes | P_cr | relative error |\n|---|---|---|---|")
    for n in (4,) + tuple(meshes):
        h = p["L"] / n
        K = _assemble(n, np.array(stiffness(h, p["EI"], p["GA"]), float))
        for name in geometric:
            G = _assemble(n, np.array(geometric[name](h, p["EI"], p["GA"]), float))
            load = sl.eigh(K, G, eigvals_only=True)[0]
            print(f"| {n} | {name} | {load:.6f} | {load / engesser - 1:+.2e} |")


def table_modes(meshes=(4, 8, 16, 32, 64)):
    exact = np.array([simply_supported_timoshenko(k) for k in range(1, 5)])
    print("exact ω:", " ".join(f"{w:.5f}" for w in exact))
    print("| elements | ω₁ | ω₂ | ω₃ | ω₄ (relative error) |\n|---|---|---|---|---|")
    for n in meshes:
        omega = bending_frequencies(n, TIMOSHENKO["GA"])
        print(f"| {n} | " + " | ".join(f"{e:.2e}" for e in omega / exact - 1) + " |")
    rigid, stiff = bending_frequencies(8, None), bending_frequencies(8, 1e12)
    print(f"\nGA = 1e12 vs no GA, 8 elements: max |Δω/ω| = {np.max(np.abs(stiff / rigid - 1)):.1e}")


def table_cantilever():
    import latdyn  # noqa: PLC0415

    EI, GA, L, P = 1.0, 25.0, 1.0, 1e-6
    section = {"EA": 1.0e6, "EIy": 2.0, "EIz": EI, "GJ": 1.0, "rhoA": 1.0, "GAy": GA}
    tip = latdyn.run(_cantilever(section, force=P, length=L), out_dir=None).probes["tip"][-1]
    exact = P * L**3 / (3 * EI) + P * L / GA
    print(f"one element: δ = {tip:.12e}, PL³/3EI + PL/GA = {exact:.12e}, relative error {tip / exact - 1:.1e}")


def table_spaghetti(meshes=(10, 20, 40, 80), steps=(0.01, 0.005, 0.0025, 0.00125)):
    print("| elements | dt | E (GA = EA) | E (no GA) | drift after 5 s (GA) | wall s |\n|---|---|---|---|---|---|")
    for n in meshes:
        for dt in steps:
            t0 = time.perf_counter()
            shear, _ = spaghetti_energy(n, dt)
            rigid, _ = spaghetti_energy(n, dt, GA=None)
            print(f"| {n} | {dt:g} | {shear[0]:.4f} | {rigid[0]:.4f} | {np.ptp(shear) / shear[0]:.1e} | "
                  f"{time.perf_counter() - t0:.1f} |", flush=True)


TABLES = {"shapes": table_shapes, "modes": table_modes, "cantilever": table_cantilever, "spaghetti": table_spaghetti}

if __name__ == "__main__":
    for name in sys.argv[1:] or list(TABLES):
        print(f"\n## {name}\n")
        TABLES[name]()
