"""Many towns in one go: ``osm-expand batch``, one job per town, on Dask (``dask.distributed``).

A job is exactly the main command, ``osm-expand INPUT -o DIR/NAME.expanded.xml
--seed SEED [pipeline options]``: a worker (:func:`run_job`) parses those
arguments into an :class:`~osm_expand.app.ExpandRequest` and calls
:func:`osm_expand.app.run_expand`, the function the main command calls, its
progress and errors written to ``DIR/logs/NAME.log``. So a job's output is
byte for byte what that single command writes, and anyone can rerun one job
alone. The pipeline options are declared once
(:data:`osm_expand.app.EXPAND_ARGUMENTS`); this package never imports the
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

from osm_expand.batch.cluster import INSTALL_HINT, probe, source_digest
from osm_expand.batch.command import PIPELINE_ARGUMENTS, JobsFailed, add_batch_arguments, cmd_batch, pipeline_argv
from osm_expand.batch.inputs import Town, check_pipeline_args, read_towns
from osm_expand.batch.jobs import (
    SEED_MODULUS,
    BatchSummary,
    Job,
    JobResult,
    JobStatus,
    derive_seed,
    request_from_argv,
    run_job,
)
from osm_expand.batch.run import run_batch

__all__ = ["BatchSummary", "Job", "JobResult", "JobStatus", "JobsFailed", "Town", "add_batch_arguments", "cmd_batch",
           "derive_seed", "read_towns", "run_batch", "run_job",
           # more public names of the batch's modules, importable from here as before the split
           "INSTALL_HINT", "PIPELINE_ARGUMENTS", "SEED_MODULUS", "check_pipeline_args", "pipeline_argv", "probe",
           "request_from_argv", "source_digest"]
