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
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(scene, out)
    latdyn.run(scene, out, resume=True)
    return out, whole
