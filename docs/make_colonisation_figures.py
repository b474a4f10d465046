"""Draw the README's pictures of space colonisation's effects (seed 001; needs matplotlib).

    python docs/make_colonisation_figures.py [--out docs]

Five PNGs, one per effect the thesis shows: a grid at 90° (001 fig. 74c,
§5.3), organic streets at 30–45° (fig. 74b), a source leaving a park empty
(§5.2, fig. 95), a vortex making rings (§5.4.2, fig. 102b) and a boulevard
along a coast (§5.5.2, fig. 109). Streets are coloured by hierarchy (red
primary, orange secondary, grey tertiary), the old street is black, flow
fields are drawn as light arrows. Units are metres, SL = 100 m.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import shapely  # noqa: E402

from synth.colonisation import ColonisationOptions, ColonisationResult, colonise  # noqa: E402
from synth.flowfield import FlowField, FlowPrimitive, flow_field  # noqa: E402

SL = 100.0
COLOURS = ("#d7191c", "#f29e2e", "#6e6e6e")
WIDTHS = (2.6, 1.8, 1.0)


def draw(ax: plt.Axes, res: ColonisationResult, seeds: list[np.ndarray], region: shapely.Geometry, title: str, *,
         water: shapely.Geometry | None = None, flow: FlowField | None = None, arrows: int = 3,
         mark: shapely.Geometry | None = None) -> None:
    """One panel: region outline, water, flow arrows, the old streets and the grown streets by level."""
    x, y = region.exterior.xy
    ax.fill(x, y, color="#f7f4ee", zorder=0)
    ax.plot(x, y, color="0.7", lw=0.8, zorder=1)
    if water is not None:
        for poly in getattr(water, "geoms", [water]):
            wx, wy = poly.exterior.xy
            ax.fill(wx, wy, color="#a6cee3", zorder=1)
    if mark is not None:
        mx, my = mark.exterior.xy
        ax.fill(mx, my, color="#b8dca0", zorder=1)
    if flow is not None:
        ny, nx = flow.vectors.shape[:2]
        c = flow.centres().reshape(ny, nx, 2)[::arrows, ::arrows].reshape(-1, 2)
        v = flow.vectors[::arrows, ::arrows].reshape(-1, 2)
        speed = np.hypot(*v.T)
        u = np.where(speed[:, None] > 0, v / np.maximum(speed, 1e-300)[:, None], 0.0)
        ax.quiver(c[:, 0], c[:, 1], u[:, 0], u[:, 1], color="#9bb7d4", scale=40, width=0.0025, zorder=2)
    for line in seeds:
        ax.plot(*np.asarray(line).T, color="black", lw=3.2, solid_capstyle="round", zorder=5)
    for level in (2, 1, 0):
        for s in res.streets:
            if s.level == level:
                ax.plot(*s.xy.T, color=COLOURS[level], lw=WIDTHS[level], solid_capstyle="round", zorder=4 - level / 3)
    ax.set_title(title, fontsize=10)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    x0, y0, x1, y1 = region.bounds
    ax.plot([x0, x0 + 500], [y0 - 120, y0 - 120], color="black", lw=3)
    ax.text(x0, y0 - 90, "500 m", fontsize=8, va="bottom")
    ax.set_xlim(x0 - 150, x1 + 150)
    ax.set_ylim(y0 - 200, y1 + 150)


def save(fig: plt.Figure, path: Path) -> None:
    handles = [plt.Line2D([], [], color=c, lw=w) for c, w in zip(COLOURS, WIDTHS)]
    handles.append(plt.Line2D([], [], color="black", lw=3))
    fig.legend(handles, ["primary", "secondary", "tertiary", "old street"], loc="lower center", ncol=4,
               frameon=False, fontsize=9)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    fig.savefig(path, dpi=80, bbox_inches="tight", pad_inches=0.1)  # the titles whole
    plt.close(fig)
    print(path)


def grid(out: Path) -> None:
    """90° in both phases (001 §5.3's grid), from an old street along the south edge."""
    region = shapely.box(0, 0, 3000, 2400)
    street = np.array([[-200.0, 0.0], [3200.0, 0.0]])
    fig, axes = plt.subplots(1, 2, figsize=(13, 6))
    for ax, second, title in ((axes[0], False, "phase 1: 90°, or straight ahead"),
                              (axes[1], True, "+ phase 2, also at 90°")):
        opts = ColonisationOptions(segment_length=SL, second_phase=second, angle_range_2=(90.0, 90.0))
        res = colonise(region, seeds=[street], forbidden=None, options=opts, rng=np.random.default_rng(2))
        draw(ax, res, [street], region, title)
    save(fig, out / "colonisation-grid.png")


def organic(out: Path) -> None:
    """No angle restriction against [30°, 45°] with the straight-ahead tolerance [0°, 7.5°] (001 fig. 74a-b)."""
    region = shapely.box(0, 0, 3000, 3000)
    street = np.array([[1400.0, 0.0], [1600.0, 0.0]])
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.6))
    for ax, angles, title in ((axes[0], (0.0, 180.0), "no angle restriction"),
                              (axes[1], (30.0, 45.0), "[30°, 45°], tolerance [0°, 7.5°]")):
        opts = ColonisationOptions(segment_length=SL, angle_range_1=angles, angle_range_2=angles,
                                   ap_density=(0.5, 0.5), kill_distance=(2.0, 0.0), seed_spacing=1.0)
        res = colonise(region, seeds=[street], forbidden=None, options=opts, rng=np.random.default_rng(4))
        draw(ax, res, [street], region, title)
    save(fig, out / "colonisation-organic.png")


def source_park(out: Path) -> None:
    """A source in a northward flow: no road can grow towards it, so a park stays empty (001 §5.2).

    Roads follow the flow or its perpendicular, never against it, so they stay
    on equipotentials φ = U y + a/(2π) ln r or move to higher ones: the closed
    equipotential through the stagnation point (drawn green) bounds the park.
    Segments are one SL long and take the flow at their far end, so a few cut
    into its edge and its southern tip: the metres of street inside it are
    printed for both panels.
    """
    region = shapely.box(0, 0, 3000, 3000)
    street = np.array([[-200.0, 0.0], [3200.0, 0.0]])
    centre, strength, speed = (1500.0, 2000.0), 8000.0, 1.0
    prims = [FlowPrimitive("uniform", strength=speed, direction_deg=90.0),
             FlowPrimitive("source", *centre, strength=strength)]
    flow = flow_field(prims, bounds=region.bounds, cell=50.0)
    plain = flow_field(prims[:1], bounds=region.bounds, cell=50.0)
    gx, gy = np.meshgrid(np.linspace(0, 3000, 301), np.linspace(0, 3000, 301))
    phi = speed * gy + strength / (2 * np.pi) * np.log(np.maximum(np.hypot(gx - centre[0], gy - centre[1]), 1e-6))
    stagnation = (centre[0], centre[1] - strength / (2 * np.pi * speed))
    level = speed * stagnation[1] + strength / (2 * np.pi) * np.log(centre[1] - stagnation[1])

    def in_park(xy: np.ndarray) -> np.ndarray:
        """Inside the closed equipotential through the stagnation point (north of it, φ below its level)."""
        r = np.maximum(np.hypot(xy[:, 0] - centre[0], xy[:, 1] - centre[1]), 1e-6)
        return (xy[:, 1] > stagnation[1]) & (speed * xy[:, 1] + strength / (2 * np.pi) * np.log(r) < level)

    fig, axes = plt.subplots(1, 2, figsize=(13, 6.6))
    for ax, field, title in ((axes[0], plain, "uniform flow northward (100 %)"),
                             (axes[1], flow, "+ a source: the park (green) stays almost empty")):
        opts = ColonisationOptions(segment_length=SL)
        res = colonise(region, seeds=[street], forbidden=None, options=opts, rng=np.random.default_rng(1),
                       flow=field)
        draw(ax, res, [street], region, title, flow=field, arrows=4)
        pts = np.concatenate([_every_metre(s.xy) for s in res.streets])
        print(f"  {title}: {in_park(pts).sum()} m of {len(pts)} m of street inside the park")
        if field is flow:
            closed = np.where(gy > stagnation[1], phi, np.inf)  # the egg, not the open field south of it
            ax.contourf(gx, gy, closed, levels=[phi.min() - 1.0, level], colors=["#b8dca0"], zorder=1)
            ax.plot(*centre, marker="*", color="#2b8a3e", ms=12, zorder=6)
    save(fig, out / "colonisation-source-park.png")


def _every_metre(xy: np.ndarray) -> np.ndarray:
    """Points one metre apart along a polyline (metres), its first point included."""
    line = shapely.LineString(xy)
    return shapely.get_coordinates(shapely.line_interpolate_point(line, np.arange(0.0, line.length, 1.0)))


def vortex_rings(out: Path) -> None:
    """A counter-clockwise vortex: roads follow the flow (rings) or cross it (radial roads) (001 §5.4.2)."""
    region = shapely.Point(1500.0, 1500.0).buffer(1500.0, quad_segs=32)
    street = np.array([[1500.0, -50.0], [1500.0, 1350.0]])
    flow = flow_field([FlowPrimitive("vortex", 1500.0, 1500.0, strength=1.0)], bounds=region.bounds, cell=50.0)
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.6))
    for ax, second, title in ((axes[0], False, "phase 1 in a vortex (100 %)"),
                              (axes[1], True, "+ phase 2: rings and radial roads")):
        opts = ColonisationOptions(segment_length=SL, angle_range_1=(0.0, 180.0), angle_range_2=(0.0, 180.0),
                                   second_phase=second, seed_spacing=1.0)
        res = colonise(region, seeds=[street], forbidden=None, options=opts, rng=np.random.default_rng(3), flow=flow)
        draw(ax, res, [street], region, title, flow=flow, arrows=4)
    save(fig, out / "colonisation-vortex-rings.png")


def coast_boulevard(out: Path) -> None:
    """Sources along the shore point the flow inland; its perpendicular runs along the coast (001 §5.5.2).

    The sources sit every 100 m just offshore, continuing past the map's ends
    so that the row acts as a line: its equipotentials, which roads may
    follow, run parallel to the shore.
    """

    def shore_x(y: np.ndarray) -> np.ndarray:
        return 2300.0 + 350.0 * np.sin(2.2 * np.pi * y / 3000.0 + 0.4)

    ys = np.linspace(0.0, 3000.0, 61)
    sea = shapely.Polygon(np.vstack([np.column_stack([shore_x(ys), ys]), [[3200.0, 3000.0], [3200.0, 0.0]]]))
    region = shapely.box(0, 0, 3200, 3000)
    land = region.difference(sea)
    street = np.array([[300.0, 0.0], [float(shore_x(np.array([0.0]))[0]) - 60.0, 0.0]])
    along = np.arange(-2000.0, 5000.0, 100.0)
    sources = [FlowPrimitive("source", float(x) + 120.0, float(y), strength=100.0)
               for x, y in zip(shore_x(along), along)]
    flow = flow_field(sources, bounds=region.bounds, cell=50.0, core=100.0)
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.6))
    for ax, field, title in ((axes[0], None, "no flow field: a grid that ignores the coast"),
                             (axes[1], flow, "sources along the shore: a boulevard follows it")):
        opts = ColonisationOptions(segment_length=SL)
        res = colonise(land, seeds=[street], forbidden=sea, options=opts, rng=np.random.default_rng(5), flow=field)
        draw(ax, res, [street], region, title, water=sea, flow=field, arrows=4)
    save(fig, out / "colonisation-coast-boulevard.png")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent), help="folder for the PNGs")
    parser.add_argument("--only", default="", help="comma-separated subset: grid,organic,source,vortex,coast")
    args = parser.parse_args()
    out = Path(args.out)
    figures = {"grid": grid, "organic": organic, "source": source_park, "vortex": vortex_rings,
               "coast": coast_boulevard}
    for name, make in figures.items():
        if not args.only or name in args.only.split(","):
            make(out)


if __name__ == "__main__":
    main()
