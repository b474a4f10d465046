"""How fast the street-pattern kernel grows a year's streets in a 3,000-segment town.

    python benchmarks/patterns_speed.py [--pattern organic] [--steps 20] [--take 100] [--json]

The town is a 40 × 40 perturbed grid (80 m blocks, ±10 m jitter, 15 % of the
streets removed so that blocks of several sizes leave room to grow): about
2,650 segments. Every fifth row and column is a major road; its junctions are
the nuclei (003 §3.3.2). Each step is one engine year's minor-road growth:
candidates Z (``candidate_points``), the ranking (``rank_candidates``, take
G(t) = ``--take``) and ``grow_streets``, each timed. At the end the graph is
rebuilt from its arrays with ``StreetGraph.from_segments`` and timed too.

Wall and CPU (``process_time``) seconds are shown: on a shared machine the
CPU time is the steadier figure. The budget (issue: a whole year in ≤ 1 s at ~3,000 streets) leaves the minor
streets a small share: ≤ 0.2 s per step for 100 starts.
"""
from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np

from osm_expand.engine.growth.nuclei import candidate_points, find_nuclei, rank_candidates
from synth.patterns import PATTERNS, grow_streets
from synth.street_graph import StreetGraph


def town(n: int = 40, spacing: float = 80.0, jitter: float = 10.0, drop: float = 0.15, seed: int = 0):
    """Node positions, segments and a major-road mask of a perturbed grid."""
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    xy = np.stack([i.ravel(), j.ravel()], 1) * spacing + rng.uniform(-jitter, jitter, (n * n, 2))
    idx = np.arange(n * n).reshape(n, n)
    rows = np.stack([idx[:-1].ravel(), idx[1:].ravel()], 1)          # along x, at fixed j
    cols = np.stack([idx[:, :-1].ravel(), idx[:, 1:].ravel()], 1)    # along y, at fixed i
    edges = np.concatenate([rows, cols])
    major = np.concatenate([(j[:-1].ravel() % 5) == 0, (i[:, :-1].ravel() % 5) == 0])
    keep = major | (rng.random(len(edges)) > drop)
    return xy, edges[keep], major[keep]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pattern", default="organic", choices=sorted(PATTERNS))
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--take", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()

    xy, edges, major = town(seed=args.seed)
    t0 = time.perf_counter()
    g = StreetGraph.from_segments(xy, edges, major=major)
    build_first = time.perf_counter() - t0
    lo, hi = xy.min(0) - 200, xy.max(0) + 200
    bounds = (lo[0], lo[1], hi[0], hi[1])
    nuclei = find_nuclei(xy, edges[major], bounds=bounds)
    options = PATTERNS[args.pattern]
    rng = np.random.default_rng(args.seed)
    failed = np.zeros((0, 2))
    rows = []
    for step in range(args.steps):
        t0 = time.perf_counter()
        z = candidate_points(g, spawned_mask=g.spawned, ell=20.0, max_degree=options.max_degree,
                             temporary_points=options.segment_starts, segment_mask=~g.bridge,
                             exclude_points=failed)
        t1 = time.perf_counter()
        starts = z.take(rank_candidates(z.xy, nuclei, take=args.take))
        t2, c2 = time.perf_counter(), time.process_time()
        result = grow_streets(g, starts, options=options, rng=rng, centre=nuclei[0].xy, time=float(step))
        t3, c3 = time.perf_counter(), time.process_time()
        failed = np.concatenate([failed, result.failed_xy])
        rows.append({"step": step, "segments": g.n_segments, "candidates": len(z), "grown": int(result.grown.sum()),
                     "candidates_s": t1 - t0, "rank_s": t2 - t1, "grow_s": t3 - t2, "grow_cpu_s": c3 - c2,
                     "total_s": t3 - t0})
    t0 = time.perf_counter()
    StreetGraph.from_segments(g.xy, g.edges, created=g.created, bridge=g.bridge, major=g.major)
    build_last = time.perf_counter() - t0
    summary = {
        "pattern": args.pattern, "take": args.take, "steps": args.steps,
        "segments_start": int(len(edges)), "segments_end": g.n_segments,
        "build_start_s": build_first, "build_end_s": build_last,
        "grow_s_median": statistics.median(r["grow_s"] for r in rows),
        "grow_s_max": max(r["grow_s"] for r in rows),
        "grow_cpu_s_median": statistics.median(r["grow_cpu_s"] for r in rows),
        "grow_cpu_s_max": max(r["grow_cpu_s"] for r in rows),
        "step_s_median": statistics.median(r["total_s"] for r in rows),
        "step_s_max": max(r["total_s"] for r in rows),
    }
    if args.json:
        print(json.dumps({"summary": summary, "steps": rows}))
        return
    print(f"{'step':>4} {'segments':>8} {'|Z|':>6} {'grown':>5} {'Z s':>7} {'rank s':>7} {'grow s':>7} "
          f"{'grow cpu':>8} {'total s':>7}")
    for r in rows:
        print(f"{r['step']:>4} {r['segments']:>8} {r['candidates']:>6} {r['grown']:>5} {r['candidates_s']:>7.3f} "
              f"{r['rank_s']:>7.3f} {r['grow_s']:>7.3f} {r['grow_cpu_s']:>8.3f} {r['total_s']:>7.3f}")
    print(f"from_segments: {summary['segments_start']} segments {build_first:.4f} s, "
          f"{summary['segments_end']} segments {build_last:.4f} s")
    print(f"per step (median / max): grow {summary['grow_s_median']:.3f} / {summary['grow_s_max']:.3f} s "
          f"(CPU {summary['grow_cpu_s_median']:.3f} / {summary['grow_cpu_s_max']:.3f} s), "
          f"all {summary['step_s_median']:.3f} / {summary['step_s_max']:.3f} s")


if __name__ == "__main__":
    main()
