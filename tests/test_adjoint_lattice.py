"""The flagship case of the discrete adjoint through events (docs/parameters.md, "The discrete adjoint"): a 3D
lattice deployed by its root hinge's spring that latches, each member's EA a parameter, the latch-impact response
the hinge's torque (the spring's while free, the latch's reaction once latched).

The scene is ``benchmarks/transient_sensitivities_cost.py``'s ``lattice_latch`` (``--scene lattice_latch``: 9 bays,
108 members, for the cost) at 2 bays (24 members, 8 joint bodies on a 5-kg hub), written out as the YAML a user
runs. Reference: the forward method on the same scene — both are the exact derivative of the same discrete run,
the latch included, so each output's end, max and min derivatives and the latch time's agree to round-off and the
forward method's differences of the impulse weight (asserted ≤ 1e-10 of each output's largest derivative). The
Richardson check of whole runs for one parameter is in the benchmark's output (``--richardson``)."""
from __future__ import annotations

import json

import numpy as np
import yaml

import latdyn
from benchmarks.transient_sensitivities_cost import lattice_latch
from tests.cli_runs import latdyn_run

#: longerons of the root bay (0, 1), the root bay's bottom diagonal (8) and a batten at the tip (20)
NAMES = ["F0", "F1", "F8", "F20"]


def _text(method: str | None = None) -> str:
    data = lattice_latch(NAMES, bays=2, t_end=0.12)
    if method:
        data["solve"]["sensitivity_method"] = method
    return yaml.safe_dump(data, sort_keys=False)


def test_a_deploying_lattice_that_latches_adjoint_equals_the_forward_method(tmp_path):
    """The CLI's adjoint (summary.json) against the API's forward method, through the latch at 0.0844 s: the
    torque's end, max and min by four members' EA, measured 1.2e-11 of each output's largest derivative, and the
    latch time's (below); the run latches once, without a step cut, its energy balance 3.1e-3."""
    forward = latdyn.run(latdyn.load_scene(yaml.safe_load(_text())))
    completed, out = latdyn_run(tmp_path, _text("adjoint"), quiet=True)
    assert completed.returncode == 0, completed.stderr
    adjoint = json.loads((out / "summary.json").read_text())
    assert [(e["joint"], e["kind"]) for e in adjoint["events"]] == [("post.end", "latch")]
    assert adjoint["rejected_steps"] == 0 and adjoint["energy_balance_error"] < 5e-3
    for which in ("end", "max", "min"):
        f, a = (np.array([by[n] for n in NAMES]) for by in (forward.summary["probe_sensitivities"]["torque"][which],
                                                             adjoint["probe_sensitivities"]["torque"][which]))
        assert np.abs(f).max() > 0 and np.abs(a - f).max() <= 1e-10 * np.abs(f).max(), which
    # the latch time barely moves with a member's EA (p/t dt/dp ≈ 3e-6: the truss swings nearly rigid), and its
    # derivative is the difference of terms of the size t/p: judged on that scale (measured 6e-15 of it; 2.6e-9
    # of the derivative itself)
    t_latch = adjoint["events"][0]["t"]
    parameters = yaml.safe_load(_text())["parameters"]
    f_dt, a_dt = forward.summary["event_sensitivities"][0]["dt"], adjoint["event_sensitivities"][0]["dt"]
    assert list(f_dt) == list(a_dt) == NAMES
    for name in NAMES:
        assert f_dt[name] != 0 and abs(a_dt[name] - f_dt[name]) <= 1e-10 * t_latch / parameters[name], name
