"""The ``osm-expand`` command: argument parsing, files, logging, exit codes.

Exit codes: 0 success, 2 bad usage or unusable input (one line on stderr
naming the file and the problem, nothing written), 1 an internal error.
Results go to files or, with ``--json``, to stdout; everything else goes to
stderr.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from osm_expand.errors import InputError

PROG = "osm-expand"
OUTPUT_WRITERS = {".osm": "osm", ".geojson": "geojson", ".json": "geojson"}


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2
        self.exit(2, f"{PROG}: error: {message} (see '{PROG} --help')\n")


class _Log:
    """Progress lines with elapsed time on stderr, silent with --quiet."""

    def __init__(self, quiet: bool):
        self.quiet = quiet
        self.t0 = time.perf_counter()

    def __call__(self, message: str) -> None:
        if not self.quiet:
            print(f"[{time.perf_counter() - self.t0:6.2f}s] {message}", file=sys.stderr, flush=True)


def _add_input_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("city", help="OSM extract: .osm, .osm.gz, .osm.bz2 or .osm.pbf")
    p.add_argument("--service", action="store_true", help="also keep highway=service roads")
    p.add_argument("--paths", action="store_true", help="also keep footways, paths, tracks and cycleways")
    p.add_argument("--json", action="store_true", help="print the report as one JSON object on stdout")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog=PROG, description="Grow a real OpenStreetMap town.")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser, metavar="COMMAND")
    simp = sub.add_parser("simplify", help="simplify a town's streets into junctions and whole streets",
                          description="Simplify a town's street network (seed 004 §4.2) and write it.")
    _add_input_options(simp)
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
    rep.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    return parser


def _output_path(city: Path, output: str | None, default_suffix: str,
                 writers: dict[str, str] = OUTPUT_WRITERS) -> tuple[Path, str]:
    path = Path(output) if output else city.with_name(_stem(city) + default_suffix)
    kind = writers.get(path.suffix.lower())
    if kind is None:
        raise InputError(f"{path}: unsupported output type (use {' or '.join(sorted(writers))})")
    if not path.parent.exists() and str(path.parent) != "":
        raise InputError(f"{path}: output directory does not exist")
    if path.is_dir():
        raise InputError(f"{path}: is a directory")
    return path, kind


def _stem(path: Path) -> str:
    name = path.name
    for suffix in (".osm.gz", ".osm.bz2", ".osm.pbf", ".osm", ".pbf", ".gz", ".bz2", ".xml"):
        if name.lower().endswith(suffix):
            return name[: -len(suffix)]
    return path.stem


def _simplify_or_fail(city: Path, net, args: argparse.Namespace, options=None):
    """Simplify, or fail in one line naming the file when nothing is left."""
    from osm_expand.pipeline import simplified_or_fail

    try:
        return simplified_or_fail(net, options)
    except InputError as exc:
        raise _in_file(city, exc, args) from None


def _in_file(city: Path, exc: InputError, args: argparse.Namespace) -> InputError:
    """The error, naming the file; when nothing survived simplification, what might help."""
    from osm_expand.pipeline import NOTHING_LEFT

    hint = "; try --service" if str(exc) == NOTHING_LEFT and not args.service else ""
    return InputError(f"{city}: {exc}{hint}")


def cmd_simplify(args: argparse.Namespace, log: _Log) -> dict:
    from osm_expand.export import write_geojson, write_osm
    from osm_expand.ingest import load
    from simplify import SimplifyOptions
    from simplify.invariants import violations

    city = Path(args.city)
    out, kind = _output_path(city, args.output, ".simplified.osm")
    if args.cluster_radius is not None and not args.cluster_radius > 0:
        raise InputError(f"--cluster-radius must be positive, got {args.cluster_radius}")
    log(f"reading {city}")
    net = load(city, service=args.service, paths=args.paths, context=False)
    log(f"{len(net.streets)} streets, {len(net.xy)} street nodes; simplifying")
    opts = SimplifyOptions() if args.cluster_radius is None else SimplifyOptions(cluster_radius=args.cluster_radius)
    result = _simplify_or_fail(city, net, args, opts)
    log(f"{result.report['junctions']} junctions, {result.report['streets']} streets; writing {out}")
    (write_osm if kind == "osm" else write_geojson)(result.network, out)
    broken = {k: v for k, v in violations(result.network).items() if v}
    if broken:  # never expected: say so rather than hand over a flawed network silently
        print(f"{PROG}: warning: {out}: simplified network still has {broken}; please report this input",
              file=sys.stderr)
    return {"input": str(city), "output": str(out), "violations": broken, **result.report}


def cmd_stats(args: argparse.Namespace, log: _Log) -> dict:
    from osm_expand.ingest import load
    from simplify.example import build_example
    from simplify.invariants import is_valid
    from simplify.statistics import example_statistics

    city = Path(args.city)
    log(f"reading {city}")
    net = load(city, service=args.service, paths=args.paths, context=False)
    dead_ends = None
    if not is_valid(net):  # raw OSM: simplify first; an osm-expand output already is
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


def cmd_reproduce(args: argparse.Namespace, log: _Log) -> dict:
    from osm_expand.ingest import load
    from simplify.example import build_example
    from synth.reproduce import reproduce

    city = Path(args.city)
    log(f"reading {city}")
    net = load(city, service=args.service, paths=args.paths, context=False)
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


COMMANDS: dict[str, Callable[[argparse.Namespace, _Log], dict]] = {
    "simplify": cmd_simplify, "stats": cmd_stats, "reproduce": cmd_reproduce}


EXPAND_WRITERS = {".xml": "urbanenvironment", ".osm": "osm", ".geojson": "geojson", ".json": "geojson"}
FORMAT_SUFFIX = {"urbanenvironment": ".xml", "osm": ".osm", "geojson": ".geojson"}


def build_expand_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Grow a district next to a real town and write it "
                                       "(osm-expand COMMAND --help for the other commands: simplify, stats, reproduce).")
    _add_input_options(p)
    p.add_argument("-o", "--output", help="output file (default: CITY.expanded.xml beside the input)")
    p.add_argument("--format", choices=sorted(FORMAT_SUFFIX), help="output format (default: from -o, else urbanenvironment)")
    p.add_argument("--preview", metavar="OUT.png|OUT.svg", help="also draw a map of the result")
    p.add_argument("--seed", type=int, default=0, help="random seed; the same seed gives the same bytes")
    p.add_argument("--direction", choices=["auto", "N", "NE", "E", "SE", "S", "SW", "W", "NW"], default="auto",
                   help="grow on this side of the town (default: the best site anywhere)")
    p.add_argument("--at", metavar="X,Y", help="site centre in metres of the local projection")
    p.add_argument("--at-lonlat", metavar="LON,LAT", help="site centre in degrees")
    p.add_argument("--area", type=float, metavar="M2", help="district area in m² (default: a quarter of the built-up area)")
    return p


def _pair(text: str, flag: str) -> tuple[float, float]:
    try:
        a, b = (float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"{flag} expects two numbers separated by a comma, got {text!r}") from None
    return a, b


def cmd_expand(args: argparse.Namespace, log: _Log) -> dict:
    from osm_expand.pipeline import ExpandOptions, expand
    from osm_expand.export import write_geojson, write_osm, write_urbanenvironment
    from osm_expand.ingest import check_readable, load

    city = Path(args.city)
    default = FORMAT_SUFFIX[args.format or "urbanenvironment"]
    out, kind = _output_path(city, args.output, ".expanded" + default, EXPAND_WRITERS)
    kind = args.format or kind
    if args.preview and Path(args.preview).suffix.lower() not in (".png", ".svg"):
        raise InputError(f"{args.preview}: the preview must be .png or .svg")
    if args.area is not None and not args.area > 0:
        raise InputError(f"--area must be positive, got {args.area}")
    at = _pair(args.at, "--at") if args.at else None
    lonlat = _pair(args.at_lonlat, "--at-lonlat") if args.at_lonlat else None
    if lonlat and not (-180 <= lonlat[0] <= 180 and -90 <= lonlat[1] <= 90):
        raise InputError(f"--at-lonlat {lonlat[0]},{lonlat[1]} is not a longitude,latitude")
    check_readable(city)
    log(f"reading {city}")
    raw = load(city, service=args.service, paths=args.paths)
    if lonlat:
        x, y = raw.context.projection.to_xy(lonlat[0], lonlat[1])
        at = (float(x), float(y))
    options = ExpandOptions(seed=args.seed, direction=None if args.direction == "auto" else args.direction,
                            at=at, area=args.area)
    try:
        result = expand(raw, options, progress=log)
    except InputError as exc:
        raise _in_file(city, exc, args) from None
    log(f"{result.report['grown_streets']} new streets, {result.report['connections']} joins to the town; writing {out}")
    if kind == "urbanenvironment":
        write_urbanenvironment(result.network, out, origins=result.origins)
    elif kind == "osm":
        write_osm(result.network, out)
    else:
        write_geojson(result.network, out)
    if args.preview:
        from osm_expand.export.preview import write_preview

        write_preview(result.network, result.origins, args.preview, result.site.region,
                      title=f"{_stem(city)}: grown district (seed {args.seed})")
        log(f"preview written to {args.preview}")
    return {"input": str(city), "output": str(out), "format": kind, "seed": args.seed, **result.report}


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    if argv and argv[0] not in COMMANDS and not argv[0].startswith("-"):
        parser = build_expand_parser()
        command = cmd_expand
    else:
        command = None
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, or a usage error already printed in one line
        return int(exc.code or 0)
    if command is None and args.command is None:
        parser.print_help(sys.stderr)
        return 2
    log = _Log(args.quiet)
    try:
        report = (command or COMMANDS[args.command])(args, log)
    except InputError as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # a bug: say so in one line, details on request
        if os.environ.get("OSM_EXPAND_DEBUG"):
            raise
        print(f"{PROG}: internal error: {type(exc).__name__}: {exc} "
              "(set OSM_EXPAND_DEBUG=1 for a traceback)", file=sys.stderr)
        return 1
    if args.json:
        print(json.dumps(report, sort_keys=True))
    log("done")
    return 0


if __name__ == "__main__":
    sys.exit(main())
