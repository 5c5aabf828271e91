"""The progress bar of a run: a tqdm bar over simulated time (or load factor), or a no-op object
when it is disabled or tqdm is missing (:func:`progress_bar`)."""
from __future__ import annotations

import sys
import time

__all__ = ["progress_bar"]


class _NoProgress:
    """A disabled bar: ``update`` and ``close`` do nothing; also a context manager."""

    def update(self, t, **postfix) -> None:
        pass

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


class _Progress(_NoProgress):
    """A tqdm bar over simulated time (or load factor); ``update`` takes the absolute value.

    tqdm itself (an import of 30–60 ms with its ``multiprocessing``) is imported only when the bar
    would first show: at the first update after its delay (:func:`progress_bar`). The bar made then
    is dated from this object's making, so it shows and times what a bar made at the start shows;
    a run shorter than the delay never imports tqdm."""

    def __init__(self, total_time: float, unit: str, interactive: bool):
        self._total = float(total_time)
        self._unit, self._interactive = unit, interactive
        # on a terminal: after half a second; in a log: only runs longer than 5 s,
        # and seldom, so a log is not flooded with carriage returns
        self._delay = 0.5 if interactive else 5.0
        self._started = time.time()  # tqdm's own clock (its default timer)
        self._bar = None
        self._postfix = None

    def _made(self):
        """The tqdm bar, made now and dated from the start (None: tqdm is missing)."""
        try:
            from tqdm import tqdm
        except ImportError:
            self._delay = float("inf")  # never again: a bar without tqdm is the no-op
            return None
        bar = tqdm(
            total=self._total,
            unit=self._unit,
            file=sys.stderr,
            leave=True,
            dynamic_ncols=True,
            delay=self._delay,
            mininterval=0.2 if self._interactive else 30.0,
            bar_format="{l_bar}{bar}| {n:.4g}/{total:.4g} {unit} [{elapsed}<{remaining}{postfix}]",
        )
        bar.start_t = bar.last_print_t = self._started
        return bar

    def update(self, t, **postfix) -> None:
        value = min(max(float(t), 0.0), self._total)
        if postfix:
            self._postfix = postfix
        if self._bar is None:
            if time.time() < self._started + self._delay:
                return
            self._bar = self._made()
            if self._bar is None:
                return
        if self._postfix:
            self._bar.set_postfix(self._postfix, refresh=False)
            self._postfix = None
        self._bar.update(value - self._bar.n)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


def progress_bar(total_time: float, enabled: bool = True, unit: str = "s"):
    """A progress bar over ``[0, total_time]``: an object with ``.update(t, **postfix)``
    (``t`` absolute; ``postfix`` e.g. ``dt=1e-3, newton=3``) and ``.close()``; also a
    context manager.

    Disabled (a no-op object) when ``enabled`` is false or tqdm is missing. When
    enabled it appears after 0.5 s on a terminal, and in a non-terminal stderr (a log)
    only for runs that last more than 5 s, refreshed at most every 30 s. Use
    ``unit="load"`` and ``total_time=1`` for static runs.
    """
    if not enabled or not total_time or total_time <= 0:
        return _NoProgress()
    try:
        interactive = sys.stderr.isatty()
    except (AttributeError, ValueError):
        interactive = False
    return _Progress(total_time, unit, interactive)
