"""The application layer: one run of the main command, ``run_expand(request) -> report``.

Read the town (clipped out of a large file when asked), grow and join a
district, let it live through the history's years, and write the output,
its preview and snapshots all or nothing. The command line
(:mod:`osm_expand.cli`) and ``osm-expand batch`` (:mod:`osm_expand.batch`)
both call :func:`run_expand`, so a batch job writes exactly the bytes the
single command writes; neither imports the other.

The main command's options are declared once, in :data:`EXPAND_ARGUMENTS`
(flags, types, choices, help): the command line's parser adds them with
:func:`add_arguments`, and ``batch`` adds the same table to its own parser
(as text, passed to every job) without reaching into argparse's internals.
An :class:`ExpandRequest` holds one run's options as the user gave them;
:func:`check_options` checks what needs no input before any work (``batch``
calls it before its first job).

One idea a module: :mod:`~osm_expand.app.arguments` (the options
declared once), :mod:`~osm_expand.app.request` (one run's request and its
checks), :mod:`~osm_expand.app.files` (reading, output names, writing all
or nothing), :mod:`~osm_expand.app.run` (the run and its exit code). This
package re-exports their public names.

They import only the standard library and :mod:`osm_expand.errors` at
their top (``osm-expand --help`` stays fast); the stages are imported when
a run needs them.
"""
from __future__ import annotations

from osm_expand.app.arguments import (
    CLIP_ARGUMENTS,
    EXPAND_ARGUMENTS,
    INPUT_ARGUMENTS,
    PROG,
    Argument,
    add_arguments,
    seed_value,
    years_value,
)
from osm_expand.app.files import (
    EXPAND_WRITERS,
    FORMAT_SUFFIX,
    Log,
    clip_text,
    in_file,
    output_path,
    read_from,
    shown,
    snapshot_name,
    stem,
    writable,
    write_result,
    writing,
)
from osm_expand.app.request import MAX_AREA_M2, CheckedOptions, ExpandRequest, check_clip, check_options
from osm_expand.app.run import exit_code, one_line, run_expand

__all__ = ["CLIP_ARGUMENTS", "EXPAND_ARGUMENTS", "EXPAND_WRITERS", "FORMAT_SUFFIX", "INPUT_ARGUMENTS", "MAX_AREA_M2",
           "PROG", "Argument", "CheckedOptions", "ExpandRequest", "Log", "add_arguments", "check_clip",
           "check_options", "clip_text", "exit_code", "in_file", "one_line", "output_path",
           "read_from", "run_expand", "seed_value", "shown", "snapshot_name", "stem", "writable", "write_result",
           "writing", "years_value"]
