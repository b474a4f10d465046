"""The README's gallery: for each town, a real part of it beside its grown district, at the same scale.

    python docs/make_gallery.py            # writes docs/gallery-<town>.png

The real part shown is the typical one (off on the median number of
measures among the real parts the district is judged against); under each
panel, the verdict of the fidelity score (:mod:`osm_expand.fidelity`).
"""
from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import shapely  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402

from osm_expand.ingest import load  # noqa: E402
from osm_expand.model import Origin  # noqa: E402
from osm_expand.pipeline import ExpandOptions, expand  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
TOWNS = {"krems.osm.gz": "Krems", "andorra.osm.pbf": "Andorra", "north-bayreuth.osm.gz": "north of Bayreuth",
         "campo-grande.osm.gz": "Campo Grande"}


def draw(name: str, title: str, seed: int = 0) -> Path:
    city = load(REPO / "fixtures" / name)
    result = expand(city, ExpandOptions(seed=seed))
    report = result.fidelity
    net = result.city.network
    town = [net.street_xy(s) for s in net.streets if s.origin == Origin.SOURCE]
    new = [net.street_xy(net.streets[k]) for k in result.city.new_streets()]
    k = int(np.argsort(report.part_off, kind="stable")[len(report.part_off) // 2])
    part = report.reference.windows[k]
    radius = float(np.sqrt(part.area / np.pi)) * 1.1
    window = result.growth.footprint
    fig, axes = plt.subplots(1, 2, figsize=(12, 6.4))
    for ax, centre, lines, colour, shape, caption in (
            (axes[0], np.asarray(part.centroid.coords[0]), town, "0.25", part,
             f"a real neighbourhood of {title}: off on {report.part_off[k]} of {len(report.verdicts)} measures"),
            (axes[1], np.asarray(window.centroid.coords[0]), new, "tab:red", window,
             f"the grown district: off on {report.off} of {len(report.verdicts)} (a typical real neighbourhood: "
             f"{report.typical_off:g})")):
        ax.add_collection(LineCollection(town, colors="0.75", linewidths=0.6))
        ax.add_collection(LineCollection(lines, colors=colour, linewidths=1.0))
        for poly in shapely.get_parts(shape):
            ax.plot(*poly.exterior.xy, color="black", lw=0.6, ls="--")
        ax.set_xlim(centre[0] - radius, centre[0] + radius)
        ax.set_ylim(centre[1] - radius, centre[1] + radius)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_xlabel(caption, fontsize=10)
    bar = 10 ** np.floor(np.log10(radius / 2))
    x0, y0 = axes[0].get_xlim()[0], axes[0].get_ylim()[0]
    axes[0].plot([x0 + 0.05 * radius, x0 + 0.05 * radius + bar], [y0 + 0.05 * radius] * 2, color="black", lw=3)
    axes[0].text(x0 + 0.05 * radius, y0 + 0.09 * radius, f"{bar:,.0f} m")
    fig.suptitle(f"{title} (seed {seed}): same scale; "
                 f"{'believable' if report.believable else 'not as alike as a real part'}, "
                 f"street density {'in' if report.density_ok else 'out of'} range", fontsize=11)
    fig.text(0.5, 0.01, "Map data © OpenStreetMap contributors (ODbL)", ha="center", fontsize=7)
    out = REPO / "docs" / f"gallery-{name.split('.')[0]}.png"
    fig.savefig(out, dpi=80, bbox_inches="tight", metadata={"Software": None})
    plt.close(fig)
    return out


if __name__ == "__main__":
    for name in sys.argv[1:] or TOWNS:
        print(draw(name, TOWNS.get(name, name)))
