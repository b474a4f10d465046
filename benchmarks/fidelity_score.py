"""How long the fidelity score takes, stage by stage, and how real parts of a town score.

    python benchmarks/fidelity_score.py                     # Campo Grande and Krems, best of 3
    python benchmarks/fidelity_score.py fixtures/north-bayreuth.osm.gz --repeat 5 --table
    python benchmarks/fidelity_score.py --json > result.json

The district is the town itself inside a disc of a quarter of the town's
area (its streets' convex hull; ``--share`` changes the quarter), centred on
the street point nearest the middle of the town. Stages, each the best of
``--repeat`` runs:

- town: gather the lines and measure the whole town;
- parts: draw 16 real parts, measure each, KS distances to the town;
- district: measure the district in its window and judge it (the real
  parts judged leave-one-out included).

Reading the file is not timed. ``--table`` also prints, for the first real
part, its value and the range the other fifteen allow on each measure.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import shapely

from osm_expand.fidelity import judge, town_reference
from osm_expand.ingest import load
from osm_expand.measures import LineSet, measure_network

REPO = Path(__file__).resolve().parent.parent
TOWNS = ["campo-grande.osm.gz", "krems.osm.gz"]


def district_window(town: LineSet, share: float) -> shapely.Polygon:
    """A disc of ``share`` of the town's hull area around the street point nearest its middle."""
    area = share * town.hull(0.0).area
    middle = town.coords.mean(axis=0)
    centre = town.coords[np.argmin(np.hypot(*(town.coords - middle).T))]
    return shapely.Point(centre).buffer(np.sqrt(area / np.pi), quad_segs=16)


def run(path: Path, repeat: int, share: float, seed: int) -> dict:
    net = load(path, context=False)
    lines = [net.street_xy(s) for s in net.streets]
    best = {"town": np.inf, "parts": np.inf, "district": np.inf}
    for _ in range(repeat):
        t0 = time.perf_counter()
        town_set = LineSet.from_lines(lines)
        town = measure_network(town_set)
        t1 = time.perf_counter()
        window = district_window(town_set, share)
        ref = town_reference(town_set, float(window.area), parts=16, rng=np.random.default_rng(seed), town=town)
        t2 = time.perf_counter()
        district_lines = [shapely.get_coordinates(g) for g in shapely.get_parts(
            shapely.intersection(town_set.geoms, window)) if g.geom_type == "LineString"]
        t3 = time.perf_counter()  # cutting the district out of the town is not part of the score
        report = judge(measure_network(district_lines, window=window), ref)
        t4 = time.perf_counter()
        for stage, seconds in zip(best, (t1 - t0, t2 - t1, t4 - t3)):
            best[stage] = min(best[stage], seconds)
    return {"file": path.name, "streets": len(lines), "town_km": round(town.length / 1000, 1),
            "district_km2": round(window.area / 1e6, 2),
            "seconds": {k: round(v, 4) for k, v in best.items()} | {"total": round(sum(best.values()), 4)},
            "district_off": report.off, "median_part_off": report.typical_off, "part_off": list(report.part_off),
            "part_table": [v.to_dict() | {"measure": v.measure.value} for v in report.part_verdicts(0)]}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("files", nargs="*", type=Path, default=[REPO / "fixtures" / t for t in TOWNS])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--share", type=float, default=0.25, help="district area as a share of the town's hull")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--table", action="store_true", help="print one real part's values and the others' ranges")
    p.add_argument("--json", action="store_true")
    args = p.parse_args()
    rows = [run(f, args.repeat, args.share, args.seed) for f in args.files]
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    print(f"{'file':24} {'streets':>7} {'km':>7} {'km²':>6} {'town s':>7} {'parts s':>7} {'distr s':>7} "
          f"{'total s':>7} {'off':>4} {'median part off':>15}")
    for r in rows:
        s = r["seconds"]
        print(f"{r['file']:24} {r['streets']:7d} {r['town_km']:7.1f} {r['district_km2']:6.2f} {s['town']:7.3f} "
              f"{s['parts']:7.3f} {s['district']:7.3f} {s['total']:7.3f} {r['district_off']:4d} "
              f"{r['median_part_off']:15.1f}")
    if args.table:
        for r in rows:
            print(f"\n{r['file']}: real part 0 judged against the other 15 (part off counts {r['part_off']})")
            print(f"  {'measure':20} {'value':>9} {'low':>9} {'high':>9}  ok")
            for v in r["part_table"]:
                low = "" if v["kind"] == "distribution" else v["low"]
                ok = "yes" if v["ok"] else "OFF"
                print(f"  {v['measure']:20} {v['value']!s:>9} {low!s:>9} {v['high']!s:>9}  {ok}")


if __name__ == "__main__":
    main()
