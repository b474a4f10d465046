"""Is the whole town in every output? The city-model checks, measured on the fixtures.

For each town: run ``osm-expand CITY`` (in-process, seed 0) into all three
formats and report, from the files alone and against the input read with
osmium directly:

- drivable ways of the input whose id is in the OSM output (split ways count once);
- buildings of the input (ways and multipolygons) whose id is in the OSM output;
- buildings of the input with a ``origin="source"`` building in the XML;
- joins to the town; nodes outside the written ``<bounds>``;
- objects without an origin in each format;
- the referee's ``urban`` verdict on the XML, when ``--referee PATH`` is given.

Usage: ``python benchmarks/whole_town.py [--referee ../shared/tools/referee.py] [TOWN ...]``
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import osmium
from lxml import etree

REPO = Path(__file__).resolve().parent.parent
TOWNS = ["krems.osm.gz", "monaco.osm.gz", "andorra.osm.pbf", "north-bayreuth.osm.gz", "campo-grande.osm.gz"]
#: the small fixtures grow only with a larger area than their default (and outside their tiny bounds)
SMALL = {"West-Oakland.osm.bz2": 200_000.0, "berlin-siegessaeule.osm.gz": 150_000.0}
ORIGIN_KEY = "osm_expand:origin"


def reference(path: Path) -> tuple[set[int], set[tuple[str, int]]]:
    from osm_expand.model.highways import DRIVABLE

    ways, buildings = set(), set()
    for obj in osmium.FileProcessor(str(path), osmium.osm.WAY | osmium.osm.RELATION):
        tags = obj.tags
        if obj.is_way() and tags.get("highway") in DRIVABLE and tags.get("area") != "yes":
            ways.add(obj.id)
        if tags.get("building", "no") != "no" and (obj.is_way() or tags.get("type") == "multipolygon"):
            buildings.add(("way" if obj.is_way() else "relation", obj.id))
    return ways, buildings


def check(name: str, out: Path, referee: str | None) -> dict:
    from osm_expand.export import write_geojson, write_osm, write_urbanenvironment
    from osm_expand.ingest import load
    from osm_expand.pipeline import ExpandOptions, expand

    path = REPO / "fixtures" / name
    t0 = time.perf_counter()
    result = expand(load(path), ExpandOptions(seed=0, area=SMALL.get(name), beyond_bounds=name in SMALL))
    seconds = time.perf_counter() - t0
    write_osm(result.city, out / "t.osm")
    write_urbanenvironment(result.city, out / "t.xml")
    write_geojson(result.city, out / "t.geojson")
    ways, buildings = reference(path)
    seen_ways, seen_rels, untagged, outside = set(), set(), 0, 0
    root = etree.parse(str(out / "t.osm")).getroot()
    b = root.find("bounds")
    lon0, lat0, lon1, lat1 = (float(b.get(k)) for k in ("minlon", "minlat", "maxlon", "maxlat"))
    for node in root.iter("node"):
        lon, lat = float(node.get("lon")), float(node.get("lat"))
        outside += not (lon0 <= lon <= lon1 and lat0 <= lat <= lat1)
    for el in root.iter("way", "relation"):
        tags = {t.get("k"): t.get("v") for t in el.iter("tag")}
        (seen_ways if el.tag == "way" else seen_rels).add(int(el.get("id")))
        untagged += bool(tags) and ORIGIN_KEY not in tags
    kept = {("way", i) for i in seen_ways} | {("relation", i) for i in seen_rels}
    xml = etree.parse(str(out / "t.xml")).getroot()
    xml_source = {int(el.get("osm_id")) for el in xml.iter("building") if el.get("origin") == "source"}
    doc = json.loads((out / "t.geojson").read_text())
    row = {
        "town": name, "seconds": round(seconds, 1),
        "ways kept": f"{len(ways & seen_ways)}/{len(ways)}",
        "buildings kept (osm)": f"{len(buildings & kept)}/{len(buildings)}",
        "buildings in xml": f"{len({i for _, i in buildings} & xml_source)}/{len(buildings)}",
        "joins": result.joins.joins, "grown streets": result.report["grown_streets"],
        "nodes outside bounds": outside,
        "no origin (osm/xml/geojson)": f"{untagged}/{sum(1 for el in xml.iter('street', 'building') if not el.get('origin'))}"
                                       f"/{sum(1 for f in doc['features'] if 'origin' not in f['properties'])}",
    }
    if referee:
        verdict = json.loads(subprocess.run([sys.executable, referee, "urban", str(out / "t.xml")],
                                            capture_output=True, text=True).stdout)
        row["referee urban"] = verdict["violations"]
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("towns", nargs="*", default=TOWNS + list(SMALL))
    ap.add_argument("--referee", help="path to the referee script, to judge the XML too")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.towns:
            rows.append(check(name, Path(tmp), args.referee))
            print(json.dumps(rows[-1]), file=sys.stderr)
    keys = list(rows[0])
    print("| " + " | ".join(keys) + " |")
    print("|" + "---|" * len(keys))
    for row in rows:
        print("| " + " | ".join(str(row.get(k, "")) for k in keys) + " |")


if __name__ == "__main__":
    main()
