"""How space colonisation's growth time grows with the number of attraction points.

    python benchmarks/colonisation_scaling.py [--points 2500,10000,40000] [--repeat N] [--density D]

The points per phase are scattered at a constant density (``--density`` per
SL², default the kernel's), so the square region grows with the point count
and all-pairs code would show: each ×4 in points should cost at most ×5 in
time (about ×4 for linear work, a little more for n log n). The region is a
square of side sqrt(points / density) segment lengths with one old street
along its southern edge; both phases run with the default options (SL 100 m).
Wall-clock seconds (the best of ``--repeat`` runs; each run uses seed 0, 1, …)
and the same run's CPU seconds of this process, which a shared machine
disturbs less, are printed with their ratios to the previous size.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import shapely

from synth.colonisation import ColonisationOptions, colonise


def run(points: int, density: float, seed: int) -> tuple[float, float, int]:
    """Wall and CPU seconds of one :func:`colonise` call, and the number of grown segments."""
    opts = ColonisationOptions(ap_density=(density, density))
    side = float(np.sqrt(points / density)) * opts.segment_length
    region = shapely.box(0.0, 0.0, side, side)
    street = np.array([[0.0, 0.0], [side, 0.0]])
    start, cpu = time.perf_counter(), time.process_time()
    res = colonise(region, seeds=[street], forbidden=None, options=opts, rng=np.random.default_rng(seed))
    return time.perf_counter() - start, time.process_time() - cpu, len(res.edges)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", default="2500,10000,40000", help="APs per phase, comma-separated")
    parser.add_argument("--repeat", type=int, default=1, help="runs per size; the best time counts")
    parser.add_argument("--density", type=float, default=ColonisationOptions().ap_density[0],
                        help="APs per SL² (default: the kernel's)")
    args = parser.parse_args()
    sizes = [int(v) for v in args.points.split(",")]
    print(f"space colonisation, {args.density:g} APs per SL² per phase, best of {args.repeat}")
    print(f"{'APs/phase':>10} {'side (SL)':>10} {'segments':>9} {'seconds':>8} {'x time':>7} {'CPU s':>8} {'x CPU':>6}")
    previous = None
    for n in sizes:
        best, cpu, edges = min(run(n, args.density, seed) for seed in range(args.repeat))
        ratio = "" if previous is None else f"{best / previous[0]:7.2f} {cpu:8.2f} {cpu / previous[1]:6.2f}"
        if previous is None:
            ratio = f"{'':7} {cpu:8.2f}"
        print(f"{n:>10} {np.sqrt(n / args.density):>10.0f} {edges:>9} {best:8.2f} {ratio}", flush=True)
        previous = (best, cpu)


if __name__ == "__main__":
    main()
