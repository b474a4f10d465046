"""A town whose houses are not mapped: does the tool still read its streets as occupied? (issue 20)

Much of OpenStreetMap has streets but no buildings. This takes the buildings
out of a town's file (in memory: the town is read, then its buildings are
dropped, so the tool sees exactly what it would see in such a file), grows
it with default options (a district and the default history's 30 years),
and counts against the withheld buildings — the ground truth:

- generated buildings standing on a real one (footprints that intersect),
  as a share of the generated buildings (issue 20: at most 1 %);
- real buildings a new street (district, joins or engine) crosses (at most 2).

The same run with the buildings in the file is printed beside it.

``--works`` reads works' enclosures as settlement (``osm_expand.land.WORKS``) and ``--dead-end-open DEG``
takes the land past dead ends' tips but for DEG either side of straight on (``LandOptions.dead_end_open_deg``):
the two land readings measured for issue 20, off by default.

Usage: ``python benchmarks/withheld_buildings.py [--seed 0] [--years N] [--history H] [--works]
[--dead-end-open DEG] [--option NAME=VALUE ...] [TOWN ...]`` (``--option``: a ``GrowthOptions`` field, as
``benchmarks/engine_growth.py`` reads it)
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import shapely

REPO = Path(__file__).resolve().parent.parent
TOWNS = ["north-bayreuth.osm.gz", "krems.osm.gz"]


def count(city, real: np.ndarray) -> dict:
    """Generated buildings on a real one, and real buildings crossed by new streets."""
    from osm_expand.model import Origin

    tree = shapely.STRtree(real)
    generated = np.array([b.polygon for b in city.buildings if b.origin != Origin.SOURCE], dtype=object)
    on_real = np.unique(tree.query(generated, predicate="intersects")[0]) if len(generated) else np.zeros(0)
    net = city.network
    lines = net.street_lines()
    new = np.array([s.is_new for s in net.streets], dtype=bool)
    street, hit = tree.query(lines[new], predicate="intersects") if new.any() else (np.zeros(0, int),) * 2
    origin = np.array([s.origin.value for s in net.streets], dtype=object)[new]
    by = {o: len(np.unique(hit[origin[street] == o])) for o in sorted(set(origin[street].tolist()))}
    return {"generated": len(generated), "on_real": len(on_real),
            "share": len(on_real) / len(generated) if len(generated) else 0.0,
            "new_streets": int(new.sum()), "real_crossed": len(np.unique(hit)), "crossed_by": by}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("towns", nargs="*", default=TOWNS)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--years", type=int, default=None, help="default: the history's own (30)")
    ap.add_argument("--history", default="example", help="a bundled history or a TOML file (default: example)")
    ap.add_argument("--works", action="store_true", help="works' enclosures are settlement (land.WORKS)")
    ap.add_argument("--dead-end-open", type=float, default=None, metavar="DEG",
                    help="land past dead ends' tips taken but for DEG either side of straight on")
    from engine_growth import growth_option  # this directory: the one reader of --option NAME=VALUE

    ap.add_argument("--option", type=growth_option, action="append", default=[], metavar="NAME=VALUE",
                    help="a GrowthOptions field for the engine's years, e.g. district_town_reach=1.5 (repeatable)")
    args = ap.parse_args()
    from osm_expand.engine.growth.minor_streets import GrowthOptions
    from osm_expand.engine.history import load_history
    from osm_expand.engine.loop import EngineOptions
    from osm_expand.ingest import load
    from osm_expand.land import SETTLEMENT, WORKS, LandOptions
    from osm_expand.maturation import MatureOptions, mature_result
    from osm_expand.pipeline import ExpandOptions, expand

    land = LandOptions(settlement=SETTLEMENT + (WORKS if args.works else ()), dead_end_open_deg=args.dead_end_open)
    print("| town | buildings in the file | generated | on a real building | share | new streets "
          "| real buildings crossed | CPU s |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.towns:
        city = load(REPO / "fixtures" / name)
        real = np.array([b.polygon for b in city.buildings], dtype=object)
        for label, town in (("withheld", city.replace(buildings=())), ("mapped", city)):
            t0 = time.process_time()
            grown = mature_result(expand(town, ExpandOptions(seed=args.seed, fidelity=False, land=land)),
                                  load_history(args.history),
                                  MatureOptions(years=args.years, fidelity=False,
                                                engine=EngineOptions(growth=GrowthOptions(**dict(args.option)))),
                                  args.seed).city
            c = count(grown, real)
            print(f"| {name} | {label} | {c['generated']} | {c['on_real']} | {100 * c['share']:.1f} % "
                  f"| {c['new_streets']} | {c['real_crossed']} {c['crossed_by'] or ''} | {time.process_time() - t0:.1f} |",
                  flush=True)


if __name__ == "__main__":
    main()
