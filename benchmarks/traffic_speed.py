"""Seconds per simulated year of the traffic kernels on perturbed grids.

    PYTHONPATH=. python benchmarks/traffic_speed.py [--sizes 1000 3000 10000] [--years 5] [--json]

Each network is a square grid of 100 m blocks with every node moved by
N(0, 10 m), about 1,000, 3,000 and 10,000 segments. Residents are 0–60 per
segment. The first fill samples every segment once (``full=True``); then
each simulated year:

- grows the town: 1 % more segments appended as spurs at the edge (the
  graph is rebuilt, the trip state extended), 3 % of the segments change
  residents;
- re-samples trips (new + changed + the ``sample_rate`` share, at most
  ``max_sources``), then planned → built and widths;
- runs Algorithm 2 for every pair of 8 neighbours (28 pairs, two routes
  each over ~40 segments).

Times are wall-clock seconds for the year's whole traffic part (graph
rebuild included), best and median over the years, and the median CPU
seconds of this process (less sensitive to other jobs on the 2 shared
cores); run it on an idle machine for wall-clock numbers to compare.
"""
from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from osm_expand.engine.traffic.trade import add_route, new_trade_state, segment_capacity, trade_year
from osm_expand.engine.traffic.trips import (
    TripOptions,
    extend_trip_state,
    new_trip_state,
    step_trips,
    trip_graph,
    update_status,
    update_widths,
)


def perturbed_grid(segments: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and edges of an n × n grid with about ``segments`` edges (2n(n−1))."""
    n = int(round((1 + np.sqrt(1 + 2 * segments)) / 2))
    xs, ys = np.meshgrid(np.arange(n) * 100.0, np.arange(n) * 100.0)
    xy = np.c_[xs.ravel(), ys.ravel()] + rng.normal(0.0, 10.0, (n * n, 2))
    idx = np.arange(n * n).reshape(n, n)
    edges = np.r_[np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()], np.c_[idx[:-1, :].ravel(), idx[1:, :].ravel()]]
    return xy, edges


def grow(xy: np.ndarray, edges: np.ndarray, count: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Append ``count`` 80 m spurs from random nodes, pointing away from the grid's centre."""
    base = rng.choice(len(xy), count, replace=False)
    out = xy[base] - xy.mean(axis=0)
    out /= np.maximum(np.hypot(out[:, 0], out[:, 1]), 1e-9)[:, None]
    new_xy = xy[base] + 80.0 * out + rng.normal(0.0, 5.0, (count, 2))
    new_edges = np.c_[base, np.arange(len(xy), len(xy) + count)]
    return np.r_[xy, new_xy], np.r_[edges, new_edges]


def trade_setup(edges: np.ndarray, rng: np.random.Generator):
    """28 pairs of 8 neighbours, two random 40-segment routes each."""
    state = new_trade_state(len(edges))
    pairs = [(u, v) for u in range(8) for v in range(u + 1, 8)]
    for pair in pairs:
        for length in (4000.0, 5000.0):
            state = add_route(state, pair, rng.choice(len(edges), 40, replace=False), length)
    return state, pairs


def run(segments: int, years: int, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    options = TripOptions()
    xy, edges = perturbed_grid(segments, rng)
    e = len(edges)
    residents = rng.uniform(0.0, 60.0, e)
    start = time.perf_counter()
    graph = trip_graph(xy, edges, options=options)
    trips, first = step_trips(new_trip_state(e), graph, residents, rng, full=True, options=options)
    fill = time.perf_counter() - start
    built = np.ones(e, bool)
    built_year = np.zeros(e, np.int64)
    width = np.full(e, 7.5)
    pending = np.full(e, -1, np.int64)
    trade, pairs = trade_setup(edges, rng)
    per_year, cpu_year, trip_times, trade_times, sources = [], [], [], [], []
    for year in range(1, years + 1):
        added = max(1, e // 100)
        xy, edges = grow(xy, edges, added, rng)
        residents = np.r_[residents, rng.uniform(0.0, 60.0, added)]
        changed = rng.random(len(residents)) < 0.03
        residents = np.where(changed, rng.uniform(0.0, 60.0, len(residents)), residents)
        built = np.r_[built, np.zeros(added, bool)]
        built_year = np.r_[built_year, np.zeros(added, np.int64)]
        width = np.r_[width, np.full(added, 7.5)]
        pending = np.r_[pending, np.full(added, -1, np.int64)]
        start, cpu = time.perf_counter(), time.process_time()
        graph = trip_graph(xy, edges, previous=graph, options=options)
        trips = extend_trip_state(trips, len(edges))
        trips, report = step_trips(trips, graph, residents, rng, options=options)
        built, built_year = update_status(built, trips.traffic, built_year, year=year, options=options)
        width, pending = update_widths(width, trips.traffic, built, built_year, pending, year=year, options=options)
        mid = time.perf_counter()
        cap = segment_capacity(width)[: trade.n_segments]
        trade, _, _ = trade_year(trade, pairs, 40.0, cap)
        end = time.perf_counter()
        trip_times.append(mid - start)
        trade_times.append(end - mid)
        per_year.append(end - start)
        cpu_year.append(time.process_time() - cpu)
        sources.append(report.sources)
        e = len(edges)
    return {
        "segments": int(e), "first_fill_s": round(fill, 3), "first_fill_trips": first.trips,
        "year_best_s": round(min(per_year), 3), "year_median_s": round(float(np.median(per_year)), 3),
        "year_cpu_median_s": round(float(np.median(cpu_year)), 3),
        "trips_median_s": round(float(np.median(trip_times)), 3),
        "trade_median_s": round(float(np.median(trade_times)), 4),
        "sources_per_year": int(np.median(sources)),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 3000, 10000])
    parser.add_argument("--years", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", action="store_true", help="one JSON object on stdout")
    args = parser.parse_args(argv)
    rows = [run(size, args.years, args.seed) for size in args.sizes]
    if args.json:
        json.dump({"years": args.years, "results": rows}, sys.stdout)
        print()
        return 0
    print(f"{'segments':>9} {'fill s':>7} {'year best':>10} {'year median':>12} {'year cpu':>9} "
          f"{'trips':>7} {'trade':>7} {'sources':>8}")
    for r in rows:
        print(f"{r['segments']:>9} {r['first_fill_s']:>7.2f} {r['year_best_s']:>10.3f} {r['year_median_s']:>12.3f} "
              f"{r['year_cpu_median_s']:>9.3f} {r['trips_median_s']:>7.3f} {r['trade_median_s']:>7.4f} "
              f"{r['sources_per_year']:>8}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
