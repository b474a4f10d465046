"""Check a finished run's build-out from its files: the issue's "done when" list, one row per run.

    python benchmarks/buildout_check.py OUT.xml [OUT.xml ...] [--json] [--markdown]

Each ``OUT.xml`` is an ``<urbanenvironment>`` written by ``osm-expand ... -o
OUT.xml --json > OUT.json``; the ``--json`` report is read from ``OUT.json``
next to it and the referee's verdict from ``OUT.referee.json`` when it is
there (``referee.py urban OUT.xml > OUT.referee.json``). The geometry is
judged from the XML alone (not the referee, not the engine's own report):

- every generated building (``origin`` not ``source``) lies in the lot it
  names (at most 0.01 m² outside it);
- every lot lies in the block it names (at most 0.5 m² outside its outline:
  the XML writes coordinates to the millimetre);
- every lot touches the street it names: its distance to that street's centre
  line is at most half the street's width plus 0.5 m (lots are the block
  shrunk by half the street widths); ``touch_any`` counts lots touching any
  street by the same rule;
- no generated building on a street's carriageway (centre line buffered by
  half its width, overlap above 0.5 m²).

From the ``--json`` report: generated buildings (≥ 50), each land-use share
against its goal (within 0.05), each type's lot-area quartiles against its
class's bounds (recomputed from the XML's lots too), the generated
footprint-area median against the town's (within 25 %), the generated height
median against the town's tagged heights (or the target without tags), and the
seconds of the build-out and of the whole engine.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import shapely
from lxml import etree

#: Tolerances (m², m): coordinates are written to the millimetre.
BUILDING_OUT, LOT_OUT, STREET_GAP, CARRIAGEWAY = 0.01, 0.5, 0.5, 0.5
SHARE_TOL, FOOTPRINT_TOL, MIN_BUILDINGS = 0.05, 0.25, 50


def _outline(el) -> shapely.Geometry:
    """The element's outline; an invalid one (a block's ring touching itself) made valid."""
    pts = [(float(n.get("x")), float(n.get("y"))) for n in el.iter("node")]
    poly = shapely.Polygon(pts)
    return poly if poly.is_valid else shapely.make_valid(poly)


def read_urban(path: Path) -> dict:
    """Streets (centre lines, widths), buildings, lots and blocks of an ``<urbanenvironment>``."""
    root = etree.parse(str(path)).getroot()
    streets = {}
    for s in root.iter("street"):
        segs = [((float(g.get("x1")), float(g.get("y1"))), (float(g.get("x2")), float(g.get("y2"))))
                for g in s.iter("segment")]
        streets[int(s.get("id"))] = (shapely.MultiLineString(segs), float(s.get("width", 0) or 0))
    buildings = [(_outline(b), b.get("origin", "source"), b.get("lot"), float(b.get("height")))
                 for b in root.iter("building")]
    lots = {int(lot.get("id")): (_outline(lot), int(lot.get("block")), int(lot.get("street")), lot.get("landuse"))
            for lot in root.iter("lot")}
    blocks = {int(b.get("id")): _outline(b) for b in root.iter("block")}
    return {"streets": streets, "buildings": buildings, "lots": lots, "blocks": blocks}


def geometry_checks(doc: dict) -> dict:
    """Counts of the geometric failures (see the module docstring); zero is a pass."""
    streets, lots, blocks = doc["streets"], doc["lots"], doc["blocks"]
    generated = [b for b in doc["buildings"] if b[1] != "source"]
    out = {"generated": len(generated), "lots": len(lots), "building_not_in_lot": 0, "building_without_lot": 0,
           "lot_not_in_block": 0, "lot_without_block": 0, "lot_off_its_street": 0, "lot_off_every_street": 0,
           "building_on_carriageway": 0, "examples": []}
    for poly, _, lot_id, _ in generated:
        lot = lots.get(int(lot_id)) if lot_id is not None else None
        if lot is None:
            out["building_without_lot"] += 1
        elif poly.difference(lot[0]).area > BUILDING_OUT:
            out["building_not_in_lot"] += 1
            _example(out, "building_not_in_lot", poly)
    for lot_id, (poly, block_id, street_id, _) in lots.items():
        block = blocks.get(block_id)
        if block is None:
            out["lot_without_block"] += 1
            _example(out, "lot_without_block", poly, lot_id)
        elif poly.difference(block).area > LOT_OUT:
            out["lot_not_in_block"] += 1
            _example(out, "lot_not_in_block", poly, lot_id)
        street = streets.get(street_id)
        if street is None or poly.distance(street[0]) > 0.5 * street[1] + STREET_GAP:
            out["lot_off_its_street"] += 1
            _example(out, "lot_off_its_street", poly, lot_id)
    ids = sorted(streets)
    lines = [streets[i][0] for i in ids]
    half = np.array([0.5 * streets[i][1] for i in ids])
    tree = shapely.STRtree(lines)
    lot_polys = [v[0] for v in lots.values()]
    if lot_polys:
        near, line = tree.query(lot_polys, predicate="dwithin", distance=float(half.max()) + STREET_GAP)
        d = shapely.distance(np.asarray(lot_polys, dtype=object)[near], np.asarray(lines, dtype=object)[line])
        ok = np.zeros(len(lot_polys), bool)
        ok[near[d <= half[line] + STREET_GAP]] = True
        out["lot_off_every_street"] = int((~ok).sum())
    gen_polys = np.asarray([b[0] for b in generated], dtype=object)
    if len(gen_polys):
        carriageways = shapely.buffer(np.asarray(lines, dtype=object), half, cap_style="flat")
        ctree = shapely.STRtree(carriageways)
        b, c = ctree.query(gen_polys, predicate="intersects")
        over = shapely.area(shapely.intersection(gen_polys[b], carriageways[c])) > CARRIAGEWAY
        out["building_on_carriageway"] = int(len(np.unique(b[over])))
    return out


def _example(out: dict, kind: str, poly, ident=None) -> None:
    if len(out["examples"]) < 6:
        c = poly.representative_point()
        out["examples"].append({"kind": kind, "id": ident, "at": [round(c.x, 1), round(c.y, 1)]})


def report_checks(report: dict, doc: dict) -> dict:
    """The ``--json`` report's build-out measures against the issue's targets."""
    engine = report.get("engine", {})
    bo = engine.get("buildout", {})
    out: dict = {"seconds_buildout": engine.get("seconds", {}).get("buildout"),
                 "seconds_engine": round(sum(engine.get("seconds", {}).values()), 2)}
    if not bo:
        return out
    lu = bo["land_use"]["types"]
    out["share_deviation"] = round(max(abs(v["share"] - v["goal"]) for v in lu.values()), 3)
    out["shares"] = {k: [v["share"], v["goal"]] for k, v in lu.items()}
    xml_area: dict[str, list[float]] = {}
    for poly, _, _, land in doc["lots"].values():
        xml_area.setdefault(land, []).append(poly.area)
    quart, outside = {}, []
    for name, t in bo["lots"]["types"].items():
        lo, hi = t["bounds_m2"]
        q = t["area_quartiles_m2"]
        a = np.array(xml_area.get(name, []))
        quart[name] = {"count": t["count"], "q": q, "bounds": [lo, hi],
                       "min_max_xml": [round(float(a.min()), 1), round(float(a.max()), 1)] if len(a) else None}
        if q and not all(lo - 1 <= v <= hi + 1 for v in q):
            outside.append(name)
    out["lot_quartiles"] = quart
    out["quartiles_outside"] = outside
    b = bo["buildings"]
    fm, hm = b["footprint_median_m2"], b["height_median_m"]
    out["generated_report"] = b["generated"]
    out["footprint"] = [fm["generated"], fm["town"]]
    out["footprint_ratio"] = round(fm["generated"] / fm["town"], 3) if fm["generated"] and fm["town"] else None
    out["height"] = [hm["generated"], hm["town"], hm["target"]]
    out["tagged_buildings"] = b.get("tagged_buildings")
    ref = hm["town"] or hm["target"]
    out["height_ratio"] = round(hm["generated"] / ref, 3) if hm["generated"] and ref else None
    return out


def check(xml: Path) -> dict:
    doc = read_urban(xml)
    row = {"run": xml.stem, **geometry_checks(doc)}
    js = xml.with_suffix(".json")
    if js.exists() and js.stat().st_size:
        row.update(report_checks(json.loads(js.read_text()), doc))
    ref = xml.with_suffix(".referee.json")
    if ref.exists() and ref.stat().st_size:
        row["referee"] = json.loads(ref.read_text())["violations"]
    fails = [k for k in ("building_not_in_lot", "building_without_lot", "lot_not_in_block", "lot_without_block",
                         "lot_off_its_street", "lot_off_every_street", "building_on_carriageway") if row[k]]
    if row["generated"] < MIN_BUILDINGS:
        fails.append("generated<50")
    if row.get("referee"):
        fails.append("referee")
    if row.get("share_deviation", 0) > SHARE_TOL:
        fails.append("shares")
    if row.get("quartiles_outside"):
        fails.append("quartiles")
    row["fails"] = fails
    return row


def markdown(rows: list[dict]) -> str:
    head = ("| run | referee | generated | lots | bldg∉lot | lot∉block | lot off street | max share dev | "
            "quartiles in bounds | footprint gen/town (m²) | height gen/town-or-target (m) | build-out s | engine s |")
    lines = [head, "|" + "---|" * head.count("|")[:-1] if False else "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        fp = r.get("footprint", [None, None])
        ht = r.get("height", [None, None, None])
        lines.append(
            f"| {r['run']} | {r.get('referee', '?')} | {r['generated']} | {r['lots']} | "
            f"{r['building_not_in_lot'] + r['building_without_lot']} | {r['lot_not_in_block'] + r['lot_without_block']} | "
            f"{r['lot_off_its_street']} | {r.get('share_deviation')} | "
            f"{'yes' if not r.get('quartiles_outside') else 'no: ' + ', '.join(r['quartiles_outside'])} | "
            f"{fp[0]} / {fp[1]} | {ht[0]} / {ht[1] or ht[2]}{'' if ht[1] else ' (target)'} | "
            f"{r.get('seconds_buildout')} | {r.get('seconds_engine')} |")
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("xml", nargs="+", type=Path)
    ap.add_argument("--json", action="store_true", help="one JSON object per run")
    ap.add_argument("--markdown", action="store_true", help="a Markdown table")
    args = ap.parse_args()
    rows = [check(p) for p in args.xml]
    if args.json:
        for r in rows:
            print(json.dumps(r))
    if args.markdown or not args.json:
        print(markdown(rows))
        for r in rows:
            if r["fails"]:
                print(f"{r['run']}: FAILS {', '.join(r['fails'])}; examples {r['examples']}")
    return 1 if any(r["fails"] for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
