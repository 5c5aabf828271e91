"""Energy and momentum probes in the sensitivities' loop of steps: what a gradient run costs, and its equality
(benchmarks/hinge_sensitivities_loop.py's three modes on these scenes).

    python benchmarks/energy_sensitivities_loop.py [--scene spinup|arm|free] [--repeats 5]
    python benchmarks/energy_sensitivities_loop.py --scene spinup --check DIR
    python benchmarks/energy_sensitivities_loop.py --scene spinup --user 5 [--trees ROOT_A,ROOT_B]

``--scene spinup``: tests/test_sensitivities_in_loop_energies.py's SPINUP over 2 s (examples/spinup.yaml's hub
turned by its prescribed rotation, its total, kinetic and strain energies probed, dt = 0.005, a row every 0.01 s),
``[EI]``. ``--scene arm``: its ARM_ENERGIES over 0.3 s, the 3D hinged arm with a spring and a damper, its kinetic,
strain, potential and total energies and the six momenta probed (STATE_PROBES), ``[E, rho, F, k]``. ``--scene free``:
its FREE_BEAM over 0.5 s, a free 3D beam thrown spinning, the same probes, ``[E, rho, F]``. The modes, the
times and the ratios printed: benchmarks/hinge_sensitivities_loop.py's docstring (the same functions).
"""
from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: this checkout's benchmarks/hinge_sensitivities_loop.py (its modes; it reads the tests' scenes after PYTHONPATH's build)
_SPEC = importlib.util.spec_from_file_location("hinge_sensitivities_loop", ROOT / "benchmarks" / "hinge_sensitivities_loop.py")
hinge_sensitivities_loop = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(hinge_sensitivities_loop)
_from_tests = hinge_sensitivities_loop._from_tests   # noqa: SLF001

#: the scenes of tests/test_sensitivities_in_loop_energies.py, run longer
SCENES = {"spinup": lambda: _from_tests("test_sensitivities_in_loop_energies", "SPINUP")().replace("t_end: 0.3", "t_end: 2.0"),
          "arm": lambda: _from_tests("test_sensitivities_in_loop_energies", "ARM_ENERGIES")().replace("t_end: 0.06", "t_end: 0.3"),
          "free": lambda: _from_tests("test_sensitivities_in_loop_energies", "FREE_BEAM")().replace("t_end: 0.1", "t_end: 0.5")}

if __name__ == "__main__":
    hinge_sensitivities_loop.main(SCENES, "spinup", __doc__)
