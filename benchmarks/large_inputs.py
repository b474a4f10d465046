"""Large inputs: ``simplify`` on tiled country-sized files, and one town clipped out of the largest.

Builds ``.osm.pbf`` files of about 0.5 M, 1 M and 3 M nodes honestly from the
real fixtures: copies of the towns laid side by side on a grid of
``CELL_DEG`` cells (ids shifted by ``ID_STEP`` per copy, coordinates shifted
to the copy's cell), written sorted (nodes, ways, relations, ascending ids)
with their versions, timestamps and tags, as a country extract would be. One
copy of Krems sits at Krems' own coordinates in the middle of every file.

Then measures, each run in a fresh child process (peak memory: the child's
own ``ru_maxrss``, as ``os.wait4`` returns it, imports included):

- ``simplify``: ``osm_expand.ingest.load(path, context=False)`` then
  ``simplify.simplify(city.network)``, on each file: time, MB/s of the file,
  peak memory;
- the clipped run: :func:`osm_expand.clip.clip_extracts` of Krems' box out
  of the largest file, then ``osm-expand CLIP -o OUT.xml --seed 0 -q`` on the
  extract: the time and peak memory of each, beside those of simplify on the
  whole file and of the same command on ``fixtures/krems.osm.gz`` itself
  (the extract is the fixture with shifted ids, so the two should match);
- many towns: the first ``--towns`` copies of the largest file clipped
  together (one :func:`~osm_expand.clip.clip_extracts` call): time, reads
  of the file, peak memory.

Usage::

    python benchmarks/large_inputs.py                     # 0.5 M, 1 M, 3 M nodes in a temp dir
    python benchmarks/large_inputs.py --out /tmp/large    # keep the files (and reuse them next time)
    python benchmarks/large_inputs.py --sizes 500000 --json
    python benchmarks/large_inputs.py --clip-strategies   # also compare the clip's strategies on the largest file
    python benchmarks/large_inputs.py --towns 100         # clip 100 towns of the largest file together
"""
from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # this checkout's osm_expand, in this process as in the children
FIXTURES = REPO / "fixtures"
#: The sorted fixtures copied into the large files (circle-bug.osm.gz is unsorted and is left out).
TILES = ["krems.osm.gz", "monaco.osm.gz", "campo-grande.osm.gz", "north-bayreuth.osm.gz", "andorra.osm.pbf",
         "berlin-siegessaeule.osm.gz", "bautzen.osm", "West-Oakland.osm.bz2"]
#: Ids of copy k are the fixture's plus (k + 1) × ID_STEP (the fixtures' largest id is 9.7e9).
ID_STEP = 10 ** 10
#: Grid cell of one copy, degrees (the largest fixture, Andorra, spans 0.36° × 0.22°).
CELL_DEG = 0.4
SIZES = (500_000, 1_000_000, 3_000_000)
KREMS = "krems.osm.gz"


@dataclass
class Town:
    """One fixture in memory: plain Python values, ready to be shifted and written."""

    name: str
    box: tuple[float, float, float, float]  # W, S, E, N of its data (or header bounds)
    nodes: list[tuple]  # (id, lon, lat, tags, version, timestamp)
    ways: list[tuple]  # (id, refs, tags, version, timestamp)
    relations: list[tuple]  # (id, members (type, ref, role), tags, version, timestamp)


def read_town(path: Path) -> Town:
    import osmium

    nodes, ways, relations = [], [], []
    for obj in osmium.FileProcessor(str(path)):
        meta = (obj.version, obj.timestamp)
        tags = dict(obj.tags)
        if obj.is_node():
            if obj.location.valid():
                nodes.append((obj.id, obj.location.lon, obj.location.lat, tags, *meta))
        elif obj.is_way():
            ways.append((obj.id, [n.ref for n in obj.nodes], tags, *meta))
        else:
            relations.append((obj.id, [(m.type, m.ref, m.role) for m in obj.members], tags, *meta))
    for items in (nodes, ways, relations):
        items.sort(key=lambda t: t[0])
    box = osmium.FileProcessor(str(path)).header.box()
    if box.valid():
        bounds = (box.bottom_left.lon, box.bottom_left.lat, box.top_right.lon, box.top_right.lat)
    else:
        lons, lats = [n[1] for n in nodes], [n[2] for n in nodes]
        bounds = (min(lons), min(lats), max(lons), max(lats))
    return Town(path.name, bounds, nodes, ways, relations)


def layout(towns: list[Town], target_nodes: int) -> list[tuple[Town, float, float]]:
    """Copies cycling through the towns until ``target_nodes``, each with its (dlon, dlat) shift.

    The grid is square; the cell nearest its middle holds a Krems copy at
    Krems' own coordinates (shift 0), the rest are placed around it.
    """
    chosen, total = [], 0
    while total < target_nodes:
        town = towns[len(chosen) % len(towns)]
        chosen.append(town)
        total += len(town.nodes)
    side = math.ceil(math.sqrt(len(chosen)))
    middle = (side // 2) * side + side // 2
    krems = min((k for k, t in enumerate(chosen) if t.name == KREMS), key=lambda k: abs(k - middle))
    if middle < len(chosen):
        chosen[middle], chosen[krems] = chosen[krems], chosen[middle]
    else:
        middle = krems
    ref = next(t for t in towns if t.name == KREMS).box
    mc, mr = middle % side, middle // side
    placed = []
    for k, town in enumerate(chosen):
        c, r = k % side, k // side
        dlon = ref[0] + (c - mc) * CELL_DEG - town.box[0]
        dlat = ref[1] + (r - mr) * CELL_DEG - town.box[1]
        placed.append((town, dlon, dlat))
    return placed


def write_tiled(placed: list[tuple[Town, float, float]], out: Path) -> dict:
    """Write the copies as one sorted ``.osm.pbf``; returns counts and Krems' box in the file."""
    import osmium
    from osmium.osm.mutable import Node, Relation, Way

    lons, lats = [], []
    for town, dlon, dlat in placed:
        lons += [town.box[0] + dlon, town.box[2] + dlon]
        lats += [town.box[1] + dlat, town.box[3] + dlat]
    header = osmium.io.Header()
    header.add_box(osmium.osm.Box(osmium.osm.Location(min(lons), min(lats)), osmium.osm.Location(max(lons), max(lats))))
    header.set("generator", "osm-expand benchmarks/large_inputs.py")
    header.set("sorting", "Type_then_ID")
    tmp = out.with_name(".part-" + out.name)
    tmp.unlink(missing_ok=True)
    counts = {"nodes": 0, "ways": 0, "relations": 0}
    with osmium.SimpleWriter(str(tmp), header=header, overwrite=True) as writer:
        for k, (town, dlon, dlat) in enumerate(placed):
            shift = (k + 1) * ID_STEP
            for i, lon, lat, tags, version, ts in town.nodes:
                writer.add_node(Node(id=i + shift, location=(round(lon + dlon, 7), round(lat + dlat, 7)),
                                     tags=tags, version=version, timestamp=ts))
            counts["nodes"] += len(town.nodes)
        for k, (town, _, _) in enumerate(placed):
            shift = (k + 1) * ID_STEP
            for i, refs, tags, version, ts in town.ways:
                writer.add_way(Way(id=i + shift, nodes=[r + shift for r in refs], tags=tags, version=version,
                                   timestamp=ts))
            counts["ways"] += len(town.ways)
        for k, (town, _, _) in enumerate(placed):
            shift = (k + 1) * ID_STEP
            for i, members, tags, version, ts in town.relations:
                writer.add_relation(Relation(id=i + shift, members=[(t, r + shift, role) for t, r, role in members],
                                             tags=tags, version=version, timestamp=ts))
            counts["relations"] += len(town.relations)
    tmp.replace(out)
    krems = next((town, dlon, dlat) for town, dlon, dlat in placed if town.name == KREMS and dlon == 0 and dlat == 0)
    boxes = [[town.name, k, town.box[0] + dlon, town.box[1] + dlat, town.box[2] + dlon, town.box[3] + dlat]
             for k, (town, dlon, dlat) in enumerate(placed)]
    return {**counts, "copies": len(placed), "krems_box": list(krems[0].box), "boxes": boxes}


def build(out_dir: Path, sizes: tuple[int, ...]) -> dict[int, tuple[Path, dict]]:
    """The tiled files (reused when ``out_dir`` already holds them with their ``.json`` description)."""
    towns = None
    files = {}
    for size in sizes:
        path = out_dir / f"tiled-{size // 1000}k.osm.pbf"
        meta_path = path.with_suffix(".json")
        if path.exists() and meta_path.exists():
            meta = json.loads(meta_path.read_text())
            if "boxes" in meta:
                files[size] = (path, meta)
                continue
        if towns is None:
            towns = [read_town(FIXTURES / name) for name in TILES]
        t0 = time.perf_counter()
        meta = write_tiled(layout(towns, size), path)
        meta["build_s"] = round(time.perf_counter() - t0, 1)
        meta_path.write_text(json.dumps(meta))
        files[size] = (path, meta)
        print(f"built {path.name}: {meta['nodes']:,} nodes, {meta['ways']:,} ways, {meta['copies']} copies, "
              f"{path.stat().st_size / 1e6:.1f} MB in {meta['build_s']} s", file=sys.stderr)
    return files


# --- measurements, each in a fresh child process ---------------------------------------------------

SIMPLIFY_CHILD = """
import json, sys, time
from osm_expand.ingest import load
from simplify import simplify
t0 = time.perf_counter()
city = load(sys.argv[1], context=False)
t1 = time.perf_counter()
result = simplify(city.network)
t2 = time.perf_counter()
print(json.dumps({"read_s": t1 - t0, "simplify_s": t2 - t1, "street_nodes": len(city.network.xy),
                  "streets": len(city.network.streets), "junctions": result.report["junctions"]}))
"""

CLIP_CHILD = """
import json, sys, time
from osm_expand.clip import ClipOptions, clip_extracts
src, box, out, strategy = sys.argv[1], json.loads(sys.argv[2]), sys.argv[3], sys.argv[4]
t0 = time.perf_counter()
result = clip_extracts(src, {"krems": tuple(box)}, out, options=ClipOptions(strategy=strategy))
print(json.dumps({"clip_s": time.perf_counter() - t0, "reads": result.reads, **result.counts["krems"],
                  "clip_mb": result.paths["krems"].stat().st_size / 1e6}))
"""

TOWNS_CHILD = """
import json, sys, time
from osm_expand.clip import clip_extracts
src, boxes, out = sys.argv[1], json.loads(sys.argv[2]), sys.argv[3]
t0 = time.perf_counter()
result = clip_extracts(src, {name: tuple(box) for name, box in boxes.items()}, out)
print(json.dumps({"clip_s": time.perf_counter() - t0, "reads": result.reads, "extracts": len(result.paths),
                  "nodes": sum(c["nodes"] for c in result.counts.values())}))
"""

GROW_CHILD = """
import contextlib, io, json, sys, time
from osm_expand.cli import main
t0 = time.perf_counter()
with contextlib.redirect_stdout(io.StringIO()) as out:
    code = main([sys.argv[1], "-o", sys.argv[2], "--seed", "0", "-q", "--json"])
seconds = time.perf_counter() - t0
report = json.loads(out.getvalue()) if code == 0 else {}
print(json.dumps({"grow_s": seconds, "exit": code,
                  "town": {k: report.get(k) for k in ("source_streets", "source_buildings", "spacing_m")}}))
"""


def child(code: str, *args: str) -> dict:
    """Run ``code`` in a fresh Python: its JSON line, wall time and peak memory (MB).

    The peak is the child's own ``ru_maxrss`` as ``wait4`` returns it (what
    ``getrusage(RUSAGE_CHILDREN)`` reports when this is the only child), so
    each measurement is its own, whatever ran before it.
    """
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-c", code, *args], cwd=REPO, stdout=out, stderr=err,
                                env={**os.environ, "PYTHONPATH": str(REPO)})
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        wall = time.perf_counter() - t0
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read().decode(), err.read().decode()
    if proc.returncode != 0:
        last = stderr.strip().splitlines()[-1] if stderr.strip() else f"exit {proc.returncode}"
        raise RuntimeError(f"child failed: {last}")
    result = json.loads(stdout.strip().splitlines()[-1])
    result["wall_s"] = wall
    result["peak_mb"] = usage.ru_maxrss / 1024  # Linux: kilobytes
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="keep the tiled files here (reused when present)")
    parser.add_argument("--sizes", type=lambda s: tuple(int(v) for v in s.split(",")), default=SIZES,
                        help="node counts, comma separated (default 500000,1000000,3000000)")
    parser.add_argument("--clip-strategies", action="store_true", help="also time each clip strategy")
    parser.add_argument("--no-grow", action="store_true", help="clip only, do not grow the town")
    parser.add_argument("--towns", type=int, default=24, metavar="N",
                        help="also clip the first N copies of the largest file together, in one go (default 24; 0: no)")
    parser.add_argument("--json", action="store_true", help="print the figures as one JSON object")
    args = parser.parse_args()
    tmp = None
    if args.out is None:
        tmp = tempfile.TemporaryDirectory(prefix="osm-expand-large-")
        out_dir = Path(tmp.name)
    else:
        out_dir = args.out
        out_dir.mkdir(parents=True, exist_ok=True)
    try:
        return run(out_dir, tuple(sorted(args.sizes)), args)
    finally:
        if tmp is not None:
            tmp.cleanup()


def run(out_dir: Path, sizes: tuple[int, ...], args: argparse.Namespace) -> int:
    files = build(out_dir, sizes)
    report: dict = {"simplify": [], "clip": []}
    for size in sizes:
        path, meta = files[size]
        mb = path.stat().st_size / 1e6
        r = child(SIMPLIFY_CHILD, str(path))
        seconds = r["read_s"] + r["simplify_s"]
        row = {"file": path.name, "nodes": meta["nodes"], "ways": meta["ways"], "mb": round(mb, 1),
               "read_s": round(r["read_s"], 2), "simplify_s": round(r["simplify_s"], 2), "seconds": round(seconds, 2),
               "mb_per_s": round(mb / seconds, 2), "peak_mb": round(r["peak_mb"]),
               "street_nodes": r["street_nodes"], "junctions": r["junctions"]}
        report["simplify"].append(row)
        if not args.json:
            print(f"simplify {row['file']:>20}: {row['nodes']:>9,} nodes {row['mb']:6.1f} MB  "
                  f"read {row['read_s']:6.2f} s + simplify {row['simplify_s']:6.2f} s = {row['seconds']:6.2f} s  "
                  f"{row['mb_per_s']:5.2f} MB/s  peak {row['peak_mb']} MB", flush=True)
    largest, meta = files[sizes[-1]]
    from osm_expand.clip import ClipStrategy

    strategies = list(ClipStrategy) if args.clip_strategies else [ClipStrategy.TWO_PASS]
    with tempfile.TemporaryDirectory(prefix="osm-expand-clip-") as tmp:
        work = Path(tmp)
        for strategy in strategies:
            r = child(CLIP_CHILD, str(largest), json.dumps(meta["krems_box"]), str(work), str(strategy))
            row = {"file": largest.name, "strategy": str(strategy), "seconds": round(r["clip_s"], 2),
                   "peak_mb": round(r["peak_mb"]), "reads": r["reads"], "nodes": r["nodes"], "ways": r["ways"],
                   "relations": r["relations"], "clip_mb": round(r["clip_mb"], 2)}
            report["clip"].append(row)
            if not args.json:
                print(f"clip Krems out of {row['file']} ({row['strategy']}): {row['seconds']:.2f} s, "
                      f"{row['reads']} reads, peak {row['peak_mb']} MB; {row['nodes']:,} nodes, "
                      f"{row['ways']:,} ways, {row['relations']} relations ({row['clip_mb']} MB)", flush=True)
        if args.towns:
            picked = [b for b in meta["boxes"]][: args.towns]
            boxes = {f"{name.split('.')[0]}-{k}": box for name, k, *box in picked}
            r = child(TOWNS_CHILD, str(largest), json.dumps(boxes), str(work))
            report["many_towns"] = {"towns": len(boxes), "seconds": round(r["clip_s"], 2), "reads": r["reads"],
                                    "extracts": r["extracts"], "nodes": r["nodes"], "peak_mb": round(r["peak_mb"])}
            m = report["many_towns"]
            if not args.json:
                print(f"clip {m['towns']} towns out of {largest.name} together: {m['seconds']:.2f} s, {m['reads']} reads, "
                      f"peak {m['peak_mb']} MB; {m['extracts']} extracts, {m['nodes']:,} nodes", flush=True)
        if not args.no_grow:
            clip_row = report["clip"][0]
            grown = child(GROW_CHILD, str(work / "krems.osm.pbf"), str(work / "krems.expanded.xml"))
            original = child(GROW_CHILD, str(FIXTURES / KREMS), str(work / "original.expanded.xml"))
            whole = report["simplify"][-1]
            report["clipped_run"] = {
                "clip_s": clip_row["seconds"], "grow_s": round(grown["grow_s"], 2),
                "seconds": round(clip_row["seconds"] + grown["grow_s"], 2), "exit": grown["exit"],
                "clip_peak_mb": clip_row["peak_mb"], "grow_peak_mb": round(grown["peak_mb"]),
                "peak_mb": max(clip_row["peak_mb"], round(grown["peak_mb"])),
                "whole_file_simplify_peak_mb": whole["peak_mb"],
                "original_krems_grow_s": round(original["grow_s"], 2),
                "original_krems_grow_peak_mb": round(original["peak_mb"]),
                "town_as_original": grown["town"] == original["town"], "town": grown["town"]}
            c = report["clipped_run"]
            if not args.json:
                print(f"clipped run (Krems' copy in {largest.name}): clip {c['clip_s']:.2f} s + grow {c['grow_s']:.2f} s "
                      f"= {c['seconds']:.2f} s (exit {c['exit']}); peak {c['peak_mb']} MB (clip {c['clip_peak_mb']}, "
                      f"grow {c['grow_peak_mb']}) against {c['whole_file_simplify_peak_mb']} MB for simplify on the "
                      f"whole file; growing fixtures/{KREMS} itself: {c['original_krems_grow_s']:.2f} s, peak "
                      f"{c['original_krems_grow_peak_mb']} MB; the town read from the clip "
                      f"{'is' if c['town_as_original'] else 'is NOT'} the fixture's ({c['town']})", flush=True)
    if args.json:
        print(json.dumps(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
