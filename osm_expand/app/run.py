"""One run of the main command: ``run_expand(request) -> report`` (read, expand, mature, write atomically),
and the exit code of a run that failed.
"""
from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from osm_expand.app.arguments import PROG
from osm_expand.app.files import (
    Log,
    clip_text,
    expand_outputs,
    in_file,
    read_from,
    shown,
    snapshot_dir,
    snapshot_name,
    stem,
    write_result,
)
from osm_expand.app.request import ExpandRequest, check_options, site_point
from osm_expand.errors import InputError, OptionError

if TYPE_CHECKING:
    pass



def _quiet(message: str) -> None:
    """The default progress and note callback: says nothing."""


def _say_note(city: Path) -> Log:
    def note(text: str) -> None:
        print(f"{PROG}: {city}: {text}", file=sys.stderr)
    return note


def run_expand(request: ExpandRequest, *, progress: Log = _quiet, stages: Callable[[int], None] = lambda n: None,
               note: Log | None = None) -> dict:
    """One run of the main command: read, expand, mature, write atomically; the report.

    Everything that can be checked before the work is checked first, in the
    order the command line always has (the input, the outputs, the options,
    the snapshots folder); a failure writes nothing.

    Parameters
    ----------
    request : ExpandRequest
        The run's options.
    progress : callable
        Told each stage's name as it starts.
    stages : callable
        Told how many stages the history adds (one per era the run passes), once the town is read.
    note : callable, optional
        Told each of the report's notes (what a user should know of the result); default: one line each on
        stderr, ``osm-expand: CITY: NOTE``, as the command line prints them even with ``-q``.

    Returns
    -------
    dict
        The JSON-ready report: input, output, format, seed, the clip, the preview and snapshots written, and
        the pipeline's report.

    Raises
    ------
    InputError
        One of its named kinds (:mod:`osm_expand.errors`), naming the file; nothing is written.
    """
    from osm_expand.ingest import check_readable, load
    from osm_expand.maturation import MatureOptions, mature_result
    from osm_expand.pipeline import ExpandOptions, expand

    city_path = check_readable(request.city)
    out, kind, preview = expand_outputs(request)
    if request.debug_layers and kind != "geojson":
        raise OptionError(f"--debug-layers needs a GeoJSON output (-o OUT.geojson), got {out.name}")
    checked = check_options(request)
    history, years = checked.history, checked.years
    name = stem(city_path)
    snapshots = snapshot_dir(request, years, history, name)
    say = note or _say_note(city_path)
    what = clip_text(request.bbox, request.around, request.radius) if checked.box is not None else ""
    with read_from(city_path, checked.box, checked.clip, what, out.parent, progress) as (src, clip):
        # the extract stays until the output is written: the OSM output is the extract plus what grew
        progress(f"reading {city_path}" + (" (the extract)" if clip else ""))
        city = load(src, service=request.service, paths=request.paths)
        # a stage per era the run passes, and judging the district when asked
        stages(len(history.eras_visited(city.year, years)) + request.judge)
        pictures: list = []
        options = ExpandOptions(seed=request.seed, direction=None if request.direction == "auto" else request.direction,
                                at=site_point(request, checked, city), area=request.area,
                                beyond_bounds=request.beyond_bounds, land=checked.land, pattern=request.pattern,
                                fidelity=request.judge)
        try:
            result = expand(city, options, progress=progress)
            result = mature_result(result, history, MatureOptions(years=years, snapshot_every=request.snapshot_every,
                                                                     fidelity=request.judge),
                                   request.seed, progress=progress,
                                   snapshot=(lambda *picture: pictures.append(picture)) if snapshots else None)
        except InputError as exc:
            raise in_file(city_path, exc, request.service) from None
        report = result.report
        for text in report.get("notes", []):  # what a user should know of the result, even with -q
            say(text)
        progress(f"{len(result.city.new_streets())} new streets; writing {out}")
        title = f"{shown(name)}: the town and what grew (seed {request.seed})"
        debug = list(result.growth.debug.get("features", [])) if request.debug_layers else None
        write_result(result, out, kind, preview, title=title, snapshots=snapshots, pictures=pictures, name=name,
                     debug=debug, frame=request.preview_frame)
    return {"input": str(city_path), "output": str(out), "format": kind, "seed": request.seed, **clip,
            **({"preview": str(preview)} if preview else {}),
            **({"snapshots": [str(snapshots / snapshot_name(name, p[1], p[2])) for p in pictures]}
               if snapshots else {}), **report}


def one_line(text: str) -> str:
    """A message on one line: a file name with a newline or a control character shown escaped."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def exit_code(exc: BaseException) -> int:
    """The main command's exit code for an exception a run raised: 2 for the input's fault (an
    :class:`InputError`, or not enough memory for this input), else 1 (a bug)."""
    if isinstance(exc, InputError):
        return int(getattr(exc, "exit_code", 2))
    return 2 if isinstance(exc, MemoryError) else 1
