"""A map of the expanded town (PNG or SVG): water, the old town in grey, the new district
coloured by hierarchy, the site outline and a scale bar."""
from __future__ import annotations

import os

import numpy as np

from osm_expand.export.atomic import atomic_write
from osm_expand.model import StreetNetwork


def write_preview(net: StreetNetwork, origins: list[str], path: str | os.PathLike, site_region=None,
                  title: str = "") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    pts = net.xy[net.used_nodes()]
    if site_region is not None:
        pts = np.vstack([pts, np.asarray(site_region.exterior.coords)])
    (x0, y0), (x1, y1) = pts.min(axis=0), pts.max(axis=0)
    aspect = (y1 - y0) / max(x1 - x0, 1.0)
    fig, ax = plt.subplots(figsize=(10, float(np.clip(10 * aspect, 4, 14)) + 0.6))
    for geom in [*net.context.water, *net.context.sea]:
        for poly in getattr(geom, "geoms", [geom]):
            if poly.geom_type == "Polygon":
                ax.fill(*poly.exterior.xy, color="#b9d7ea", lw=0)
    old = [net.street_xy(s) for s, o in zip(net.streets, origins) if o == "source"]
    ax.add_collection(LineCollection(old, colors="0.55", linewidths=0.8))
    new = [(s.hierarchy, net.street_xy(s)) for s, o in zip(net.streets, origins) if o == "grown"]
    if new:
        levels = np.array([lv for lv, _ in new], dtype=float)
        lc = LineCollection([pts for _, pts in new], cmap="plasma_r", linewidths=1.4)
        lc.set_array(levels)
        ax.add_collection(lc)
        fig.colorbar(lc, ax=ax, shrink=0.5, label="hierarchy (Gravelius level)")
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
    ax.set_xlabel("Map data © OpenStreetMap contributors (ODbL); grown streets by osm-expand", fontsize=8)
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
