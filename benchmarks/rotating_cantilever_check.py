"""An independent check of benchmarks/references/rotating_cantilever.json: the flapwise frequencies
of a cantilever spinning about an axis through its root (hub radius 0), from the linear beam
equation in the rotating frame, EI w'''' − (T w')' = ρA ω² w with the centrifugal tension
T(x) = ρA Ω² (L² − x²)/2, solved with N cubic Hermite elements (tension integrated by 6-point
Gauss) — no latdyn code. Nondimensional: γ = Ω √(ρA L⁴/EI), ω̄ = ω √(ρA L⁴/EI).

    python benchmarks/rotating_cantilever_check.py

prints the table at N = 60 and 120 (finer meshes lose digits to round-off in the lowest mode) beside the reference's entries (parts per million)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import scipy.linalg as sla

REFERENCE = Path(__file__).resolve().parent / "references" / "rotating_cantilever.json"


def flapwise(gamma: float, elements: int, count: int = 3) -> np.ndarray:
    h = 1.0 / elements
    x, w = np.polynomial.legendre.leggauss(6)
    s, w = 0.5 * (x + 1), 0.5 * w
    N = np.array([1 - 3 * s**2 + 2 * s**3, h * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3, h * (-s**2 + s**3)])
    dN = np.array([-6 * s + 6 * s**2, h * (1 - 4 * s + 3 * s**2), 6 * s - 6 * s**2, h * (-2 * s + 3 * s**2)]) / h
    d2N = np.array([-6 + 12 * s, h * (-4 + 6 * s), 6 - 12 * s, h * (-2 + 6 * s)]) / h**2
    n = 2 * (elements + 1)
    K, M = np.zeros((n, n)), np.zeros((n, n))
    for e in range(elements):
        tension = gamma**2 * (1 - ((e + s) * h) ** 2) / 2
        block = slice(2 * e, 2 * e + 4)
        K[block, block] += (d2N * w * h) @ d2N.T + (dN * w * h * tension) @ dN.T
        M[block, block] += (N * w * h) @ N.T
    return np.sqrt(sla.eigh(K[2:, 2:], M[2:, 2:], eigvals_only=True)[:count])  # clamped root


def main() -> None:
    reference = json.loads(REFERENCE.read_text())
    table = reference["omega_bar"]
    print(f"{'gamma':>5} {'flap 1':>9} {'flap 2':>9} {'flap 3':>9}   reference - computed (N = 120), ppm")
    for k, gamma in enumerate(reference["gamma"]):
        coarse, fine = flapwise(gamma, 60), flapwise(gamma, 120)
        given = np.array([table[f"flap_{m}"][k] for m in (1, 2, 3)])
        ppm = (given - fine) / fine * 1e6
        print(f"{gamma:5g} " + " ".join(f"{v:9.4f}" for v in fine)
              + "   " + " ".join(f"{p:+7.1f}" for p in ppm) + f"   (N = 60 vs 120: {np.abs(coarse / fine - 1).max():.1e})")


if __name__ == "__main__":
    main()
