"""How much does a grown district look like its town? The fidelity verdict over towns and seeds.

For each town and seed: ``osm-expand CITY`` in-process with default options
(the town is learned once per town), and the district judged against real
parts of the town (:mod:`osm_expand.fidelity`). Prints, per town, the mean
number of measures the district is off on, the seeds whose street density is
out of range, how often each measure is off, and the full table (value,
range) for the first seed; and the time of the score against the whole run.

Usage: ``python benchmarks/district_fidelity.py [--seeds 0 1 2 3 4] [--pattern example] [TOWN ...]``
"""
from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
TOWNS = ["krems.osm.gz", "andorra.osm.pbf", "north-bayreuth.osm.gz", "campo-grande.osm.gz", "monaco.osm.gz"]


def run(name: str, seeds: list[int], pattern: str, overrides: dict) -> list[dict]:
    from osm_expand.ingest import load
    from osm_expand.pipeline import ExpandOptions, expand, learn
    from synth.patches import ExamplePatches, PatchOptions

    city = load(REPO / "fixtures" / name)
    grower = ExamplePatches(learn(city).example, PatchOptions(**overrides)) if overrides else None
    rows = []
    for seed in seeds:
        t0 = time.perf_counter()
        result = expand(city, ExpandOptions(seed=seed, pattern=pattern, years=0), pattern=grower)
        total = time.perf_counter() - t0
        f = result.report["fidelity"]
        rows.append({"seed": seed, "off": f["off"], "density_ok": f["density_ok"], "typical": f["typical_part_off"],
                     "measures": f["measures"], "streets": result.report["grown_streets"], "seconds": total,
                     "joins": result.report["connections"]})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("towns", nargs="*", default=TOWNS)
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4])
    ap.add_argument("--pattern", default="example")
    ap.add_argument("--table", action="store_true", help="print every measure of the first seed")
    ap.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                    help="a PatchOptions field for the example pattern (for tuning), e.g. cells=3")
    args = ap.parse_args()
    overrides = {k: json.loads(v) for k, v in (o.split("=", 1) for o in args.option)}
    print("| town | off per seed | mean off | typical real part | density out | often off | streets | joins | s/run |")
    print("|---|---|---|---|---|---|---|---|---|")
    tables = {}
    for name in args.towns:
        rows = run(name, args.seeds, args.pattern, overrides)
        off = [r["off"] for r in rows]
        often = Counter(k for r in rows for k, v in r["measures"].items() if not v["ok"])
        print(f"| {name} | {' '.join(map(str, off))} | {np.mean(off):.1f} | {rows[0]['typical']:g} "
              f"| {sum(not r['density_ok'] for r in rows)} | "
              f"{', '.join(f'{k} {v}' for k, v in often.most_common(4))} | "
              f"{np.mean([r['streets'] for r in rows]):.0f} | {np.mean([r['joins'] for r in rows]):.0f} "
              f"| {np.mean([r['seconds'] for r in rows]):.1f} |", flush=True)
        tables[name] = rows[0]["measures"]
    if args.table:
        for name, measures in tables.items():
            print(f"\n{name}, seed {args.seeds[0]}:\n\n| measure | district | range | ok |\n|---|---|---|---|")
            for k, v in measures.items():
                low = "" if v["kind"] == "distribution" else f"{v['low']} – "
                print(f"| {k} | {v['value']} | {low}{v['high']} | {'yes' if v['ok'] else 'no'} |")


if __name__ == "__main__":
    main()
