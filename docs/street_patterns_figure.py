"""Draw docs/street-patterns.png: every named street pattern grown for 15 years on the same map.

    python docs/street_patterns_figure.py

Two straight major roads cross at the origin (100 m pieces, a 50 m river east
of the centre with the road's bridge). Each year the 40 best-ranked candidates
(003 §3.3.2) grow with the pattern; grey: grown streets, black: major roads,
red: bridges.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import shapely  # noqa: E402

from osm_expand.engine.growth.nuclei import candidate_points, find_nuclei, rank_candidates  # noqa: E402
from synth.patterns import PATTERNS, grow_streets  # noqa: E402
from synth.street_graph import StreetGraph  # noqa: E402

OUT = Path(__file__).resolve().parent / "street-patterns.png"


def crossroads():
    xs = np.arange(-1000, 1001, 100.0)
    n, mid = len(xs), len(xs) // 2
    xy = np.concatenate([np.stack([xs, 0 * xs], 1), np.stack([0 * xs, xs], 1)])
    e1 = np.stack([np.arange(n - 1), np.arange(1, n)], 1)
    e2 = np.stack([np.arange(n, 2 * n - 1), np.arange(n + 1, 2 * n)], 1)
    e2[e2 == n + mid] = mid
    return xy, np.concatenate([e1, e2])


def main() -> None:
    xy, edges = crossroads()
    water = shapely.box(350, -1200, 400, 1200)
    fig, axes = plt.subplots(2, 4, figsize=(20, 10))
    for ax, name in zip(axes.ravel(), PATTERNS):
        options = PATTERNS[name]
        g = StreetGraph.from_segments(xy, edges, major=np.ones(len(edges), bool))
        g.bridge[:] = shapely.intersects(water, shapely.linestrings(xy[edges]))
        nuclei = find_nuclei(xy, edges, bounds=(-1000, -1000, 1000, 1000))
        rng = np.random.default_rng(3)
        failed = np.zeros((0, 2))
        for year in range(15):
            z = candidate_points(g, spawned_mask=g.spawned, ell=20.0, max_degree=options.max_degree,
                                 temporary_points=options.segment_starts, segment_mask=~g.bridge,
                                 exclude_points=failed)
            step = grow_streets(g, z.take(rank_candidates(z.xy, nuclei, take=40)), options=options, rng=rng,
                                water=water, centre=nuclei[0].xy, time=float(year))
            failed = np.concatenate([failed, step.failed_xy])
        ax.add_patch(plt.Rectangle((350, -1200), 50, 2400, color="lightblue"))
        seg = g.xy[g.edges]
        for k in range(g.n_segments):
            colour = "red" if g.bridge[k] else ("black" if g.major[k] else "grey")
            ax.plot(seg[k, :, 0], seg[k, :, 1], color=colour, lw=1.4 if g.major[k] else 0.7)
        ax.set_title(f"{name}: {g.n_segments - len(edges)} new segments")
        ax.set_aspect("equal")
        ax.set_xlim(-700, 700)
        ax.set_ylim(-700, 700)
        ax.set_xticks([])
        ax.set_yticks([])
    axes.ravel()[-1].axis("off")
    fig.tight_layout()
    fig.savefig(OUT, dpi=55)


if __name__ == "__main__":
    main()
