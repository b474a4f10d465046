"""Where a batch's jobs run: one after the other in this process, or on Dask (a local cluster of
one-thread workers, or an existing cluster whose workers are checked first: same osm-expand, same inputs)."""
from __future__ import annotations

import hashlib
import os
import sys
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path

from osm_expand.batch.jobs import Job, JobResult, JobStatus, run_job
from osm_expand.errors import InputError

__all__ = ["INSTALL_HINT", "probe", "source_digest"]

INSTALL_HINT = "pip install 'osm-expand[cluster]'"
#: Packages whose sources must match between this process and a cluster's workers.
_PACKAGES = ("osm_expand", "simplify", "synth")


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
