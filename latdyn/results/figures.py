"""Matplotlib figures on the Agg canvas, never through pyplot: plotting needs no display and
does not change the backend of a program that imports latdyn (``latdyn plot``, ``latdyn animate``)."""
from __future__ import annotations

__all__ = ["agg_figure"]


def agg_figure(width: float, height: float):
    """A ``matplotlib.figure.Figure`` of ``width`` × ``height`` inches with constrained layout,
    attached to an Agg canvas."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(figure)
    return figure
