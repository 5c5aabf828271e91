"""The searches of a run's start for the laws' jumps, kept in the laws' cache and made once (issue 31).

A law's jumps over (0, t_end] (its values', its prescribed rate's kinks, its prescribed acceleration's jumps:
latdyn.timeloop.jumps) are a function of its text (parameters substituted), of the search and of t_end: a
process whose laws were searched before reads the instants back from the laws' cache (the spin-up's start
swept and halved ≈ 50 × 4 098 samples three times, 13–14 ms of CPU). These tests type the
scenes as YAML: a warm process searches nothing and runs to the same numbers; a changed law, parameter,
t_end or search is searched afresh (exact instants: the laws' own); a restart at a jump does not search
the laws again (before, the first restart searched all three ways once more)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

import latdyn
import latdyn.timeloop.jumps as jumps
from test_prescribed_motion_work import RAMP_10_MS
from test_prescribed_motion_work import crank as crank_scene

ROOT = Path(__file__).resolve().parents[1]


def crank(angle: str, t_end: float, parameters: str = "") -> str:
    """The crank carrying a free rod of tests/test_prescribed_motion_work.py, at dt 0.01, with ``parameters``."""
    return crank_scene(angle, 0.01, t_end, 0.01).replace("inputs: {u: 0.0}", f"inputs: {{u: 0.0}}\n{parameters}")


#: kinks (jumps of the rate) at 0.5 and 1.5; the value and the acceleration away from them continuous
TWO_KINKS = "Piecewise((0, t < 0.5), (2*(t - 0.5), t < 1.5), (2, True))"


def found(text: str) -> tuple[list[float], list[float], list[float]]:
    """The instants of the jumps of the scene's laws as its run's start finds them: (values, rates,
    accelerations)."""
    scene = latdyn.load_scene(yaml.safe_load(text))
    searched = jumps.searched_jumps(scene, float(scene.solve.t_end))
    return tuple(sorted({t for _, t in part}) for part in searched)


def test_a_warm_process_reads_the_laws_jumps_back_instead_of_searching(monkeypatch):
    """The spin-up (its Piecewise angle joins continuously: no jump), cut to 1 s, run twice: the second run,
    its laws searched before (the same text, the same t_end), sweeps no law and halves no interval, and its
    probes are the first's to the bit. Before, every run searched its laws' values, rates and accelerations."""
    swept = []
    sweep, zeros = jumps._jumps_of_values, jumps._zeros_in_time
    monkeypatch.setattr(jumps, "_jumps_of_values", lambda *a, **k: swept.append("values") or sweep(*a, **k))
    monkeypatch.setattr(jumps, "_zeros_in_time", lambda *a, **k: swept.append("zeros") or zeros(*a, **k))
    data = yaml.safe_load((ROOT / "examples" / "spinup.yaml").read_text())
    data["solve"]["t_end"] = 1.0
    first = latdyn.run(latdyn.load_scene(data))
    swept.clear()
    second = latdyn.run(latdyn.load_scene(data))
    assert first.summary["status"] == second.summary["status"] == "solved"
    assert swept == []
    for name in ("tip_v", "energy"):
        assert np.array_equal(first.probes[name], second.probes[name])


def test_a_changed_law_parameter_t_end_or_search_is_searched_afresh():
    """Each scene after the first finds its laws' own instants although the one before it left its search
    in the cache: the same text to a longer t_end (its second kink, beyond the first t_end), a parameter
    changed (another text once substituted), and the three searches of one text (the values' finds nothing,
    the rates' the kinks, the accelerations' the ramp's ends): a cache keyed without any of these would give
    the answer of the scene before."""
    assert found(crank(TWO_KINKS, 1.0)) == ([], [0.5], [])
    assert found(crank(TWO_KINKS, 2.0)) == ([], [0.5, 1.5], [])
    moved = "Piecewise((0, t < T), (2*(t - T), True))"
    assert found(crank(moved, 1.0, "parameters: {T: 0.5}")) == ([], [0.5], [])
    assert found(crank(moved, 1.0, "parameters: {T: 0.75}")) == ([], [0.75], [])
    values, rates, accelerations = found(crank(RAMP_10_MS, 1.0))
    assert (values, rates) == ([], [])
    assert np.allclose(accelerations, [0.5, 0.51], rtol=0, atol=1e-12), accelerations
    assert found(crank("Piecewise((0, t < 0.5), (0.5, True))", 1.0)) == ([0.5], [], [])


def test_a_restart_at_a_jump_does_not_search_the_laws_again(monkeypatch):
    """The crank's 10 ms ramp: the run lands on its ends and restarts there. With the laws' cache left out, the
    one law is swept three times, once a search (its values, rate and acceleration) at the run's start, and
    not again at the restart; the run's numbers are those of a run that reads its searches from the cache,
    to the bit. Before, the first restart searched all three again (six sweeps)."""
    text = crank(RAMP_10_MS, 0.6)
    cached = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    swept = []
    sweep = jumps._jumps_of_values
    monkeypatch.setattr(jumps, "_searched", lambda search, law, t_end, find: find(), raising=False)
    monkeypatch.setattr(jumps, "_jumps_of_values", lambda *a, **k: swept.append(1) or sweep(*a, **k))
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert result.summary["status"] == cached.summary["status"] == "solved"
    assert result.probes["rate"][-1] < -4.8   # the rod took the ramp's impulse (measured −4.867 at dt 0.01)
    assert np.array_equal(result.probes["rate"], cached.probes["rate"])
    assert len(swept) == 3, swept
