"""Static sensitivities of structures whose hinges have rigid stops (``limits`` without ``contact``) and latches
(``lock_at``) (docs/parameters.md, "Sensitivities"). A static analysis does not apply them (events of the time
loop, docs/static_paths.md): its rows are the path without them, and their sensitivities are that path's. Checked
against Richardson central differences of whole runs (tests/test_sensitivities.py's ``_richardson``), planar and
3D, and against the same scene without the stops (the same numbers, exactly); a path that ends past a stop is
flagged, the warning naming the sensitivities.
"""
from __future__ import annotations

import numpy as np
import yaml

from test_sensitivities import ARM_3D, PLANAR, _richardson, _run
from tests.cli_runs import latdyn_run, summary_of

#: the planar hinged cantilever with a stop and a latch at its hinge that its path never reaches (it turns to
#: ≈ −0.32 rad)
PLANAR_STOPS = PLANAR.replace('stiffness: "k + 0.5*k*theta**2"}',
                              'stiffness: "k + 0.5*k*theta**2", limits: [-0.6, 0.6], lock_at: -0.5}')

#: the 3D arm (by the load, the moment and the hinge law: parameters every kernel variant differentiates) and the
#: same with a stop and a latch at its skew hinge that its path never reaches
ARM_3D_FREE = ARM_3D.replace("sensitivities: [F, k, th0, M, EI, G]", "sensitivities: [F, k, th0, M]")
ARM_3D_STOPS = ARM_3D_FREE.replace('rest_angle: "th0"}', 'rest_angle: "th0", limits: [-1.2, 1.5], lock_at: 1.4}')


def _agree(text: str, names, tolerance: float) -> float:
    result, worst = _run(text), 0.0
    for name in names:
        for probe, expected in _richardson(text, name).items():
            scale = np.abs(expected).max()
            assert scale > 1e-9, (probe, name)
            error = np.abs(result.sensitivities[(probe, name)] - expected).max() / scale
            assert error <= tolerance, (probe, name, error)
            worst = max(worst, error)
    return worst


def test_planar_static_sensitivities_with_a_stop_and_a_latch_agree_with_richardson_differences():
    """Load control of the planar hinged cantilever, its hinge between a stop and a latch it does not reach, by
    the load and the hinge stiffness (measured ≤ 2e-12), the same as without them."""
    assert _agree(PLANAR_STOPS, ("P", "k"), 1e-6) <= 1e-6
    held, free = _run(PLANAR_STOPS), _run(PLANAR)
    assert np.abs(held.probes["hinge"]).max() < 0.5
    for key, values in free.sensitivities.items():
        np.testing.assert_array_equal(held.sensitivities[key], values)


def test_3d_static_sensitivities_with_a_stop_and_a_latch_agree_with_richardson_differences():
    """The skew 3D arm with its hinge's stop and latch, by the loads and the hinge law (measured ≤ 1.3e-10), the same
    as without them."""
    assert _agree(ARM_3D_STOPS, ("F", "k", "th0", "M"), 1e-6) <= 1e-6
    held, free = _run(ARM_3D_STOPS), _run(ARM_3D_FREE)
    for key, values in free.sensitivities.items():
        np.testing.assert_array_equal(held.sensitivities[key], values)


def test_a_static_path_past_a_stop_is_flagged_with_its_sensitivities(tmp_path):
    """A stop the load turns the hinge past ([-0.1, 0.1], the hinge at ≈ −0.32 rad): the rows and their
    sensitivities are the path's without the stop (they agree with the differences of whole runs, measured
    ≤ 2e-12), and the warning (stderr and summary.json) says so."""
    text = PLANAR.replace('stiffness: "k + 0.5*k*theta**2"}', 'stiffness: "k + 0.5*k*theta**2", limits: [-0.1, 0.1]}')
    assert _agree(text, ("P", "k"), 1e-6) <= 1e-6
    run, out = latdyn_run(tmp_path, text)
    assert run.returncode == 0, run.stderr
    warnings = summary_of(out)["warnings"]
    assert any("past its limits" in w and "its sensitivities (solve.sensitivities) are those of this path" in w
               for w in warnings), warnings
    assert "its sensitivities" in run.stderr
    data = yaml.safe_load(text)
    del data["solve"]["sensitivities"]
    plain = tmp_path / "plain"
    plain.mkdir()
    run, out = latdyn_run(plain, yaml.safe_dump(data))
    assert run.returncode == 0 and not any("sensitivities" in w for w in summary_of(out)["warnings"])
