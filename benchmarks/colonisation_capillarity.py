"""Capillarity and right angles of space colonisation, measured (seed 001 §5.3, figs. 96-97; issue 12).

    python benchmarks/colonisation_capillarity.py [--seeds 0 1 2 3 4] [--skip-phase2] [--skip-grid]

The numbers behind ``tests/test_colonisation.py``'s ``test_capillarity_*`` and
``test_a_right_angled_first_phase_*``, with the same set-ups, over more seeds:

* **phase 1** (001 fig. 96): §5.3's parameters (SL 1 → 10 m here, a
  100 × 100 SL square, RoI 5 SL, 2,500 APs per phase = 0.25 per SL², N = 1,
  hierarchy thresholds 1 %/1 %, 90° turns), one old street along the south
  edge, phase 1 only, KD 2, 3, 4 SL;
* **phase 2** (001 fig. 97): phase 1 at KD 3 SL, then phase 2 with N = 4 at
  KD 1.0, 1.5, 2.0 SL;
* **dead-end share**: dead ends / (dead ends + junctions of degree ≥ 3)
  among the grown graph's nodes; **street density**: grown length in SL per
  SL² of the square;
* **right angles** (phase 1 only at 90°, SL 100 m, 3 × 3 km, default
  options otherwise): junctions of degree ≥ 3 of the whole network (grown
  segments plus the old street's pieces at a grown node on it). A junction
  is right-angled when every angle between consecutive segments around it is
  within 10° of 90° *or of 180°* — a T junction's straight-through street
  makes 180°, and no node of degree 3 can have three angles of 90°. The
  strict share (every angle within 10° of 90°, only possible at degree 4) is
  printed too.

Means ± standard deviations over the seeds; the tests assert that the share
rises and the density falls with KD, and that ≥ 80 % of junctions are
right-angled.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import shapely

from synth.colonisation import ColonisationOptions, colonise


def capillarity(kd1: float, kd2: float, seed: int, second_phase: bool) -> tuple[float, float, int]:
    """§5.3's set-up: (dead-end share, street length per SL², grown edges) of one run."""
    sl = 10.0
    opts = ColonisationOptions(segment_length=sl, radius_of_influence=5.0, kill_distance=(kd1, kd2),
                               nodes_per_ap=(1, 4), ap_density=(0.25, 0.25), angle_range_1=(90.0, 90.0),
                               angle_range_2=(90.0, 90.0), hierarchy_threshold=(0.01, 0.01),
                               second_phase=second_phase)
    region = shapely.box(0, 0, 100 * sl, 100 * sl)
    res = colonise(region, seeds=[np.array([[0.0, 0.0], [100 * sl, 0.0]])], forbidden=None, options=opts,
                   rng=np.random.default_rng(seed))
    deg = np.bincount(res.edges.ravel(), minlength=len(res.xy))
    ends, junctions = int((deg == 1).sum()), int((deg >= 3).sum())
    length = np.hypot(*(res.xy[res.edges[:, 0]] - res.xy[res.edges[:, 1]]).T).sum() / sl
    return ends / max(ends + junctions, 1), float(length) / 100 ** 2, len(res.edges)


def right_angles(seed: int) -> tuple[int, int, int, dict[int, int]]:
    """(junctions of degree >= 3, right-angled ones, strictly right-angled ones, count by degree)."""
    sl = 100.0
    opts = ColonisationOptions(segment_length=sl, angle_range_1=(90.0, 90.0), second_phase=False)
    region = shapely.box(0, 0, 30 * sl, 30 * sl)
    street = np.array([[0.0, 0.0], [30 * sl, 0.0]])
    res = colonise(region, seeds=[street], forbidden=None, options=opts, rng=np.random.default_rng(seed))
    xy, edges = res.xy, res.edges
    nbrs: dict[int, list[np.ndarray]] = {}
    for u, v in edges.tolist():
        nbrs.setdefault(u, []).append(xy[v] - xy[u])
        nbrs.setdefault(v, []).append(xy[u] - xy[v])
    for j in res.joins:  # the old street continues both ways through a join inside it
        for end in street:
            if abs(j.xy[0] - end[0]) > 1e-6:
                nbrs.setdefault(j.node, []).append(np.subtract(end, j.xy))
    total = good = strict = 0
    by_degree: dict[int, int] = {}
    for d in nbrs.values():
        if len(d) < 3:
            continue
        ang = np.sort(np.mod(np.degrees(np.arctan2([v[1] for v in d], [v[0] for v in d])), 360.0))
        gaps = np.diff(np.append(ang, ang[0] + 360.0))
        off = np.minimum(np.abs(gaps - 90.0), np.abs(gaps - 180.0))
        total += 1
        good += bool((off <= 10.0).all())
        strict += bool((np.abs(gaps - 90.0) <= 10.0).all())
        by_degree[len(d)] = by_degree.get(len(d), 0) + 1
    return total, good, strict, by_degree


def summary(values: list[float]) -> str:
    a = np.asarray(values)
    return f"{a.mean():.3f} ± {a.std(ddof=1) if len(a) > 1 else 0.0:.3f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4])
    ap.add_argument("--skip-phase2", action="store_true")
    ap.add_argument("--skip-grid", action="store_true")
    args = ap.parse_args()
    t0 = time.perf_counter()
    blocks = [("phase 1 only (fig. 96)", [(kd, 0.0, False) for kd in (2.0, 3.0, 4.0)])]
    if not args.skip_phase2:
        blocks.append(("phase 1 at KD 3, phase 2 (fig. 97)", [(3.0, kd, True) for kd in (1.0, 1.5, 2.0)]))
    for title, runs in blocks:
        print(f"\n{title}, seeds {' '.join(map(str, args.seeds))}")
        print("| KD phase 1 | KD phase 2 | dead-end share | street density (SL/SL²) | grown segments | per seed "
              "(share/density) |")
        print("|---|---|---|---|---|---|")
        for kd1, kd2, second in runs:
            rows = [capillarity(kd1, kd2, s, second) for s in args.seeds]
            per = ", ".join(f"{r[0]:.2f}/{r[1]:.3f}" for r in rows)
            print(f"| {kd1:g} | {kd2:g} | {summary([r[0] for r in rows])} | {summary([r[1] for r in rows])} "
                  f"| {np.mean([r[2] for r in rows]):.0f} | {per} |", flush=True)
    if not args.skip_grid:
        print(f"\nright angles, phase 1 only at 90°, seeds {' '.join(map(str, args.seeds))}")
        print("| seed | junctions (deg ≥ 3) | by degree | right-angled (90° or straight) | strictly 90° |")
        print("|---|---|---|---|---|")
        tot = good = strict = 0
        for s in args.seeds:
            t, g, st, deg = right_angles(s)
            tot, good, strict = tot + t, good + g, strict + st
            print(f"| {s} | {t} | {dict(sorted(deg.items()))} | {g} ({g / max(t, 1):.1%}) "
                  f"| {st} ({st / max(t, 1):.1%}) |", flush=True)
        print(f"| all | {tot} | | {good} ({good / max(tot, 1):.1%}) | {strict} ({strict / max(tot, 1):.1%}) |")
    print(f"\n{time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
