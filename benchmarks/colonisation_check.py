"""Check a colonisation run's output file: referee, joins, forbidden ground, buildings in its blocks (issue 12).

    osm-expand TOWN --pattern colonisation -o OUT.xml --json > OUT.json
    python benchmarks/colonisation_check.py TOWN OUT.xml OUT.json

Everything is read from the files the CLI wrote (the ``<urbanenvironment>``
XML and the ``--json`` report) plus the town itself, so the check is
independent of the code that grew the district:

* **referee**: ``/work/shared/tools/referee.py urban OUT.xml`` (violations must be 0);
* **joins**: the report's joins (``joins.at``, ``connections``), and,
  recounted from the XML, the distinct points where a colonisation street
  (``origin="grown"``) or a join street of the growth year meets a street of
  the town as mapped (``origin="source"``) within 1 cm;
* **forbidden ground**: the colonisation streets (and the growth year's join
  streets) against the town read again with :func:`osm_expand.ingest.load`
  and :func:`osm_expand.pipeline.prepare` (default land rules, as the CLI
  without ``--unbuildable``): metres inside water or sea, inside unbuildable
  land (mapped areas, and the town's buildings with their margin), inside the town's blocks shrunk by 1 m (:attr:`City.occupied`'s
  rule: streets may run along a block's edge), and metres within 1 m of a
  never-joined road (motorway, motorway_link, trunk_link) on the ground;
* **the district's blocks**: blocks (``<block>``) whose boundary runs at
  least ``--shared`` metres (default 10) along colonisation streets; their
  lots (``<lot block=...>``) and the buildings the engine placed on those
  lots (``<building origin="engine" lot=...>``);
* **fidelity**: the report's verdict (``off`` measures out of 13, the median
  real part's count, density in range, the measures that are off).

Prints one JSON object; ``--markdown`` also prints a table row.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import shapely
from lxml import etree

REFEREE = Path("/work/shared/tools/referee.py")
#: Never-joined classes (:class:`synth.colonisation_pattern.ColonisationPatternOptions.never_joined`).
NEVER_JOINED = ("motorway", "motorway_link", "trunk_link")
#: A street point this close to a town street is on it (m).
ON_STREET = 0.01


def read_xml(path: Path) -> dict:
    """Streets (lines with attributes), blocks, lots and buildings of an ``<urbanenvironment>`` file."""
    root = etree.parse(str(path), etree.XMLParser(huge_tree=True)).getroot()
    streets = []
    for st in root.iterfind("streets/street"):
        segs = np.array([[float(sg.get(k)) for k in ("x1", "y1", "x2", "y2")] for sg in st.iterfind("segment")])
        streets.append({**dict(st.attrib), "segments": segs.reshape(-1, 2, 2)})

    def ring(el) -> np.ndarray:
        return np.array([[float(n.get("x")), float(n.get("y"))] for n in el.iterfind("node")])

    blocks = {int(b.get("id")): {**dict(b.attrib), "ring": ring(b)} for b in root.iterfind("blocks/block")}
    lots = {int(lt.get("id")): {**dict(lt.attrib), "ring": ring(lt)} for lt in root.iterfind("lots/lot")}
    buildings = [{**dict(b.attrib), "ring": ring(b)} for b in root.iterfind("buildings/building")]
    return {"lon0": float(root.get("lon0")), "lat0": float(root.get("lat0")), "streets": streets, "blocks": blocks,
            "lots": lots, "buildings": buildings}


def lines_of(streets: list[dict]) -> shapely.Geometry:
    """All segments of ``streets`` as one MultiLineString."""
    segs = [s["segments"] for s in streets if len(s["segments"])]
    if not segs:
        return shapely.MultiLineString()
    return shapely.multilinestrings(shapely.linestrings(np.concatenate(segs)))


def referee(path: Path) -> dict:
    out = subprocess.run([sys.executable, str(REFEREE), "urban", str(path)], capture_output=True, text=True)
    report = json.loads(out.stdout) if out.stdout.strip() else {"stderr": out.stderr[-500:]}
    report["exit"] = out.returncode
    return report


def joins_in_xml(grown: list[dict], source: list[dict]) -> int:
    """Distinct points (rounded to 1 cm) where a grown street's vertex lies on a town street."""
    town = shapely.linestrings(np.concatenate([s["segments"] for s in source]))
    tree = shapely.STRtree(town)
    pts = np.unique(np.round(np.concatenate([s["segments"].reshape(-1, 2) for s in grown]), 2), axis=0)
    hit = tree.query(shapely.points(pts), predicate="dwithin", distance=ON_STREET)[0]
    return int(len(np.unique(hit)))


def crossings_of(mine: list[dict], streets: list[dict]) -> int:
    """Segments of ``mine`` that meet a segment of another street (or a non-adjacent one of the same
    street) anywhere but at an end point of both, on the same layer (the referee's rule, for these only)."""
    segs, owner, layer = [], [], []
    for k, s in enumerate(streets):
        for seg in s["segments"]:
            segs.append(seg)
            owner.append(k)
            layer.append((s.get("layer", "0"), s.get("bridge", "no"), s.get("tunnel", "no")))
    segs_a = np.asarray(segs)
    lines = shapely.linestrings(segs_a)
    tree = shapely.STRtree(lines)
    ids = {id(s) for s in mine}
    chosen = np.array([id(streets[o]) in ids for o in owner])
    a, b = tree.query(lines[chosen], predicate="intersects")
    a = np.flatnonzero(chosen)[a]
    bad = 0
    for i, j in zip(a.tolist(), b.tolist()):
        if i == j or (chosen[j] and j < i) or layer[i] != layer[j]:
            continue
        ends_i, ends_j = segs_a[i], segs_a[j]
        pts = shapely.get_coordinates(shapely.intersection(lines[i], lines[j]))
        ok = all(np.hypot(*(ends_i - p).T).min() < 1e-3 and np.hypot(*(ends_j - p).T).min() < 1e-3 for p in pts)
        bad += not ok
    return bad


def forbidden_metres(new: shapely.Geometry, town_path: Path, lon0: float, lat0: float) -> dict:
    """Metres of ``new`` inside water, unbuildable land, the town's blocks, and near never-joined roads."""
    from osm_expand.ingest import load
    from osm_expand.model import Origin
    from osm_expand.pipeline import prepare

    city = prepare(load(town_path))
    proj = city.projection
    if abs(proj.lon0 - lon0) > 1e-9 or abs(proj.lat0 - lat0) > 1e-9:
        raise SystemExit(f"projection differs: town {proj.lon0},{proj.lat0} vs XML {lon0},{lat0}")
    net = city.network
    water = city.water_geometry()
    unbuild = city.unbuildable if city.unbuildable is not None else shapely.Polygon()
    blocks = shapely.union_all(shapely.buffer(np.array([b.polygon for b in city.blocks], dtype=object), -1.0))
    barred = [shapely.LineString(net.street_xy(s)) for s in net.streets
              if s.origin == Origin.SOURCE and s.highway in NEVER_JOINED and s.layer_key == (0, False, False)]
    roads = shapely.buffer(shapely.union_all(barred), 1.0) if barred else shapely.Polygon()
    return {name: round(float(shapely.length(shapely.intersection(new, geom))), 2)
            for name, geom in (("water_m", water), ("unbuildable_m", unbuild), ("town_blocks_m", blocks),
                               ("never_joined_roads_m", roads))}


def district_blocks(data: dict, grown: shapely.Geometry, shared: float) -> list[int]:
    """Ids of the blocks whose boundary runs at least ``shared`` metres along the grown streets."""
    ids = sorted(data["blocks"])
    if not ids:
        return []
    rings = np.array([shapely.LineString(np.vstack([data["blocks"][i]["ring"], data["blocks"][i]["ring"][:1]]))
                      for i in ids], dtype=object)
    along = shapely.length(shapely.intersection(rings, shapely.buffer(grown, 0.5)))
    return [i for i, a in zip(ids, along.tolist()) if a >= shared]


def check(town: Path, xml: Path, rep: dict, *, shared: float = 10.0) -> dict:
    """The checks of the module docstring for one run: the town, its output XML, and its report (``--json``)."""
    data = read_xml(xml)
    streets = data["streets"]
    source = [s for s in streets if s.get("origin") == "source"]
    grown = [s for s in streets if s.get("origin") == "grown"]
    first = min((int(s["year"]) for s in grown if s.get("year")), default=None)
    links = [s for s in streets if s.get("origin") == "join" and s.get("year") and int(s["year"]) == first
             and not s.get("era")]
    new = lines_of(grown + links)
    ref = referee(xml)
    mine = district_blocks(data, lines_of(grown), shared)
    mine_set = set(mine)
    lots = [k for k, lt in data["lots"].items() if int(lt["block"]) in mine_set]
    lot_set = set(lots)
    built = [b for b in data["buildings"] if b.get("origin") == "engine" and b.get("lot")
             and int(b["lot"]) in lot_set]
    f = rep.get("fidelity", {})
    eng = rep.get("engine", {})
    return {
        "town": town.name, "seed": rep.get("seed"), "years": eng.get("years", 0),
        "referee_violations": ref.get("violations"), "referee_exit": ref["exit"],
        "referee_counts": ref.get("counts"),
        "grown_crossings": crossings_of(grown + links, streets), "grown_streets": len(grown), "grown_km": round(float(shapely.length(lines_of(grown))) / 1000, 2),
        "join_streets": len(links), "joins_report": len(rep.get("joins", {}).get("at", [])),
        "connections_report": rep.get("connections"), "joins_xml": joins_in_xml(grown + links, source),
        **forbidden_metres(new, town, data["lon0"], data["lat0"]),
        "district_blocks": len(mine), "district_blocks_grown_origin": sum(
            1 for i in mine if data["blocks"][i].get("origin") == "grown"),
        "district_lots": len(lots), "district_buildings": len(built),
        "engine_buildings_total": sum(1 for b in data["buildings"] if b.get("origin") == "engine"),
        "fidelity_off": f.get("off"), "fidelity_median_part_off": f.get("typical_part_off"),
        "believable": f.get("believable"), "density_ok": f.get("density_ok"),
        "off_measures": sorted(k for k, v in f.get("measures", {}).items() if not v.get("ok")),
        "district": f.get("district"), "spacing_m": rep.get("spacing_m"), "site_rank": rep.get("site_rank"),
        "district_area_m2": rep.get("district_area_m2"),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("town", type=Path, help="the input town (fixtures/krems.osm.gz, ...)")
    ap.add_argument("xml", type=Path, help="the urbanenvironment file osm-expand wrote")
    ap.add_argument("report", type=Path, help="the --json report osm-expand printed")
    ap.add_argument("--shared", type=float, default=10.0,
                    help="metres of a block's boundary along colonisation streets that make it the district's")
    ap.add_argument("--markdown", action="store_true", help="also print a table row")
    args = ap.parse_args()
    row = check(args.town, args.xml, json.loads(args.report.read_text()), shared=args.shared)
    print(json.dumps(row))
    if args.markdown:
        print(TABLE_HEAD)
        print(markdown_row(row))


#: Columns of :func:`markdown_row`.
TABLE_HEAD = ("| town | years | referee violations | colonisation streets (km) | crossings | joins (report/XML) "
              "| m in water / unbuildable / town blocks / by motorways | district blocks | lots | engine buildings "
              "| fidelity off of 13 (median real part) | density ok | measures off |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|")


def markdown_row(row: dict) -> str:
    """One table row of :func:`check`'s result (columns :data:`TABLE_HEAD`)."""
    return (f"| {row['town']} | {row['years']} | {row['referee_violations']} | {row['grown_streets']} "
            f"({row['grown_km']}) | {row['grown_crossings']} | {row['joins_report']} / {row['joins_xml']} "
            f"| {row['water_m']:g} / {row['unbuildable_m']:g} / {row['town_blocks_m']:g} "
            f"/ {row['never_joined_roads_m']:g} | {row['district_blocks']} | {row['district_lots']} "
            f"| {row['district_buildings']} | {row['fidelity_off']} ({row['fidelity_median_part_off']}) "
            f"| {row['density_ok']} | {', '.join(row['off_measures'])} |")


if __name__ == "__main__":
    main()
