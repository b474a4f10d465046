"""A map of the city (PNG or SVG): the town as mapped in grey, what the tool made in colour.

Water in blue, the town's buildings and streets in greys, the new streets
coloured by hierarchy (Gravelius level), joining streets in black, the site
outline dashed, a scale bar. The same city gives the same bytes: the SVG's
element ids are salted with a constant, and no dates are written.
"""
from __future__ import annotations

import os

import numpy as np
import shapely

from osm_expand.export.atomic import atomic_write
from osm_expand.model import City, Origin


def write_preview(city: City, path: str | os.PathLike, site_region: shapely.Geometry | None = None,
                  title: str = "") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection, PolyCollection

    net = city.network
    with plt.rc_context({"svg.hashsalt": "osm-expand", "path.simplify": True}):
        pts = net.xy[net.used_nodes()]
        if site_region is not None:
            pts = np.vstack([pts, np.asarray(site_region.exterior.coords)])
        (x0, y0), (x1, y1) = pts.min(axis=0), pts.max(axis=0)
        aspect = (y1 - y0) / max(x1 - x0, 1.0)
        fig, ax = plt.subplots(figsize=(10, float(np.clip(10 * aspect, 4, 14)) + 0.6))
        water = [np.asarray(p.exterior.coords) for g in (*city.water, *city.sea)
                 for p in getattr(g, "geoms", [g]) if p.geom_type == "Polygon"]
        ax.add_collection(PolyCollection(water, facecolors="#b9d7ea", edgecolors="none"))
        ax.add_collection(PolyCollection([b.ring for b in city.buildings if b.origin == Origin.SOURCE],
                                         facecolors="0.78", edgecolors="none"))
        new_buildings = [b.ring for b in city.buildings if b.origin != Origin.SOURCE]
        if new_buildings:
            ax.add_collection(PolyCollection(new_buildings, facecolors="#e8a33d", edgecolors="none"))
        old = [net.street_xy(s) for s in net.streets if s.origin == Origin.SOURCE]
        ax.add_collection(LineCollection(old, colors="0.45", linewidths=0.7))
        grown = [s for s in net.streets if s.origin in (Origin.GROWN, Origin.ENGINE)]
        if grown:
            from matplotlib.colors import BoundaryNorm

            levels = np.array([max(s.hierarchy, 0) for s in grown])
            top = int(levels.max())
            norm = BoundaryNorm(np.arange(-0.5, top + 1.5), plt.get_cmap("plasma_r").N)
            lc = LineCollection([net.street_xy(s) for s in grown], cmap="plasma_r", norm=norm, linewidths=1.4)
            lc.set_array(levels.astype(float))
            ax.add_collection(lc)
            bar = fig.colorbar(lc, ax=ax, shrink=0.5, label="new streets: hierarchy (Gravelius level)")
            bar.set_ticks(range(0, top + 1, max(1, (top + 1) // 8)))
        joins = [net.street_xy(s) for s in net.streets if s.origin == Origin.JOIN]
        if joins:
            ax.add_collection(LineCollection(joins, colors="black", linewidths=1.6))
        if site_region is not None:
            ax.plot(*site_region.exterior.xy, ls="--", color="black", lw=0.8)
        pad = 0.05 * max(x1 - x0, y1 - y0)
        ax.set_xlim(x0 - pad, x1 + pad)
        ax.set_ylim(y0 - pad, y1 + pad)
        ax.set_aspect("equal")
        _scale_bar(ax)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(title)
        ax.set_xlabel("Map data © OpenStreetMap contributors (ODbL): the town in grey; "
                      "new streets by osm-expand in colour, joining streets in black", fontsize=8)
        suffix = str(path).lower().rsplit(".", 1)[-1]
        with atomic_write(path, "wb") as fh:
            fig.savefig(fh, format="svg" if suffix == "svg" else "png", dpi=110, bbox_inches="tight",
                        metadata={"Software": None} if suffix == "png" else {"Date": None})
        plt.close(fig)


def _scale_bar(ax) -> None:
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    length = 10 ** np.floor(np.log10((x1 - x0) / 4))
    ax.plot([x0 + 0.05 * (x1 - x0), x0 + 0.05 * (x1 - x0) + length], [y0 + 0.04 * (y1 - y0)] * 2, color="black", lw=3)
    ax.text(x0 + 0.05 * (x1 - x0), y0 + 0.06 * (y1 - y0), f"{length:,.0f} m")
