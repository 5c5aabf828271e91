"""Bending–twist coupling of the beam element (issue 22, item 1), through the front door.

Scenes are YAML text (benchmarks/bending_twist.py writes them as a user would) run through the CLI and
the API.  Lateral-torsional buckling of a narrow cantilever: P_cr = 4.013 √(EI_weak GJ)/L² (Timoshenko &
Gere §6.2); the helix of a cantilever under an end couple with components along and across its axis,
whose centreline does not depend on GJ.  The full convergence tables: ``python benchmarks/bending_twist.py``
(docs/verification.md, "Bending–twist coupling").
"""
from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks import bending_twist as bt  # noqa: E402

import latdyn  # noqa: E402


def _cli(scene_text: str, tmp_path: Path, name: str) -> dict[str, np.ndarray]:
    """Write the scene without ParaView frames, run ``python -m latdyn run`` on it, return probes.csv's columns."""
    scene = tmp_path / f"{name}.yaml"
    scene.write_text(scene_text.replace("\noutput:\n", "\noutput:\n  paraview_every: 0\n", 1))
    out = tmp_path / f"{name}_out"
    done = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    with open(out / "probes.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    return {key: np.array([float(row[key]) for row in rows]) for key in rows[0]}


@pytest.mark.parametrize("formulation, tolerance", [("default", 0.005), ("cr4402", 0.005)])
def test_lateral_torsional_buckling_16_elements(formulation, tolerance):
    """The loaded tangent loses definiteness within 0.5 % of 4.013 √(EI GJ)/L² with 16 elements
    (main's `default`, node 1's corotational frame: +3.5 %)."""
    load = bt.ltb_critical_load(16, formulation)
    assert abs(load / bt.LTB_REFERENCE - 1) < tolerance, load


def test_lateral_torsional_buckling_converges_at_second_order():
    """Successive differences of P_cr at 4, 8, 16 elements fall ≈ 4× (4.03; first order, 2×, with node 1's
    corotational frame)."""
    loads = [bt.ltb_critical_load(n, "default") for n in (4, 8, 16)]
    ratio = (loads[0] - loads[1]) / (loads[1] - loads[2])
    assert 3.5 < ratio < 4.5, (loads, ratio)


def test_lateral_torsional_buckling_through_the_cli(tmp_path):
    """Load stepping with a small lateral imperfection (10⁻⁴ of the load): the tip stays near its plane up to
    0.95 P_cr and has swung out, on the imperfection's side, past 1.04 P_cr (P_cr from the tangent, same
    scene without the imperfection)."""
    load = 1.1 * bt.LTB_REFERENCE
    text = bt.ltb_scene(16, "default", load=load, lateral=1e-4 * load, steps=22)
    probes = _cli(text, tmp_path, "ltb")
    critical = bt.ltb_critical_load(16, "default") / load
    factor, lateral = probes["load_factor"], probes["tip_y"]
    assert np.abs(lateral[factor <= 0.95 * critical]).max() < 2e-3
    assert lateral[factor >= 1.04 * critical].min() > 0.1
    api = latdyn.run(bt.load_yaml(text))
    assert np.allclose(api.probes["tip_y"], probes["tip_y"], rtol=1e-9, atol=1e-12)


def test_helix_centreline_independent_of_gj(tmp_path):
    """Tip of the end-couple helix: O(h²) error at every GJ, and its GJ dependence falls ≈ 4× per halving
    (the exact centreline has none).  16 elements through the CLI, 8 through the API."""
    exact = bt.helix_exact()
    tips = {}
    for GJ in (0.5, 2.0):
        probes = _cli(bt.helix_scene(16, "default", GJ), tmp_path, f"helix_{GJ}")
        tips[16, GJ] = np.array([probes[f"tip_{c}"][-1] for c in "xyz"])
        api = latdyn.run(bt.load_yaml(bt.helix_scene(8, "default", GJ)))
        tips[8, GJ] = np.array([api.probes[f"tip_{c}"][-1] for c in "xyz"])
    for GJ in (0.5, 2.0):
        assert np.linalg.norm(tips[16, GJ] - exact) < 1.2e-3
        ratio = np.linalg.norm(tips[8, GJ] - exact) / np.linalg.norm(tips[16, GJ] - exact)
        assert 3.5 < ratio < 4.5, (GJ, ratio)
    spread = {n: np.linalg.norm(tips[n, 0.5] - tips[n, 2.0]) for n in (8, 16)}
    assert 3.5 < spread[8] / spread[16] < 4.5, spread
