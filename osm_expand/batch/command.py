"""``osm-expand batch`` on the command line: its options (the main command's pipeline options among them, from
:data:`osm_expand.app.EXPAND_ARGUMENTS`), and the report and exit code of :func:`cmd_batch`."""
from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path

from osm_expand.app import EXPAND_ARGUMENTS, PROG, Argument, add_arguments
from osm_expand.batch.run import _count, run_batch
from osm_expand.errors import InputError

__all__ = ["PIPELINE_ARGUMENTS", "JobsFailed", "add_batch_arguments", "cmd_batch", "pipeline_argv"]

#: Options of the main command that are the batch's own (not copied into the batch parser).
_NOT_PIPELINE = {"output", "seed", "preview"}
#: The main command's options a batch passes to every job, in the main command's order.
PIPELINE_ARGUMENTS: tuple[Argument, ...] = tuple(a for a in EXPAND_ARGUMENTS if a.dest not in _NOT_PIPELINE)


class JobsFailed(InputError):
    """Some jobs of a batch failed (the others ran; ``summary.json`` has them all).

    ``exit_code`` is 2 when every failure was the input's (a job's exit code
    2), else 1 (an internal error, or a worker that died).
    """

    def __init__(self, message: str, exit_code: int = 2):
        super().__init__(message)
        self.exit_code = exit_code


def add_batch_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``batch`` sub-command's options, the main command's pipeline options included.

    The pipeline options are the main command's own table
    (:data:`PIPELINE_ARGUMENTS`, from :data:`osm_expand.app.EXPAND_ARGUMENTS`,
    so new ones follow automatically), kept as text, to be passed to every
    job as given.
    """

    parser.description = ("Grow many towns: one job per input, or per row of --towns against one large input "
                          "(read once), on a local Dask cluster or an existing one.")
    parser.add_argument("inputs", nargs="+", metavar="INPUT", help="OSM extracts (with --towns: one large file)")
    parser.add_argument("--out", required=True, metavar="DIR",
                        help="output folder: NAME.expanded.xml, logs/NAME.log, clips/, summary.json")
    parser.add_argument("--towns", metavar="TOWNS.csv",
                        help="a table name,lon,lat,radius (degrees, metres): one job per town, clipped from the input")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, metavar="N",
                       help="local worker processes, one thread each (default: the CPU count)")
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="an existing Dask cluster: tcp://host:port or a scheduler file (never shut down)")
    parser.add_argument("--seed", type=int, default=0,
                        help="batch seed; each job's seed derives from it and the job's name (default 0)")
    parser.add_argument("--preview", choices=["png", "svg"], help="also draw each town's map as DIR/NAME.png|svg")
    parser.add_argument("--json", action="store_true", help="print the batch report as one JSON object on stdout")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    group = parser.add_argument_group("pipeline options (passed to every job as given; see osm-expand --help)")
    add_arguments(group, PIPELINE_ARGUMENTS, as_text=True, dest_prefix="pipeline__")
    parser.set_defaults(batch_pipeline_options=tuple(
        ("pipeline__" + a.flag.lstrip("-").replace("-", "_"), a.flag, a.takes_value) for a in PIPELINE_ARGUMENTS))


def pipeline_argv(args: argparse.Namespace) -> list[str]:
    """The pipeline options given to ``batch``, as main-command arguments (in the main parser's order)."""
    argv = []
    for dest, flag, takes_value in getattr(args, "batch_pipeline_options", ()):
        if not hasattr(args, dest):
            continue
        argv += [f"{flag}={getattr(args, dest)}"] if takes_value else [flag]
    return argv


def cmd_batch(args: argparse.Namespace, log: Callable[[str], None]) -> dict:
    """``osm-expand batch``: run the jobs, write ``summary.json``, return the report.

    Raises :class:`JobsFailed` (exit 2) after all jobs ran if any failed,
    having printed each failure in one line on stderr (and the report on
    stdout with ``--json``).
    """
    summary = run_batch(args.inputs, args.out, towns=args.towns, workers=args.workers, scheduler=args.scheduler,
                        seed=args.seed, pipeline_args=pipeline_argv(args), preview=args.preview,
                        progress=not args.quiet and sys.stderr.isatty(), log=log)
    report = summary.to_dict()
    failed = summary.failed
    summary_path = Path(summary.out_dir) / "summary.json"
    if not failed:
        if not args.json:
            print(f"{_count(len(summary.jobs), 'job')} ok in {summary.seconds:.1f} s on {summary.where}; "
                  f"{summary_path}")
        return report
    for job in failed:
        print(f"{PROG}: batch: {job.name} failed: {job.error}", file=sys.stderr)
    if args.json:
        print(json.dumps(report, sort_keys=True))
    code = 2 if all(job.exit_code == 2 for job in failed) else 1
    raise JobsFailed(f"{len(failed)} of {_count(len(summary.jobs), 'job')} failed; see {summary_path}", code)
