"""Many towns in one go: ``osm-expand batch``, one job per town, on Dask (``dask.distributed``).

A job is exactly the main command, ``osm-expand INPUT -o DIR/NAME.expanded.xml
--seed SEED [pipeline options]``: a worker (:func:`run_job`) parses those
arguments into an :class:`~osm_expand.app.ExpandRequest` and calls
:func:`osm_expand.app.run_expand`, the function the main command calls, its
progress and errors written to ``DIR/logs/NAME.log``. So a job's output is
byte for byte what that single command writes, and anyone can rerun one job
alone. The pipeline options are declared once
(:data:`osm_expand.app.EXPAND_ARGUMENTS`); this module never imports the
command line (:mod:`osm_expand.cli`).

Jobs come from input files (one each, named by the file's stem) or from the
rows of a towns table (``name,lon,lat,radius`` in degrees and metres) against
one large input: the input is read once by :func:`osm_expand.clip.clip_extracts`,
every town's extract is written into ``DIR/clips/`` in that one read, and the
small extracts are farmed out.

Determinism: a job's seed is :func:`derive_seed` of the batch seed and the
job's name (BLAKE2b, not Python's salted ``hash``), so it is the same on any
machine, in any order, with any number of workers; task keys are unique per
batch (``pure=False``); nothing per-process (times, pids, temporary paths)
reaches an output. pyosmium's thread pool is limited to one thread inside
workers (``OSMIUM_POOL_THREADS=1``), since the workers themselves are the
parallelism.

Where jobs run:

- default: a local cluster of N worker processes with one thread each
  (``distributed.LocalCluster``), N = ``workers`` or the number of CPUs, at
  most one per job; closed at the end;
- ``scheduler``: an existing cluster (``tcp://host:port`` or a scheduler
  file). Before any job, every worker must import the same osm-expand
  (version and source) and see the inputs and the output folder; if not,
  one line says which worker lacks what. A user's cluster is never shut down.
  A job captures its process's stderr into its log, so a worker runs one job
  at a time: give workers one thread (``dask worker --nthreads 1``);
- without Dask installed, ``workers=1`` runs the jobs one after the other in
  this process (no isolation from a crash); anything else says how to
  install Dask (``pip install 'osm-expand[cluster]'``).

A failing job (exit code ≠ 0, an exception, or a worker that died under it,
e.g. killed for memory) is recorded with its one-line error and does not
stop the others. ``DIR/summary.json`` lists every job: status, seconds,
seed, exit code, error, counts from the job's report and output paths.
"""
from __future__ import annotations

import argparse
import contextlib
import csv
import hashlib
import json
import math
import os
import sys
import threading
import time
import typing
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass, field
from enum import StrEnum
from functools import lru_cache
from pathlib import Path

from osm_expand.app import EXPAND_ARGUMENTS, Argument, ExpandRequest, add_arguments, check_options, exit_code, one_line
from osm_expand.errors import InputError, OptionError, OutputError, UnreadableInputError

__all__ = ["BatchSummary", "Job", "JobResult", "JobStatus", "JobsFailed", "Town", "add_batch_arguments", "cmd_batch",
           "derive_seed", "read_towns", "run_batch", "run_job"]

INSTALL_HINT = "pip install 'osm-expand[cluster]'"
#: How the main command starts its one-line errors.
_PREFIX = "osm-expand: "
#: Output suffix of each ``--format``.
FORMAT_SUFFIX = {"urbanenvironment": ".xml", "osm": ".osm", "geojson": ".geojson"}
#: Suffixes dropped from an input's name to name its job.
_OSM_SUFFIXES = (".osm.pbf", ".osm.gz", ".osm.bz2", ".osm", ".pbf", ".xml.gz", ".xml.bz2", ".xml", ".geojson", ".json")
#: Main-command options a batch sets per job itself (refused among the pipeline options).
_PER_JOB = {"-o", "--output", "--seed", "--preview", "--version", "-h", "--help"}
#: Main-command options that clip the input (a towns table does that itself).
_CLIP_OPTIONS = {"--bbox", "--around", "--radius", "--clip-index"}
#: Options of the main command that are the batch's own (not copied into the batch parser).
_NOT_PIPELINE = {"output", "seed", "preview"}
#: The main command's options a batch passes to every job, in the main command's order.
PIPELINE_ARGUMENTS: tuple[Argument, ...] = tuple(a for a in EXPAND_ARGUMENTS if a.dest not in _NOT_PIPELINE)
#: The seed derivation's modulus: seeds stay below 2**31, valid for every numpy generator.
SEED_MODULUS = 2 ** 31
#: Packages whose sources must match between this process and a cluster's workers.
_PACKAGES = ("osm_expand", "simplify", "synth")


# --- jobs --------------------------------------------------------------------------------------------


def derive_seed(seed: int, name: str) -> int:
    """A job's seed from the batch seed and its name, the same in every process and on every machine.

    ``int(BLAKE2b-64(f"{seed}:{name}")) mod 2**31`` (big-endian digest).

    Parameters
    ----------
    seed : int
        The batch seed, ≥ 0.
    name : str
        The job's name.

    Returns
    -------
    int
        In ``[0, 2**31)``.
    """
    digest = hashlib.blake2b(f"{seed}:{name}".encode(), digest_size=8).digest()
    return int.from_bytes(digest, "big") % SEED_MODULUS


@dataclass(frozen=True)
class Job:
    """One run of the main command (absolute paths: workers may run elsewhere)."""

    name: str
    input: str
    output: str
    log: str
    seed: int
    #: the pipeline options passed through, in order
    args: tuple[str, ...] = ()
    #: the preview drawn beside the output, if any
    preview: str | None = None

    def argv(self) -> list[str]:
        """The main command's arguments for this job."""
        extra = ["--preview", self.preview] if self.preview else []
        return [self.input, "-o", self.output, "--seed", str(self.seed), *extra, *self.args]


class JobStatus(StrEnum):
    """A job's outcome."""

    OK = "ok"
    FAILED = "failed"


@dataclass
class JobResult:
    """How a job went."""

    name: str
    input: str
    status: JobStatus
    seconds: float
    seed: int
    exit_code: int | None = None
    error: str | None = None
    #: the numbers of the job's report (streets, joins, areas, ...)
    counts: dict = field(default_factory=dict)
    outputs: list[str] = field(default_factory=list)
    log: str | None = None


@dataclass
class BatchSummary:
    """Every job's result, by name, and how the batch ran."""

    jobs: list[JobResult]
    seed: int
    seconds: float
    where: str
    out_dir: str
    clips: dict = field(default_factory=dict)

    @property
    def failed(self) -> list[JobResult]:
        return [j for j in self.jobs if j.status != JobStatus.OK]

    def to_dict(self) -> dict:
        return {"out_dir": self.out_dir, "seed": self.seed, "where": self.where, "seconds": round(self.seconds, 2),
                "jobs_total": len(self.jobs), "jobs_ok": len(self.jobs) - len(self.failed),
                "jobs_failed": len(self.failed), **({"clips": self.clips} if self.clips else {}),
                "jobs": [asdict(j) for j in self.jobs]}


class JobsFailed(InputError):
    """Some jobs of a batch failed (the others ran; ``summary.json`` has them all).

    ``exit_code`` is 2 when every failure was the input's (a job's exit code
    2), else 1 (an internal error, or a worker that died).
    """

    def __init__(self, message: str, exit_code: int = 2):
        super().__init__(message)
        self.exit_code = exit_code


@contextlib.contextmanager
def _environment(**values: str) -> Iterator[None]:
    old = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


#: One job at a time per process: a job redirects the process's stderr, so a worker
#: with several threads (a user's cluster) still runs its jobs one after the other.
_ONE_JOB_AT_A_TIME = threading.Lock()


def run_job(job: Job) -> JobResult:
    """Run one job as the main command does; never raises for the job's own failure.

    The job's arguments are parsed as the main command parses them and run
    by :func:`osm_expand.app.run_expand`; its progress, notes and one-line
    error go to ``job.log`` (a timed line each, as the main command prints
    them when stderr is no terminal), its report gives the counts. pyosmium
    gets one thread. An interrupt (Ctrl-C) is not a job's failure: it
    propagates.
    """
    import warnings

    from osm_expand.app import run_expand

    with _ONE_JOB_AT_A_TIME:
        t0 = time.perf_counter()
        report: dict = {}
        with open(job.log, "w", encoding="utf-8") as log, _environment(OSMIUM_POOL_THREADS="1"), \
                contextlib.redirect_stderr(log), warnings.catch_warnings():
            if not os.environ.get("OSM_EXPAND_DEBUG"):  # a library's warning is no line for the user (issue 21)
                warnings.simplefilter("ignore")

            def say(message: str) -> None:
                print(f"[{time.perf_counter() - t0:6.2f}s] {message}", file=log, flush=True)

            try:
                report = run_expand(_job_request(job), progress=say)
                say("done")
                code = 0
            except (KeyboardInterrupt, SystemExit):
                raise
            except InputError as exc:
                print(f"{_PREFIX}{one_line(str(exc))}", file=log)
                code = exit_code(exc)
            except MemoryError as exc:
                print(f"{_PREFIX}{one_line(job.input)}: not enough memory for this input", file=log)
                code = exit_code(exc)
            except Exception as exc:  # noqa: BLE001 - a bug in this job: recorded, the others go on
                print(f"{_PREFIX}internal error: {type(exc).__name__}: {one_line(str(exc))}", file=log)
                code = exit_code(exc)
        seconds = time.perf_counter() - t0
    result = JobResult(name=job.name, input=job.input, status=JobStatus.OK if code == 0 else JobStatus.FAILED,
                       seconds=round(seconds, 2), seed=job.seed, exit_code=code, log=job.log)
    if code == 0:
        result.counts = {k: v for k, v in sorted(report.items())
                         if isinstance(v, (int, float)) and not isinstance(v, bool)}
        result.outputs = [job.output] + ([job.preview] if job.preview else [])
    else:
        result.error = _error_line(Path(job.log), code)
    return result


class _ArgumentsParser(argparse.ArgumentParser):
    """The main command's options parsed without printing or exiting: a bad one is an :class:`OptionError`."""

    def error(self, message: str) -> typing.NoReturn:
        raise OptionError(message)


def _request_parser() -> argparse.ArgumentParser:
    """A parser of the main command's arguments (the input and :data:`~osm_expand.app.EXPAND_ARGUMENTS`)."""
    parser = _ArgumentsParser(prog="osm-expand", add_help=False)
    parser.add_argument("city")
    add_arguments(parser, EXPAND_ARGUMENTS)
    return parser


def request_from_argv(argv: Sequence[str]) -> ExpandRequest:
    """The request of a main command's arguments (``INPUT -o OUT --seed N [pipeline options]``)."""
    return ExpandRequest.from_namespace(_request_parser().parse_args(list(argv)))


def _job_request(job: Job) -> ExpandRequest:
    return request_from_argv(job.argv())


def _error_line(log: Path, code: int) -> str:
    """The main command's one-line error from the job's log."""
    lines = [ln.strip() for ln in log.read_text(encoding="utf-8", errors="replace").splitlines() if ln.strip()]
    for line in reversed(lines):
        if line.startswith(_PREFIX):
            return line[len(_PREFIX):]
    return lines[-1] if lines else f"exit code {code}"


# --- inputs and towns --------------------------------------------------------------------------------


def job_name(path: str | os.PathLike) -> str:
    """An input's job name: its file name without the OSM suffixes (``krems.osm.gz`` → ``krems``)."""
    name = Path(path).name
    for suffix in _OSM_SUFFIXES:
        if name.lower().endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)]
    return name


@dataclass(frozen=True)
class Town:
    """A row of the towns table: a town's name, centre (degrees) and radius (metres)."""

    name: str
    lon: float
    lat: float
    radius: float


def read_towns(path: str | os.PathLike) -> list[Town]:
    """The towns table: a CSV with a header naming the columns ``name,lon,lat,radius``.

    Longitude and latitude in degrees, radius in metres; other columns are
    ignored. Every row is checked before any work: one line names the row and
    what is wrong.
    """
    from osm_expand.clip import box_around

    p = Path(path)
    if not p.is_file():
        raise UnreadableInputError(f"{p}: no such towns table")
    try:
        with open(p, newline="", encoding="utf-8-sig") as fh:
            rows = list(csv.reader(fh))
    except UnicodeDecodeError as exc:
        raise UnreadableInputError(f"{p}: not UTF-8 text (byte {exc.start}); save the towns table as UTF-8") from None
    except csv.Error as exc:
        raise UnreadableInputError(f"{p}: not a readable CSV table ({exc})") from None
    rows = [r for r in rows if any(cell.strip() for cell in r)]
    if not rows:
        raise UnreadableInputError(f"{p}: empty towns table (expected a header name,lon,lat,radius and one row "
                                   "per town)")
    header = [c.strip().lower() for c in rows[0]]
    missing = [c for c in ("name", "lon", "lat", "radius") if c not in header]
    if missing:
        raise UnreadableInputError(f"{p}: the header lacks {', '.join(missing)} (expected name,lon,lat,radius)")
    col = {c: header.index(c) for c in ("name", "lon", "lat", "radius")}
    towns, seen = [], set()
    for line, row in enumerate(rows[1:], start=2):
        where = f"{p} line {line}"
        if len(row) < len(header):
            raise UnreadableInputError(f"{where}: {len(row)} columns, the header has {len(header)}")
        name = row[col["name"]].strip()
        if not name:
            raise UnreadableInputError(f"{where}: no name")
        if name in seen:
            raise UnreadableInputError(f"{where}: the name {name!r} is used twice (names name the outputs)")
        seen.add(name)
        values = {}
        for key in ("lon", "lat", "radius"):
            try:
                values[key] = float(row[col[key]])
            except ValueError:
                raise UnreadableInputError(f"{where}: {key} {row[col[key]]!r} is not a number") from None
            if not math.isfinite(values[key]):
                raise UnreadableInputError(f"{where}: {key} {row[col[key]]!r} is not a finite number")
        try:
            box_around(values["lon"], values["lat"], values["radius"])
        except InputError as exc:
            raise UnreadableInputError(f"{where} ({name}): {exc}") from None  # the table is at fault
        towns.append(Town(name, values["lon"], values["lat"], values["radius"]))
    if not towns:
        raise UnreadableInputError(f"{p}: no towns below the header")
    return towns


def _check_name(name: str, what: str) -> None:
    from osm_expand.clip.extract import _check_name as check

    try:
        check(name)
    except InputError:
        raise OptionError(f"{what}: {name!r} cannot name output files (no slashes or control characters)") from None


# --- the pipeline options passed through ---------------------------------------------------------------


def check_pipeline_args(args: Sequence[str]) -> list[str]:
    """The pipeline options as the main command accepts them, checked before any job runs."""
    args = [str(a) for a in args]
    for a in args:
        flag = a.split("=", 1)[0]
        if flag in _PER_JOB:
            raise OptionError(f"batch: {flag} is set per job by the batch (outputs are DIR/NAME.expanded.*, "
                              "seeds derive from --seed, previews come with --preview png|svg)")
    try:
        request = request_from_argv(["CITY.osm", *args])
    except OptionError as exc:
        raise OptionError(f"batch: pipeline options: {one_line(str(exc))}") from None
    try:
        check_options(request)  # --area nan, a broken --history, ...: refused before the first job
    except InputError as exc:
        raise type(exc)(f"batch: pipeline options: {exc}") from None
    return args


def _output_suffix(args: Sequence[str]) -> str:
    fmt = None
    for i, a in enumerate(args):
        if a == "--format" and i + 1 < len(args):
            fmt = args[i + 1]
        elif a.startswith("--format="):
            fmt = a.split("=", 1)[1]
    return FORMAT_SUFFIX.get(fmt or "urbanenvironment", ".xml")


# --- running -----------------------------------------------------------------------------------------


def run_batch(inputs: Sequence[str | os.PathLike], out_dir: str | os.PathLike, *,
              towns: str | os.PathLike | None = None,
              workers: int | None = None, scheduler: str | None = None, seed: int = 0,
              pipeline_args: Sequence[str] = (), preview: str | None = None, progress: bool = False,
              log: Callable[[str], None] | None = None) -> BatchSummary:
    """Run one job per input (or per town of ``towns`` against the one input) and write ``summary.json``.

    Parameters
    ----------
    inputs : paths
        The towns' extracts; with ``towns``, exactly one large input.
    out_dir : path
        ``DIR``: outputs ``DIR/NAME.expanded.xml``, logs ``DIR/logs/NAME.log``,
        clips ``DIR/clips/NAME.osm.pbf``, ``DIR/summary.json``. Created if its
        parent exists.
    towns : path, optional
        A CSV ``name,lon,lat,radius`` (degrees, metres): one job per row.
    workers : int, optional
        Local worker processes (one thread each); default the CPU count, at
        most one per job.
    scheduler : str, optional
        An existing cluster's address (``tcp://host:port``) or scheduler
        file; excludes ``workers``.
    seed : int
        The batch seed, ≥ 0; each job's is :func:`derive_seed` ``(seed, name)``.
    pipeline_args : list of str
        Main-command options passed to every job (``--area 200000``, ...).
    preview : {"png", "svg"}, optional
        Also draw each job's map, ``DIR/NAME.png``.
    progress : bool
        A tqdm bar over the jobs on stderr.
    log : callable, optional
        Called with a line per stage.

    Returns
    -------
    BatchSummary
        Also written to ``DIR/summary.json``. Failed jobs are in it, not raised.
    """
    say = log or (lambda message: None)
    t0 = time.perf_counter()
    if not isinstance(seed, int) or seed < 0:
        raise OptionError(f"--seed must be 0 or more, got {seed}")
    if workers is not None and scheduler is not None:
        raise OptionError("batch: give --workers or --scheduler, not both")
    if workers is not None and workers < 1:
        raise OptionError(f"--workers must be 1 or more, got {workers}")
    if preview not in (None, "png", "svg"):
        raise OptionError(f"--preview must be png or svg, got {preview!r}")
    args = check_pipeline_args(pipeline_args)
    dask_ok = _dask_available()
    if not dask_ok and (scheduler is not None or workers != 1):
        raise OptionError(f"batch with several workers needs Dask: {INSTALL_HINT} (or run the jobs one by one "
                          "with --workers 1)")
    paths = [Path(p) for p in inputs]
    if not paths:
        raise OptionError("batch: no inputs")
    out = Path(out_dir).resolve()
    suffix = _output_suffix(args)

    def job(name: str, path: Path) -> Job:
        return Job(name=name, input=str(path.resolve()), output=str(out / f"{name}.expanded{suffix}"),
                   log=str(out / "logs" / f"{name}.log"), seed=derive_seed(seed, name), args=tuple(args),
                   preview=str(out / f"{name}.{preview}") if preview else None)

    # Everything that can be checked is checked before any work.
    if towns is not None:
        if len(paths) != 1:
            raise OptionError(f"batch --towns takes exactly one input (the large file), got {len(paths)}")
        clipping = sorted({a.split("=", 1)[0] for a in args} & _CLIP_OPTIONS)
        if clipping:
            raise OptionError(f"batch --towns clips each town out of the input itself; drop {', '.join(clipping)}")
        from osm_expand.ingest import OSM_SUFFIXES, check_readable

        check_readable(paths[0], OSM_SUFFIXES)
        table = read_towns(towns)
        for t in table:
            _check_name(t.name, str(towns))
        jobs: list[Job] = []
    else:
        jobs = _file_jobs(paths, job)
    _make_out_dir(out)
    failed_early: list[JobResult] = []
    clips: dict = {}
    client = cluster = None
    where = "this process"
    try:
        if scheduler is not None:  # can its workers run these jobs at all?
            client = _connect(scheduler)
            where = f"the cluster at {client.scheduler.address}"
            _preflight(client, scheduler, [j.input for j in jobs], out)
        if towns is not None:
            jobs, failed_early, clips = _clip_towns(paths[0], table, out, job, say)
        (out / "logs").mkdir(exist_ok=True)
        if dask_ok and client is None and jobs:
            from distributed import Client

            n = workers or min(len(jobs), os.cpu_count() or 1)
            say(f"starting a local cluster of {_count(n, 'worker')} (processes of one thread)")
            cluster = _local_cluster(n)
            client, where = Client(cluster), f"a local cluster of {_count(n, 'worker')}"
        say(f"running {_count(len(jobs), 'job')} on {where}")
        results = _gather(client, jobs, progress) if client is not None else _run_here(jobs, progress)
    finally:
        if client is not None:
            client.close()  # a user's cluster stays up: only this connection closes
        if cluster is not None:
            cluster.close()
    summary = BatchSummary(jobs=sorted(results + failed_early, key=lambda r: r.name), seed=seed,
                           seconds=time.perf_counter() - t0, where=where, out_dir=str(out), clips=clips)
    _write_summary(out / "summary.json", summary)
    return summary


def _file_jobs(inputs: list[Path], job: Callable[[str, Path], Job]) -> list[Job]:
    """One job per input file, named by its stem (two inputs of one name are refused)."""
    from osm_expand.ingest import check_readable

    jobs: list[Job] = []
    names: dict[str, Path] = {}
    for path in inputs:
        check_readable(path)
        name = job_name(path)
        _check_name(name, str(path))
        if name in names:
            raise OptionError(f"batch: {names[name]} and {path} would both be named {name!r}; rename one")
        names[name] = path
        jobs.append(job(name, path))
    return jobs


def _local_cluster(n: int):
    """N worker processes with one thread each on 127.0.0.1 (any free port, no dashboard)."""
    import dask
    from distributed import LocalCluster

    with dask.config.set({"distributed.scheduler.allowed-failures": 0,  # a job that kills its worker fails at once
                          "distributed.nanny.pre-spawn-environ.OSMIUM_POOL_THREADS": 1}):
        # no dashboard; the scheduler's HTTP endpoint on any free port, so parallel batches never collide
        return LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1", scheduler_port=0,
                            dashboard_address=None, silence_logs=50,
                            scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})


def _make_out_dir(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise OutputError(f"{out}: is not a folder")
    from osm_expand.export.atomic import check_writable

    try:
        if not out.exists():
            if not out.parent.is_dir():
                raise OutputError(f"{out}: its parent folder does not exist")
            out.mkdir()
        check_writable(out / "summary.json")  # a real probe: root passes os.access() on a read-only mount
    except OSError as exc:
        raise OutputError(f"{out}: the output folder cannot be made or written ({exc.strerror or exc})") from None


def _clip_towns(src: Path, table: list[Town], out: Path, job: Callable[[str, Path], Job],
                say: Callable[[str], None]) -> tuple[list[Job], list[JobResult], dict]:
    """One read of the large input: every town's extract in ``DIR/clips``; towns without data fail."""
    from osm_expand.clip import box_around, clip_extracts

    boxes = {t.name: box_around(t.lon, t.lat, t.radius) for t in table}
    clip_dir = out / "clips"
    clip_dir.mkdir(exist_ok=True)
    say(f"clipping {len(boxes)} towns out of {src} together")
    t0 = time.perf_counter()
    result = clip_extracts(src, boxes, clip_dir)
    clips = {"input": str(src.resolve()), "seconds": round(time.perf_counter() - t0, 2), "reads": result.reads,
             "extracts": {name: {"path": str(path), **result.counts[name]} for name, path in result.paths.items()}}
    jobs = [job(t.name, result.paths[t.name]) for t in table if t.name in result.paths]
    failed = [JobResult(name=name, input=str(src.resolve()), status=JobStatus.FAILED, seconds=0.0,
                        seed=job(name, src).seed, exit_code=2, error=result.why_empty[name]) for name in result.empty]
    return jobs, failed, clips


def _dask_available() -> bool:
    try:
        import distributed  # noqa: F401
    except ImportError:
        return False
    return True


def _bar(total: int, progress: bool):
    from tqdm import tqdm

    return tqdm(total=total, file=sys.stderr, unit="job", leave=False, dynamic_ncols=True,
                disable=not (progress and sys.stderr.isatty()))


def _run_here(jobs: list[Job], progress: bool) -> list[JobResult]:
    results = []
    with _bar(len(jobs), progress) as bar:
        for job in jobs:
            results.append(run_job(job))
            bar.set_postfix_str(f"{job.name} {results[-1].status}")
            bar.update(1)
    return results


def _connect(scheduler: str):
    from distributed import Client

    try:
        if Path(scheduler).is_file():
            return Client(scheduler_file=scheduler, timeout="10s")
        return Client(scheduler, timeout="10s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise InputError(f"--scheduler {scheduler}: cannot reach the scheduler ({str(exc).splitlines()[0]})") from None


def _gather(client, jobs: list[Job], progress: bool, task: Callable[[Job], JobResult] = run_job) -> list[JobResult]:
    """Submit every job (unique keys, no retries) and collect them as they complete."""
    from distributed import as_completed

    futures = {client.submit(task, job, pure=False, retries=0): job for job in jobs}
    results = []
    with _bar(len(jobs), progress) as bar:
        for future in as_completed(futures):
            job = futures[future]
            if future.status == "finished":
                result = future.result()
            else:
                result = _lost(job, future.exception())
            future.release()
            results.append(result)
            bar.set_postfix_str(f"{job.name} {result.status}")
            bar.update(1)
    return results


def _lost(job: Job, exc: BaseException | None) -> JobResult:
    """A job whose task raised or whose worker died (killed for memory, say)."""
    kind = type(exc).__name__ if exc is not None else "cancelled"
    if kind == "KilledWorker":
        error = "its worker died while running it (killed for memory?)"
    else:
        error = f"{kind}: {str(exc).splitlines()[0] if exc is not None and str(exc) else 'no detail'}"
    return JobResult(name=job.name, input=job.input, status=JobStatus.FAILED, seconds=0.0, seed=job.seed, error=error,
                     log=job.log)


# --- an existing cluster's workers -------------------------------------------------------------------


@lru_cache(maxsize=1)
def source_digest() -> str:
    """A digest of the package sources (``osm_expand``, ``simplify``, ``synth``) this process runs."""
    import importlib

    h = hashlib.blake2b(digest_size=8)
    for package in _PACKAGES:
        module_file = importlib.import_module(package).__file__
        assert module_file is not None  # the three packages are imported from files
        root = Path(module_file).parent
        for path in sorted(root.rglob("*.py")):
            h.update(f"{package}/{path.relative_to(root).as_posix()}\0".encode())
            h.update(path.read_bytes())
    return h.hexdigest()


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("osm-expand")
    except PackageNotFoundError:
        return "unknown"


def probe(paths: list[str], out_dir: str) -> dict:
    """What a worker runs before any job: its osm-expand, and which paths it cannot use."""
    return {"version": _version(), "source": source_digest(),
            "unreadable": [p for p in paths if not os.access(p, os.R_OK)],
            "out_dir_ok": os.path.isdir(out_dir) and os.access(out_dir, os.W_OK)}


def _preflight(client, scheduler: str, inputs: list[str], out: Path) -> None:
    """Every worker imports the same osm-expand and sees the inputs and the output folder, or one line says not."""
    workers = client.scheduler_info().get("workers", {})
    if not workers:
        raise InputError(f"--scheduler {scheduler}: the cluster has no workers")
    paths = sorted(set(inputs))
    try:
        answers = client.run(probe, paths, str(out), on_error="return")
    except Exception as exc:  # noqa: BLE001 - the workers could not even run the probe
        raise InputError(f"--scheduler {scheduler}: its workers cannot run osm-expand "
                         f"({type(exc).__name__}: {exc})") from None
    mine = (_version(), source_digest())
    for address, answer in sorted(answers.items()):
        if isinstance(answer, BaseException):
            raise InputError(f"--scheduler {scheduler}: worker {address} cannot import osm-expand "
                             f"({type(answer).__name__}: {answer}); install this version there")
        if (answer["version"], answer["source"]) != mine:
            raise InputError(f"--scheduler {scheduler}: worker {address} runs osm-expand {answer['version']} "
                             f"(source {answer['source']}), this one {mine[0]} (source {mine[1]}); "
                             "install the same version on the workers")
        if answer["unreadable"]:
            raise InputError(f"--scheduler {scheduler}: worker {address} cannot read {answer['unreadable'][0]}"
                             + (f" and {len(answer['unreadable']) - 1} more inputs"
                                if len(answer["unreadable"]) > 1 else "")
                             + " (put the inputs on a folder every worker sees)")
        if not answer["out_dir_ok"]:
            raise InputError(f"--scheduler {scheduler}: worker {address} cannot write to {out} "
                             "(use an output folder every worker sees)")


def _write_summary(path: Path, summary: BatchSummary) -> None:
    from osm_expand.export.atomic import atomic_write

    with atomic_write(path, "w") as fh:
        json.dump(summary.to_dict(), fh, indent=2, sort_keys=True)
        fh.write("\n")


# --- the command line ----------------------------------------------------------------------------------


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
        print(f"osm-expand: batch: {job.name} failed: {job.error}", file=sys.stderr)
    if args.json:
        print(json.dumps(report, sort_keys=True))
    code = 2 if all(job.exit_code == 2 for job in failed) else 1
    raise JobsFailed(f"{len(failed)} of {_count(len(summary.jobs), 'job')} failed; see {summary_path}", code)


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"
