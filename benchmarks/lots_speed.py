"""Lots and buildings on real towns' blocks: time, lot sizes, footprint median against the town's.

    python benchmarks/lots_speed.py [FILE ...] [--seed N] [--mix]

For each town (default: Krems and Andorra, 73 + 171 blocks): its blocks
(faces of the simplified network), their frontage from the bounding streets
and from the town's streets as mapped that run into blocks, lots
(:func:`osm_expand.engine.buildout.lots.subdivide_blocks`) and buildings
(:func:`osm_expand.engine.buildout.footprints.place_buildings`) calibrated from the
town's own footprints. Prints the seconds for lots and for buildings, the
lot-area quartiles per land use against its ``max_area``, and the generated
footprint-area median next to the town's, and counts of what must not
happen (lots outside blocks, buildings overlapping, streets through
buildings, …; all 0). ``--mix`` gives blocks a mix of
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
    """Blocks, street lines, ids, widths, traffic, the existing footprints and the streets as mapped.

    The one place that touches the ingest/simplify/blocks APIs, which may change shape.
    """
    from osm_expand.blocks import blocks
    from osm_expand.ingest import load
    from osm_expand.model.highways import rank
    from simplify import simplify

    city = load(path)
    raw = city.network
    net = simplify(raw).network
    lines = [shapely.LineString(net.street_xy(s)) for s in net.streets]
    widths = np.array([s.width or WIDTH.get(s.highway.removesuffix("_link"), 8.0) for s in net.streets])
    traffic = np.array([10.0 - rank(s.highway) for s in net.streets])  # stand-in: more important, more traffic
    footprints = [b.ring for b in city.buildings]
    raw_lines = [shapely.LineString(raw.street_xy(s)) for s in raw.streets]
    return [b.polygon for b in blocks(net)], lines, np.arange(len(lines)), widths, traffic, footprints, raw_lines


def run(path: Path, seed: int, mix: bool) -> None:
    from osm_expand.engine.buildout.footprint_sizes import calibrate_sizes, calibrated_lot_options
    from osm_expand.engine.buildout.footprints import place_buildings
    from osm_expand.engine.buildout.lots import block_frontage, subdivide_blocks

    bl, lines, ids, widths, traffic, footprints, raw_lines = town(path)
    rng = np.random.default_rng(seed)
    names, weights = zip(*MIX)
    uses = list(rng.choice(names, size=len(bl), p=weights)) if mix else ["residential_low"] * len(bl)
    sizes = calibrate_sizes(footprints, street_lines=lines)
    options = calibrated_lot_options(sizes)

    t0, c0 = time.perf_counter(), time.process_time()
    # bounding streets from the simplified network, streets inside blocks from the town as mapped
    frontage = block_frontage(bl, lines + raw_lines, np.arange(len(lines) + len(raw_lines)),
                              np.concatenate([widths, np.full(len(raw_lines), 6.0)]))
    t1, c1 = time.perf_counter(), time.process_time()
    lots = subdivide_blocks(bl, frontage, uses, options=options, rng=rng)
    t2, c2 = time.perf_counter(), time.process_time()
    traffic = np.concatenate([traffic, np.zeros(len(raw_lines))])
    buildings = place_buildings(lots, traffic_per_street=traffic, built_streets=np.ones(len(traffic), bool),
                                rng=rng, sizes=sizes)
    t3, c3 = time.perf_counter(), time.process_time()

    print(f"{path.name}: {len(bl)} blocks, {len(lots)} lots, {len(buildings)} buildings")
    print(f"  seconds (wall / cpu): frontage {t1 - t0:.2f} / {c1 - c0:.2f}, lots {t2 - t1:.2f} / {c2 - c1:.2f}, "
          f"buildings {t3 - t2:.2f} / {c3 - c2:.2f}, total {t3 - t0:.2f} / {c3 - c0:.2f}")
    print("  checks:", invariants(bl, lots, buildings, lines, raw_lines))
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


def invariants(bl, lots, buildings, lines, raw_lines) -> dict[str, int]:
    """Counts of what the referee and the issue forbid; all 0 except perhaps the last.

    ``raw_streets_through_buildings`` counts buildings crossed by the town's
    streets as mapped (dead ends and loops that simplification removed run
    into blocks); the pipeline passes those lines as ``obstacles``.
    """
    polys = [b.rectangle.polygon for b in buildings]
    out = {"lots_outside_block": sum(not bl[lot.block].buffer(1e-6).covers(lot.polygon) for lot in lots),
           "lots_without_street": sum(not len(lot.streets) for lot in lots),
           "buildings_outside_lot": sum(not lots[b.lot].polygon.buffer(1e-6).covers(p)
                                        for b, p in zip(buildings, polys))}
    worst = 0.0
    for b in buildings:
        sides = np.roll(b.rectangle.corners, -1, axis=0) - b.rectangle.corners
        unit = sides / np.hypot(sides[:, 0], sides[:, 1])[:, None]
        worst = max(worst, float(np.abs((unit * np.roll(unit, -1, axis=0)).sum(axis=1)).max()))
    out["buildings_not_rectangular"] = int(worst > 0.02)
    if polys:
        tree = shapely.STRtree(polys)
        i, j = tree.query(polys, predicate="intersects")
        out["overlapping_buildings"] = int(sum(polys[a].intersection(polys[b]).area > 0.5
                                               for a, b in zip(i.tolist(), j.tolist()) if a < b))
        out["streets_through_buildings"] = len(np.unique(tree.query(lines, predicate="intersects")[1]))
        out["raw_streets_through_buildings"] = len(np.unique(tree.query(raw_lines, predicate="intersects")[1]))
    return out


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
