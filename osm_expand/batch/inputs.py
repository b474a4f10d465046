"""What a batch runs on, checked before any job: the inputs and their jobs' names, the towns table, and the
pipeline options passed through to every job."""
from __future__ import annotations

import csv
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from osm_expand.app import FORMAT_SUFFIX, check_options, one_line
from osm_expand.batch.jobs import request_from_argv
from osm_expand.errors import InputError, OptionError, UnreadableInputError

__all__ = ["Town", "check_pipeline_args", "read_towns"]

#: Main-command options a batch sets per job itself (refused among the pipeline options).
_PER_JOB = {"-o", "--output", "--seed", "--preview", "--version", "-h", "--help"}
#: Main-command options that clip the input (a towns table does that itself).
_CLIP_OPTIONS = {"--bbox", "--around", "--radius", "--clip-index"}


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
