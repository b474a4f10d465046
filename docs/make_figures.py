"""Draw the README's before/after picture of a simplified town (needs matplotlib).

    python docs/make_figures.py fixtures/krems.osm.gz docs/krems-simplified.png
"""
from __future__ import annotations

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from osm_expand.ingest import load  # noqa: E402
from simplify import simplify  # noqa: E402
from osm_expand.model.topology import junction_mask  # noqa: E402


def draw(source: str, target: str) -> None:
    raw = load(source, context=False).network
    result = simplify(raw)
    net = result.network
    fig, axes = plt.subplots(1, 2, figsize=(14, 7), sharex=True, sharey=True)
    for s in raw.streets:
        p = raw.street_xy(s)
        axes[0].plot(p[:, 0], p[:, 1], color="0.25", lw=0.6)
    raw_junctions = junction_mask(raw.streets, len(raw.xy))
    axes[0].set_title(f"OSM input: {raw.stats['input_ways']} ways, {len(raw.xy)} street nodes")
    axes[0].plot(*raw.xy[raw_junctions].T, ".", color="0.6", ms=2)
    cmap = plt.get_cmap("tab10")
    for k, s in enumerate(net.streets):
        p = net.street_xy(s)
        axes[1].plot(p[:, 0], p[:, 1], color=cmap(k % 10), lw=1.2)
    j = junction_mask(net.streets, len(net.xy))
    axes[1].plot(*net.xy[j].T, "o", color="black", ms=2.5)
    axes[1].set_title(f"simplified: {result.report['streets']} streets, {result.report['junctions']} junctions")
    for ax in axes:
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
    x0, _, x1, _ = raw.context.bounds_xy
    bar = 500.0
    axes[1].plot([x0 + 100, x0 + 100 + bar], [np.min(raw.xy[:, 1])] * 2, color="black", lw=3)
    axes[1].text(x0 + 100, np.min(raw.xy[:, 1]) + 40, "500 m")
    fig.text(0.5, 0.02, "Map data © OpenStreetMap contributors (ODbL)", ha="center", fontsize=8)
    fig.tight_layout()
    fig.savefig(target, dpi=90)


if __name__ == "__main__":
    draw(sys.argv[1], sys.argv[2])
