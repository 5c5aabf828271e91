"""What a fresh ``latdyn run`` with ``solve.sensitivities`` pays before its first step (docs/performance.md,
"Forward sensitivities: where a step goes"): with its kernels and texts in the cache it imports neither SymPy
(the parameters' derivative texts are cached, the time dependence of a load read without it) nor the generated
NumPy module (the inertia tangent, compiled on first use, is found from its entry beside the unit's index), and
its sensitivities are those of the process that made the caches, to the bit.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from tests.imported_modules import listing_environment, run_listed, sparse_modules
from tests.test_sensitivities_transient import LONG_3D

#: A planar arm on a hinge, a load growing in t whose amplitude is a parameter, a section value that is one.
SCENE = """\
parameters: {P: 2.0, E: 4.0e6}
sections:
  s: {EA: E, EIy: 50, EIz: 80, GJ: 40, rhoA: 1.0, rhoIy: 0.01, rhoIz: 0.02}
bodies:
  base: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: base, to: [2, 0, 0], section: s, elements: 6,
        start: {hinge: {axis: [0, 0, 1], stiffness: 30, damping: 0.2}}}
loads:
  - {at: arm.end, force: [0, "-P*t", 0]}
solve: {analysis: transient, dt: 0.01, t_end: 0.1, sensitivities: [P, E]}
output:
  every: 0.05
  probes:
    tip_y: {point: arm.end, quantity: position, component: y}
"""

def test_a_sensitivity_run_from_the_caches_imports_neither_sympy_nor_the_generated_module(tmp_path):
    scene = tmp_path / "scene.yaml"
    scene.write_text(SCENE)
    environment = listing_environment(tmp_path)
    imported = {}
    for out in ("first", "second"):   # the first puts the kernels and texts in the cache, the second reads them
        imported[out] = run_listed(environment, scene, tmp_path / out, tmp_path / f"{out}.json")
    modules = imported["second"]
    assert {"latdyn.analyses.transient_sensitivities", "latdyn.solve"} <= modules   # the hook saw the run
    assert not {m for m in modules if m == "sympy" or m.startswith("sympy.")}, "SymPy imported"
    generated = sorted(m for m in modules if m.startswith("latdyn_generated."))
    assert generated == [], f"the generated modules {generated} imported"
    first, second = ((tmp_path / out / "sensitivities.csv").read_text() for out in ("first", "second"))
    assert first == second
    rows = np.genfromtxt(tmp_path / "second" / "sensitivities.csv", delimiter=",", names=True)
    assert np.all(np.isfinite(rows["tip_yP"])) and np.any(rows["tip_yP"] != 0.0)


def test_an_on_demand_kernel_from_its_index_entry_is_the_one_compiled(monkeypatch, tmp_path):
    """The inertia tangent (compiled on first use) read in a fresh process from its entry beside the unit's index
    (latdyn.model.kernels._on_demand_index), without importing the generated module: the same library and numbers;
    an unreadable entry is made again."""
    from latdyn.model import kernels

    index = tmp_path / "index-{}.marshal"
    monkeypatch.setattr(kernels, "_index", lambda stem: Path(str(index).format(stem)))
    monkeypatch.setattr(kernels, "_LOADED", {})
    made = kernels.load_kernels("c", "default_xy")
    made_tangent = made.beam_inertia_tangent
    entry = kernels._on_demand_index("beam_default_xy", "beam_inertia_tangent")
    assert entry.is_file()
    real_import = kernels.importlib.import_module

    def no_generated_module(name, *args):
        assert not name.startswith(kernels.PACKAGE + "."), f"imported {name}"
        return real_import(name, *args)

    monkeypatch.setattr(kernels.importlib, "import_module", no_generated_module)
    monkeypatch.setattr(kernels, "_LOADED", {})
    read = kernels.load_kernels("c", "default_xy")
    read_tangent = read.beam_inertia_tangent
    assert read.library("beam_inertia_tangent")._name == made.library("beam_inertia_tangent")._name
    rng = np.random.default_rng(2)
    arrays = [rng.standard_normal((4, int(width))) for _, width in read.info["beam_inertia_tangent"]["inputs"]]
    for a, b in zip(read_tangent(*arrays), made_tangent(*arrays)):
        np.testing.assert_array_equal(a, b)
    monkeypatch.setattr(kernels.importlib, "import_module", real_import)
    entry.write_bytes(b"not an entry")
    monkeypatch.setattr(kernels, "_LOADED", {})
    again = kernels.load_kernels("c", "default_xy")
    assert again.library("beam_inertia_tangent")._name == made.library("beam_inertia_tangent")._name


def test_a_fresh_sensitivity_run_of_a_small_model_does_not_import_scipy_sparse(tmp_path, monkeypatch):
    """docs/performance.md, "A sensitivity run's start (issue 34)": a model the dense or band LU serves takes the
    start's M and C as latdyn.numerics.csr's CSR and keeps the step matrix's C and K as values, so a fresh
    ``latdyn run`` with ``solve.sensitivities`` does not import scipy.sparse (≈ 0.1 s of CPU), nor by the adjoint
    (its start and the reverse pass's transposed start); its files are those of the start through SciPy's CSR (the
    API, the CSR start switched off), to the bit."""
    import latdyn
    from latdyn.analyses import transient_sensitivities

    environment = listing_environment(tmp_path)
    monkeypatch.setattr(transient_sensitivities, "start_without_scipy", lambda model: False)
    adjoint = LONG_3D.replace("sensitivities: [EI, rho]}", "sensitivities: [EI, rho], sensitivity_method: adjoint}")
    assert adjoint != LONG_3D
    # 12 and 132 coordinates (past the dense LU's 120), the latter by the forward method and by the adjoint
    for name, text in (("arm", SCENE), ("cantilever", LONG_3D), ("adjoint", adjoint)):
        scene = tmp_path / f"{name}.yaml"
        scene.write_text(text)
        listing = tmp_path / f"{name}.json"
        for out in ("warm", "fresh"):   # the first may compile the scene's laws; the second is a user's next run
            modules = run_listed(environment, scene, tmp_path / out / name, listing)
        assert "latdyn.analyses.transient_sensitivities" in modules   # the hook saw the run
        sparse = sparse_modules(modules)
        assert sparse == [], f"{name}: {sparse[:3]} imported"
        latdyn.run(latdyn.load_scene(str(scene)), str(tmp_path / "scipy" / name))
        for written in ("sensitivities.csv", "probes.csv"):
            fresh, through_scipy = ((tmp_path / out / name / written).read_bytes() for out in ("fresh", "scipy"))
            assert fresh == through_scipy, f"{name}: {written}"
        rows = np.atleast_2d(np.genfromtxt(tmp_path / "fresh" / name / "sensitivities.csv", delimiter=",", skip_header=1))
        assert np.all(np.isfinite(rows[:, 1:])) and np.any(rows[:, 1] != 0.0)
