"""A fresh run with geometry parameters reads its kernels' metadata from the kernel cache, not from the generated
package: its refusal check (geometry_sensitivities.model_refusal, whether the variant holds the reference
derivatives) imported ``latdyn_generated.beam_default`` — 11 MB of NumPy source, 2 s of a fresh process where Python
writes no bytecode — though the run's kernels come from C (latdyn.model.kernels.generated_info)."""
from __future__ import annotations

from tests.imported_modules import listing_environment, run_listed
from tests.test_sensitivities_in_loop_geometry import LATTICE


def test_a_fresh_geometry_sensitivity_run_imports_no_generated_numpy_module(tmp_path):
    scene = tmp_path / "lattice.yaml"
    scene.write_text(LATTICE)
    environment = listing_environment(tmp_path)
    first = run_listed(environment, scene, tmp_path / "first", tmp_path / "first.json")   # may write the index
    second = run_listed(environment, scene, tmp_path / "second", tmp_path / "second.json")
    generated = sorted(m for m in second if m.startswith("latdyn_generated.beam_"))
    assert generated == [], generated   # was ['latdyn_generated.beam_default']
    assert (tmp_path / "second" / "sensitivities.csv").read_bytes() == (tmp_path / "first" / "sensitivities.csv").read_bytes()
    assert "latdyn.analyses.geometry_sensitivities" in first
