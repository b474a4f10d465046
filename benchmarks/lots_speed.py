"""Lots and buildings on real towns' blocks: time, lot sizes, footprint median against the town's.

    python benchmarks/lots_speed.py [FILE ...] [--seed N] [--mix]

For each town (default: Krems and Andorra): its blocks (faces of the
simplified network), their frontage from the bounding streets, lots
(:func:`osm_expand.engine.lots.subdivide_blocks`) and buildings
(:func:`osm_expand.engine.footprints.place_buildings`) calibrated from the
town's own footprints. Prints the seconds for lots and for buildings, the
lot-area quartiles per land use against its ``max_area``, and the generated
footprint-area median next to the town's. ``--mix`` gives blocks a mix of
land uses (55 % low-density residential, 20 % high-density, 10 % commercial,
10 % industrial, 5 % park) instead of all low-density residential.
Issue budget: lots and buildings for the default Krems run ≤ 5 s (lots ≤ 2 s).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import shapely

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # this checkout's packages, not an installed copy
TOWNS = [REPO / "fixtures" / "krems.osm.gz", REPO / "fixtures" / "andorra.osm.pbf"]
#: Full street widths (m) by highway class for the frontage (the lead's model will carry widths).
WIDTH = {"motorway": 25.0, "trunk": 20.0, "primary": 14.0, "secondary": 12.0, "tertiary": 10.0}
MIX = (("residential_low", 0.55), ("residential_high", 0.20), ("commercial", 0.10),
       ("industrial", 0.10), ("park", 0.05))


def town(path: Path):
    """Blocks, street lines, ids, widths, traffic and the existing footprints of a town.

    The one place that touches the ingest/simplify/blocks APIs, which may change shape.
    """
    from osm_expand.blocks import blocks
    from osm_expand.highways import rank
    from osm_expand.ingest import load
    from simplify import simplify

    raw = load(path)
    net = simplify(raw).network
    lines = [shapely.LineString(net.street_xy(s)) for s in net.streets]
    widths = np.array([s.width or WIDTH.get(s.highway.removesuffix("_link"), 8.0) for s in net.streets])
    traffic = np.array([10.0 - rank(s.highway) for s in net.streets])  # stand-in: more important, more traffic
    footprints = [b.ring for b in raw.context.buildings]
    return blocks(net), lines, np.arange(len(lines)), widths, traffic, footprints


def run(path: Path, seed: int, mix: bool) -> None:
    from osm_expand.engine.footprints import calibrate_sizes, calibrated_lot_options, place_buildings
    from osm_expand.engine.lots import block_frontage, subdivide_blocks

    bl, lines, ids, widths, traffic, footprints = town(path)
    rng = np.random.default_rng(seed)
    names, weights = zip(*MIX)
    uses = list(rng.choice(names, size=len(bl), p=weights)) if mix else ["residential_low"] * len(bl)
    sizes = calibrate_sizes(footprints, street_lines=lines)
    options = calibrated_lot_options(sizes)

    t0 = time.perf_counter()
    frontage = block_frontage(bl, lines, ids, widths)
    t1 = time.perf_counter()
    lots = subdivide_blocks(bl, frontage, uses, options=options, rng=rng)
    t2 = time.perf_counter()
    buildings = place_buildings(lots, traffic_per_street=traffic, built_streets=np.ones(len(ids), bool),
                                rng=rng, sizes=sizes)
    t3 = time.perf_counter()

    print(f"{path.name}: {len(bl)} blocks, {len(lots)} lots, {len(buildings)} buildings")
    print(f"  seconds: frontage {t1 - t0:.2f}, lots {t2 - t1:.2f}, buildings {t3 - t2:.2f}, "
          f"total {t3 - t0:.2f}")
    area = np.array([lot.area for lot in lots])
    use = np.array([lot.land_use for lot in lots])
    for name in names:
        a = area[use == name]
        if len(a):
            q = np.percentile(a, [25, 50, 75])
            print(f"  lots {name:17s} n={len(a):5d} quartiles {q[0]:7.0f} {q[1]:7.0f} {q[2]:7.0f} m²"
                  f"  (min_area {options[name].min_area:.0f}, max_area {options[name].max_area:.0f})")
    gen = np.array([b.rectangle.area for b in buildings])
    own = sizes.quartiles(0)
    if len(gen):
        q = np.percentile(gen, [25, 50, 75])
        print(f"  footprint area quartiles: generated {q[0]:.0f} {q[1]:.0f} {q[2]:.0f} m², "
              f"town's own ({sizes.count}) {own[0]:.0f} {own[1]:.0f} {own[2]:.0f} m²; "
              f"median off by {100 * (q[1] / own[1] - 1):+.1f} %")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="*", type=Path, default=TOWNS)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--mix", action="store_true", help="a mix of land uses instead of all low-density residential")
    args = ap.parse_args()
    for path in args.files:
        run(path, args.seed, args.mix)


if __name__ == "__main__":
    main()
