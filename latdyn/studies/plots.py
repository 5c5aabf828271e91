"""The pictures of a study (STUDY.md): ``work_precision.png`` and ``stability.png``.

**Work-precision** — error against ``wall_s``, log–log. One curve per combination of the
non-numeric ``vary`` keys (the method, the formulation) and of all numeric keys but one,
the *free* key along the curve: ``solve.dt`` when it varies, else the first numeric key.
Each point is labelled with its free-key value; beside each curve is its observed order,
the least-squares slope of log error against log dt (against log of the free key; for a
key named ``elements`` the order is minus the slope, error ~ N^-p). Where a key named
``...elements`` varies as well, the order in the mesh is fitted across meshes at each
curve group's smallest solved dt and shown in a box. Failed and unbounded cases have no
error: they are marked along the bottom edge at their solver time (to the failure).
Other codes' points (``peers: [exudyn]`` in the study) come from
``benchmarks/results/peers.json``, which ``benchmarks/peers.py`` writes (see
:func:`_peer_points`); without that file the picture says so beneath its legend.

**Stability** — the status of every case on a grid of two ``vary`` keys (``stability:``
in the study, or ``solve.dt`` across and the first other key up), one panel per
combination of the other keys; failed and unbounded cells carry the time they reached.

**Campbell** (a study of a ``modes`` scene varying one key) — each mode's frequency [Hz]
against the varied key: the spin rate [rad/s] (``spin_rate`` of each case, with its
value in Hz on the top axis) when the key is a rotation angle law (``"5*t"``) or when the
spin rate is what changes, else the key's own value. Line k joins the k-th lowest
frequency of every case (sorted order, as ``modes.csv`` lists them); each point's marker
is the mode's dominant direction (``mode_directions``), so a line whose marker changes
is two modes crossing or veering, and the picture says so instead of guessing which
branch is which. Over a spin rate, the engine-order lines f = n·Ω/2π (n = 1, 2) are
dashed: where a mode meets one, the spin excites it resonantly. Frequencies are those
seen in the frame that turns with the structure (``solve.about: steady``).

Matplotlib's object-oriented API on an Agg canvas (``Figure`` + ``FigureCanvasAgg``), never
pyplot: no display needed, and the caller's backend and open figures are left as they were.
"""
from __future__ import annotations

import itertools
import json
import math
import textwrap
from pathlib import Path

import numpy as np

__all__ = ["draw", "work_precision", "stability_map", "campbell", "campbell_axis", "observed_orders", "axis_label"]

STATUS_STYLE = {
    "solved": {"marker": "o", "color": "#2ca02c", "label": "solved"},
    "failed": {"marker": "X", "color": "#d62728", "label": "failed (Newton / error)"},
    "unbounded": {"marker": "^", "color": "#ff7f0e", "label": "unbounded (energy / non-finite)"},
}
#: Units of scene keys, by the last part of the path (SI, as in every shipped scene).
UNITS = {"dt": "s", "t_end": "s", "rho_inf": "–", "tol": "–", "EA": "N", "EIy": "N m²", "EIz": "N m²",
         "GJ": "N m²", "GAy": "N", "GAz": "N", "rhoA": "kg/m", "rhoIy": "kg m", "rhoIz": "kg m", "mass": "kg",
         "elements": "count",
         "stiffness": "N m/rad", "damping": "N m s/rad", "angle": "rad", "every": "s"}
PROBE_UNITS = {"position": "m", "displacement": "m", "velocity": "m/s", "angle": "rad", "rate": "rad/s",
               "axial_force": "N", "torque": "N m", "moment_y": "N m", "moment_z": "N m"}


def _figure(figsize):
    """A figure on its own Agg canvas: no pyplot, so the caller's backend and figures are untouched."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=figsize)
    FigureCanvasAgg(figure)
    return figure


def axis_label(key: str) -> str:
    """``solve.dt`` -> ``solve.dt [s]``."""
    unit = UNITS.get(key.rsplit(".", 1)[-1])
    return f"{key} [{unit}]" if unit else key


def _probe_unit(spec) -> str:
    from latdyn.scene.loader import load_scene

    scene = load_scene(spec.base)
    for probe in scene.output.probes:
        if probe.name == spec.probe:
            if probe.kind == "energy":
                return "J"
            if probe.kind == "momentum":
                return "kg m/s" if probe.quantity == "linear" else "kg m²/s"
            return PROBE_UNITS.get(probe.quantity, "")
    return ""


def _free_key(spec) -> str | None:
    numeric = spec.numeric_keys
    if not numeric:
        return None
    return "solve.dt" if "solve.dt" in numeric else numeric[0]


def _short(key: str, value) -> str:
    name = key.rsplit(".", 1)[-1]
    if name == "elements":
        return f"{value} el."
    if name in ("method", "formulation"):
        return str(value)
    return f"{name}={value}"


def _fit_order(x, y, key: str) -> float | None:
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = (x > 0) & (y > 0) & np.isfinite(y)
    if ok.sum() < 2 or len(np.unique(x[ok])) < 2:
        return None
    slope = np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0]
    return float(-slope if key.endswith("elements") else slope)


def _curves(table, spec):
    """{curve key (tuple of (key, value)): [rows along the free key, sorted]}."""
    free = _free_key(spec)
    others = [k for k in spec.vary if k != free]
    curves: dict = {}
    for row in table.rows:
        ident = tuple((k, row[k]) for k in others)
        curves.setdefault(ident, []).append(row)
    if free is not None:
        for rows in curves.values():
            rows.sort(key=lambda r: r[free])
    return free, curves


def observed_orders(table, spec) -> list[dict]:
    """The observed orders: along each curve (in the free key) and, where a key named
    ``elements`` varies too, across meshes at the smallest solved dt."""
    free, curves = _curves(table, spec)
    orders = []
    if free is None:
        return orders
    for ident, rows in curves.items():
        solved = [r for r in rows if r["status"] == "solved" and r["error"] is not None]
        p = _fit_order([r[free] for r in solved], [r["error"] for r in solved], free)
        orders.append({"curve": ", ".join(_short(k, v) for k, v in ident) or "all", "in": free, "order": p,
                       "points": len(solved)})
    mesh = [k for k in spec.numeric_keys if k.endswith("elements") and k != free]
    if mesh and free == "solve.dt":
        m = mesh[0]
        rest = [k for k in spec.vary if k not in (free, m)]
        groups: dict = {}
        for row in table.rows:
            groups.setdefault(tuple((k, row[k]) for k in rest), []).append(row)
        for ident, rows in groups.items():
            solved = [r for r in rows if r["status"] == "solved" and r["error"] is not None]
            for dt in sorted({r[free] for r in solved}):
                at = [r for r in solved if r[free] == dt]
                if len({r[m] for r in at}) >= 2:
                    p = _fit_order([r[m] for r in at], [r["error"] for r in at], m)
                    orders.append({"curve": ", ".join(_short(k, v) for k, v in ident) or "all", "in": m,
                                   "order": p, "at": {free: dt}, "points": len(at)})
                    break
    return orders


#: Where ``benchmarks/peers.py`` writes its measurements (schema ``latdyn-peers/1``).
PEERS_JSON = Path(__file__).resolve().parents[2] / "benchmarks" / "results" / "peers.json"
#: The peers.json problem of a scene file.
PEER_PROBLEMS = {"spinup.yaml": "spinup", "D1_spinup.yaml": "spinup",
                 "D2_right_angle_cantilever.yaml": "cantilever"}


def _peer_points(spec, path=None) -> tuple[list, str | None]:
    """Other codes' points for the work-precision axes, and a note saying what they are.

    The hook: ``benchmarks/results/peers.json``, written by ``benchmarks/peers.py`` (Exudyn
    and latdyn on the same machine, same problem). For each name in the study's ``peers``,
    its ``ok`` rows of the problem of the study's scene give (``solver_s``, ``error``);
    latdyn's rows of the same file come with them, hollow, so that the two codes are
    compared under one error definition (peers.json's, stated in the note: not the study's
    norm). Without the file, no points and a note saying how to make it.
    """
    if not spec.peers:
        return [], None
    path = Path(path) if path is not None else PEERS_JSON
    problem = PEER_PROBLEMS.get(Path(spec.scene_file).name)
    if problem is None:
        return [], f"peers: no peers.json problem for {Path(spec.scene_file).name}"
    if not path.is_file():
        return [], ("peers " + ", ".join(spec.peers) + f": {path.name} not found — run "
                    "`python benchmarks/peers.py` to put their points here")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        rows = data["rows"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return [], f"peers: {path.name} unreadable ({type(exc).__name__})"
    points = []
    for row in rows:
        if row.get("problem") != problem or row.get("status") != "ok":
            continue
        if row.get("code") not in set(spec.peers) | {"latdyn"}:
            continue
        if not row.get("error") or not row.get("solver_s"):
            continue
        points.append({"peer": row["code"], "label": f"{row['code']} {row.get('setting', '')}".strip(),
                       "wall_s": float(row["solver_s"]), "error": float(row["error"])})
    found = {p["peer"] for p in points}
    definition = (data.get("problems", {}).get(problem, {}) or {}).get("error", "its own error")
    note = (f"◆ {', '.join(spec.peers)}, ◇ latdyn: benchmarks/results/{path.name} "
            f"({data.get('created', '?')}; solver_s, error = {definition}) — not the study's norm")
    missing = [p for p in spec.peers if p not in found]
    if missing:
        note += f"; no ok rows of {', '.join(missing)}"
    return points, note


def _spread(values, gap):
    """Positions as close to ``values`` as possible, at least ``gap`` apart (same order)."""
    order = np.argsort(values)
    out = np.asarray(values, float).copy()
    for a, b in zip(order[:-1], order[1:]):
        out[b] = max(out[b], out[a] + gap)
    return out


def work_precision(table, spec, path) -> list[dict]:
    """Draw ``path`` (see the module docstring); returns the observed orders."""
    import matplotlib

    free, curves = _curves(table, spec)
    orders = observed_orders(table, spec)
    along = {o["curve"]: o for o in orders if o["in"] == free}
    fig = _figure((12, 6.4))
    ax = fig.subplots()
    colours = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    linestyles = ["-", "--", ":", "-."]
    markers = ["o", "s", "v", "P"]
    numeric_others = [k for k in spec.numeric_keys if k != free]
    # colour by the non-numeric keys (method, formulation), line style by the numeric ones (mesh)
    categorical = [k for k in spec.vary if k not in spec.numeric_keys]
    colour_of, style_of = {}, {}
    failures, ends = [], []
    solved_rows = [r for r in table.rows if r["status"] == "solved" and r["error"] and r["wall_s"]]
    peers, peer_note = _peer_points(spec)
    for ident, rows in curves.items():
        cat = tuple(v for k, v in ident if k in categorical)
        num = tuple(v for k, v in ident if k in numeric_others)
        colour = colour_of.setdefault(cat, colours[len(colour_of) % len(colours)])
        style = style_of.setdefault(num, len(style_of))
        name = ", ".join(_short(k, v) for k, v in ident) or "all"
        solved = [r for r in rows if r["status"] == "solved" and r["error"] and r["error"] > 0 and r["wall_s"]]
        order = along.get(name, {}).get("order")
        label = name + (f"  (p = {order:.2f} in {free.rsplit('.', 1)[-1]})" if order is not None else "")
        line_style = linestyles[style % len(linestyles)]
        marker = markers[style % len(markers)]
        if solved:
            x = [r["wall_s"] for r in solved]
            y = [r["error"] for r in solved]
            ax.plot(x, y, linestyle=line_style, marker=marker, color=colour, label=label, markersize=5)
            if free is not None:
                for r in solved:
                    ax.annotate(f"{r[free]:g}", (r["wall_s"], r["error"]), textcoords="offset points",
                                xytext=(-3, 4), fontsize=6.5, color=colour, alpha=0.85, ha="right")
            if order is not None:
                last = max(solved, key=lambda r: r["wall_s"])
                ends.append((last["wall_s"], last["error"], f"p={order:.2f}", colour))
        else:
            lost = sum(r["status"] != "solved" for r in rows)
            ax.plot([], [], linestyle=line_style, marker=marker, color=colour,
                    label=f"{name}  (nothing solved: {lost} failed/unbounded)")
        for r in rows:
            if r["status"] != "solved" and r["wall_s"]:
                failures.append((r, colour))
    for peer in peers:
        hollow = peer["peer"] == "latdyn"
        ax.plot(peer["wall_s"], peer["error"], marker="D", linestyle="none", markersize=6,
                color="0.35" if hollow else "k", markerfacecolor="none" if hollow else "k")
        ax.annotate(peer.get("label", peer["peer"]), (peer["wall_s"], peer["error"]), textcoords="offset points",
                    xytext=(4, -9), fontsize=6.5, color="0.35" if hollow else "k")
    ax.set_xscale("log")
    ax.set_yscale("log")
    xs = [r["wall_s"] for r in table.rows if r["wall_s"]] + [p["wall_s"] for p in peers]
    ys = [r["error"] for r in solved_rows] + [p["error"] for p in peers]
    if xs:
        ax.set_xlim(min(xs) / 1.5, max(xs) * 2.2)
    if ys:
        ax.set_ylim(min(ys) / (6.0 if failures else 2.0), max(ys) * 2.0)
    if failures:  # no error to plot: along the bottom edge, at their time to failure
        strip = ax.get_ylim()[0] * 1.8
        for status in ("failed", "unbounded"):
            pts = [(r, c) for r, c in failures if r["status"] == status]
            if not pts:
                continue
            ax.scatter([r["wall_s"] for r, _ in pts], [strip] * len(pts), marker=STATUS_STYLE[status]["marker"],
                       s=60, c=[c for _, c in pts], edgecolors="k", linewidths=0.6, zorder=5,
                       label=f"{status}: {len(pts)} case(s), at their time to failure (no error)")
        ax.axhline(strip * 1.9, color="0.6", linewidth=0.6, linestyle=":")
    if ends:  # the observed orders beside the expensive end of each curve, pushed apart to stay legible
        to_display = ax.transData.transform
        points = to_display([(x, y) for x, y, _, _ in ends])
        spread = _spread(points[:, 1], 11.0)
        for (x, y, text, colour), (px, _), py in zip(ends, points, spread):
            xd, yd = ax.transData.inverted().transform((px + 10, py))
            ax.annotate(text, (x, y), xytext=(xd, yd), textcoords="data", fontsize=8, color=colour,
                        fontweight="bold", va="center",
                        arrowprops={"arrowstyle": "-", "color": colour, "linewidth": 0.5, "alpha": 0.6})
    unit = _probe_unit(spec)
    ax.set_xlabel("solver wall time per run, wall_s [s] (median of repeats, compile excluded)")
    ax.set_ylabel(f"{spec.norm} error of {spec.probe}" + (f" [{unit}]" if unit else "") + " against the reference")
    ax.set_title(textwrap.fill(spec.title, 100), fontsize=10.5)
    ax.grid(True, which="both", alpha=0.25)
    ax.tick_params(axis="both", which="minor", labelsize=6.5)
    notes = []
    if free is not None:
        notes.append(f"point labels: {axis_label(free)}\np: observed order in {free.rsplit('.', 1)[-1]} "
                     "(slope of log error vs log " + free.rsplit('.', 1)[-1] + ")")
    for o in orders:
        if o["in"] != free and o["order"] is not None:
            at = ", ".join(f"{k.rsplit('.', 1)[-1]}={v:g}" for k, v in o.get("at", {}).items())
            notes.append(f"order in {o['in'].rsplit('.', 1)[-1]}, {o['curve'] or 'all'} ({at}): {o['order']:.2f}")
    if peer_note:
        notes.append(peer_note)
    ax.legend(fontsize=7.5, loc="upper left", bbox_to_anchor=(1.01, 1.0), framealpha=0.9)
    fig.subplots_adjust(left=0.08, right=0.64, bottom=0.1, top=0.93)
    if notes:
        notes = [textwrap.fill(n, 64, subsequent_indent="  ") if "\n" not in n else n for n in notes]
        fig.text(0.655, 0.1, "\n".join(notes), va="bottom", ha="left", fontsize=7.5)
    fig.savefig(path, dpi=130)
    return orders


def _stability_keys(spec) -> tuple[str, str]:
    if spec.stability:
        return spec.stability
    keys = list(spec.vary)
    x = "solve.dt" if "solve.dt" in keys else keys[0]
    y = next(k for k in keys if k != x)
    return x, y


def _ordered(values):
    values = list(dict.fromkeys(values))
    try:
        return sorted(values)
    except TypeError:
        return values


def stability_map(table, spec, path) -> None:
    """Draw ``path``: status on a grid of two vary keys, a panel per combination of the others."""
    from matplotlib.lines import Line2D

    kx, ky = _stability_keys(spec)
    rest = [k for k in spec.vary if k not in (kx, ky)]
    panels = list(itertools.product(*(spec.vary[k] for k in rest))) if rest else [()]
    n = len(panels)
    cols = min(n, 3)
    nrows = math.ceil(n / cols)
    xs, ys = _ordered(spec.vary[kx]), _ordered(spec.vary[ky])
    fig = _figure((max(7.5, 1.2 + 3.2 * cols + 0.35 * len(xs)), 1.6 + 2.9 * nrows))
    axes = fig.subplots(nrows, cols, squeeze=False)
    seen = set()
    for index, combo in enumerate(panels):
        ax = axes[index // cols][index % cols]
        for row in table.rows:
            if any(row[k] != v for k, v in zip(rest, combo)):
                continue
            i, j = xs.index(row[kx]), ys.index(row[ky])
            st = STATUS_STYLE[row["status"]]
            ax.scatter([i], [j], marker=st["marker"], c=st["color"], s=170, edgecolors="k", linewidths=0.6,
                       label=st["label"] if row["status"] not in seen else None, zorder=3)
            seen.add(row["status"])
            if row["status"] != "solved" and row.get("t_reached") is not None:
                ax.annotate(f"t={row['t_reached']:.3g}", (i, j), textcoords="offset points", xytext=(0, -16),
                            ha="center", fontsize=6.5)
            elif row["status"] == "solved" and row.get("error") is not None and np.isfinite(row["error"]):
                ax.annotate(f"{row['error']:.1e}", (i, j), textcoords="offset points", xytext=(0, -16),
                            ha="center", fontsize=6, color="0.35")
        ax.set_xticks(range(len(xs)))
        ax.set_xticklabels([f"{v:g}" if isinstance(v, float) else str(v) for v in xs], rotation=30, fontsize=8)
        ax.set_yticks(range(len(ys)))
        ax.set_yticklabels([f"{v:g}" if isinstance(v, float) else str(v) for v in ys], fontsize=8)
        ax.set_xlim(-0.6, len(xs) - 0.4)
        ax.set_ylim(-0.7, len(ys) - 0.4)
        ax.grid(True, alpha=0.25)
        ax.set_xlabel(axis_label(kx))
        ax.set_ylabel(axis_label(ky))
        if rest:
            ax.set_title(", ".join(_short(k, v) for k, v in zip(rest, combo)), fontsize=9.5)
    for index in range(n, nrows * cols):
        axes[index // cols][index % cols].axis("off")
    handles = [Line2D([], [], linestyle="none", marker=STATUS_STYLE[s]["marker"], color=STATUS_STYLE[s]["color"],
                          markeredgecolor="k", markersize=10, label=STATUS_STYLE[s]["label"]) for s in STATUS_STYLE]
    fig.legend(handles=handles, loc="lower center", ncol=3, fontsize=8.5, bbox_to_anchor=(0.5, 0.0))
    title = textwrap.fill(spec.title, int(fig.get_figwidth() * 12))
    fig.suptitle(f"{title}\n(under each case: its error if solved, else t = the time its run reached)", fontsize=10)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(path, dpi=130)


def draw(table, spec, out) -> tuple[list[Path], list[dict]]:
    """The pictures the study asks for (``plots``) that apply; returns (paths, observed orders)."""
    out = Path(out)
    written, orders = [], observed_orders(table, spec)
    if "work-precision" in spec.plots:
        orders = work_precision(table, spec, out / "work_precision.png")
        written.append(out / "work_precision.png")
    if "stability" in spec.plots and len(spec.vary) >= 2:
        stability_map(table, spec, out / "stability.png")
        written.append(out / "stability.png")
    if "campbell" in spec.plots:
        campbell(table, spec, out / "campbell.png")
        written.append(out / "campbell.png")
    return written, orders


# =========================================================================== Campbell
#: Markers of a mode's dominant direction (``mode_directions``: latdyn/analyses/linearise.py).
DIRECTION_MARKERS = {"x": "s", "y": "o", "z": "^", "rx": "D", "ry": "v", "rz": "P", "hinge": "*"}
DIRECTION_WORDS = {"x": "x (axial for a beam along x)", "y": "y (chordwise, in the plane of a spin about z)",
                   "z": "z (flapwise, out of the plane of a spin about z)", "rx": "rotation about x (torsion)",
                   "ry": "rotation about y", "rz": "rotation about z", "hinge": "hinge angle"}
#: Engine-order (per-revolution) lines drawn over a spin rate.
HARMONICS = (1, 2)


def campbell_axis(table, spec) -> tuple[str, list, bool]:
    """(x-axis label, x of each row (None where unknown), whether x is the spin rate in rad/s)."""
    key = next(iter(spec.vary))
    rates = [r.get("spin_rate") for r in table.rows]
    known = [x for x in rates if x is not None]
    numeric = key in spec.numeric_keys
    if known and (key.endswith("rotation.angle") or not numeric):  # an angle law "5*t": its rate
        return "spin rate Ω [rad/s]  (" + key + ")", rates, True
    if numeric:
        return axis_label(key), [r[key] for r in table.rows], False
    return key + " (case order)", list(range(len(table.rows))), False


def campbell(table, spec, path) -> None:
    """Draw ``path``: the Campbell diagram of a modal study (see the module docstring)."""
    import matplotlib
    from matplotlib.lines import Line2D

    label, xs, spin = campbell_axis(table, spec)
    rows = [(x, r) for x, r in zip(xs, table.rows) if x is not None and r["status"] == "solved"]
    rows.sort(key=lambda item: item[0])
    count = sum(c.startswith("mode_") and c.endswith("_hz") for c in table.columns)
    fig = _figure((10.5, 6.2))
    ax = fig.subplots()
    colours = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    seen_directions: list = []
    ends = []
    for k in range(1, count + 1):
        colour = colours[(k - 1) % len(colours)]
        points = [(x, r.get(f"mode_{k}_hz"), r.get(f"mode_{k}_direction") or "") for x, r in rows
                  if r.get(f"mode_{k}_hz") is not None]
        if not points:
            continue
        ax.plot([p[0] for p in points], [p[1] for p in points], color=colour, linewidth=1.4, zorder=2)
        for direction in dict.fromkeys(p[2] for p in points):
            at = [p for p in points if p[2] == direction]
            ax.plot([p[0] for p in at], [p[1] for p in at], linestyle="none", color=colour, markersize=6,
                    marker=DIRECTION_MARKERS.get(direction, "o"), markeredgecolor="k", markeredgewidth=0.5,
                    zorder=3)
            if direction not in seen_directions:
                seen_directions.append(direction)
        ends.append((points[-1][0], points[-1][1], f"mode {k}", colour))
    failed = [(x, r) for x, r in zip(xs, table.rows) if x is not None and r["status"] != "solved"]
    for x, r in failed:
        ax.axvline(x, color="#d62728", linewidth=0.8, linestyle=":", zorder=1)
    top = max([y for _, y, _, _ in ends] + [1e-12])
    ax.set_ylim(0.0, top * 1.08)
    if rows:
        x0, x1 = rows[0][0], rows[-1][0]
        ax.set_xlim(x0, x1 + 0.16 * max(x1 - x0, 1e-12))
    harmonic_handles = []
    if spin and rows:
        grid = np.linspace(0.0, ax.get_xlim()[1], 200)
        for n, style in zip(HARMONICS, ("--", (0, (6, 3, 1, 3)))):
            ax.plot(grid, n * grid / (2 * np.pi), color="0.35", linestyle=style, linewidth=1.0, zorder=1)
            harmonic_handles.append(Line2D([], [], color="0.35", linestyle=style,
                                           label=f"{n}× spin: f = {n}·Ω/2π" if n > 1 else "1× spin: f = Ω/2π"))
        ax.set_ylim(0.0, top * 1.08)
        secondary = ax.secondary_xaxis("top", functions=(lambda w: w / (2 * np.pi), lambda f: f * 2 * np.pi))
        secondary.set_xlabel("spin frequency Ω/2π [Hz]")
    if ends:  # "mode k" beside the last point of each line, pushed apart to stay legible
        to_display = ax.transData.transform
        points = to_display([(x, y) for x, y, _, _ in ends])
        spread = _spread(points[:, 1], 13.0)
        for (x, y, text, colour), (px, _), py in zip(ends, points, spread):
            xd, yd = ax.transData.inverted().transform((px + 12, py))
            ax.annotate(text, (x, y), xytext=(xd, yd), textcoords="data", fontsize=8, color=colour,
                        fontweight="bold", va="center", zorder=4,
                        bbox={"boxstyle": "square,pad=0.1", "facecolor": "white", "edgecolor": "none", "alpha": 0.85},
                        arrowprops={"arrowstyle": "-", "color": colour, "linewidth": 0.5, "alpha": 0.6})
    handles = [Line2D([], [], linestyle="none", marker=DIRECTION_MARKERS.get(d, "o"), color="0.7",
                      markeredgecolor="k", markersize=7,
                      label=textwrap.fill("dominant " + DIRECTION_WORDS.get(d, d or "?"), 34, subsequent_indent="  "))
               for d in seen_directions]
    handles += harmonic_handles
    if failed:
        handles.append(Line2D([], [], color="#d62728", linestyle=":", label=f"{len(failed)} case(s) not solved"))
    ax.legend(handles=handles, fontsize=7.5, loc="upper left", bbox_to_anchor=(1.01, 1.0), framealpha=0.9)
    ax.set_xlabel(label)
    ax.set_ylabel("frequency [Hz]" + ("  (seen in the spinning frame)" if spin else ""))
    ax.grid(True, alpha=0.25)
    fig.suptitle(textwrap.fill(spec.title or "Campbell diagram", 90), fontsize=10.5)
    note = ("Line k joins the k-th lowest frequency of every case (sorted by frequency, not tracked by "
            "shape); the marker is each mode's dominant direction, so a line whose marker changes is "
            "two modes crossing or veering.")
    if spin:
        note += " Where a mode meets a dashed n× line, the spin excites it at resonance."
    fig.text(0.695, 0.12, textwrap.fill(note, 44), va="bottom", ha="left", fontsize=7.5)
    fig.subplots_adjust(left=0.08, right=0.68, bottom=0.1, top=0.84)
    fig.savefig(path, dpi=130)
