"""Time osmnx and osm-expand simplifying the same OSM file, in the same run.

    python benchmarks/simplify_vs_osmnx.py [--repeat N] [--whole N] [--json] [FILE ...]

Two comparisons, each printed with its ratio:

The whole command (``--whole`` runs of each side, default 5; 0 skips it)
    ``osm-expand simplify FILE -o OUT.osm -q`` against osmnx's whole script
    for the same job (``import osmnx``; ``graph_from_xml`` with its default
    simplification; ``project_graph``; ``consolidate_intersections(10)``),
    each a fresh process, interpreter start and imports included, what a user
    waits for. The runs are interleaved; the ratio is of the best wall times.
    Before timing, this checkout's packages are byte-compiled (``compileall``)
    as ``pip install`` does for osmnx: otherwise an editable install run with
    ``PYTHONDONTWRITEBYTECODE`` set recompiles every module on every start.

The work alone (``--repeat`` runs, default 3), sides as follows:
    osmnx:  the chain the benchmark issue names, as a user would write it:
            graph_from_xml, then simplify_graph, project_graph and
            consolidate_intersections(tolerance=10). The headline ratio.
    osmnx-streets: the same chain with osmnx's graph first cut down to our
            default highway set, so both sides simplify the same streets; a
            stricter comparison, printed beside the headline.
    ours:   simplify(load(path, context=False)), which is exactly what
            ``osm-expand simplify`` does before writing its output.

How it measures, and why
    * Each run of each side is a fresh child process (this script with
      ``--side``), so one side's imports, caches and freed-but-kept heap never
      leak into the other's time or memory, and every run starts equally cold.
    * The child times only the work, after its imports; the import time and the
      child's total wall time are reported beside it, because a one-shot CLI
      user pays for both.
    * Peak memory is the child's ``ru_maxrss`` at its end: the whole process,
      imports included. The parent imports nothing heavy, since Linux carries a
      forked parent's resident size into the child's high-water mark.
    * Each side runs ``--repeat`` times (interleaved, to spread any drift in the
      machine's load); best and median are reported, and the ratio uses the
      best times, the usual estimate of what the code itself costs.
    * osmnx's ``graph_from_xml`` has no tag filter: it turns every way in the
      file (buildings, landuse, rivers, ...) into graph edges, and the plain
      chain simplifies all of them. ``osmnx-streets`` drops the edges outside
      our default highway set (and ``area=yes``) right after loading, inside
      the timed region since osmnx offers no earlier place to do it.
    * Compressed input is given to both sides as is: osmnx (>= 2.0) reads .gz
      and .bz2 itself, so both decompress inside the timed region. osmnx cannot
      read PBF; such a file is reported as an osmnx failure.
    * An osmnx error (e.g. a way referencing a node missing from a clipped
      extract) is caught in the child and reported, not raised.
"""
from __future__ import annotations

import argparse
import compileall
import importlib.util
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DEFAULT_FILES = (REPO / "fixtures" / "north-bayreuth.osm.gz",)
SIDES = ("osmnx", "osmnx-streets", "ours")
OSMNX_TOLERANCE = 10.0

Phases = dict[str, float]
Counts = dict[str, int]
Work = Callable[[str], tuple[Phases, Counts]]


# --------------------------------------------------------------------- child --

def peak_rss_mb() -> float:
    """This process's peak resident set size so far (ru_maxrss is KiB on Linux)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


class Clock:
    """Records how long each named phase of one run took."""

    def __init__(self) -> None:
        self.phases: Phases = {}

    def __call__(self, name: str, fn: Callable, *args, **kwargs):
        start = time.perf_counter()
        out = fn(*args, **kwargs)
        self.phases[name] = time.perf_counter() - start
        return out


def import_ours() -> Work:
    """Import our pipeline; return the work to time."""
    from osm_expand.ingest import load
    from simplify import simplify

    def work(path: str) -> tuple[Phases, Counts]:
        clock = Clock()
        net = clock("ingest", load, path, context=False).network
        report = clock("simplify", simplify, net).report
        return clock.phases, {k: report[k] for k in ("input_ways", "junctions", "streets", "street_nodes")}

    return work


def import_osmnx(streets_only: bool = False) -> Work:
    """Import osmnx; return the work to time (optionally cut to our highway set first)."""
    import networkx as nx
    import osmnx as ox

    from osm_expand.model.highways import highway_set

    kept = highway_set()

    def keep_streets(G: nx.MultiDiGraph) -> nx.MultiDiGraph:
        drop = [(u, v, k) for u, v, k, d in G.edges(keys=True, data=True)
                if d.get("highway") not in kept or d.get("area") == "yes"]
        G.remove_edges_from(drop)
        G.remove_nodes_from(list(nx.isolates(G)))
        return G

    def work(path: str) -> tuple[Phases, Counts]:
        if path.lower().endswith(".pbf"):
            raise ValueError("osmnx reads OSM XML only, not PBF")
        clock = Clock()
        G = clock("load", ox.graph_from_xml, path, simplify=False, retain_all=True)
        loaded = G.number_of_edges()
        if streets_only:
            G = clock("filter", keep_streets, G)
        streets = G.number_of_edges()
        G = clock("simplify", ox.simplify_graph, G)
        G = clock("project", ox.project_graph, G)
        G = clock("consolidate", ox.consolidate_intersections, G, tolerance=OSMNX_TOLERANCE)
        return clock.phases, {"loaded_edges": loaded, "street_edges": streets,
                              "nodes": G.number_of_nodes(), "edges": G.number_of_edges()}

    return work


IMPORTERS: dict[str, Callable[[], Work]] = {
    "osmnx": import_osmnx,
    "osmnx-streets": lambda: import_osmnx(streets_only=True),
    "ours": import_ours,
}


def run_side(side: str, path: str) -> dict:
    """One timed run of one side in this process, as a JSON-ready dict."""
    start = time.perf_counter()
    work = IMPORTERS[side]()
    result: dict = {"side": side, "file": path, "import_s": time.perf_counter() - start,
                    "rss_after_import_mb": peak_rss_mb()}
    try:
        phases, counts = work(path)
    except Exception as exc:  # noqa: BLE001 - any failure of the library is a result
        result.update(ok=False, error=f"{type(exc).__name__}: {exc}"[:300])
    else:
        result.update(ok=True, seconds=sum(phases.values()), phases=phases, counts=counts)
    result["peak_rss_mb"] = peak_rss_mb()
    return result


# ------------------------------------------------------------- whole command --

#: ``osm-expand`` as installed (``osm_expand.cli:main``), run from this checkout.
OURS_COMMAND = "import sys; from osm_expand.cli import main; sys.exit(main())"

#: osmnx's whole script for what ``osm-expand simplify`` does: read the XML into a simplified graph
#: (graph_from_xml's default simplify=True), project it and consolidate intersections within 10 m.
OSMNX_SCRIPT = """
import sys
import osmnx as ox
G = ox.graph_from_xml(sys.argv[1])
G = ox.project_graph(G)
G = ox.consolidate_intersections(G, tolerance=10)
print(G.number_of_nodes(), G.number_of_edges())
"""


def byte_compile_ours() -> None:
    """Write this checkout's bytecode, as an installed package has it."""
    for package in ("osm_expand", "simplify", "synth"):
        if (REPO / package).is_dir():
            compileall.compile_dir(REPO / package, quiet=1)


def timed_process(code: str, *args: str) -> tuple[float, float]:
    """Wall seconds and peak memory (MB, the child's own ``ru_maxrss``) of ``python -c code args``."""
    with tempfile.TemporaryFile() as err:
        start = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-c", code, *args], cwd=REPO, stdout=subprocess.DEVNULL,
                                stderr=err, env={**os.environ, "PYTHONPATH": str(REPO)})
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - start
        if os.waitstatus_to_exitcode(status) != 0:
            err.seek(0)
            tail = (err.read().decode().strip().splitlines() or ["no message"])[-1]
            raise RuntimeError(f"{code.split(';')[0].strip() or 'script'} failed: {tail}")
    return wall, usage.ru_maxrss / 1024  # Linux: kilobytes


def whole_command_ratio(path: Path, repeat: int) -> dict:
    """``osm-expand simplify`` against osmnx's script, fresh processes, interleaved; best wall of each."""
    byte_compile_ours()
    ours, theirs = [], []
    with tempfile.TemporaryDirectory(prefix="osm-expand-whole-") as tmp:
        out = str(Path(tmp) / "simplified.osm")
        for i in range(repeat):
            print(f"{path.name}: whole commands, run {i + 1}/{repeat}", file=sys.stderr, flush=True)
            ours.append(timed_process(OURS_COMMAND, "simplify", str(path), "-o", out, "-q"))
            theirs.append(timed_process(OSMNX_SCRIPT, str(path)))
    best_ours, best_theirs = min(w for w, _ in ours), min(w for w, _ in theirs)
    return {"file": path.name, "runs": repeat, "ours_s": [round(w, 3) for w, _ in ours],
            "osmnx_s": [round(w, 2) for w, _ in theirs], "ours_best_s": round(best_ours, 3),
            "osmnx_best_s": round(best_theirs, 2), "ratio": round(best_theirs / best_ours, 1),
            "ours_median_s": round(statistics.median(w for w, _ in ours), 3),
            "osmnx_median_s": round(statistics.median(w for w, _ in theirs), 2),
            "ours_peak_mb": round(max(m for _, m in ours)), "osmnx_peak_mb": round(max(m for _, m in theirs))}


def render_whole(w: dict) -> str:
    return (f"whole command on {w['file']}, fresh processes, imports included, best of {w['runs']}: "
            f"osm-expand simplify {w['ours_best_s']:.2f} s (median {w['ours_median_s']:.2f}, peak "
            f"{w['ours_peak_mb']} MB), osmnx graph_from_xml + project_graph + consolidate_intersections(10) "
            f"{w['osmnx_best_s']:.2f} s (median {w['osmnx_median_s']:.2f}, peak {w['osmnx_peak_mb']} MB): "
            f"{w['ratio']}x")


# -------------------------------------------------------------------- parent --

@dataclass
class SideStats:
    """All runs of one side on one file."""

    runs: list[dict] = field(default_factory=list)

    @property
    def error(self) -> str | None:
        return next((r["error"] for r in self.runs if not r["ok"]), None)

    def median_of(self, key: str) -> float:
        return statistics.median(r[key] for r in self.runs)

    @property
    def best(self) -> float:
        return min(r["seconds"] for r in self.runs)

    @property
    def median(self) -> float:
        return self.median_of("seconds")

    @property
    def peak_rss_mb(self) -> float:
        return max(r["peak_rss_mb"] for r in self.runs)

    def best_run(self) -> dict:
        return min(self.runs, key=lambda r: r["seconds"])

    def summary(self) -> dict:
        if not self.runs:
            return {"ok": False, "error": "not run"}
        if self.error:
            return {"ok": False, "error": self.error, "runs": self.runs}
        return {"ok": True, "best_s": self.best, "median_s": self.median, "peak_rss_mb": self.peak_rss_mb,
                "import_s": self.median_of("import_s"), "child_wall_s": self.median_of("wall_s"),
                "rss_after_import_mb": self.median_of("rss_after_import_mb"),
                "phases_best_run": self.best_run()["phases"], "counts": self.best_run()["counts"],
                "runs": self.runs}


def run_child(side: str, path: Path, timeout: float) -> dict:
    """Run one side once in a fresh interpreter and parse its JSON line."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--side", side, str(path)]
    start = time.perf_counter()
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=REPO)
    except subprocess.TimeoutExpired:
        return {"side": side, "ok": False, "error": f"timed out after {timeout:g} s"}
    wall = time.perf_counter() - start
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
    if not lines:
        tail = (proc.stderr.strip().splitlines() or ["no output"])[-1]
        return {"side": side, "ok": False, "error": f"child exited {proc.returncode}: {tail}"}
    return {**json.loads(lines[-1]), "wall_s": wall}


def bench_file(path: Path, repeat: int, timeout: float) -> dict[str, SideStats]:
    """Interleave the sides' runs; stop repeating a side once it has failed."""
    stats = {side: SideStats() for side in SIDES}
    for i in range(repeat):
        for side in SIDES:
            if stats[side].error:
                continue
            print(f"{path.name}: {side} run {i + 1}/{repeat}", file=sys.stderr, flush=True)
            stats[side].runs.append(run_child(side, path, timeout))
    return stats


def ratio(stats: dict[str, SideStats], peer: str = "osmnx") -> float | None:
    if stats[peer].error or stats["ours"].error:
        return None
    return stats[peer].best / stats["ours"].best


def notes() -> list[str]:
    return [
        "times: the work only, after imports, best and median of the runs; ratio = osmnx best / ours best",
        "peak RSS: the child process's ru_maxrss at its end (whole process, imports included), max over runs",
        "osmnx loads every way in the file (buildings, landuse, water...) as edges and the plain chain keeps "
        "them; osmnx-streets drops edges outside our default highway set (and area=yes) before "
        "simplify_graph, and that filter is timed",
        "compressed files go to both sides as is (osmnx >= 2.0 reads .gz/.bz2): both decompress inside the timing",
        f"osmnx: consolidate_intersections(tolerance={OSMNX_TOLERANCE:g}) after project_graph; "
        "ours: simplify(load(path, context=False)), as `osm-expand simplify`",
        "osmnx edges are directed (a two-way street counts twice); our streets run junction to junction "
        "and dead ends are pruned, so the counts describe each output, they are not meant to match",
    ]


def _secs(s: SideStats) -> str:
    return "FAILED" if s.error else f"{s.best:.2f} / {s.median:.2f} s"


def _rss(s: SideStats) -> str:
    return "-" if s.error else f"{s.peak_rss_mb:.0f} MB"


def render_table(results: dict[Path, dict[str, SideStats]]) -> str:
    head = ("file", "osmnx best / median", "osmnx-streets", "ours best / median", "ratio", "ratio-streets",
            "osmnx RSS", "ours RSS")
    rows = [head]
    for path, st in results.items():
        r, rs = ratio(st), ratio(st, "osmnx-streets")
        rows.append((path.name, _secs(st["osmnx"]), _secs(st["osmnx-streets"]), _secs(st["ours"]),
                     "-" if r is None else f"{r:.1f}x", "-" if rs is None else f"{rs:.1f}x",
                     _rss(st["osmnx"]), _rss(st["ours"])))
    widths = [max(len(row[i]) for row in rows) for i in range(len(head))]
    lines = ["  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths)))
             for row in rows]
    lines.insert(1, "-" * len(lines[0]))
    return "\n".join(lines)


def _phases(phases: Phases) -> str:
    return ", ".join(f"{k} {v:.2f}" for k, v in phases.items())


def render_details(path: Path, stats: dict[str, SideStats]) -> list[str]:
    out = [f"{path.name}:"]
    for side in SIDES:
        s = stats[side]
        if s.error:
            out.append(f"  {side}: {side} failed: {s.error}")
            continue
        best = s.best_run()
        counts = ", ".join(f"{k} {v}" for k, v in best["counts"].items())
        out.append(f"  {side}: import {s.median_of('import_s'):.2f} s, child wall {s.median_of('wall_s'):.2f} s, "
                   f"RSS after import {s.median_of('rss_after_import_mb'):.0f} MB")
        out.append(f"  {' ' * len(side)}  best run s: {_phases(best['phases'])}; {counts}")
    return out


def render_text(results: dict[Path, dict[str, SideStats]], repeat: int) -> str:
    parts = [f"osmnx {package_version('osmnx')} vs osm-expand {package_version('osm-expand')}, "
             f"Python {platform.python_version()}, {repeat} run(s) per side, each in a fresh process", "",
             render_table(results), ""]
    for path, stats in results.items():
        parts += render_details(path, stats)
    parts += ["", "notes:"] + [f"  - {n}" for n in notes()]
    return "\n".join(parts)


def render_json(results: dict[Path, dict[str, SideStats]], repeat: int) -> str:
    files = [{"file": str(path), "ratio": ratio(st), "ratio_streets": ratio(st, "osmnx-streets"), **{side: st[side].summary() for side in SIDES}}
             for path, st in results.items()]
    return json.dumps({"osmnx_version": package_version("osmnx"),
                       "osm_expand_version": package_version("osm-expand"),
                       "python": platform.python_version(), "repeat": repeat, "notes": notes(),
                       "files": files}, indent=2)


def package_version(name: str) -> str:
    try:
        return version(name)
    except PackageNotFoundError:
        return "?"


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("files", nargs="*", type=Path, default=list(DEFAULT_FILES),
                   help="OSM files (default: fixtures/north-bayreuth.osm.gz)")
    p.add_argument("--repeat", type=int, default=3, help="runs per side and file, work alone (default 3)")
    p.add_argument("--whole", type=int, default=5, metavar="N",
                   help="runs of each whole command on the first file (default 5; 0: skip)")
    p.add_argument("--timeout", type=float, default=1800, help="seconds before a run counts as failed")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    p.add_argument("--side", choices=SIDES, help="internal: run one side once here and print one JSON line")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.side:
        print(json.dumps(run_side(args.side, str(args.files[0]))))
        return 0
    if importlib.util.find_spec("osmnx") is None:
        print("error: osmnx is not installed; install the benchmark extra: pip install -e '.[bench]'",
              file=sys.stderr)
        return 2
    missing = [str(f) for f in args.files if not f.is_file()]
    if missing or args.repeat < 1:
        print(f"error: {'no such file: ' + ', '.join(missing) if missing else '--repeat must be >= 1'}",
              file=sys.stderr)
        return 2
    whole = whole_command_ratio(args.files[0].resolve(), args.whole) if args.whole > 0 else None
    results = {path.resolve(): bench_file(path.resolve(), args.repeat, args.timeout) for path in args.files}
    if args.json:
        report = json.loads(render_json(results, args.repeat))
        print(json.dumps({**report, "whole_command": whole}, indent=2))
    else:
        print(render_text(results, args.repeat) + ("\n\n" + render_whole(whole) if whole else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
