"""A picture of the city at one moment of its history, traffic green to red (``--snapshots DIR``).

Seed 000 draws its simulated cities with every street coloured by its
traffic, green for quiet to red for busy; a sequence of these, one per era,
shows where the city grew and where its traffic went. Streets are drawn
thicker when major; the town as mapped and the buildings stay in grey.
"""
from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np

from osm_expand.export.atomic import atomic_write
from osm_expand.model import City, Origin
from osm_expand.model.highways import MAJOR

#: Traffic at or above this percentile of the streets' traffic is drawn fully red.
TOP_PERCENTILE = 95.0


def write_snapshot(city: City, traffic: Mapping[int, float], path: str | os.PathLike, *, title: str = "") -> None:
    """Draw ``city`` with each street coloured by ``traffic`` (people a day, by street id) into a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.colors import Normalize

    net = city.network
    pts = net.xy[net.used_nodes()]
    (x0, y0), (x1, y1) = pts.min(axis=0), pts.max(axis=0)
    aspect = (y1 - y0) / max(x1 - x0, 1.0)
    with plt.rc_context({"path.simplify": True}):
        fig, ax = plt.subplots(figsize=(10, float(np.clip(10 * aspect, 4, 14)) + 0.6))
        water = [np.asarray(p.exterior.coords) for g in (*city.water, *city.sea)
                 for p in getattr(g, "geoms", [g]) if p.geom_type == "Polygon"]
        ax.add_collection(PolyCollection(water, facecolors="#cfe3f0", edgecolors="none"))
        ax.add_collection(PolyCollection([b.ring for b in city.buildings], facecolors="0.82", edgecolors="none"))
        values = np.array([traffic.get(s.id, 0.0) for s in net.streets])
        top = float(np.percentile(values[values > 0], TOP_PERCENTILE)) if (values > 0).any() else 1.0
        major = np.array([s.highway in MAJOR for s in net.streets])
        lines = LineCollection([net.street_xy(s) for s in net.streets], cmap="RdYlGn_r",
                               norm=Normalize(0.0, max(top, 1.0)), linewidths=np.where(major, 2.0, 0.9))
        lines.set_array(values)
        ax.add_collection(lines)
        fig.colorbar(lines, ax=ax, shrink=0.5, label="traffic, people a day")
        new = [net.street_xy(s) for s in net.streets if s.origin != Origin.SOURCE]
        if new:  # a faint outline marks what grew
            ax.add_collection(LineCollection(new, colors="black", linewidths=0.3, alpha=0.4))
        pad = 0.05 * max(x1 - x0, y1 - y0)
        ax.set_xlim(x0 - pad, x1 + pad)
        ax.set_ylim(y0 - pad, y1 + pad)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(title)
        ax.set_xlabel("Map data © OpenStreetMap contributors (ODbL); streets by traffic, green (quiet) to red "
                      "(busy); major roads thicker; new streets outlined", fontsize=8)
        with atomic_write(path, "wb") as fh:
            fig.savefig(fh, format="png", dpi=100, bbox_inches="tight", metadata={"Software": None})
        plt.close(fig)
