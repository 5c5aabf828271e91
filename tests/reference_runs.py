"""The whole runs a Richardson reference of a scene's sensitivities differences, made as cheaply as they can be made
the same: one helper for the test files' ``_agree`` and ``_richardson`` helpers.

A run's probes do not depend on ``solve.sensitivities`` except at events and cable changes, where a run with them ends
its steps to 1e-12 and restarts at solve.dt (the steps "the sensitivities' own": latdyn/timeloop/loop.py, the warning
of ``_summarize``; docs/parameters.md, "Sensitivities through events"). Where the scene's run with sensitivities had
none of those, the reference's runs leave the sensitivities out, once a run without them has written that run's
probes to the bit; elsewhere they keep them. Either way the reference differences the probes the checked run wrote,
bit for bit at the scene's own parameters."""
from __future__ import annotations

from typing import Callable

import numpy as np
import yaml

import latdyn

#: the words of the warning a run with sensitivities writes where some of its steps are theirs (loop.py)
OWN_STEPS = "steps are the sensitivities' own"


def without_sensitivities(text: str, **parameters):
    """``text`` run through the API at ``parameters``, ``solve.sensitivities`` (and ``sensitivity_method``) left out."""
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    for key in ("sensitivities", "sensitivity_method"):
        data["solve"].pop(key, None)
    return latdyn.run(latdyn.load_scene(data))


def reference_runs(text: str, result, with_sensitivities: Callable) -> Callable:
    """The function of parameters (keywords) whose runs a Richardson reference of ``text`` differences:
    :func:`without_sensitivities` where ``result`` (``text`` run with sensitivities) had no event, no cable change, no
    step of the sensitivities' own, and a run without them writes ``result``'s probes to the bit; else
    ``with_sensitivities`` (the caller's run with them)."""
    summary = result.summary
    if (summary.get("events") or summary.get("cable_events")
            or any(OWN_STEPS in warning for warning in summary.get("warnings", []))):
        return with_sensitivities
    plain = without_sensitivities(text)
    if plain.probes.keys() != result.probes.keys() or not all(
            np.array_equal(plain.probes[k], result.probes[k]) for k in result.probes):
        return with_sensitivities
    return lambda **parameters: without_sensitivities(text, **parameters)
