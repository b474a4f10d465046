"""Large inputs: ``simplify`` on tiled country-sized files, and one town clipped out of the largest.

Builds ``.osm.pbf`` files of about 0.5 M, 1 M and 3 M nodes honestly from the
real fixtures: copies of the towns laid side by side on a grid of
``CELL_DEG`` cells (ids shifted by ``ID_STEP`` per copy, coordinates shifted
to the copy's cell), written sorted (nodes, ways, relations, ascending ids)
with their versions, timestamps and tags, as a country extract would be. One
copy of Krems sits at Krems' own coordinates in the middle of every file.

Then measures, each run in a fresh child process (peak memory: the child's
own ``ru_maxrss``, as ``os.wait4`` returns it, imports included):

- ``simplify``: the command ``osm-expand simplify FILE -o OUT.osm`` on each
  file, as a user runs it: wall time (interpreter, imports, read, simplify,
  write), the phases from its progress lines, MB/s of the file, peak memory;
  and the time per node of the largest file against the smallest (1.0 is
  linear);
- the clipped run: ``osm-expand LARGEST --bbox <Krems' copy> -o OUT.xml
  --seed 0`` (clip, then the whole main command, engine included): time and
  peak memory, beside those of simplify on the whole file and of the same
  command on ``fixtures/krems.osm.gz`` itself (the extract is the fixture
  with shifted ids, so the town read should match);
- with ``--clip-strategies``, each clip strategy alone on Krems' copy;
- many towns: the first ``--towns`` copies of the largest file clipped
  together (one :func:`~osm_expand.clip.clip_extracts` call): time, reads
  of the file, peak memory;
- the whole-command ratio against osmnx on ``fixtures/north-bayreuth.osm.gz``,
  measured as ``simplify_vs_osmnx.py`` does (:func:`whole_command_ratio`:
  ``osm-expand simplify FILE -o OUT.osm -q`` against osmnx's script, fresh
  processes, imports included, ``--osmnx-repeat`` runs of each interleaved;
  the ratio of the best wall times).

Usage::

    python benchmarks/large_inputs.py                     # 0.5 M, 1 M, 3 M nodes in a temp dir
    python benchmarks/large_inputs.py --out /tmp/large    # keep the files (and reuse them next time)
    python benchmarks/large_inputs.py --sizes 500000 --json
    python benchmarks/large_inputs.py --clip-strategies   # also compare the clip's strategies on the largest file
    python benchmarks/large_inputs.py --towns 100         # clip 100 towns of the largest file together
    python benchmarks/large_inputs.py --sizes 500000 --no-grow --towns 0 --osmnx-repeat 0   # quick
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
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
    krems = next(((town, dlon, dlat) for town, dlon, dlat in placed if town.name == KREMS and dlon == 0 and dlat == 0),
                 None)  # a town tiled on itself (benchmarks/engine_speed.py --synthetic) has no Krems copy
    boxes = [[town.name, k, town.box[0] + dlon, town.box[1] + dlat, town.box[2] + dlon, town.box[3] + dlat]
             for k, (town, dlon, dlat) in enumerate(placed)]
    return {**counts, "copies": len(placed), "krems_box": list(krems[0].box) if krems else None, "boxes": boxes}


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

#: The ``osm-expand`` console script, as installed (``osm_expand.cli:main``), run from this checkout.
COMMAND = "import sys; from osm_expand.cli import main; sys.exit(main())"

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

READ_CHILD = """
import json, sys, time
from osm_expand.ingest import load
t0 = time.perf_counter()
city = load(sys.argv[1])
print(json.dumps({"read_s": time.perf_counter() - t0, "streets": len(city.network.streets),
                  "buildings": len(city.buildings)}))
"""

_STAMP = re.compile(r"^\[\s*([0-9.]+)s\] (.*)$")


def child(code: str, *args: str, json_out: bool = True) -> dict:
    """Run ``python -c code args`` fresh: its last JSON line (if ``json_out``), wall and CPU time (user + system),
    peak memory (MB), stderr.

    The peak is the child's own ``ru_maxrss`` as ``wait4`` returns it, so
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
    result = json.loads(stdout.strip().splitlines()[-1]) if json_out else {}
    result.update(wall_s=wall, cpu_s=usage.ru_utime + usage.ru_stime, peak_mb=usage.ru_maxrss / 1024,
                  stderr=stderr)  # Linux: kilobytes
    return result


def stamps(stderr: str) -> list[tuple[float, str]]:
    """The command's progress lines (``[  1.23s] reading ...``) as (seconds, message)."""
    return [(float(m.group(1)), m.group(2)) for m in map(_STAMP.match, stderr.splitlines()) if m]


def since(lines: list[tuple[float, str]], start: str, stop: str) -> float:
    """Seconds from the first line containing ``start`` to the first later one containing ``stop``."""
    t0 = next(t for t, msg in lines if start in msg)
    return next(t for t, msg in lines if t >= t0 and stop in msg and start not in msg) - t0


def simplify_row(path: Path, meta: dict, work: Path) -> dict:
    """``osm-expand simplify FILE -o OUT.osm --json`` in a fresh process: phases, MB/s, peak memory."""
    r = child(COMMAND, "simplify", str(path), "-o", str(work / "simplified.osm"), "--json")
    lines = stamps(r["stderr"])
    mb = path.stat().st_size / 1e6
    return {"file": path.name, "nodes": meta["nodes"], "ways": meta["ways"], "mb": round(mb, 1),
            "seconds": round(r["wall_s"], 2), "read_s": round(since(lines, "reading", "simplifying"), 2),
            "simplify_s": round(since(lines, "simplifying", "writing"), 2),
            "write_s": round(since(lines, "writing", "done"), 2), "mb_per_s": round(mb / r["wall_s"], 2),
            "peak_mb": round(r["peak_mb"]), "street_nodes": r["input_nodes"], "junctions": r["junctions"]}


def clipped_run(largest: Path, box: list[float], work: Path) -> dict:
    """The main command growing Krems' copy out of the largest file (``--bbox``), and growing the fixture itself."""
    bbox = ",".join(repr(v) for v in box)
    grown = child(COMMAND, str(largest), f"--bbox={bbox}", "-o", str(work / "krems-copy.expanded.xml"), "--seed", "0",
                  "--json")
    original = child(COMMAND, str(FIXTURES / KREMS), "-o", str(work / "krems.expanded.xml"), "--seed", "0", "--json")
    whole = child(READ_CHILD, str(largest))  # what the main command would read without --bbox
    keys = ("source_streets", "source_buildings", "spacing_m")
    return {"seconds": round(grown["wall_s"], 2), "clip_s": round(since(stamps(grown["stderr"]), "clipping", "reading"), 2),
            "peak_mb": round(grown["peak_mb"]), "clip": grown["clip"],
            "original_seconds": round(original["wall_s"], 2), "original_peak_mb": round(original["peak_mb"]),
            "town": {k: grown.get(k) for k in keys}, "town_as_original": all(grown.get(k) == original.get(k) for k in keys),
            "years": grown.get("engine", {}).get("years"), "whole_read_s": round(whole["read_s"], 2),
            "whole_read_peak_mb": round(whole["peak_mb"]), "whole_streets": whole["streets"]}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="keep the tiled files here (reused when present)")
    parser.add_argument("--sizes", type=lambda s: tuple(int(v) for v in s.split(",")), default=SIZES,
                        help="node counts, comma separated (default 500000,1000000,3000000)")
    parser.add_argument("--clip-strategies", action="store_true", help="also time each clip strategy")
    parser.add_argument("--no-grow", action="store_true", help="do not grow Krems' copy out of the largest file")
    parser.add_argument("--towns", type=int, default=24, metavar="N",
                        help="also clip the first N copies of the largest file together, in one go (default 24; 0: no)")
    parser.add_argument("--osmnx-repeat", type=int, default=5, metavar="N",
                        help="runs of each side against osmnx on north-bayreuth (default 5; 0: skip)")
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


def say(args: argparse.Namespace, text: str) -> None:
    if not args.json:
        print(text, flush=True)


def run(out_dir: Path, sizes: tuple[int, ...], args: argparse.Namespace) -> int:
    files = build(out_dir, sizes)
    report: dict = {"simplify": [], "clip": []}
    with tempfile.TemporaryDirectory(prefix="osm-expand-bench-") as tmp:
        work = Path(tmp)
        for size in sizes:
            row = simplify_row(*files[size], work)
            report["simplify"].append(row)
            say(args, f"simplify {row['file']:>20}: {row['nodes']:>9,} nodes {row['mb']:6.1f} MB  {row['seconds']:6.2f} s "
                      f"(read {row['read_s']:.2f}, simplify {row['simplify_s']:.2f}, write {row['write_s']:.2f})  "
                      f"{row['mb_per_s']:5.2f} MB/s  peak {row['peak_mb']} MB")
        if len(report["simplify"]) > 1:
            first, last = report["simplify"][0], report["simplify"][-1]
            report["linearity"] = round((last["seconds"] / last["nodes"]) / (first["seconds"] / first["nodes"]), 2)
            say(args, f"time per node, {last['file']} against {first['file']}: {report['linearity']}x (1.0 is linear)")
        largest, meta = files[sizes[-1]]
        from osm_expand.clip import ClipStrategy

        for strategy in (list(ClipStrategy) if args.clip_strategies else []):
            r = child(CLIP_CHILD, str(largest), json.dumps(meta["krems_box"]), str(work), str(strategy))
            row = {"file": largest.name, "strategy": str(strategy), "seconds": round(r["clip_s"], 2),
                   "peak_mb": round(r["peak_mb"]), "reads": r["reads"], "nodes": r["nodes"], "ways": r["ways"],
                   "relations": r["relations"], "clip_mb": round(r["clip_mb"], 2)}
            report["clip"].append(row)
            say(args, f"clip Krems out of {row['file']} ({row['strategy']}): {row['seconds']:.2f} s, "
                      f"{row['reads']} reads, peak {row['peak_mb']} MB; {row['nodes']:,} nodes, "
                      f"{row['ways']:,} ways, {row['relations']} relations ({row['clip_mb']} MB)")
        if args.towns:
            boxes = {f"{name.split('.')[0]}-{k}": box for name, k, *box in meta["boxes"][: args.towns]}
            r = child(TOWNS_CHILD, str(largest), json.dumps(boxes), str(work))
            m = report["many_towns"] = {"towns": len(boxes), "seconds": round(r["clip_s"], 2), "reads": r["reads"],
                                        "extracts": r["extracts"], "nodes": r["nodes"], "peak_mb": round(r["peak_mb"])}
            say(args, f"clip {m['towns']} towns out of {largest.name} together: {m['seconds']:.2f} s, {m['reads']} reads, "
                      f"peak {m['peak_mb']} MB; {m['extracts']} extracts, {m['nodes']:,} nodes")
        if not args.no_grow:
            c = report["clipped_run"] = clipped_run(largest, meta["krems_box"], work)
            whole = report["simplify"][-1]
            say(args, f"clipped run: osm-expand {largest.name} --bbox <Krems' copy> grows it in {c['seconds']:.2f} s "
                      f"(clip {c['clip_s']:.2f} s, {c['clip']['reads']} reads; {c['years']} years), peak {c['peak_mb']} MB; "
                      f"without --bbox the main command would first read the whole file ({c['whole_read_s']:.2f} s, peak "
                      f"{c['whole_read_peak_mb']} MB, {c['whole_streets']:,} streets) and simplify it (simplify alone: "
                      f"{whole['seconds']:.2f} s, peak {whole['peak_mb']} MB); fixtures/{KREMS} itself: "
                      f"{c['original_seconds']:.2f} s, peak {c['original_peak_mb']} MB; the town read from the clip "
                      f"{'is' if c['town_as_original'] else 'is NOT'} the fixture's ({c['town']})")
        if args.osmnx_repeat:
            import importlib.util

            if importlib.util.find_spec("osmnx") is None:
                say(args, "osmnx is not installed (pip install -e '.[bench]'): no whole-command ratio")
            else:
                from simplify_vs_osmnx import render_whole, whole_command_ratio  # this folder's sibling script

                o = report["osmnx"] = whole_command_ratio(FIXTURES / "north-bayreuth.osm.gz", args.osmnx_repeat)
                say(args, render_whole(o))
    if args.json:
        print(json.dumps(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
