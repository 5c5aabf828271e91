"""A fresh ``latdyn run`` of the deploying boom's design by the discrete adjoint does not import scipy.sparse
(docs/performance.md, "Sensitivity rows in the loop and the adjoint without SciPy's sparse package (issue 34)"): the
reverse steps around the latch, which take the Python path (the step size's column and its transpose), read the
exact step matrix's held C and K as latdyn.numerics.csr's CSR and their transposes as
:class:`latdyn.numerics.csr.Transpose`, whose products are SciPy's; the files are those of the same reverse pass
through SciPy's CSC transposes, to the bit.
"""
from __future__ import annotations

import json

from tests.imported_modules import listing_environment, run_listed, sparse_modules
from tests.test_sensitivities_in_loop import BOOM_DESIGN

#: examples/deploying_boom_sensitivities.py's scene to 0.3 s after its latch (≈ 1.1 s), by the adjoint
BOOM_ADJOINT = BOOM_DESIGN.replace("t_end: 2.5", "t_end: 1.4").replace(
    "sensitivities: [k, c]}", "sensitivities: [k, c], sensitivity_method: adjoint}")
assert "t_end: 1.4" in BOOM_ADJOINT and "sensitivity_method: adjoint" in BOOM_ADJOINT


def _through_scipy(step_matrix) -> tuple:
    """(Cᵀ, Kᵀ) as the reverse pass took them before: SciPy's CSC views of the held C and K."""
    import scipy.sparse as sps

    return tuple(sps.csr_matrix((m.data, m.indices, m.indptr), shape=m.shape, copy=False).transpose(copy=False)
                 for m in (step_matrix.damping, step_matrix.stiffness))


def test_a_fresh_adjoint_run_through_a_latch_does_not_import_scipy_sparse(tmp_path, monkeypatch):
    import latdyn
    from latdyn.analyses.adjoint_sensitivities import AdjointSensitivities

    scene = tmp_path / "boom.yaml"
    scene.write_text(BOOM_ADJOINT)
    environment = listing_environment(tmp_path)
    for out in ("warm", "fresh"):   # the first may compile the scene's laws; the second is a user's next run
        modules = run_listed(environment, scene, tmp_path / out, tmp_path / "modules.json")
    assert "latdyn.analyses.adjoint_sensitivities" in modules   # the hook saw the run
    sparse = sparse_modules(modules)
    assert sparse == [], f"{sparse[:3]} imported"
    summary = json.loads((tmp_path / "fresh" / "summary.json").read_text())
    assert [event["kind"] for event in summary["events"]] == ["latch"]
    assert summary["sensitivity_steps_in_loop"] > 0   # the smooth steps stored in C; the latch's from Python
    taken = []
    monkeypatch.setattr(AdjointSensitivities, "_held_transposes",
                        staticmethod(lambda step_matrix: taken.append(1) or _through_scipy(step_matrix)))
    latdyn.run(latdyn.load_scene(str(scene)), str(tmp_path / "scipy"))
    assert taken   # the reverse pass took SciPy's transposes around the latch
    through_scipy = json.loads((tmp_path / "scipy" / "summary.json").read_text())
    for key in ("events", "probe_sensitivities", "event_sensitivities"):
        assert summary[key] == through_scipy[key], key
    for written in ("sensitivities.csv", "probes.csv"):
        assert (tmp_path / "fresh" / written).read_bytes() == (tmp_path / "scipy" / written).read_bytes(), written
