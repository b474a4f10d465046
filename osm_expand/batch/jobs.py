"""One job of a batch: its seed, the main command's arguments it runs, and how it went (:func:`run_job`, on a
worker, through :func:`osm_expand.app.run_expand`); and the batch's summary of every job."""
from __future__ import annotations

import argparse
import contextlib
import hashlib
import os
import threading
import time
import typing
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, field
from enum import StrEnum
from pathlib import Path

from osm_expand.app import EXPAND_ARGUMENTS, PROG, ExpandRequest, add_arguments, exit_code, one_line
from osm_expand.errors import InputError, OptionError

__all__ = ["SEED_MODULUS", "BatchSummary", "Job", "JobResult", "JobStatus", "derive_seed", "request_from_argv",
           "run_job"]

#: How the main command starts its one-line errors.
_PREFIX = f"{PROG}: "
#: The seed derivation's modulus: seeds stay below 2**31, valid for every numpy generator.
SEED_MODULUS = 2 ** 31


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
    propagates. The cyclic collector is paused for the job's run, as the
    main command pauses it (:mod:`osm_expand.gcpause`): it is process state,
    and a process runs one job at a time (``_ONE_JOB_AT_A_TIME``), so no
    other job's pause is undone under it.
    """
    import warnings

    from osm_expand.app import run_expand
    from osm_expand.gcpause import cyclic_gc_paused

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
                with cyclic_gc_paused():
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
