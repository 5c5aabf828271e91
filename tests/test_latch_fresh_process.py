"""A fresh ``latdyn run`` of a model the dense or band LU serves does not import scipy.sparse at a latch
(docs/performance.md, "The latch without SciPy's sparse package (issue 31/34)"): the impulse
(latdyn.timeloop.impulse._response on _OwnMatrices) and, with ``solve.sensitivities``, the latch's weight derivative
(latdyn.analyses.weight_derivative._sparse) take latdyn.numerics.csr's CSR, and the files are those of the
impulse through SciPy's matrices, to the bit.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from tests.imported_modules import listing_environment, run_listed, sparse_modules
from tests.test_sensitivities_joint_forces import BOOM

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

def _run_through_scipy(latdyn, scene: Path, out: Path) -> None:
    """The API's run with the impulse and the weight derivative through SciPy's matrices, as before."""
    from latdyn.analyses import weight_derivative
    from latdyn.timeloop import impulse

    without_scipy, largest = impulse.without_scipy, weight_derivative.RCM_IN_PYTHON
    impulse.without_scipy, weight_derivative.RCM_IN_PYTHON = (lambda model: False), 0
    try:
        latdyn.run(latdyn.load_scene(str(scene)), str(out))
    finally:
        impulse.without_scipy, weight_derivative.RCM_IN_PYTHON = without_scipy, largest


def test_a_fresh_run_that_latches_does_not_import_scipy_sparse(tmp_path):
    """The boom (19 coordinates, a latch into which every direction has inertia), its design run with
    sensitivities (examples/deploying_boom_sensitivities.py's to 0.3 s after the latch:
    test_sensitivities_joint_forces.BOOM), the cable-deployed truss (91-99 coordinates, latches next to directions
    without inertia: the condensed impulse) and the slider-crank (a guide and a rigid crank: the impulse of its
    crank's acceleration that jumps, on the dense reduced matrices), each a fresh ``latdyn run``: no scipy.sparse
    imported and (but the slider-crank) a latch taken; probes.csv, state.h5 (sensitivities.csv), the summary's
    events (and sensitivities) equal by bytes (state.h5 by its contents) to the API's run with the impulse and the weight derivative through
    SciPy's matrices. The truss's fresh run and the API's differ in its cables' last bits on 6cf2a79 already (its
    cable events' times), so its CSR impulse is compared API with API."""
    import latdyn

    environment = listing_environment(tmp_path)
    scenes = {"boom": (EXAMPLES / "deploying_boom.yaml").read_text(), "design": BOOM,
              "truss": (EXAMPLES / "cable_deploying_truss.yaml").read_text(),
              "slider": (EXAMPLES / "slider_crank.yaml").read_text()}
    for name, text in scenes.items():
        scene = tmp_path / f"{name}.yaml"
        scene.write_text(text)
        modules = run_listed(environment, scene, tmp_path / "fresh" / name, tmp_path / f"{name}.json")
        assert "latdyn.timeloop.impulse" in modules   # the hook saw the run
        sparse = sparse_modules(modules)
        assert sparse == [], f"{name}: {sparse[:3]} imported"
        if name == "truss":
            latdyn.run(latdyn.load_scene(str(scene)), str(tmp_path / "fresh" / name))
        _run_through_scipy(latdyn, scene, tmp_path / "scipy" / name)
        assert "scipy.sparse" in sys.modules   # the API's run took SciPy's matrices
        summary, scipy_summary = (json.loads((tmp_path / out / name / "summary.json").read_text())
                                  for out in ("fresh", "scipy"))
        if name != "slider":   # its impulse: the crank's acceleration that jumps (a guide, rigid links)
            assert any(event["kind"] == "latch" for event in summary["events"]), f"{name}: no latch"
        for key in ("events", "probe_sensitivities", "event_sensitivities"):
            assert summary.get(key) == scipy_summary.get(key), f"{name}: {key}"
        written = ["probes.csv", "state.h5"] + (["sensitivities.csv"] if name == "design" else [])
        for file in written:
            fresh, through_scipy = (tmp_path / out / name / file for out in ("fresh", "scipy"))
            if file == "state.h5":   # its bytes follow how often the history was rewritten (every few seconds of
                assert _contents(fresh) == _contents(through_scipy), f"{name}: {file}"   # wall time): a loaded CI
            else:
                assert fresh.read_bytes() == through_scipy.read_bytes(), f"{name}: {file}"


def _contents(path: Path) -> dict:
    """Every dataset's and group's name, values (as bytes), shape, type and attributes in the HDF5 file ``path``:
    the file's contents, whatever the history's rewrites left as its layout (latdyn/results/writer.py
    ``_checkpoint_due``: timed by the wall clock, so a run under load rewrites it at other rows)."""
    import h5py
    import numpy as np

    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, item):
            attrs = {key: _value(value) for key, value in item.attrs.items()}
            if isinstance(item, h5py.Dataset):
                value = np.asarray(item[()])
                out[name] = (_value(value), value.shape, str(value.dtype), attrs)
            else:
                out[name] = attrs
        out["/"] = {key: _value(value) for key, value in f.attrs.items()}
        f.visititems(visit)
    return out


def _value(value):
    """An HDF5 value as comparable bytes: numbers' bytes, strings (objects) by their text."""
    import numpy as np

    value = np.asarray(value)
    return repr(value.tolist()) if value.dtype.kind == "O" else value.tobytes()
