"""How much a grown district looks like its town (issue 3's growth criteria).

    python benchmarks/growth_statistics.py [FILE ...] [--seeds 0,1,2,3,4]

Grows into an empty square the town's size just east of it (the town's water
as obstacles), then prints, as the mean over the seeds: crossings without a
junction, segments in water, the Kolmogorov–Smirnov distance between grown
and source junction spacing and turning angles, and the 3-way / 4-way
junction shares of both. Shares are measured on both sides the same way:
simplified, then as an example (what ``osm-expand stats`` does for a town).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import shapely
from scipy.stats import ks_2samp

from osm_expand.ingest import load
from osm_expand.model import network_from_lines
from simplify import simplify
from simplify.example import build_example
from simplify.invariants import violations
from simplify.statistics import example_statistics
from synth.grow import grow

REPO = Path(__file__).resolve().parent.parent
TOWNS = ["krems.osm.gz", "north-bayreuth.osm.gz", "campo-grande.osm.gz"]


def measure(path: Path, seeds: list[int]) -> dict[str, float]:
    city = load(path)
    result = simplify(city.network)
    source = build_example(result.network, result.dead_ends)
    lo, hi = source.xy.min(axis=0), source.xy.max(axis=0)
    side = float((hi - lo).max())
    region = shapely.box(hi[0] + 200, (lo[1] + hi[1] - side) / 2, hi[0] + 200 + side, (lo[1] + hi[1] + side) / 2)
    water = [*city.water, *city.sea]
    obstacles = shapely.union_all(water) if water else None
    cat = lambda e, a: np.concatenate([getattr(s, a) for s in e.streets])  # noqa: E731
    rows = []
    for seed in seeds:
        start = time.perf_counter()
        grown = grow(source, region, obstacles=obstacles, seed=seed)
        seconds = time.perf_counter() - start
        lines = [[tuple(p) for p in pl] for _, pl in grown.polylines()]
        net = network_from_lines(lines, [{"hierarchy": lv} for lv, _ in grown.polylines()])
        example = build_example(net)
        again = simplify(net)
        stats = example_statistics(build_example(again.network, again.dead_ends))
        wet = 0 if obstacles is None else sum(obstacles.intersects(shapely.LineString(pl)) for pl in lines)
        rows.append([seconds, violations(net)["crossings_without_junction"], wet,
                     ks_2samp(cat(example, "spacing"), cat(source, "spacing")).statistic,
                     ks_2samp(cat(example, "turning"), cat(source, "turning")).statistic,
                     stats["three_way_share"], stats["four_way_share"]])
    mean = np.mean(rows, axis=0)
    town = example_statistics(source)
    return {"grow_s": mean[0], "crossings": mean[1], "in_water": mean[2], "ks_spacing": mean[3],
            "ks_turning": mean[4], "three_way": mean[5], "three_way_town": town["three_way_share"],
            "four_way": mean[6], "four_way_town": town["four_way_share"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="*", default=[str(REPO / "fixtures" / t) for t in TOWNS])
    ap.add_argument("--seeds", default="0,1,2,3,4")
    args = ap.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    print(f"mean over seeds {seeds}")
    print(f"{'town':<24}{'grow s':>8}{'cross':>7}{'water':>7}{'KS sp':>7}{'KS turn':>8}{'3-way':>13}{'4-way':>13}")
    for f in args.files:
        m = measure(Path(f), seeds)
        print(f"{Path(f).name:<24}{m['grow_s']:>8.2f}{m['crossings']:>7.0f}{m['in_water']:>7.0f}"
              f"{m['ks_spacing']:>7.3f}{m['ks_turning']:>8.3f}"
              f"{m['three_way']:>7.2f}/{m['three_way_town']:.2f}{m['four_way']:>7.2f}/{m['four_way_town']:.2f}")


if __name__ == "__main__":
    main()
