"""Seconds per simulated year of the whole engine against the number of streets, on real towns.

    python benchmarks/engine_speed.py                         # Krems, north-bayreuth, Campo Grande; 10 years
    python benchmarks/engine_speed.py fixtures/monaco.osm.gz --years 20 --history european
    python benchmarks/engine_speed.py fixtures/krems.osm.gz --years 150 --history european   # to ~3,300 streets
    python benchmarks/engine_speed.py --json > engine.json
    python benchmarks/engine_speed.py --synthetic 10000 --years 30   # Campo Grande tiled to ~10,000 streets
    python benchmarks/engine_speed.py fixtures/campo-grande.osm.gz --years 30 --command   # and the whole command

``--synthetic N`` adds a synthetic town of about N streets: copies of
``--tile`` (default Campo Grande, 4,800 streets as mapped) laid edge to edge
on a square grid, ids shifted per copy, written as a sorted ``.osm.pbf`` by
:func:`benchmarks.large_inputs.write_tiled` (kept in ``--out``, reused when
there). The copies touch but their streets do not join: one map whose
engine has N streets to keep up with, as issue 22 asks. ``--roads-per-year
0`` leaves the major roads out, to time the rest of the year on a town
whose road search does not fit in memory.

For each town: load, grow the district (``--years 0`` work, not timed), then
run the engine's year loop (:func:`osm_expand.maturation.mature`) with the
build-out for ``--years`` years and time every year (wall clock, from the
loop's progress callback). The pathfinding lattice is built once, the first
time a trade route runs short, and is reported apart (it is 003's one-off
G′ construction); the year it was built is left out of the per-year
figures. The years are also grouped in bands of 500 streets (the city's
street count after the year), with the median wall and CPU seconds of each
band: that is the curve of seconds per year against streets. The stage
split (growth, blocks, traffic, roads, build-out) is the loop's own
``report["seconds"]``, summed over the run: wall seconds. Beside it
``stages_cpu_s`` gives the same stages in CPU seconds of the process (the
loop's stage functions wrapped in the child: on a machine shared with other
jobs the wall split was three to four times the CPU one, Campo Grande 350
against 100 s); its ``roads`` holds the lattice's year, and its ``blocks``
the blocks made at the start and after a new road too (the wall split
counts the first in ``start``, the second nowhere). ``stages_peak_mb``
gives, per stage, how far the process's peak memory rose while it ran
(summed over the years, MB; what is left of ``peak_mb`` rose before the
loop: the read and the district): which stage sets the peak. CPU seconds of the process are
printed too: they move less than wall time when other jobs share the
machine's 2 cores. Each town runs in a child process of its own, so its
peak memory (``peak_mb``: the child's ``ru_maxrss``, imports and the
town's load and district included) is the town's alone. Each year is also
told on stderr as it ends (streets, wall and CPU seconds), so a run too slow
to finish still shows how far it got.

With ``--command`` each town also runs the whole default command as a user
types it (``osm-expand FILE -o OUT.xml --preview OUT.png --seed S -q``: the
history's own years, the district, the outputs and the preview included)
in a fresh process, after the year loop's child: its CPU seconds (user +
system, the child's own ``wait4`` usage), wall seconds and peak memory
(``command`` in the JSON). That is issue 22's "whole default command"
figure; the per-year figures above leave out the read, the district and
the writing.

Targets: issue 10, about 3,000 streets at ≤ 1 s a year (Weber et al. 2009
grew 3,005 streets in 58 s for a whole run); issue 22, ≤ 1 s of CPU a year
at 5,000 streets, ≤ 2.5 s at 10,000; the whole default command: Campo Grande
≤ 30 s CPU and 1 GB, Krems ≤ 5 s, the synthetic 10,000-street town ≤ 90 s and 2 GB.
"""
from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import resource
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from osm_expand.engine.history import load_history  # noqa: E402
from osm_expand.engine.loop import EngineOptions  # noqa: E402
from osm_expand.ingest import load  # noqa: E402
from osm_expand.maturation import MatureOptions, mature  # noqa: E402
from osm_expand.pipeline import ExpandOptions, expand  # noqa: E402

TOWNS = ["krems.osm.gz", "north-bayreuth.osm.gz", "campo-grande.osm.gz"]


def measure(path: Path, history_name: str, years: int, seed: int, roads_per_year: int = 1) -> dict:
    city = load(path)
    grown = expand(city, ExpandOptions(seed=seed, fidelity=False))
    history = load_history(history_name)
    stamps: list[tuple[float, float]] = []
    cpu_stages, peak_stages, restore = _timed_stages()
    streets: list[int] = []
    cpu0, t0 = time.process_time(), time.perf_counter()
    def progress(done: int, total: int, era: str) -> None:
        stamps.append((time.perf_counter(), time.process_time()))
        last = stamps[-2] if len(stamps) > 1 else (t0, cpu0)
        print(f"{path.name} year {done}/{total} ({era}): {streets[-1] if streets else '?'} streets, "
              f"{stamps[-1][0] - last[0]:.2f} s wall, {stamps[-1][1] - last[1]:.2f} s CPU", file=sys.stderr, flush=True)

    engine = mature(grown.city, history, MatureOptions(years=years, fidelity=False, snapshot_every=1,
                                                      engine=EngineOptions(roads_per_year=roads_per_year)),
                    seed, learned=grown.learned, join_points=grown.joins.at, each_year=progress,
                    snapshot=lambda c, year, era, traffic: streets.append(len(c.network.streets)))
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    restore()
    seconds = engine.report["engine"]["seconds"]
    start = seconds.get("start", 0.0)  # wall; CPU of the start is taken as the same
    previous = [(t0 + start, cpu0 + start), *stamps[:-1]]
    timeline = [[n, round(b[0] - a[0], 3), round(b[1] - a[1], 3)] for n, a, b in zip(streets, previous, stamps)]
    if seconds.get("lattice", 0.0):  # the year the lattice was built, left out of the figures
        max(timeline, key=lambda row: row[1]).append("lattice")
    kept = [row for row in timeline if len(row) == 3]
    return {"town": path.name, "history": history_name, "years": years,
            "streets_start": len(grown.city.network.streets), "streets_end": len(engine.city.network.streets),
            "buildings_end": len(engine.city.buildings),
            "s_per_year_median": round(statistics.median(r[1] for r in kept), 3) if kept else None,
            "s_per_year_max": round(max(r[1] for r in kept), 3) if kept else None,
            "cpu_per_year_median": round(statistics.median(r[2] for r in kept), 3) if kept else None,
            "lattice_s": round(seconds.get("lattice", 0.0), 2), "start_s": round(start, 2),
            "total_wall_s": round(wall, 2), "total_cpu_s": round(cpu, 2),
            "stages_s": {k: round(v, 2) for k, v in sorted(seconds.items())},
            "stages_cpu_s": {k: round(v, 2) for k, v in cpu_stages.items()},
            "stages_peak_mb": {k: round(v) for k, v in peak_stages.items()},
            "by_streets": _by_streets(kept), "timeline": timeline}


#: The year loop's stages (:mod:`osm_expand.engine.loop`'s functions) timed in CPU seconds.
CPU_STAGES = {"growth": "_grow", "blocks": "_with_blocks", "traffic": "traffic_year", "roads": "major_roads_year",
              "buildout": "buildout_year"}


def _timed_stages() -> tuple[dict[str, float], dict[str, float], Callable[[], None]]:
    """The CPU seconds of each of :data:`CPU_STAGES` from now on, the MB the process's peak memory rose
    while each ran, and how to put the loop's functions back."""
    import osm_expand.engine.loop as loop

    spent = dict.fromkeys(CPU_STAGES, 0.0)
    raised = dict.fromkeys(CPU_STAGES, 0.0)
    kept = {name: getattr(loop, name) for name in CPU_STAGES.values()}

    def timed(stage: str, f: Callable) -> Callable:
        def run(*args, **kwargs):
            t, peak = time.process_time(), _peak_mb()
            try:
                return f(*args, **kwargs)
            finally:
                spent[stage] += time.process_time() - t
                raised[stage] += _peak_mb() - peak
        return run

    def restore() -> None:
        for name, f in kept.items():
            setattr(loop, name, f)

    for stage, name in CPU_STAGES.items():
        setattr(loop, name, timed(stage, kept[name]))
    return spent, raised, restore


def _peak_mb() -> float:
    """The process's peak resident memory so far, MB (``ru_maxrss``)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _measured(args: tuple) -> dict:
    """:func:`measure` in this (child) process, with its peak memory."""
    row = measure(*args)
    row["peak_mb"] = round(_peak_mb())
    return row


def whole_command(path: Path, seed: int) -> dict:
    """The default command on ``path`` in a fresh process (module docstring, ``--command``): CPU, wall, peak."""
    from benchmarks.large_inputs import child

    with tempfile.TemporaryDirectory() as out:
        run = child(COMMAND, str(path), "-o", str(Path(out) / "out.xml"), "--preview", str(Path(out) / "out.png"),
                    "--seed", str(seed), "-q", json_out=False)
    return {"cpu_s": round(run["cpu_s"], 2), "wall_s": round(run["wall_s"], 2), "peak_mb": round(run["peak_mb"])}


#: The child of :func:`whole_command`: the CLI as ``osm-expand`` runs it.
COMMAND = "import sys; from osm_expand.cli import main; sys.exit(main(sys.argv[1:]))"


def _by_streets(timeline: list[list]) -> list[dict]:
    """Median wall and CPU seconds per year in bands of 500 streets."""
    bands: dict[int, list[list]] = {}
    for row in timeline:
        bands.setdefault(row[0] // 500 * 500, []).append(row)
    return [{"streets": f"{k}-{k + 499}", "years": len(v),
             "s_per_year_median": round(statistics.median(r[1] for r in v), 3),
             "s_per_year_max": round(max(r[1] for r in v), 3),
             "cpu_per_year_median": round(statistics.median(r[2] for r in v), 3)} for k, v in sorted(bands.items())]


def synthetic_town(streets: int, tile: Path, out_dir: Path) -> Path:
    """A town of about ``streets`` streets: copies of ``tile`` edge to edge (see the module docstring)."""
    from benchmarks.large_inputs import read_town, write_tiled

    per_copy = len(load(tile).network.streets)
    copies = max(1, round(streets / max(per_copy, 1)))
    path = out_dir / f"synthetic-{tile.name.split('.')[0]}-x{copies}.osm.pbf"
    if path.exists():
        return path
    town = read_town(tile)
    side = math.ceil(math.sqrt(copies))
    w, h = town.box[2] - town.box[0], town.box[3] - town.box[1]
    placed = [(town, (k % side) * w, (k // side) * h) for k in range(copies)]
    meta = write_tiled(placed, path)
    print(f"built {path.name}: {copies} copies of {tile.name} ({per_copy} streets each), {meta['nodes']:,} nodes",
          file=sys.stderr)
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("towns", nargs="*", help="OSM files (default: three bundled towns)")
    parser.add_argument("--years", type=int, default=10)
    parser.add_argument("--history", default="example")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--synthetic", type=int, metavar="N", help="also a synthetic town of about N streets")
    parser.add_argument("--tile", type=Path, default=ROOT / "fixtures" / "campo-grande.osm.gz",
                        help="the fixture tiled into the synthetic town")
    parser.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()),
                        help="where the synthetic town is written (and reused from)")
    parser.add_argument("--command", action="store_true",
                        help="also time the whole default command on each town (CPU, wall, peak memory)")
    parser.add_argument("--roads-per-year", type=int, default=EngineOptions.roads_per_year,
                        help="major roads searched a year (0: the year without them, to time the rest)")
    args = parser.parse_args(argv)
    paths = [Path(t) for t in args.towns] or ([] if args.synthetic else [ROOT / "fixtures" / t for t in TOWNS])
    if args.synthetic:
        paths.append(synthetic_town(args.synthetic, args.tile, args.out))
    rows = []
    for p in paths:  # a fresh child per town: its peak memory is its own
        with multiprocessing.get_context("spawn").Pool(1, maxtasksperchild=1) as pool:
            rows.append(pool.apply(_measured, ((p, args.history, args.years, args.seed, args.roads_per_year),)))
        if args.command:
            rows[-1]["command"] = whole_command(p, args.seed)
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    print(f"{'town':24} {'streets':>15} {'s/year med':>10} {'max':>6} {'lattice':>8} {'wall':>7} {'cpu':>7} "
          f"{'peak MB':>8}  stages (s)")
    for r in rows:
        stages = " ".join(f"{k}={v}" for k, v in r["stages_s"].items())
        print(f"{r['town']:24} {r['streets_start']:>6} → {r['streets_end']:<6} {r['s_per_year_median']:>10} "
              f"{r['s_per_year_max']:>6} {r['lattice_s']:>8} {r['total_wall_s']:>7} {r['total_cpu_s']:>7} "
              f"{r['peak_mb']:>8}  {stages}")
        print("    stages CPU (s): " + " ".join(f"{k}={v}" for k, v in r["stages_cpu_s"].items()))
        print("    peak raised by stage (MB): " + " ".join(f"{k}={v}" for k, v in r["stages_peak_mb"].items()))
        for band in r["by_streets"]:
            print(f"    streets {band['streets']:>11}: {band['years']:>4} years, median {band['s_per_year_median']} s "
                  f"(CPU {band['cpu_per_year_median']} s), max {band['s_per_year_max']} s")
        if "command" in r:
            c = r["command"]
            print(f"    whole default command: {c['cpu_s']} s CPU, {c['wall_s']} s wall, {c['peak_mb']} MB peak")
    return 0


if __name__ == "__main__":
    sys.exit(main())
