"""Sensitivities through a latch on a slewing base (a prescribed rotation and translation) with rigid links: the
event's impulse weight W = M + dt² K at t_e + δt_e moves in time with the reduction's projection P, which hangs the
dependent nodes from the prescribed base, so ∂(K w)/∂t holds ∂/∂t (∂Pᵀ/∂q[w]) · r_inertia, the geometric term of
the inertia forces moved by the motion (``TransientSensitivities._geometric_rate_in_time``,
latdyn/analyses/weight_derivative.py ``linked_geometric_rate_in_time``; docs/parameters.md, "Sensitivities through
events"). Left out on 06a6a72: the gimbal's sensitivities were 3e-6 off Richardson central differences after its
latch, at every difference step; with it, 2e-8. A controller makes the term count (it leaves the event with more
motion to carry); on a model without links (no P) the same scene family agreed before and after."""
from __future__ import annotations

import pytest

from tests.test_sensitivities_events import _agree
from tests.test_sensitivities_in_loop_linked2 import GIMBAL_SLEW
from tests.test_sensitivities_in_loop_linked_controllers import SLEWING_PD
from tests.test_sensitivities_in_loop_state_laws import _run

#: the gimbal on its slewing base (tests/test_sensitivities_in_loop_linked2.py), a PD on the latching inner hinge's
#: own angle and rate, its boom of one element
SLEWING_HINGE_PD = (GIMBAL_SLEW
                    .replace("parameters: {k1: 6.0,", "parameters: {Kp: 0.8, Kd: 0.05, ref: 0.3, k1: 6.0,")
                    .replace('damping: "c2", lock_at', 'damping: "c2", torque: "pd", lock_at')
                    .replace("section: boom, elements: 3", "section: boom, elements: 1")
                    .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(ref - a2) - Kd*r2"}\nsolve: {')
                    .replace("sensitivities: [k1, m, P, EI, rho]", "sensitivities: [Kp, ref, k1, m]"))
assert 'torque: "pd", lock_at' in SLEWING_HINGE_PD and "elements: 1" in SLEWING_HINGE_PD
assert "Kd*r2" in SLEWING_HINGE_PD and "[Kp, ref, k1, m]" in SLEWING_HINGE_PD


@pytest.mark.parametrize("text, name", [(SLEWING_PD, "Kp"), (SLEWING_PD, "ref"), (SLEWING_HINGE_PD, "Kp"),
                                        (SLEWING_HINGE_PD, "m")],
                         ids=["gimbal PD on points by Kp", "gimbal PD on points by ref", "hinge PD by Kp",
                              "hinge PD by m"])
def test_a_latch_on_a_slewing_base_agrees_with_richardson_central_differences(text, name, monkeypatch):
    """The latching gimbal on its slewing base with a controller: every probe's sensitivity to 1e-7 of its largest
    against Richardson-extrapolated central differences of whole runs, the event time's to 1e-7 (measured: 2.4e-8,
    1.9e-8, 1.3e-8, 7.2e-9; on 06a6a72 3.2e-6, 5.1e-6, 7.6e-6, 9.0e-7), the loop of steps taking every smooth step
    (its bit equality with the per-step path through this latch: tests/test_sensitivities_in_loop_linked_controllers.py,
    and measured on SLEWING_HINGE_PD)."""
    result = _run(text, monkeypatch, True)
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    assert result.summary["sensitivity_steps_in_loop"] == result.summary["steps"] - 2
    _agree(result, text, name, tolerance=1e-7)

