"""``summary.json``, what a run was and how it ended (SCENE.md, "Commands and results").

Written atomically at the start with ``"status": "running"`` (so a killed run is recognisable)
and again when the writer closes, with the final status ``solved``, ``failed``, ``unbounded`` (a
transient run whose energy balance broke: docs/energy.md) or ``interrupted``. Keys always present: ``latdyn_version``, ``scene_hash``, ``wall_time_s``,
``steps``, ``newton_iterations``, ``rejected_steps``, ``energy_balance_error`` (``null`` when the
caller did not give one), ``status``, ``rows``, ``first_column``, ``probes``, plus the writer's
``meta`` and whatever the caller passes (:func:`compose_summary`). Non-finite floats are written
as ``null`` (strict JSON).
"""
from __future__ import annotations

import json
import time
from pathlib import Path

from latdyn.results.files import atomic_write_bytes, json_safe
from latdyn.version import __version__

__all__ = ["STATUSES", "SUMMARY_FILE", "SUMMARY_KEYS", "compose_summary", "write_summary"]

SUMMARY_FILE = "summary.json"

#: keys that summary.json always has (SCENE.md); the caller fills the values
SUMMARY_KEYS = (
    "latdyn_version",
    "scene_hash",
    "wall_time_s",
    "steps",
    "newton_iterations",
    "rejected_steps",
    "energy_balance_error",
)
STATUSES = ("running", "solved", "failed", "unbounded", "interrupted")


def compose_summary(given: dict, status: str | None, started: float, recorded: dict) -> dict:
    """The final summary, JSON-safe: ``given`` (the run's description and what its caller
    reported), with ``latdyn_version``, ``wall_time_s`` (since ``started``, a
    ``time.perf_counter()``) and None for the other :data:`SUMMARY_KEYS` where it has none;
    ``status`` (default ``given["status"]``, else ``solved``); then ``recorded``, what the files
    hold (rows, probes, state rows, ParaView files, modes), over it."""
    merged = dict(given)
    if status is None:
        status = merged.get("status") or "solved"
    if status not in STATUSES:
        raise ValueError(f"status must be one of {STATUSES}, not {status!r}")
    merged.setdefault("latdyn_version", __version__)
    if merged.get("wall_time_s") is None:
        merged["wall_time_s"] = time.perf_counter() - started
    for key in SUMMARY_KEYS:
        merged.setdefault(key, None)
    merged["status"] = status
    merged.update(recorded)
    return json_safe(merged)


def write_summary(folder: Path, summary: dict, durable: bool = True) -> None:
    """Replace ``folder/summary.json`` atomically by ``summary`` (indented, strict JSON); ``durable``:
    synced to the disk before it replaces the old one (the final summary; the ``running`` one of a
    run's start needs only the atomic replacement: results.state_history, "Crash safety")."""
    text = json.dumps(json_safe(summary), indent=2, sort_keys=False, allow_nan=False) + "\n"
    atomic_write_bytes(folder / SUMMARY_FILE, text.encode(), fsync=durable)
