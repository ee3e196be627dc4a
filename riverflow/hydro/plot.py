"""plot_flow: a picture of a river network and its flow, for authors to judge a network.

Draws, from above: the terrain as a hillshade (when given a scene), the water coloured by the
speed of the :class:`~riverflow.hydro.flow_field.FlowField` (colour bar in m/s), streamlines of
the flow (or arrows), the banks coloured by their stream-function value ψ and labelled with
their curve id and ψ, the axes dashed and the closing segments. The water is the union of the
faces that the banks and closing segments enclose and that the flow field calls INSIDE, so the
picture shows what the flow field sees, not what the file claims.

matplotlib is an optional extra (``pip install riverflow[plot]``); it is imported, with the
Agg backend, only when :func:`plot_flow` runs::

    from riverflow.hydro.plot import plot_flow
    plot_flow(rf.load_graph("rivers.graph"), "out/flow.png")
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from riverflow._atomic import atomic_files, require_suffix
from riverflow.components.status import FlowStatus
from riverflow.hydro.graph import CurveType, HydroGraph

GRID_POINTS = 400 * 400
"""About this many FlowField queries make the speed image and the streamlines."""

SPEED_CMAP = "viridis"
PSI_CMAP = "plasma"
LAND_COLOR = "#efece4"


def plot_flow(graph_or_scene: Any, out_png: str | Path, *, field: Any = None,
              size_px: int = 1200, title: str | None = None,
              style: str = "streamlines") -> Path:
    """Draw a river network and its flow into a PNG file.

    Args:
        graph_or_scene: a :class:`HydroGraph`, a scene (anything with ``.graph``, and
            optionally ``.terrain``, drawn as a hillshade), or a path to a hydro-graph file.
        out_png: the PNG to write (its folder is created).
        field: the :class:`FlowField` to draw (default: ``FlowField(graph)``).
        size_px: width of the picture [px].
        title: the title (default: the graph's source and the field's options).
        style: ``"streamlines"`` (matplotlib streamplot) or ``"arrows"`` (quiver).

    Returns:
        The path written.

    Raises:
        ImportError: matplotlib is not installed (``pip install riverflow[plot]``).
        ValueError: an unknown ``style``, a ``size_px`` below 200 or a file name not ending
            in .png, .svg or .pdf (the extension decides the format).
    """
    if style not in ("streamlines", "arrows"):
        raise ValueError(f"style must be 'streamlines' or 'arrows', got {style!r}")
    require_suffix(out_png, (".png", ".svg", ".pdf"), "a flow picture")
    if size_px < 200:
        raise ValueError(f"size_px must be at least 200, got {size_px}")
    mpl, Figure, FigureCanvasAgg = _import_matplotlib()
    graph, terrain = _graph_and_terrain(graph_or_scene)
    if field is None:
        from riverflow.hydro.flow_field import FlowField

        field = FlowField(graph, cache_tiles=1024)

    tol = max(min((graph.curves[a].width_m for a in graph.axes()), default=1.0) / 100.0, 0.05)
    lines = {i: graph.polyline(i, tol) for i in range(len(graph.curves))}
    x0, y0, x1, y1 = _extent(graph, lines)
    aspect = (x1 - x0) / (y1 - y0)
    nx = max(16, round(math.sqrt(GRID_POINTS * aspect)))
    ny = max(16, round(math.sqrt(GRID_POINTS / aspect)))
    xs = np.linspace(x0, x1, nx)
    ys = np.linspace(y0, y1, ny)
    gx, gy = np.meshgrid(xs, ys)
    pts = np.stack([gx.ravel(), gy.ravel()], axis=1)
    status, velocity = field.query(pts, level=_level_for(field, xs[1] - xs[0]))
    inside = (status == FlowStatus.INSIDE).reshape(ny, nx)
    u = velocity[:, 0].reshape(ny, nx).astype(np.float64)
    v = velocity[:, 1].reshape(ny, nx).astype(np.float64)
    speed = np.hypot(u, v)

    map_w_in = size_px / 100.0
    map_h_in = map_w_in / aspect
    fig = Figure(figsize=(map_w_in, map_h_in + 1.9), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    gs = fig.add_gridspec(2, 2, height_ratios=[map_h_in, 0.28])
    ax = fig.add_subplot(gs[0, :])
    ax.set_facecolor(LAND_COLOR)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.tick_params(labelsize=8)

    if terrain is not None:
        _draw_hillshade(ax, mpl, terrain, (x0, y0, x1, y1))
    water_path = _water_path(mpl, graph, lines, field)
    speed_img, vmax = _draw_speed(ax, mpl, speed, inside, (x0, y0, x1, y1), water_path)
    if inside.sum() >= 4:
        _draw_flow(ax, mpl, xs, ys, u, v, inside, style, graph, water_path)
    psi_norm, labels = _draw_curves(ax, mpl, graph, lines)

    cax = fig.add_subplot(gs[1, 0])
    cb = fig.colorbar(speed_img, cax=cax, orientation="horizontal",
                      extend="max" if speed[inside].max(initial=0.0) > vmax else "neither")
    cb.set_label("water speed |v| [m/s]")
    pax = fig.add_subplot(gs[1, 1])
    if psi_norm is not None:
        cb2 = fig.colorbar(mpl.cm.ScalarMappable(psi_norm, _psi_cmap(mpl)), cax=pax,
                           orientation="horizontal")
        cb2.set_label("bank stream function ψ [m²/s]")
    else:
        pax.set_axis_off()

    if title is None:
        seed = getattr(graph_or_scene, "seed", None)
        if seed is not None:
            name = f"scene (seed {seed})"
        elif graph.source:
            name = Path(graph.source).name
        else:
            name = "river network"
        title = (f"{name}: flow field (slip {field.slip:g}, "
                 f"search radius {field.search_radius_factor:g} × widest axis)")
    ax.set_title(title, fontsize=12)
    n_in = int(inside.sum())
    stats = (f"{len(graph.axes())} axes, {len(graph.banks())} banks · "
             f"{n_in} of {inside.size} samples in the water · "
             f"max speed {speed[inside].max(initial=0.0):.2f} m/s")
    ax.text(0.005, 0.995, stats, transform=ax.transAxes, va="top", ha="left", fontsize=8,
            bbox=dict(boxstyle="round,pad=0.25", fc="white", ec="0.6", alpha=0.85), zorder=10)

    fig.draw_without_rendering()  # lay out once, place the labels in pixels, keep that layout
    fig.set_layout_engine("none")
    _place_labels(fig, ax, labels)

    out = Path(out_png)
    with atomic_files(out) as (temp,):       # complete or not at all; the extension decides
        fig.savefig(temp, dpi=100)
    return out


# -- helpers ------------------------------------------------------------------------------------


def _psi_cmap(mpl):
    """plasma without its palest tenth, which vanishes on light land."""
    from matplotlib.colors import ListedColormap

    return ListedColormap(mpl.colormaps[PSI_CMAP](np.linspace(0.0, 0.9, 256)), name="psi")


def _import_matplotlib():
    try:
        import matplotlib
    except ImportError as exc:
        raise ImportError(
            "riverflow's flow pictures need matplotlib, an optional extra: "
            "pip install 'riverflow[plot]' (or pip install matplotlib)") from exc
    # Agg canvas on a bare Figure: no pyplot, so no global backend switch in the caller's session
    import matplotlib.cm  # noqa: F401
    import matplotlib.colors  # noqa: F401
    import matplotlib.patches  # noqa: F401
    import matplotlib.path  # noqa: F401
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    return matplotlib, Figure, FigureCanvasAgg


def _graph_and_terrain(obj: Any) -> tuple[HydroGraph, Any]:
    if isinstance(obj, HydroGraph):
        return obj, None
    if isinstance(obj, (str, Path)):
        from riverflow.hydro.io import load_graph

        return load_graph(obj), None
    graph = getattr(obj, "graph", None)
    if isinstance(graph, HydroGraph):
        return graph, getattr(obj, "terrain", None)
    raise TypeError(f"plot_flow needs a HydroGraph, a scene with .graph or a graph file, "
                    f"got {type(obj).__name__}")


def _extent(graph: HydroGraph, lines: dict[int, np.ndarray]) -> tuple[float, float, float, float]:
    """The network's bounds, padded by a margin for labels."""
    pts = np.vstack(list(lines.values()))
    x0, y0 = pts.min(axis=0)
    x1, y1 = pts.max(axis=0)
    span = max(x1 - x0, y1 - y0, 1.0)
    width = max((graph.curves[a].width_m for a in graph.axes()), default=0.0)
    pad = max(0.06 * span, 0.75 * width)
    x0, x1, y0, y1 = x0 - pad, x1 + pad, y0 - pad, y1 + pad
    # no thinner than 1:4, so that a straight channel still gets a readable picture
    if (y1 - y0) < 0.25 * (x1 - x0):
        c = 0.5 * (y0 + y1)
        y0, y1 = c - 0.125 * (x1 - x0), c + 0.125 * (x1 - x0)
    elif (x1 - x0) < 0.25 * (y1 - y0):
        c = 0.5 * (x0 + x1)
        x0, x1 = c - 0.125 * (y1 - y0), c + 0.125 * (y1 - y0)
    return float(x0), float(y0), float(x1), float(y1)


def _level_for(field: Any, step_m: float) -> int | None:
    """The coarsest tile level whose ψ lattice is at least twice finer than the picture grid."""
    if hasattr(field, "level_for_spacing"):
        return field.level_for_spacing(0.5 * step_m)
    return None


def _draw_hillshade(ax, mpl, terrain, extent, max_side: int = 768) -> None:
    """The terrain under the picture as a pale hillshade, sampled from ``terrain.height``
    (a streamed terrain has no whole-map array) on a grid of at most max_side² points."""
    x0, y0, x1, y1 = extent
    cell = max(float(terrain.cell_m), max(x1 - x0, y1 - y0) / max_side)
    nx = max(int(math.ceil((x1 - x0) / cell)) + 1, 2)
    ny = max(int(math.ceil((y1 - y0) / cell)) + 1, 2)
    gx, gy = np.meshgrid(x0 + np.arange(nx) * cell, y0 + np.arange(ny) * cell)
    sub = np.asarray(terrain.height(np.c_[gx.ravel(), gy.ravel()]), np.float64).reshape(ny, nx)
    light = mpl.colors.LightSource(azdeg=315, altdeg=40)
    # hillshade wants row 0 at the top (north); our rows grow northwards
    shade = light.hillshade(sub[::-1], vert_exag=2.0, dx=cell, dy=cell)[::-1]
    rgb = mpl.colormaps["gist_earth"](mpl.colors.Normalize(sub.min(), sub.max())(sub))[..., :3]
    rgb = 0.55 + 0.45 * (0.35 * rgb + 0.65 * shade[..., None])  # pale: the water is the subject
    ax.imshow(rgb, origin="lower", interpolation="bilinear", zorder=0,
              extent=(x0 - 0.5 * cell, x0 + (nx - 0.5) * cell,
                      y0 - 0.5 * cell, y0 + (ny - 0.5) * cell))


def _water_path(mpl, graph: HydroGraph, lines: dict[int, np.ndarray], field: Any):
    """A matplotlib Path of the water: faces of the bank + closing-segment line work whose
    representative point the field calls INSIDE; None when the banks enclose nothing."""
    import shapely
    from shapely.geometry.polygon import orient

    rings = [shapely.LineString(p) for i, p in lines.items()
             if (graph.curves[i].is_bank or graph.curves[i].type == CurveType.CLOSING_SEGMENT)
             and len(p) >= 2]
    if not rings:
        return None
    faces = list(shapely.get_parts(shapely.polygonize(
        shapely.get_parts(shapely.unary_union(rings)))))
    faces = [f for f in faces if f.area > 0.0]
    if not faces:
        return None
    probe = np.array([[p.x, p.y] for p in (f.point_on_surface() for f in faces)])
    status, _ = field.query(probe)
    water = [f for f, s in zip(faces, status) if s == FlowStatus.INSIDE]
    if not water:
        return None
    verts, codes = [], []
    for poly in water:
        poly = orient(poly, sign=1.0)  # exterior counter-clockwise, holes clockwise
        for ring in [poly.exterior, *poly.interiors]:
            xy = np.asarray(ring.coords)
            verts.append(xy)
            codes.append(np.r_[mpl.path.Path.MOVETO,
                               np.full(len(xy) - 2, mpl.path.Path.LINETO),
                               mpl.path.Path.CLOSEPOLY])
    return mpl.path.Path(np.vstack(verts), np.concatenate(codes).astype(np.uint8))


def _draw_speed(ax, mpl, speed, inside, extent, water_path):
    """The speed image, clipped to the water path (its cells extended two cells outward so the
    clip, not the sample grid, makes the edge)."""
    x0, y0, x1, y1 = extent
    vmax = float(np.percentile(speed[inside], 99.5)) if inside.any() else 1.0
    vmax = vmax if vmax > 0.0 else 1.0
    norm = mpl.colors.Normalize(0.0, vmax)
    img_data = np.ma.masked_array(speed, ~inside)
    if water_path is not None and inside.any():
        from scipy.ndimage import distance_transform_edt

        dist, (jj, ii) = distance_transform_edt(~inside, return_indices=True)
        filled = speed[jj, ii]
        img_data = np.ma.masked_array(filled, dist > 2.0)
    ny, nx = speed.shape
    hx = 0.5 * (x1 - x0) / (nx - 1)
    hy = 0.5 * (y1 - y0) / (ny - 1)
    img = ax.imshow(img_data, origin="lower", cmap=SPEED_CMAP, norm=norm, zorder=1,
                    interpolation="bilinear" if water_path is not None else "nearest",
                    extent=(x0 - hx, x1 + hx, y0 - hy, y1 + hy))
    if water_path is not None:
        img.set_clip_path(mpl.patches.PathPatch(water_path, transform=ax.transData))
    return img, vmax


def _draw_flow(ax, mpl, xs, ys, u, v, inside, style, graph: HydroGraph, water_path) -> None:
    """Streamlines (or arrows) of the INSIDE samples, white with a dark rim, clipped to the
    water."""
    from matplotlib import patheffects

    rim = [patheffects.Stroke(linewidth=1.8, foreground="black", alpha=0.45), patheffects.Normal()]
    widths = [graph.curves[a].width_m for a in graph.axes()]
    step = xs[1] - xs[0]
    spacing = max(float(np.median(widths)) / 7.0, 2.0 * step)  # wanted line spacing [m]
    if style == "arrows":
        k = max(1, round(1.5 * spacing / step))
        sl = (slice(k // 2, None, k), slice(k // 2, None, k))
        keep = inside[sl]
        gx, gy = np.meshgrid(xs, ys)
        top = float(np.percentile(np.hypot(u, v)[inside], 99.5))
        q = ax.quiver(gx[sl][keep], gy[sl][keep], u[sl][keep], v[sl][keep], color="white",
                      angles="xy", scale_units="xy", scale=top / (1.3 * k * step) if top else 1.0,
                      pivot="mid", zorder=2, units="dots", width=1.4, headwidth=3.5,
                      headlength=4.5, headaxislength=4.0)
        q.set_path_effects(rim)
        if water_path is not None:
            q.set_clip_path(mpl.patches.PathPatch(water_path, transform=ax.transData))
        return
    # NaN outside the water: streamplot masks it and ends lines there. Density 1 is a 30 × 30
    # grid over the whole plot; aim for `spacing`. Seeds only in the water, deepest first (lines
    # centred in each river); streamplot's own seeding would try every land cell, slowly
    density = (float(np.clip((xs[-1] - xs[0]) / spacing / 30.0, 0.5, 12.0)),
               float(np.clip((ys[-1] - ys[0]) / spacing / 30.0, 0.5, 12.0)))
    seeds = _seeds(xs, ys, inside, density)
    if not len(seeds):
        return
    lines = ax.streamplot(xs, ys, np.where(inside, u, np.nan), np.where(inside, v, np.nan),
                          density=density, start_points=seeds, color="white", linewidth=0.7,
                          arrowsize=0.8, minlength=0.02, zorder=2)
    lines.lines.set_path_effects(rim)


def _seeds(xs: np.ndarray, ys: np.ndarray, inside: np.ndarray,
           density: tuple[float, float]) -> np.ndarray:
    """Streamplot start points: the nodes of its density mask that lie in the water at least
    1.5 samples from the edge, ordered from the deepest (farthest from any bank) outwards."""
    from scipy.ndimage import distance_transform_edt

    mx = np.linspace(xs[0], xs[-1], int(30 * density[0]))
    my = np.linspace(ys[0], ys[-1], int(30 * density[1]))
    depth = distance_transform_edt(inside)
    ii = np.rint((mx - xs[0]) / (xs[1] - xs[0])).astype(np.int64)
    jj = np.rint((my - ys[0]) / (ys[1] - ys[0])).astype(np.int64)
    d = depth[np.ix_(jj, ii)]
    j, i = np.nonzero(d >= 1.5)
    order = np.argsort(-d[j, i], kind="stable")
    return np.stack([mx[i[order]], my[j[order]]], axis=1)


def _draw_curves(ax, mpl, graph: HydroGraph, lines: dict[int, np.ndarray]):
    """Axes dashed, closing segments, banks coloured by ψ; returns ψ's Normalize and the bank
    labels to place once the layout is known."""
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D

    handles = []
    axes = [lines[i] for i in graph.axes()]
    if axes:
        ax.add_collection(LineCollection(axes, colors="0.15", linewidths=0.9,
                                         linestyles=(0, (5, 4)), zorder=3))
        handles.append(Line2D([], [], color="0.15", lw=0.9, ls=(0, (5, 4)), label="axis"))
    closing = [lines[i] for i, c in enumerate(graph.curves)
               if c.type == CurveType.CLOSING_SEGMENT and not c.is_axis]
    if closing:
        ax.add_collection(LineCollection(closing, colors="#d62728", linewidths=1.4,
                                         linestyles=(0, (1.5, 1.5)), zorder=3))
        handles.append(Line2D([], [], color="#d62728", lw=1.4, ls=(0, (1.5, 1.5)),
                              label="closing segment"))
    banks = [i for i in graph.banks() if graph.curves[i].has_potential]
    norm = None
    labels: list[tuple[int, float, np.ndarray, Any]] = []
    if banks:
        psi = np.array([graph.curves[i].potential for i in banks])
        lo, hi = float(psi.min()), float(psi.max())
        norm = mpl.colors.Normalize(lo, hi if hi > lo else lo + 1.0)
        colors = _psi_cmap(mpl)(norm(psi))
        ax.add_collection(LineCollection([lines[i] for i in banks], colors=colors,
                                         linewidths=2.2, zorder=4, capstyle="round"))
        handles.append(Line2D([], [], color=_psi_cmap(mpl)(0.45), lw=2.2,
                              label="bank (colour: ψ)"))
        labels = [(i, graph.curves[i].potential, lines[i], color)
                  for i, color in zip(banks, colors)]
    bad = [i for i in graph.banks() if not graph.curves[i].has_potential]
    if bad:
        ax.add_collection(LineCollection([lines[i] for i in bad], colors="red", linewidths=2.5,
                                         zorder=4))
        handles.append(Line2D([], [], color="red", lw=2.5, label="bank WITHOUT ψ"))
    handles.append(mpl.patches.Patch(color=mpl.colormaps[SPEED_CMAP](0.6),
                                     label="water (colour: speed)"))
    ax.legend(handles=handles, loc="best", fontsize=8, framealpha=0.85)
    return norm, labels


def _place_labels(fig, ax, labels: list[tuple[int, float, np.ndarray, Any]]) -> None:
    """'#id ψ=…' beside each bank on its dry side (right of a → b), longest banks first, each at
    the first spot along the bank that overlaps no earlier label, legend or caption."""
    from matplotlib.font_manager import FontProperties

    renderer = fig.canvas.get_renderer()
    prop = FontProperties(size=7)
    pad = 3.0
    frame = ax.get_window_extent(renderer)
    taken = [a.get_window_extent(renderer).extents for a in ax.texts + [ax.get_legend()]
             if a is not None]
    gap = 10.0 * fig.dpi / 72.0

    def length(line: np.ndarray) -> float:
        return float(np.hypot(*np.diff(line, axis=0).T).sum())

    for index, psi, line, color in sorted(labels, key=lambda item: -length(item[2])):
        text = f"#{index} ψ={psi:.4g}"
        w, h, _ = renderer.get_text_width_height_descent(text, prop, ismath=False)
        w, h = w + 2 * pad, h + 2 * pad
        best = None
        for fraction in (0.5, 0.35, 0.65, 0.2, 0.8, 0.1, 0.9):
            anchor, d = _along(line, fraction)
            if anchor is None:
                continue
            a = ax.transData.transform(anchor)
            dry = np.array([d[1], -d[0]])
            for dist in (gap, 2.5 * gap):
                c = a + dry * (dist + 0.5 * (abs(dry[0]) * w + abs(dry[1]) * h))
                box = (c[0] - w / 2, c[1] - h / 2, c[0] + w / 2, c[1] + h / 2)
                cost = sum(_overlap(box, t) for t in taken)
                cost += 1e6 * (box[0] < frame.x0 or box[2] > frame.x1 or box[1] < frame.y0
                               or box[3] > frame.y1)
                if best is None or cost < best[0]:
                    best = (cost, anchor, c - a, box)
                if cost == 0.0:
                    break
            if best is not None and best[0] == 0.0:
                break
        if best is None:
            continue
        _, anchor, offset, box = best
        taken.append(box)
        ax.annotate(text, xy=anchor, xytext=tuple(offset), textcoords="offset pixels",
                    ha="center", va="center", fontproperties=prop, zorder=6,
                    bbox=dict(boxstyle=f"round,pad={pad / 7.0:.2f}", fc="white", ec=color,
                              lw=0.8, alpha=0.9),
                    arrowprops=dict(arrowstyle="-", color=color, lw=0.7, shrinkA=0, shrinkB=0))


def _along(line: np.ndarray, fraction: float) -> tuple[np.ndarray | None, np.ndarray]:
    """The point at ``fraction`` of a polyline's length and the unit direction there."""
    seg = np.hypot(*np.diff(line, axis=0).T)
    if len(seg) == 0 or seg.sum() <= 0.0:
        return None, np.zeros(2)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    target = fraction * s[-1]
    k = int(np.clip(np.searchsorted(s, target) - 1, 0, len(seg) - 1))
    while seg[k] <= 0.0 and k > 0:
        k -= 1
    t = (target - s[k]) / seg[k] if seg[k] > 0.0 else 0.0
    return line[k] + t * (line[k + 1] - line[k]), (line[k + 1] - line[k]) / max(seg[k], 1e-12)


def _overlap(a, b) -> float:
    """Area shared by two boxes (x0, y0, x1, y1) [px²]."""
    w = min(a[2], b[2]) - max(a[0], b[0])
    h = min(a[3], b[3]) - max(a[1], b[1])
    return w * h if w > 0.0 and h > 0.0 else 0.0
