"""How the random walk's time grows with the number of junctions.

    python benchmarks/walk_scaling.py [FILE] [--repeat N]

The example's junction cloud is tiled 1x, 2x and 4x side by side (copies far
enough apart not to interact), the walk is timed on each, and the ratio of
successive times is printed: a walk that grows no faster than n log n shows
ratios near 2 (and at most 2.5) when the junction count doubles.
"""
from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

from osm_expand.ingest import load
from simplify import simplify
from simplify.example import build_example
from synth.reproduce import cloud_from_example
from synth.walk import NodeCloud, random_walk

REPO = Path(__file__).resolve().parent.parent


def tiled(cloud: NodeCloud, copies: int) -> NodeCloud:
    span = cloud.xy.max(axis=0) - cloud.xy.min(axis=0)
    step = float(span[0]) * 1.5 + 1000.0
    out = cloud
    for k in range(1, copies):
        out = out.stacked(replace(cloud, xy=cloud.xy + [k * step, 0.0]))
    return out


def best_time(cloud: NodeCloud, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        random_walk(cloud, seed=0)
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("file", nargs="?", default=str(REPO / "fixtures" / "north-bayreuth.osm.gz"))
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    result = simplify(load(args.file, context=False))
    base = cloud_from_example(build_example(result.network, result.dead_ends))
    print(f"{Path(args.file).name}: {len(base)} junctions per tile, best of {args.repeat}")
    print(f"{'tiles':>5} {'junctions':>10} {'seconds':>8} {'x time':>7}")
    previous = None
    for copies in (1, 2, 4):
        cloud = tiled(base, copies)
        seconds = best_time(cloud, args.repeat)
        ratio = "" if previous is None else f"{seconds / previous:7.2f}"
        print(f"{copies:>5} {len(cloud):>10} {seconds:8.3f} {ratio}")
        previous = seconds


if __name__ == "__main__":
    main()
