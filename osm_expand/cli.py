"""The ``osm-expand`` command: argument parsing, files, progress, exit codes.

``osm-expand CITY [options]`` grows the town; ``osm-expand COMMAND ...`` runs
one of :data:`COMMANDS`. Exit codes: 0 success, 2 bad usage or unusable
input (one line on stderr naming the file and the problem, nothing written),
1 an internal error. Everything that can be checked before the work is
checked first. Results go to files or, with ``--json``, to stdout;
progress goes to stderr (a progress bar; ``-q`` silences it). Each command
imports what it needs inside its function, for start-up time only
(``osm-expand --help`` in 0.08 s); no import cycle is dodged.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import re
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import NoReturn

from osm_expand.errors import InputError, OptionError, OutputError

PROG = "osm-expand"
OUTPUT_WRITERS = {".osm": "osm", ".geojson": "geojson", ".json": "geojson"}
EXPAND_WRITERS = {".xml": "urbanenvironment", ".osm": "osm", ".geojson": "geojson", ".json": "geojson"}
FORMAT_SUFFIX = {"urbanenvironment": ".xml", "osm": ".osm", "geojson": ".geojson"}
#: Options whose value may start with a minus sign (a negative coordinate).
_COORDINATE_OPTIONS = ("--at", "--at-lonlat", "--bbox", "--around")
_NUMBERS = re.compile(r"^-?\d*\.?\d+(e-?\d+)?(,-?\d*\.?\d+(e-?\d+)?)*$", re.IGNORECASE)


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version  # 20 ms: only when --version is asked for

    try:
        return version("osm-expand")
    except PackageNotFoundError:  # running from a source tree that is not installed
        return "unknown"


class _VersionAction(argparse.Action):
    """``--version``, looked up only when asked for (importlib.metadata costs 20 ms of every command's start)."""

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        print(f"{PROG} {_version()}")  # on stdout, as argparse's own version action does
        parser.exit()


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line, exit 2
        self.exit(2, f"{PROG}: error: {_one_line(message)} (see '{PROG} --help')\n")


class Progress:
    """Progress on stderr: a tqdm bar over the stages on a terminal, a timed line per stage otherwise;
    silent with --quiet."""

    def __init__(self, quiet: bool, stages: int = 0):
        self.quiet = quiet
        self.t0 = time.perf_counter()
        self.bar = None
        self.started = False
        if not quiet and stages and sys.stderr.isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=stages, file=sys.stderr, unit="stage", leave=False, dynamic_ncols=True,
                            bar_format="{percentage:3.0f}%|{bar:20}| {n_fmt}/{total_fmt} [{elapsed}] {desc}")

    def __call__(self, message: str) -> None:
        if self.quiet:
            return
        if self.bar is None:
            print(f"[{time.perf_counter() - self.t0:6.2f}s] {message}", file=sys.stderr, flush=True)
            return
        if self.started and self.bar.n < self.bar.total:  # the stage before this one is done
            self.bar.update(1)
        self.started = True
        self.bar.set_description_str(message)

    def add_stages(self, n: int) -> None:
        """More stages than the bar was made for (the eras of a history)."""
        if self.bar is not None and n > 0:
            self.bar.total += n
            self.bar.refresh()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def _add_input_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("city", help="OSM extract: .osm, .osm.gz, .osm.bz2 or .osm.pbf")
    p.add_argument("--service", action="store_true", help="also keep highway=service roads")
    p.add_argument("--paths", action="store_true", help="also keep footways, paths, tracks and cycleways")
    p.add_argument("--json", action="store_true", help="print the report as one JSON object on stdout")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")


def _add_clip_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("a town out of a large file (clipped at read time; docs/batch.md)")
    g.add_argument("--bbox", metavar="W,S,E,N", help="read only this box, degrees (ways crossing its edge kept whole)")
    g.add_argument("--around", metavar="LON,LAT", help="read only the box around this point, degrees (with --radius)")
    g.add_argument("--radius", type=float, metavar="M", help="with --around: metres from the point to the box's sides")
    g.add_argument("--clip-index", metavar="INDEX",
                   help="clip in one read with this node-location index (flex_mem, sparse_file_array,PATH, ...) "
                        "instead of two reads with a node store on disk beside the output")


def _check_clip(args: argparse.Namespace) -> None:
    """``--bbox`` / ``--around --radius`` / ``--clip-index`` checked before any work (``args.box``, ``args.clip``)."""
    args.box = args.clip = None
    if args.bbox is None and args.around is None and args.radius is None:
        if args.clip_index is not None:
            raise OptionError("--clip-index needs --bbox or --around")
        return
    from osm_expand.clip import options_for_index, requested_box

    args.box = requested_box(bbox=args.bbox, around=args.around, radius=args.radius)
    args.clip = options_for_index(args.clip_index)


@contextlib.contextmanager
def _read_from(args: argparse.Namespace, city: Path, scratch: Path, log: Progress) -> Iterator[tuple[Path, dict]]:
    """The file to read: the input, or its extract of ``--bbox``/``--around`` in a temporary folder in ``scratch``."""
    if args.box is None:
        yield city, {}
        return
    from osm_expand.clip import clipped

    what = f"--bbox {args.bbox}" if args.bbox is not None else f"--around {args.around} --radius {args.radius:g}"
    log(f"clipping {what} out of {city}")
    with clipped(city, args.box, scratch=scratch, what=what, options=args.clip) as (path, info):
        yield path, {"clip": info}


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--seed must be a whole number, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"--seed must be 0 or more, got {value}")
    return value


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The sub-commands' parser (``osm-expand COMMAND ...``); ``batch``'s options only when ``command`` is batch."""
    parser = _Parser(prog=PROG, description="Grow a real OpenStreetMap town.")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser, metavar="COMMAND")
    simp = sub.add_parser("simplify", help="simplify a town's streets into junctions and whole streets",
                          description="Simplify a town's street network (seed 004 §4.2) and write it.")
    _add_input_options(simp)
    _add_clip_options(simp)
    simp.add_argument("-o", "--output", help="OUT.osm or OUT.geojson (default: CITY.simplified.osm beside the input)")
    simp.add_argument("--cluster-radius", type=float, default=None, metavar="M",
                      help="disc radius for fusing junction clusters, metres (default 10)")
    stats = sub.add_parser("stats", help="street statistics of a town or of an osm-expand output",
                           description="Junctions, Gravelius levels, spacing and angle statistics, "
                                       "3-/4-way shares, dead ends and orientation entropy.")
    _add_input_options(stats)
    rep = sub.add_parser("reproduce", help="re-walk a town's own junctions and score the result",
                         description="Run the random walk on the example's junctions in place; recall and "
                                     "precision of the town's junction-to-junction segments (004 §5.3).")
    _add_input_options(rep)
    rep.add_argument("--seed", type=_seed, default=0, help="random seed (default 0)")
    comp = sub.add_parser("compare", help="is network A as alike to B as B's own districts are?",
                          description="Judge A as a district of B: 13 measures of street networks against "
                                      "real parts of B of A's size (any file the tool reads).")
    _add_input_options(comp)
    comp.add_argument("other", help="the town to compare with (B)")
    comp.add_argument("--seed", type=_seed, default=0, help="random seed for the real parts (default 0)")
    batch = sub.add_parser("batch", help="grow many towns on a Dask cluster (local or existing)")
    if command in (None, "batch"):  # its options copy the main parser's: 40 ms other commands need not pay
        from osm_expand.batch import add_batch_arguments

        add_batch_arguments(batch)
    return parser


def build_expand_parser() -> argparse.ArgumentParser:
    """The main command's parser (``osm-expand CITY ...``); its help lists the other commands too."""
    commands = "\n".join(f"  osm-expand {name} {usage}" for name, usage in COMMAND_USAGE.items())
    p = _Parser(prog=PROG, usage=f"{PROG} CITY [options]\n       {PROG} COMMAND ... (see below)",
                formatter_class=argparse.RawDescriptionHelpFormatter,
                description="Grow a real OpenStreetMap town: osm-expand CITY reads the town, learns its "
                            "streets, grows a district that looks like it, joins it to the real streets, and "
                            "writes the whole town with its new district.",
                epilog=f"other commands (osm-expand COMMAND --help for each):\n{commands}")
    p.add_argument("--version", action=_VersionAction, nargs=0, help="show the version and exit")
    _add_input_options(p)
    _add_clip_options(p)
    p.add_argument("-o", "--output", help="output file: .xml (urbanenvironment), .osm or .geojson "
                                          "(default: CITY.expanded.xml beside the input)")
    p.add_argument("--format", choices=sorted(FORMAT_SUFFIX),
                   help="output format (default: from -o, else urbanenvironment)")
    p.add_argument("--preview", metavar="OUT.png|OUT.svg", help="also draw a map of the result")
    p.add_argument("--seed", type=_seed, default=0, help="random seed (0 or more); the same seed gives the same bytes")
    p.add_argument("--direction", choices=["auto", "N", "NE", "E", "SE", "S", "SW", "W", "NW"], default="auto",
                   help="grow on this side of the town (default: the best site anywhere)")
    p.add_argument("--at", metavar="X,Y", help="site centre in metres of the local projection")
    p.add_argument("--at-lonlat", metavar="LON,LAT", help="site centre in degrees (longitude first)")
    p.add_argument("--area", type=float, metavar="M2",
                   help="district area in m² (default: a quarter of the built-up area, at most a neighbourhood "
                        "unit of 0.65 km², at least nine blocks; at most four times the built-up area)")
    p.add_argument("--pattern", choices=["example", "walk", "colonisation"], default="example",
                   help="how streets grow: example (patches of the town, seams walked; default), walk "
                        "(004's random walk over the town's junctions) or colonisation (001's space "
                        "colonisation, the town's junction spacing as segment length)")
    bounds = p.add_mutually_exclusive_group()
    bounds.add_argument("--beyond-bounds", action="store_true", default=None,
                        help="let the district grow outside the map's bounds (land there is unknown; by default "
                             "only when the town fills its map)")
    bounds.add_argument("--within-bounds", dest="beyond_bounds", action="store_false",
                        help="never grow outside the map's bounds: refuse when the town fills its map")
    p.add_argument("--unbuildable", metavar="KEY=VALUE,...",
                   help="mapped areas nobody may build on, replacing the default list "
                        "(landuse=cemetery,leisure=park,aeroway=*,...; '' for none)")
    p.add_argument("--history", metavar="NAME|FILE", default="example",
                   help="the history the city then lives through: a bundled one (example, european, "
                        "north-american) or a TOML file (docs/histories.md); default: example")
    p.add_argument("--years", type=_years, metavar="N",
                   help="years of history to simulate (default: the history's own, 30 for example; "
                        "0 grows the district only)")
    p.add_argument("--snapshots", metavar="DIR",
                   help="also draw the city at the end of each era (traffic green to red) into DIR")
    p.add_argument("--snapshot-every", type=_years, metavar="N",
                   help="with --snapshots: a picture every N years instead of one per era")
    p.add_argument("--debug-layers", action="store_true",
                   help="with a .geojson output: add the growth pattern's working layers (colonisation: "
                        "attraction points, flow field and its primitives, region, parameters)")
    return p


def _years(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number of years, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be 0 or more, got {value}")
    return value


COMMAND_USAGE = {
    "simplify": "CITY [-o OUT.osm|OUT.geojson] [--json]   the town's streets simplified (004 §4.2)",
    "stats": "FILE [--json]                           street statistics of a town or an output",
    "reproduce": "CITY [--seed N] [--json]               re-walk the town's junctions, scored",
    "compare": "A B [--seed N] [--json]                 is A as alike to B as B's own districts are?",
    "batch": "IN... --out DIR [--towns T.csv] [--workers N|--scheduler ADDR]   many towns (docs/batch.md)",
}


def _output_path(city: Path, output: str | None, default_suffix: str,
                 writers: dict[str, str] = OUTPUT_WRITERS) -> tuple[Path, str]:
    path = Path(output) if output else city.with_name(_stem(city) + default_suffix)
    if output == "":
        raise OptionError("-o needs a file name, got ''")
    try:
        return _checked_output(path, city, default_suffix, writers)
    except OSError as exc:  # a name or path too long, a loop of links, ...
        raise OutputError(f"{path}: cannot write there ({exc.strerror or exc})") from None


def _checked_output(path: Path, city: Path, default_suffix: str, writers: dict[str, str]) -> tuple[Path, str]:
    if path.is_dir():
        raise OutputError(f"{path}: is a directory; give an output file (-o DIR/NAME{default_suffix})")
    kind = writers.get(path.suffix.lower())
    if kind is None:
        raise OptionError(f"{path}: unsupported output type (use {' or '.join(sorted(writers))})")
    _not_the_input(path, city)
    _writable(path)
    return path, kind


def _not_the_input(out: Path, city: Path) -> None:
    """Refuse an output that is the input itself (by inode, or by real path when it does not exist yet)."""
    try:
        same = os.path.samefile(out, city) if out.exists() and city.exists() else \
            os.path.realpath(out) == os.path.realpath(city)
    except OSError:
        same = False
    if same:
        raise OutputError(f"{out}: is the input file; choose another output (-o) so the town is not overwritten")


@contextlib.contextmanager
def _writing(path: Path) -> Iterator[None]:
    """A write that fails (disk full, file-size limit, a folder gone) as one line naming the file, exit 2."""
    try:
        yield
    except OSError as exc:
        raise OutputError(f"{path}: cannot write it ({exc.strerror or exc}); nothing was written") from None


def _writable(path: Path) -> None:
    """Fail before any work when ``path`` cannot be written."""
    from osm_expand.export.atomic import check_writable

    if path.is_dir():
        raise OutputError(f"{path}: is a directory")
    if not path.parent.exists() and str(path.parent) != "":
        raise OutputError(f"{path}: output directory does not exist")
    try:
        check_writable(path)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write there, the folder is not writable ({exc.strerror})") from None


def _stem(path: Path) -> str:
    name = path.name
    for suffix in (".osm.gz", ".osm.bz2", ".osm.pbf", ".osm", ".pbf", ".gz", ".bz2", ".xml", ".geojson"):
        if name.lower().endswith(suffix):
            return name[: -len(suffix)]
    return path.stem


def _simplify_or_fail(city: Path, net, args: argparse.Namespace, options=None):
    """Simplify, or fail in one line naming the file when nothing is left.

    (``pipeline.simplified_or_fail`` without importing the pipeline, which costs
    ``simplify``, ``stats`` and ``reproduce`` 0.7 s of SciPy, scikit-learn and synth imports.)
    """
    from simplify import simplify

    result = simplify(net, options)
    if not result.network.streets:
        from osm_expand.pipeline import NOTHING_LEFT

        raise _in_file(city, InputError(NOTHING_LEFT), args) from None
    return result


def _in_file(city: Path, exc: InputError, args: argparse.Namespace) -> InputError:
    """The error, naming the file; when nothing survived simplification, what might help."""
    from osm_expand.pipeline import NOTHING_LEFT

    hint = "; try --service" if str(exc) == NOTHING_LEFT and not args.service else ""
    return type(exc)(f"{city}: {exc}{hint}")  # the same kind of error (osm_expand.errors), naming the file


def cmd_simplify(args: argparse.Namespace, log: Progress) -> dict:
    from osm_expand import export
    from osm_expand.gcpause import cyclic_gc_paused
    from osm_expand.ingest import load
    from osm_expand.model import City
    from simplify import SimplifyOptions
    from simplify.invariants import violations

    city = Path(args.city)
    out, kind = _output_path(city, args.output, ".simplified.osm")
    if args.cluster_radius is not None and not 0 < args.cluster_radius < float("inf"):
        raise OptionError(f"--cluster-radius must be positive and finite (metres), got {args.cluster_radius:g}")
    _check_clip(args)
    with cyclic_gc_paused():  # millions of short-lived objects on a large file (osm_expand.gcpause)
        with _read_from(args, city, out.parent, log) as (src, clip):
            log(f"reading {city}" + (" (the extract)" if clip else ""))
            net = load(src, service=args.service, paths=args.paths, context=False).network
        log(f"{len(net.streets)} streets, {len(net.xy)} street nodes; simplifying")
        opts = SimplifyOptions() if args.cluster_radius is None else SimplifyOptions(cluster_radius=args.cluster_radius)
        result = _simplify_or_fail(city, net, args, opts)
        log(f"{result.report['junctions']} junctions, {result.report['streets']} streets; writing {out}")
        write = export.write_osm if kind == "osm" else export.write_geojson  # loads that writer alone
        with _writing(out):
            write(City(network=result.network), out)
        broken = {k: v for k, v in violations(result.network).items() if v}
    if broken:  # never expected: say so rather than hand over a flawed network silently
        print(f"{PROG}: warning: {out}: simplified network still has {broken}; please report this input",
              file=sys.stderr)
    return {"input": str(city), "output": str(out), **clip, "violations": broken, **result.report}


def cmd_stats(args: argparse.Namespace, log: Progress) -> dict:
    from osm_expand.ingest import load
    from simplify.example import build_example
    from simplify.invariants import is_valid
    from simplify.statistics import example_statistics

    city = Path(args.city)
    log(f"reading {city}")
    net = load(city, service=args.service, paths=args.paths, context=False).network
    dead_ends = None
    if not is_valid(net):  # a town as mapped: simplify first; a simplified output already is
        log("simplifying")
        result = _simplify_or_fail(city, net, args)
        net, dead_ends = result.network, result.dead_ends
    example = build_example(net, dead_ends or [])
    stats = {"input": str(city), **example_statistics(example, None if dead_ends is None else len(dead_ends))}
    if not args.json:
        print(_stats_text(stats))
    return stats


def _stats_text(stats: dict) -> str:
    lines = [f"{stats['input']}: {stats['junctions']} junctions, {stats['streets']} streets, "
             f"{stats['total_length_km']} km, {stats['levels']} Gravelius levels",
             f"  3-way {stats['three_way_share']:.1%}, 4-way {stats['four_way_share']:.1%}"
             + (f", dead ends {stats['dead_end_share']:.1%}" if "dead_end_share" in stats else ""),
             f"  orientation entropy {stats['orientation_entropy']} (order {stats['orientation_order']})",
             "  level  streets  spacing mean/std (m)  turning std (deg)"]
    for lv, s in stats["per_level"].items():
        sp, tu = s["junction_spacing_m"], s["turning_angle_deg"]
        lines.append(f"  {lv:>5}  {s['streets']:>7}  {sp.get('mean', 0):>9.1f} / {sp.get('std', 0):<9.1f}"
                     f"  {tu.get('std', 0):>8.1f}")
    return "\n".join(lines)


def cmd_reproduce(args: argparse.Namespace, log: Progress) -> dict:
    from osm_expand.ingest import load
    from simplify.example import build_example
    from synth.reproduce import reproduce

    city = Path(args.city)
    log(f"reading {city}")
    net = load(city, service=args.service, paths=args.paths, context=False).network
    log("simplifying")
    result = _simplify_or_fail(city, net, args)
    example = build_example(result.network, result.dead_ends)
    log(f"walking {len(example.junctions)} junctions (seed {args.seed})")
    score = {"input": str(city), **reproduce(example, seed=args.seed)}
    score["per_level"] = {str(k): v for k, v in score["per_level"].items()}
    if not args.json:
        print(f"{city}: recall {score['recall']:.3f}, precision {score['precision']:.3f} "
              f"({score['segments_made']} segments walked, {score['segments_original']} in the town)")
    return score


def cmd_compare(args: argparse.Namespace, log: Progress) -> dict:
    from osm_expand.fidelity import compare
    from osm_expand.growth_fidelity import city_growth_fidelity
    from osm_expand.ingest import load

    a, b = Path(args.city), Path(args.other)
    lines, cities = [], []
    for path in (a, b):
        log(f"reading {path}")
        cities.append(load(path, service=args.service, paths=args.paths, context=False))
        lines.append([cities[-1].network.street_xy(s) for s in cities[-1].network.streets])
    log("measuring")
    report = compare(lines[0], lines[1], rng=args.seed).to_dict()
    grown = city_growth_fidelity(cities[0], rng=args.seed, town_lines=lines[1])  # A read back from a run's output
    if grown is not None:
        report["growth_fidelity"] = grown.to_dict()
    if not args.json:
        print(_compare_text(a, b, report))
    return {"a": str(a), "b": str(b), "seed": args.seed, **report}


def _compare_text(a: Path, b: Path, report: dict) -> str:
    typical = report.get("typical_part_off")
    typical_text = "no real neighbourhood of its size" if typical is None or typical != typical else f"{typical:g}"
    lines = [f"{a} as a district of {b}: off on {report['off']} of {len(report['measures'])} measures "
             f"(a typical real neighbourhood of {b.name}: {typical_text}); "
             f"{report['pieces']} piece{'s' if report['pieces'] != 1 else ''} on the map"]
    for name, v in report["measures"].items():
        lines.append(f"  {'ok ' if v['ok'] else 'OFF'} {name:<20} {v['value']}  [{v['low']}, {v['high']}]")
    grown = report.get("growth_fidelity")
    if grown:
        overall, lei = grown["overall"], grown["lei"]
        if overall:
            lines.append(f"what the years grew in {a.name}: off on {overall['off']} of {len(overall['measures'])}, "
                         f"{overall['pieces']} pieces")
        lines.append(f"  new street length: {lei['infill']} infill, {lei['edge']} edge expansion, "
                     f"{lei['outlying']} outlying (Landscape Expansion Index)")
    return "\n".join(lines)


def cmd_batch(args: argparse.Namespace, log: Progress) -> dict:
    """``osm-expand batch``: one job per input or per town (osm_expand.batch)."""
    from osm_expand.batch import cmd_batch as run

    return run(args, log)


COMMANDS: dict[str, Callable[[argparse.Namespace, Progress], dict]] = {
    "simplify": cmd_simplify, "stats": cmd_stats, "reproduce": cmd_reproduce, "compare": cmd_compare,
    "batch": cmd_batch}


def _pair(text: str, flag: str) -> tuple[float, float]:
    try:
        a, b = (float(v) for v in text.split(","))
    except ValueError:
        raise OptionError(f"{flag} expects two numbers separated by a comma, got {text!r}") from None
    return a, b


def _site_point(args: argparse.Namespace, city) -> tuple[float, float] | None:
    """``--at`` / ``--at-lonlat`` in metres, checked against the map's bounds."""
    if args.at_lonlat is not None:
        lon, lat = args.at_lonlat
        text = f"{lon:g},{lat:g}"
        lon0, lat0, lon1, lat1 = city.context.bounds_lonlat
        inside = lambda x, y: lon0 <= x <= lon1 and lat0 <= y <= lat1  # noqa: E731
        if inside(lat, lon) and not inside(lon, lat):
            raise OptionError(f"--at-lonlat {text}: latitude and longitude look swapped; "
                              f"give longitude first: {lat:g},{lon:g}")
        if not inside(lon, lat) and not args.beyond_bounds:
            raise OptionError(f"--at-lonlat {text} is outside the map (lon {lon0:.5f}..{lon1:.5f}, "
                              f"lat {lat0:.5f}..{lat1:.5f}); use --beyond-bounds to grow outside it")
        x, y = city.projection.to_xy(lon, lat)
        return float(x), float(y)
    if args.at is not None:
        x, y = args.at
        x0, y0, x1, y1 = city.bounds_xy
        if not args.beyond_bounds and not (x0 <= x <= x1 and y0 <= y <= y1):
            raise OptionError(f"--at {x:g},{y:g} is outside the map (x {x0:.0f}..{x1:.0f}, y {y0:.0f}..{y1:.0f} m); "
                              "use --beyond-bounds to grow outside it")
        return x, y
    return None


def _check_points(args: argparse.Namespace) -> None:
    """Parse ``--at`` and ``--at-lonlat`` (before any work); their bounds are checked once the map is read."""
    if args.at is not None:
        args.at = _pair(args.at, "--at")
        if not all(math.isfinite(v) for v in args.at):
            raise OptionError(f"--at expects two finite numbers (metres), got {args.at[0]:g},{args.at[1]:g}")
    if args.at_lonlat is not None:
        args.at_lonlat = lon, lat = _pair(args.at_lonlat, "--at-lonlat")
        if not (-180 <= lon <= 180 and -90 <= lat <= 90):
            if -180 <= lat <= 180 and -90 <= lon <= 90:
                raise OptionError(f"--at-lonlat {lon:g},{lat:g}: latitude and longitude look swapped; "
                                  f"give longitude first: {lat:g},{lon:g}")
            raise OptionError(f"--at-lonlat {lon:g},{lat:g} is not a longitude,latitude")


def _expand_outputs(args: argparse.Namespace) -> tuple[Path, str, Path | None]:
    """The output path and format, and the preview path, all checked before any work."""
    city = Path(args.city)
    if args.format and args.output:
        suffix_kind = EXPAND_WRITERS.get(Path(args.output).suffix.lower())
        if suffix_kind is not None and suffix_kind != args.format:
            raise OptionError(f"--format {args.format} contradicts the output {args.output} "
                              f"(a {Path(args.output).suffix} file is {suffix_kind}); change one of them")
    default = FORMAT_SUFFIX[args.format or "urbanenvironment"]
    out, kind = _output_path(city, args.output, ".expanded" + default, EXPAND_WRITERS)
    preview = None
    if args.preview:
        preview = Path(args.preview)
        if preview.suffix.lower() not in (".png", ".svg"):
            raise OptionError(f"{args.preview}: the preview must be .png or .svg")
        try:
            _writable(preview)
        except OSError as exc:
            raise OutputError(f"{preview}: cannot write there ({exc.strerror or exc})") from None
    return out, args.format or kind, preview


#: The largest ``--area`` accepted, m²: 10,000 km², far past any district the engine can grow in a run
#: (Berlin is 891 km²); larger values are typos or fuzz and would only fail later, with a 300-digit number.
MAX_AREA_M2 = 1e10


def check_expand_options(args: argparse.Namespace):
    """The main command's options that need no input, checked before any work; returns the history.

    Also what ``batch`` checks before its first job (docs/batch.md). Sets
    ``args.land``, ``args.box``/``args.clip`` and parses ``--at``/``--at-lonlat``.
    """
    from osm_expand.engine.history import MAX_YEARS, load_history
    from osm_expand.land import LandOptions, parse_rules

    if args.area is not None and not (0 < args.area <= MAX_AREA_M2):
        raise OptionError(f"--area must be positive (m²) and at most {MAX_AREA_M2:.0e}, got {args.area:.6g}")
    args.land = LandOptions() if args.unbuildable is None else LandOptions(unbuildable=parse_rules(args.unbuildable))
    _check_points(args)
    _check_clip(args)
    history = load_history(args.history)
    years = history.years if args.years is None else args.years
    if years > MAX_YEARS:
        raise OptionError(f"--years {years}: at most {MAX_YEARS} years can be simulated")
    return history, years


def cmd_expand(args: argparse.Namespace, log: Progress) -> dict:
    from osm_expand.ingest import check_readable, load
    from osm_expand.pipeline import ExpandOptions, expand

    city_path = check_readable(args.city)
    out, kind, preview = _expand_outputs(args)
    if args.debug_layers and kind != "geojson":
        raise OptionError(f"--debug-layers needs a GeoJSON output (-o OUT.geojson), got {out.name}")
    history, years = check_expand_options(args)
    land = args.land
    snapshots = _snapshot_dir(args, years, history, _stem(city_path))
    with _read_from(args, city_path, out.parent, log) as (src, clip):
        # the extract stays until the output is written: the OSM output is the extract plus what grew
        log(f"reading {city_path}" + (" (the extract)" if clip else ""))
        city = load(src, service=args.service, paths=args.paths)
        log.add_stages(len(history.eras_visited(city.year, years)))  # a stage per era the run passes
        pictures: list = []
        options = ExpandOptions(seed=args.seed, direction=None if args.direction == "auto" else args.direction,
                                at=_site_point(args, city), area=args.area, beyond_bounds=args.beyond_bounds, land=land,
                                pattern=args.pattern, history=history, years=years,
                                snapshot=(lambda *picture: pictures.append(picture)) if snapshots else None,
                                snapshot_every=args.snapshot_every)
        try:
            result = expand(city, options, progress=log)
        except InputError as exc:
            raise _in_file(city_path, exc, args) from None
        report = result.report
        for note in report.get("notes", []):  # what a user should know of the result, even with -q
            print(f"osm-expand: {city_path}: {note}", file=sys.stderr)
        log(f"{len(result.city.new_streets())} new streets; writing {out}")
        title = f"{_shown(_stem(city_path))}: the town and what grew (seed {args.seed})"
        debug = list(result.growth.debug.get("features", [])) if args.debug_layers else None
        _write(result, out, kind, preview, title=title, snapshots=snapshots, pictures=pictures,
               stem=_stem(city_path), debug=debug)
    return {"input": str(city_path), "output": str(out), "format": kind, "seed": args.seed, **clip,
            **({"preview": str(preview)} if preview else {}),
            **({"snapshots": [str(snapshots / _snapshot_name(_stem(city_path), p[1], p[2])) for p in pictures]}
               if snapshots else {}), **report}


def _snapshot_dir(args: argparse.Namespace, years: int, history=None, stem: str = "") -> Path | None:
    """``--snapshots DIR``, checked before any work (made if missing), and the pictures' names with it."""
    try:
        return _checked_snapshot_dir(args, years, history, stem)
    except OSError as exc:  # a name or path too long, ...
        raise OutputError(f"--snapshots {args.snapshots}: cannot write there ({exc.strerror or exc})") from None


def _checked_snapshot_dir(args: argparse.Namespace, years: int, history, stem: str) -> Path | None:
    if args.snapshot_every is not None and not args.snapshots:
        raise OptionError("--snapshot-every needs --snapshots DIR")
    if not args.snapshots:
        return None
    if years == 0:
        raise OptionError("--snapshots needs simulated years (--years 0 was given)")
    folder = Path(args.snapshots)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"--snapshots {folder}: exists and is not a directory")
    if args.snapshot_every == 0:
        raise OptionError("--snapshot-every must be 1 or more")
    existing = folder
    while not existing.exists() and existing != existing.parent:  # made with its parents when written
        existing = existing.parent
    if not existing.is_dir():
        raise OutputError(f"--snapshots {folder}: {existing} is not a directory")
    try:
        from osm_expand.export.atomic import check_writable

        check_writable(existing / "probe.png")
        if history is not None:  # the longest picture name: a six-digit year, the longest era name
            era = max((e.name for e in history.eras), key=len, default="")
            check_writable(existing / _snapshot_name(stem, 999999, era))
    except OSError as exc:
        raise OutputError(f"--snapshots {folder}: cannot write into {existing} ({exc.strerror})") from None
    return folder


def _snapshot_name(stem: str, year: int, era: str) -> str:
    return f"{stem}-{year}-{era}.png"


def _write(result, out: Path, kind: str, preview: Path | None, title: str, *, snapshots: Path | None = None,
           pictures: Sequence = (), stem: str = "", debug: list | None = None) -> None:
    """The output, the preview and the snapshots, all or nothing."""
    from osm_expand.export import all_or_nothing, write_geojson, write_osm, write_urbanenvironment

    writer = {"urbanenvironment": write_urbanenvironment, "osm": write_osm, "geojson": write_geojson}[kind]
    with _writing(out), all_or_nothing():  # a failure of the output's writing or of the final renames
        if debug is not None:
            write_geojson(result.city, out, debug=debug)
        else:
            writer(result.city, out)
        if preview is not None:
            from osm_expand.export.preview import write_preview

            with _writing(preview):
                write_preview(result.city, preview, result.site.region, title=title)
        if snapshots is not None:
            from osm_expand.export.snapshot import write_snapshot

            with _writing(snapshots):
                snapshots.mkdir(parents=True, exist_ok=True)
            for city, year, era, traffic in pictures:
                picture = snapshots / _snapshot_name(stem, year, era)
                with _writing(picture):
                    write_snapshot(city, traffic, picture, title=f"{_shown(stem)} in {year}, end of era {era}")


#: Stages the main command reports (reading, learning, site, growing, judging, writing; "done" ends the last).
EXPAND_STAGES = 6


def _join_negative_values(argv: list[str]) -> list[str]:
    """``--at -76.5,39.3`` → ``--at=-76.5,39.3``: argparse would read the value as an option."""
    out, i = [], 0
    while i < len(argv):
        if argv[i] in _COORDINATE_OPTIONS and i + 1 < len(argv) and _NUMBERS.match(argv[i + 1]):
            out.append(f"{argv[i]}={argv[i + 1]}")
            i += 2
            continue
        out.append(argv[i])
        i += 1
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; its exit code (0, 1, 2; 130/143/129 when stopped by SIGINT/SIGTERM/SIGHUP)."""
    import warnings

    from osm_expand.interrupts import Interrupted, signals_raise

    try:
        with signals_raise(), warnings.catch_warnings():
            if not os.environ.get("OSM_EXPAND_DEBUG"):  # a library's warning is no line for the user (issue 21)
                warnings.simplefilter("ignore")
            return _main(argv)
    except Interrupted as exc:  # landed outside _main's own handler (parsing the arguments, say)
        return _interrupted(exc)


def _main(argv: Sequence[str] | None) -> int:
    from osm_expand.interrupts import Interrupted, received

    argv = _join_negative_values(list(sys.argv[1:] if argv is None else argv))
    if argv and argv[0] in COMMANDS:
        parser, command = build_parser(argv[0]), None
    else:
        parser, command = build_expand_parser(), cmd_expand
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, or a usage error already printed in one line
        return int(exc.code or 0)
    log = Progress(args.quiet, EXPAND_STAGES if command is cmd_expand else 0)
    try:
        report = (command or COMMANDS[args.command])(args, log)
        if (stopped := received()) is not None:  # a signal whose exception a library swallowed
            raise stopped
        log("done")
        log.close()
        if args.json:
            print(json.dumps(report, sort_keys=True))
        return 0
    except InputError as exc:
        log.close()
        print(f"{PROG}: {_one_line(str(exc))}", file=sys.stderr)
        return getattr(exc, "exit_code", 2)
    except KeyboardInterrupt as exc:  # Ctrl-C, SIGTERM, SIGHUP (osm_expand.interrupts)
        log.close()
        return _interrupted(exc if isinstance(exc, Interrupted) else Interrupted())
    except MemoryError:
        log.close()
        where = getattr(args, "city", None)
        print(f"{PROG}: {_one_line(str(where)) + ': ' if where else ''}not enough memory for this input",
              file=sys.stderr)
        return 2
    except Exception as exc:  # a bug: say so in one line, details on request
        log.close()
        stopped = received()
        if stopped is not None:  # the interrupt, turned into another exception by a C extension's callback
            return _interrupted(stopped)
        if os.environ.get("OSM_EXPAND_DEBUG"):
            raise
        print(f"{PROG}: internal error: {type(exc).__name__}: {_one_line(str(exc))} "
              "(set OSM_EXPAND_DEBUG=1 for a traceback)", file=sys.stderr)
        return 1


def _interrupted(exc) -> int:
    """Say so (naming the signal unless it is Ctrl-C); the exit code, 128 + the signal's number."""
    print(f"{PROG}: interrupted" + (f" ({exc.args[0]})" if exc.exit_code != 130 else ""), file=sys.stderr)
    return exc.exit_code


def _shown(name: str) -> str:
    """A file name as a picture's title shows it: bytes that are not UTF-8 (kept by Python as lone
    surrogates, which matplotlib refuses) as U+FFFD."""
    return os.fsencode(name).decode("utf-8", "replace")


def _one_line(text: str) -> str:
    """A message on one line: a file name with a newline or a control character shown escaped."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


if __name__ == "__main__":
    sys.exit(main())
