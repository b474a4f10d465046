"""The ``osm-expand`` command: argument parsing, files, progress, exit codes.

``osm-expand CITY [options]`` grows the town; ``osm-expand COMMAND ...`` runs
one of :data:`COMMANDS`. Exit codes: 0 success, 2 bad usage or unusable
input (one line on stderr naming the file and the problem, nothing written),
1 an internal error. Everything that can be checked before the work is
checked first. Results go to files or, with ``--json``, to stdout;
progress goes to stderr (a progress bar; ``-q`` silences it). Each command
imports what it needs inside its function, for start-up time only
(``osm-expand --help`` in 0.08 s); no import cycle is dodged.

The main command is one call of :func:`osm_expand.app.run_expand` (read,
expand, mature, write atomically), which ``batch`` calls too; its options
are declared once in :data:`osm_expand.app.EXPAND_ARGUMENTS`. This module
parses the command line, shows progress and turns errors into exit codes.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import sys
import time
from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path
from typing import NoReturn

from osm_expand.app import (
    CLIP_ARGUMENTS,
    EXPAND_ARGUMENTS,
    INPUT_ARGUMENTS,
    PROG,
    ExpandRequest,
    add_arguments,
    check_clip,
    clip_text,
    exit_code,
    in_file,
    one_line,
    output_path,
    read_from,
    run_expand,
    seed_value,
    writing,
)
from osm_expand.errors import InputError, OptionError
from osm_expand.gcpause import cyclic_gc_paused  # 0.2 ms (gc and contextlib): imported once, here

#: ``simplify``'s output writers by suffix.
OUTPUT_WRITERS = {".osm": "osm", ".geojson": "geojson", ".json": "geojson"}
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
        self.exit(2, f"{PROG}: error: {one_line(message)} (see '{PROG} --help')\n")


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


def _add_input_options(p: argparse.ArgumentParser, *, reading: bool = True) -> None:
    p.add_argument("city", help="OSM extract: .osm, .osm.gz, .osm.bz2 or .osm.pbf")
    if reading:  # the main command adds them with the rest of its options
        add_arguments(p, INPUT_ARGUMENTS)
    p.add_argument("--json", action="store_true", help="print the report as one JSON object on stdout")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The sub-commands' parser (``osm-expand COMMAND ...``); ``batch``'s options only when ``command`` is batch."""
    parser = _Parser(prog=PROG, description="Grow a real OpenStreetMap town.")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser, metavar="COMMAND")
    simp = sub.add_parser("simplify", help="simplify a town's streets into junctions and whole streets",
                          description="Simplify a town's street network (seed 004 §4.2) and write it.")
    _add_input_options(simp)
    add_arguments(simp, CLIP_ARGUMENTS)
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
    rep.add_argument("--seed", type=seed_value, default=0, help="random seed (default 0)")
    comp = sub.add_parser("compare", help="is network A as alike to B as B's own districts are?",
                          description="Judge A as a district of B: 13 measures of street networks against "
                                      "real parts of B of A's size (any file the tool reads).")
    _add_input_options(comp)
    comp.add_argument("other", help="the town to compare with (B)")
    comp.add_argument("--seed", type=seed_value, default=0, help="random seed for the real parts (default 0)")
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
    _add_input_options(p, reading=False)
    add_arguments(p, EXPAND_ARGUMENTS)
    return p


COMMAND_USAGE = {
    "simplify": "CITY [-o OUT.osm|OUT.geojson] [--json]   the town's streets simplified (004 §4.2)",
    "stats": "FILE [--json]                           street statistics of a town or an output",
    "reproduce": "CITY [--seed N] [--json]               re-walk the town's junctions, scored",
    "compare": "A B [--seed N] [--json]                 is A as alike to B as B's own districts are?",
    "batch": "IN... --out DIR [--towns T.csv] [--workers N|--scheduler ADDR]   many towns (docs/batch.md)",
}


def _simplify_or_fail(city: Path, net, args: argparse.Namespace, options=None):
    """Simplify, or fail in one line naming the file when nothing is left.

    (``pipeline.simplified_or_fail`` without importing the pipeline, which costs
    ``simplify``, ``stats`` and ``reproduce`` 0.7 s of SciPy, scikit-learn and synth imports.)
    """
    from simplify import simplify

    result = simplify(net, options)
    if not result.network.streets:
        from osm_expand.pipeline import NOTHING_LEFT

        raise in_file(city, InputError(NOTHING_LEFT), args.service) from None
    return result


def cmd_simplify(args: argparse.Namespace, log: Progress) -> dict:
    from osm_expand import export
    from osm_expand.ingest import load
    from osm_expand.model import City
    from simplify import SimplifyOptions
    from simplify.invariants import violations

    city = Path(args.city)
    out, kind = output_path(city, args.output, ".simplified.osm", OUTPUT_WRITERS)
    if args.cluster_radius is not None and not 0 < args.cluster_radius < float("inf"):
        raise OptionError(f"--cluster-radius must be positive and finite (metres), got {args.cluster_radius:g}")
    box, clip_options = check_clip(args.bbox, args.around, args.radius, args.clip_index)
    what = clip_text(args.bbox, args.around, args.radius) if box is not None else ""
    with cyclic_gc_paused():  # millions of short-lived objects on a large file (osm_expand.gcpause)
        with read_from(city, box, clip_options, what, out.parent, log) as (src, clip):
            log(f"reading {city}" + (" (the extract)" if clip else ""))
            net = load(src, service=args.service, paths=args.paths, context=False).network
        log(f"{len(net.streets)} streets, {len(net.xy)} street nodes; simplifying")
        opts = SimplifyOptions() if args.cluster_radius is None else SimplifyOptions(cluster_radius=args.cluster_radius)
        result = _simplify_or_fail(city, net, args, opts)
        log(f"{result.report['junctions']} junctions, {result.report['streets']} streets; writing {out}")
        write = export.write_osm if kind == "osm" else export.write_geojson  # loads that writer alone
        with writing(out):
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


def cmd_expand(args: argparse.Namespace, log: Progress, *, last: bool = False) -> dict:
    """The main command: one :func:`osm_expand.app.run_expand` with this command line's options, with the
    cyclic collector paused (:mod:`osm_expand.gcpause`: the engine's years make almost no cyclic garbage, and
    the collector's walks over the live town were 4.2 s of Campo Grande's default run). ``last``: the process
    ends with this command, so what the run leaves alive is frozen, never walked again (its few cyclic
    garbage objects with it, never collected: the process exits next; :mod:`osm_expand.gcpause`)."""
    with cyclic_gc_paused(freeze=last):
        return run_expand(ExpandRequest.from_namespace(args), progress=log, stages=log.add_stages)


def cmd_batch(args: argparse.Namespace, log: Progress) -> dict:
    """``osm-expand batch``: one job per input or per town (osm_expand.batch)."""
    from osm_expand.batch import cmd_batch as run

    return run(args, log)


COMMANDS: dict[str, Callable[[argparse.Namespace, Progress], dict]] = {
    "simplify": cmd_simplify, "stats": cmd_stats, "reproduce": cmd_reproduce, "compare": cmd_compare,
    "batch": cmd_batch}


#: Stages the main command always reports (reading, learning, site, growing, writing; "done" ends the last);
#: judging the district, only with --json, and an era each are added by the run (``stages``).
EXPAND_STAGES = 5


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
    finally:
        if argv is None:  # the command line's own process, which now exits
            _leave()


def _leave() -> None:
    """Freeze every live object (:func:`gc.freeze`) before the process exits: Python's exit collects the
    cyclic garbage of all that lives, walking every object several times as it tears the modules down
    (Krems' default run: 0.4-0.7 s of CPU), and what a command leaves alive is modules, memos and a town
    that reference counting frees. The cyclic garbage made while the collector was paused (Krems'
    default run: 802 objects) is frozen with them: never collected, its finalizers never run, which
    is harmless as the process exits next, its files written and closed. Only when :func:`main` reads
    the process's own command line (``argv`` None): a caller in the same process (a test) keeps its
    collector as it was."""
    import gc

    gc.freeze()


def _main(argv: Sequence[str] | None) -> int:
    from osm_expand.interrupts import Interrupted, received

    last = argv is None  # the process's own command line: the process ends with this command
    argv = _join_negative_values(list(sys.argv[1:] if argv is None else argv))
    if argv and argv[0] in COMMANDS:
        parser, command = build_parser(argv[0]), None
    else:  # the main command; the process ends with it when this is the process's own command line
        parser, command = build_expand_parser(), partial(cmd_expand, last=last)
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, or a usage error already printed in one line
        return int(exc.code or 0)
    log = Progress(args.quiet, EXPAND_STAGES if command is not None else 0)
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
        print(f"{PROG}: {one_line(str(exc))}", file=sys.stderr)
        return exit_code(exc)
    except KeyboardInterrupt as exc:  # Ctrl-C, SIGTERM, SIGHUP (osm_expand.interrupts)
        log.close()
        return _interrupted(exc if isinstance(exc, Interrupted) else Interrupted())
    except MemoryError:
        log.close()
        where = getattr(args, "city", None)
        print(f"{PROG}: {one_line(str(where)) + ': ' if where else ''}not enough memory for this input",
              file=sys.stderr)
        return 2
    except Exception as exc:  # a bug: say so in one line, details on request
        log.close()
        stopped = received()
        if stopped is not None:  # the interrupt, turned into another exception by a C extension's callback
            return _interrupted(stopped)
        if os.environ.get("OSM_EXPAND_DEBUG"):
            raise
        print(f"{PROG}: internal error: {type(exc).__name__}: {one_line(str(exc))} "
              "(set OSM_EXPAND_DEBUG=1 for a traceback)", file=sys.stderr)
        return 1


def _interrupted(exc) -> int:
    """Say so (naming the signal unless it is Ctrl-C); the exit code, 128 + the signal's number."""
    print(f"{PROG}: interrupted" + (f" ({exc.args[0]})" if exc.exit_code != 130 else ""), file=sys.stderr)
    return exc.exit_code


if __name__ == "__main__":
    sys.exit(main())
