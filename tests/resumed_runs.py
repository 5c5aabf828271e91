"""A run interrupted (Ctrl-C) at a time and resumed from its checkpoint, beside the same run uninterrupted: what the
sensitivity tests compare byte for byte (checkpoints carry the sensitivities' state)."""
from __future__ import annotations

from pathlib import Path

import pytest

import latdyn


def interrupted_and_whole(scene: dict, tmp_path: Path, monkeypatch, t_stop: float) -> tuple[Path, Path]:
    """(resumed, whole): ``scene`` run into ``tmp_path/whole``, and into ``tmp_path/out`` interrupted by a
    KeyboardInterrupt at the first step from t ≥ ``t_stop``, then resumed there (``latdyn.run(..., resume=True)``)."""
    from latdyn.step.compiled import CompiledGeneralizedAlpha

    whole = tmp_path / "whole"
    latdyn.run(scene, whole)
    original = CompiledGeneralizedAlpha.step

    def step(self, state, *args, **kwargs):
        if state.t >= t_stop:
            raise KeyboardInterrupt
        return original(self, state, *args, **kwargs)

    out = tmp_path / "out"
    with monkeypatch.context() as m:
        m.setattr(CompiledGeneralizedAlpha, "step", step)
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(scene, out)
    latdyn.run(scene, out, resume=True)
    return out, whole
