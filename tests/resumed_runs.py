"""A run interrupted (Ctrl-C) at a time and resumed from its checkpoint, beside the same run uninterrupted: what the
sensitivity tests compare byte for byte (checkpoints carry the sensitivities' state)."""
from __future__ import annotations

from pathlib import Path

import pytest

import latdyn


def interrupted_and_whole(scene: dict, tmp_path: Path, monkeypatch, t_stop: float) -> tuple[Path, Path]:
    """(resumed, whole): ``scene`` run into ``tmp_path/whole``, and into ``tmp_path/out`` interrupted by a
    KeyboardInterrupt at the first step (or loop of steps in C) from t ≥ ``t_stop``, then resumed there (``latdyn.run(..., resume=True)``)."""
    from latdyn.step.compiled import CompiledGeneralizedAlpha

    whole = tmp_path / "whole"
    latdyn.run(scene, whole)
    originals = {name: getattr(CompiledGeneralizedAlpha, name) for name in ("step", "advance")}

    def stopping(name):   # a step from Python, or a loop of steps in C (latdyn/timeloop/loop.py)
        def call(self, state, *args, **kwargs):
            if state.t >= t_stop:
                raise KeyboardInterrupt
            return originals[name](self, state, *args, **kwargs)
        return call

    out = tmp_path / "out"
    with monkeypatch.context() as m:
        for name in originals:
            m.setattr(CompiledGeneralizedAlpha, name, stopping(name))
        # each loop of steps back in Python after a step, as a Ctrl-C finds it (its rows, sensitivity rows among
        # them, recorded in C up to the budget): else one loop may take the run from before t_stop to its end
        m.setattr("latdyn.timeloop.transient.LOOP_BUDGET_S", 1e-12)
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(scene, out)
    latdyn.run(scene, out, resume=True)
    return out, whole


def resumed_inside_the_loop_is_whole(scene: dict, tmp_path: Path, monkeypatch, t_stop: float) -> None:
    """``scene`` interrupted (Ctrl-C) as a loop of steps in C starts at t ≥ ``t_stop``, every loop up to it having
    carried the sensitivities (the forward method's columns or the adjoint's stored steps), and resumed from its
    checkpoint: sensitivities.csv and summary.json's ``probe_sensitivities`` and ``event_sensitivities`` are the
    uninterrupted run's, byte for byte, and so is the count of steps taken in the loop (> 0)."""
    import json

    from latdyn.step.compiled import CompiledGeneralizedAlpha

    whole, out = tmp_path / "whole", tmp_path / "out"
    latdyn.run(scene, whole)
    original = CompiledGeneralizedAlpha.advance
    calls = []

    def advance(self, state, **kwargs):
        calls.append(kwargs.get("sensitivities") is not None)
        if state.t >= t_stop:
            raise KeyboardInterrupt
        return original(self, state, **kwargs)

    with monkeypatch.context() as patch:
        patch.setattr(CompiledGeneralizedAlpha, "advance", advance)
        patch.setattr("latdyn.timeloop.transient.LOOP_BUDGET_S", 1e-12)   # as interrupted_and_whole
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(scene, out)
    assert calls and all(calls)   # the loop carried the sensitivities up to the interruption
    latdyn.run(scene, out, resume=True)
    assert (out / "sensitivities.csv").read_bytes() == (whole / "sensitivities.csv").read_bytes()
    resumed, uninterrupted = (json.loads((folder / "summary.json").read_text()) for folder in (out, whole))
    for key in ("probe_sensitivities", "event_sensitivities"):
        assert resumed[key] == uninterrupted[key], key
    # the run's count, carried by the checkpoint (before: the resumed process's steps alone, 39 of 59)
    assert resumed["sensitivity_steps_in_loop"] == uninterrupted["sensitivity_steps_in_loop"] > 0
