"""Two runs of one scene, the sensitivities' loop of steps on (``native``) and off (``python``, the per-step Python
path; latdyn.analyses.sensitivities_in_loop's private ``SENSITIVITIES_IN_LOOP``), compared to the bit: what the
in-loop sensitivity tests assert, each file with the extra checks it asks for (one helper for the near-copies
they kept)."""
from __future__ import annotations

import numpy as np


def runs_with_the_loop_on_and_off(scene) -> dict:
    """{True: the run with the loop of steps on, False: off} of ``scene`` (YAML text or its mapping), each through
    ``latdyn.run(latdyn.load_scene(...))``."""
    import pytest
    import yaml

    import latdyn

    data = yaml.safe_load(scene) if isinstance(scene, str) else scene
    runs = {}
    with pytest.MonkeyPatch.context() as patch:
        for in_loop in (True, False):
            patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
            runs[in_loop] = latdyn.run(latdyn.load_scene(data))
    return runs


def assert_same_sensitivities(native, python, *, python_path: bool = False, python_steps_in_loop: bool = True,
                              nonzero: str | None = None, in_loop_but: int | None = None,
                              events_may_be_absent: bool = False) -> None:
    """``native``'s sensitivities (every column, to the bit), the summary's probe sensitivities and event
    sensitivities are ``python``'s (two ``latdyn.run`` results). The options add:

    - ``python_path``: the Python run's ``time_loop`` is ``"python"``;
    - ``python_steps_in_loop`` (on unless switched off): the Python run took no step in the loop;
    - ``nonzero="each"``: every column is nonzero somewhere; ``"some"``: some column is;
    - ``in_loop_but=n``: the loop took every step of the native run but ``n``, and at least one;
    - ``events_may_be_absent``: the summaries' ``event_sensitivities`` are compared with ``.get`` (absent in both
      passes) rather than read.
    """
    assert nonzero in (None, "each", "some"), nonzero
    if python_path:
        assert python.summary["time_loop"] == "python"
    if python_steps_in_loop:
        assert python.summary["sensitivity_steps_in_loop"] == 0
    if in_loop_but is not None:
        assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] - in_loop_but > 0
    assert native.sensitivities.keys() == python.sensitivities.keys()
    for key, values in python.sensitivities.items():
        if nonzero == "each":
            assert np.abs(values).max() > 0.0, key
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    if nonzero == "some":
        assert max(np.abs(values).max() for values in python.sensitivities.values()) > 0.0
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    if events_may_be_absent:
        assert native.summary.get("event_sensitivities") == python.summary.get("event_sensitivities")
    else:
        assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]
