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

This module only imports the standard library and :mod:`osm_expand.errors`
at its top (``osm-expand --help`` stays fast); the stages are imported when
a run needs them.
"""
from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

from osm_expand.errors import InputError, OptionError, OutputError

if TYPE_CHECKING:
    from osm_expand.clip import ClipOptions
    from osm_expand.engine.history import History
    from osm_expand.land import LandOptions

__all__ = ["CLIP_ARGUMENTS", "EXPAND_ARGUMENTS", "INPUT_ARGUMENTS", "Argument", "CheckedOptions", "ExpandRequest",
           "add_arguments", "check_options", "run_expand"]

PROG = "osm-expand"
#: Output writers by the output file's suffix: the main command's (urbanenvironment XML, OSM, GeoJSON).
EXPAND_WRITERS = {".xml": "urbanenvironment", ".osm": "osm", ".geojson": "geojson", ".json": "geojson"}
#: Each ``--format``'s output suffix.
FORMAT_SUFFIX = {"urbanenvironment": ".xml", "osm": ".osm", "geojson": ".geojson"}
#: The largest ``--area`` accepted, m²: 10,000 km², far past any district the engine can grow in a run
#: (Berlin is 891 km²); larger values are typos or fuzz and would only fail later, with a 300-digit number.
MAX_AREA_M2 = 1e10

Log = Callable[[str], None]


def _quiet(message: str) -> None:
    """The default progress and note callback: says nothing."""


# --- the main command's options, declared once ----------------------------------------------------------


def _whole_number(text: str, subject: str, unit: str) -> int:
    """``text`` as a whole number, 0 or more; argparse's one-line refusal otherwise (``subject`` starts it)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{subject}must be a whole number{unit}, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{subject}must be 0 or more, got {value}")
    return value


def seed_value(text: str) -> int:
    """``--seed``: a whole number, 0 or more (argparse's ``type``)."""
    return _whole_number(text, "--seed ", "")


def years_value(text: str) -> int:
    """``--years`` and ``--snapshot-every``: a whole number of years, 0 or more (argparse's ``type``)."""
    return _whole_number(text, "", " of years")


@dataclass(frozen=True)
class Argument:
    """One option of the main command, as ``parser.add_argument(*flags, **options)`` takes it.

    ``group`` names an argument group (its title), ``exclusive`` a mutually
    exclusive group (options with the same name share one).
    """

    flags: tuple[str, ...]
    options: dict[str, Any] = field(default_factory=dict)
    group: str | None = None
    exclusive: str | None = None

    @property
    def dest(self) -> str:
        """The attribute argparse stores the value in."""
        return self.options.get("dest") or self.flags[-1].lstrip("-").replace("-", "_")

    @property
    def flag(self) -> str:
        """The long flag (what ``batch`` passes to its jobs)."""
        return self.flags[-1]

    @property
    def takes_value(self) -> bool:
        return self.options.get("action") not in ("store_true", "store_false")


_CLIP_GROUP = "a town out of a large file (clipped at read time; docs/batch.md)"

#: The options that choose what is read (the sub-commands take them too).
INPUT_ARGUMENTS: tuple[Argument, ...] = (
    Argument(("--service",), {"action": "store_true", "help": "also keep highway=service roads"}),
    Argument(("--paths",), {"action": "store_true", "help": "also keep footways, paths, tracks and cycleways"}),
)

#: Reading a town out of a large file (``simplify`` takes them too).
CLIP_ARGUMENTS: tuple[Argument, ...] = (
    Argument(("--bbox",), {"metavar": "W,S,E,N",
                           "help": "read only this box, degrees (ways crossing its edge kept whole)"}, _CLIP_GROUP),
    Argument(("--around",), {"metavar": "LON,LAT",
                             "help": "read only the box around this point, degrees (with --radius)"}, _CLIP_GROUP),
    Argument(("--radius",), {"type": float, "metavar": "M",
                             "help": "with --around: metres from the point to the box's sides"}, _CLIP_GROUP),
    Argument(("--clip-index",), {"metavar": "INDEX",
                                 "help": "clip in one read with this node-location index (flex_mem, "
                                         "sparse_file_array,PATH, ...) instead of two reads with a node store on "
                                         "disk beside the output"}, _CLIP_GROUP),
)


#: The main command's options after the input's, in the order ``--help`` lists them. ``batch`` passes all
#: but ``--output``, ``--seed`` and ``--preview`` (which it sets per job) to every job.
EXPAND_ARGUMENTS: tuple[Argument, ...] = (
    *INPUT_ARGUMENTS,
    *CLIP_ARGUMENTS,
    Argument(("-o", "--output"), {"help": "output file: .xml (urbanenvironment), .osm or .geojson "
                                          "(default: CITY.expanded.xml beside the input)"}),
    Argument(("--format",), {"choices": sorted(FORMAT_SUFFIX),
                             "help": "output format (default: from -o, else urbanenvironment)"}),
    Argument(("--preview",), {"metavar": "OUT.png|OUT.svg", "help": "also draw a map of the result"}),
    Argument(("--seed",), {"type": seed_value, "default": 0,
                           "help": "random seed (0 or more); the same seed gives the same bytes"}),
    Argument(("--direction",), {"choices": ["auto", "N", "NE", "E", "SE", "S", "SW", "W", "NW"], "default": "auto",
                                "help": "grow on this side of the town (default: the best site anywhere)"}),
    Argument(("--at",), {"metavar": "X,Y", "help": "site centre in metres of the local projection"}),
    Argument(("--at-lonlat",), {"metavar": "LON,LAT", "help": "site centre in degrees (longitude first)"}),
    Argument(("--area",), {"type": float, "metavar": "M2",
                           "help": "district area in m² (default: a quarter of the built-up area, at most a "
                                   "neighbourhood unit of 0.65 km², at least nine blocks; at most four times the "
                                   "built-up area)"}),
    Argument(("--pattern",), {"default": "example"}),  # choices and help: osm_expand.growth_patterns
    Argument(("--beyond-bounds",), {"action": "store_true", "default": None,
                                    "help": "let the district grow outside the map's bounds (land there is "
                                            "unknown; by default only when the town fills its map)"},
             exclusive="bounds"),
    Argument(("--within-bounds",), {"dest": "beyond_bounds", "action": "store_false",
                                    "help": "never grow outside the map's bounds: refuse when the town fills its "
                                            "map"}, exclusive="bounds"),
    Argument(("--unbuildable",), {"metavar": "KEY=VALUE,...",
                                  "help": "mapped areas nobody may build on, replacing the default list "
                                          "(landuse=cemetery,leisure=park,aeroway=*,...; '' for none)"}),
    Argument(("--history",), {"metavar": "NAME|FILE", "default": "example",
                              "help": "the history the city then lives through: a bundled one (example, european, "
                                      "north-american) or a TOML file (docs/histories.md); default: example"}),
    Argument(("--years",), {"type": years_value, "metavar": "N",
                            "help": "years of history to simulate (default: the history's own, 30 for example; "
                                    "0 grows the district only)"}),
    Argument(("--snapshots",), {"metavar": "DIR",
                                "help": "also draw the city at the end of each era (traffic green to red) into "
                                        "DIR"}),
    Argument(("--snapshot-every",), {"type": years_value, "metavar": "N",
                                     "help": "with --snapshots: a picture every N years instead of one per era"}),
    Argument(("--debug-layers",), {"action": "store_true",
                                   "help": "with a .geojson output: add the growth pattern's working layers "
                                           "(colonisation: attraction points, flow field and its primitives, "
                                           "region, parameters)"}),
)


def _resolved(arg: Argument) -> dict[str, Any]:
    """An argument's options, the growth patterns' choices and help filled in from their registry."""
    if arg.flag != "--pattern":
        return dict(arg.options)
    from osm_expand.growth_patterns import PATTERN_NAMES, pattern_help

    return {**arg.options, "choices": list(PATTERN_NAMES), "help": pattern_help()}


def add_arguments(parser: Any, arguments: Sequence[Argument], *, as_text: bool = False,
                  dest_prefix: str = "") -> list[Argument]:
    """Add ``arguments`` to ``parser`` (their groups made once); the arguments added, in order.

    Parameters
    ----------
    parser : argparse.ArgumentParser or an argument group of one
        Where to add them.
    arguments : sequence of Argument
        Which options, e.g. :data:`EXPAND_ARGUMENTS`.
    as_text : bool
        ``batch``'s way: every value kept as the text given (no ``type``; the
        choices still checked), flags as ``store_true``, no defaults (an option
        not given is absent from the namespace), and no exclusive groups: the
        jobs' own parsing checks them, once, before the first job.
    dest_prefix : str
        Prepended to each destination, one per flag (``--beyond-bounds`` and
        ``--within-bounds`` share one destination in the main command).
    """
    groups: dict[str, Any] = {}
    for arg in arguments:
        options = _resolved(arg)
        target: Any = parser
        if as_text:
            options = {"dest": dest_prefix + arg.flag.lstrip("-").replace("-", "_"), "help": options.get("help"),
                       "default": argparse.SUPPRESS,
                       **({"metavar": options.get("metavar") or arg.dest.upper(), "choices": options.get("choices")}
                          if arg.takes_value else {"action": "store_true"})}
        else:
            if arg.group is not None:
                target = groups.setdefault(arg.group, parser.add_argument_group(arg.group))
            if arg.exclusive is not None:
                target = groups.setdefault("exclusive:" + arg.exclusive, parser.add_mutually_exclusive_group())
            if dest_prefix:
                options["dest"] = dest_prefix + arg.dest
        target.add_argument(*arg.flags, **options)
    return list(arguments)


# --- one run's request ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ExpandRequest:
    """One run of the main command: its options as the user gave them (text where the user typed text).

    The fields are :data:`EXPAND_ARGUMENTS`' destinations plus ``city``, the
    input; :meth:`from_namespace` takes them from a parsed command line.
    """

    city: str
    output: str | None = None
    format: str | None = None
    preview: str | None = None
    seed: int = 0
    direction: str = "auto"
    at: str | None = None  #: ``X,Y`` in metres
    at_lonlat: str | None = None  #: ``LON,LAT`` in degrees
    area: float | None = None  #: m²
    pattern: str = "example"
    beyond_bounds: bool | None = None
    unbuildable: str | None = None  #: ``KEY=VALUE,...``; None the default list, '' none
    history: str = "example"  #: a bundled history's name or a TOML file
    years: int | None = None
    snapshots: str | None = None  #: a folder
    snapshot_every: int | None = None
    debug_layers: bool = False
    service: bool = False
    paths: bool = False
    bbox: str | None = None  #: ``W,S,E,N`` in degrees
    around: str | None = None  #: ``LON,LAT`` in degrees, with ``radius``
    radius: float | None = None  #: metres
    clip_index: str | None = None

    @classmethod
    def from_namespace(cls, namespace: argparse.Namespace) -> ExpandRequest:
        """The request of a parsed main command (attributes it lacks keep their defaults)."""
        return cls(**{f.name: getattr(namespace, f.name) for f in fields(cls) if hasattr(namespace, f.name)})


@dataclass(frozen=True)
class CheckedOptions:
    """What :func:`check_options` found: the options parsed and checked before any work."""

    land: LandOptions
    history: History
    years: int  #: years to simulate
    at: tuple[float, float] | None = None  #: metres; checked against the map once it is read
    at_lonlat: tuple[float, float] | None = None  #: degrees; checked against the map once it is read
    box: Any = None  #: the ``--bbox``/``--around`` box to clip, if any (:func:`osm_expand.clip.requested_box`)
    clip: ClipOptions | None = None


def _pair(text: str, flag: str) -> tuple[float, float]:
    try:
        a, b = (float(v) for v in text.split(","))
    except ValueError:
        raise OptionError(f"{flag} expects two numbers separated by a comma, got {text!r}") from None
    return a, b


def _points(request: ExpandRequest) -> tuple[tuple[float, float] | None, tuple[float, float] | None]:
    """``--at`` and ``--at-lonlat`` parsed (before any work); their bounds are checked once the map is read."""
    at = at_lonlat = None
    if request.at is not None:
        at = _pair(request.at, "--at")
        if not all(math.isfinite(v) for v in at):
            raise OptionError(f"--at expects two finite numbers (metres), got {at[0]:g},{at[1]:g}")
    if request.at_lonlat is not None:
        at_lonlat = lon, lat = _pair(request.at_lonlat, "--at-lonlat")
        if not (-180 <= lon <= 180 and -90 <= lat <= 90):
            if -180 <= lat <= 180 and -90 <= lon <= 90:
                raise OptionError(f"--at-lonlat {lon:g},{lat:g}: latitude and longitude look swapped; "
                                  f"give longitude first: {lat:g},{lon:g}")
            raise OptionError(f"--at-lonlat {lon:g},{lat:g} is not a longitude,latitude")
    return at, at_lonlat


def check_clip(bbox: str | None, around: str | None, radius: float | None, clip_index: str | None
               ) -> tuple[Any, ClipOptions | None]:
    """``--bbox`` / ``--around --radius`` / ``--clip-index`` checked before any work: the box and the clip options
    (both None when nothing is clipped)."""
    if bbox is None and around is None and radius is None:
        if clip_index is not None:
            raise OptionError("--clip-index needs --bbox or --around")
        return None, None
    from osm_expand.clip import options_for_index, requested_box

    return requested_box(bbox=bbox, around=around, radius=radius), options_for_index(clip_index)


def check_options(request: ExpandRequest) -> CheckedOptions:
    """The options that need no input, checked before any work (``batch`` checks them before its first job).

    Raises
    ------
    OptionError
        ``--area`` out of range, bad ``--at``/``--at-lonlat``/``--bbox``/``--around``, too many years.
    HistoryError
        A ``--history`` that cannot be found or read.
    """
    from osm_expand.engine.history import MAX_YEARS, load_history
    from osm_expand.land import LandOptions, parse_rules

    if request.area is not None and not (0 < request.area <= MAX_AREA_M2):
        raise OptionError(f"--area must be positive (m²) and at most {MAX_AREA_M2:.0e}, got {request.area:.6g}")
    land = LandOptions() if request.unbuildable is None else LandOptions(unbuildable=parse_rules(request.unbuildable))
    at, at_lonlat = _points(request)
    box, clip = check_clip(request.bbox, request.around, request.radius, request.clip_index)
    history = load_history(request.history)
    years = history.years if request.years is None else request.years
    if years > MAX_YEARS:
        raise OptionError(f"--years {years}: at most {MAX_YEARS} years can be simulated")
    return CheckedOptions(land=land, history=history, years=years, at=at, at_lonlat=at_lonlat, box=box, clip=clip)


def _site_point(request: ExpandRequest, checked: CheckedOptions, city) -> tuple[float, float] | None:
    """``--at`` / ``--at-lonlat`` in metres, checked against the map's bounds."""
    if checked.at_lonlat is not None:
        lon, lat = checked.at_lonlat
        text = f"{lon:g},{lat:g}"
        lon0, lat0, lon1, lat1 = city.context.bounds_lonlat
        inside = lambda x, y: lon0 <= x <= lon1 and lat0 <= y <= lat1  # noqa: E731
        if inside(lat, lon) and not inside(lon, lat):
            raise OptionError(f"--at-lonlat {text}: latitude and longitude look swapped; "
                              f"give longitude first: {lat:g},{lon:g}")
        if not inside(lon, lat) and not request.beyond_bounds:
            raise OptionError(f"--at-lonlat {text} is outside the map (lon {lon0:.5f}..{lon1:.5f}, "
                              f"lat {lat0:.5f}..{lat1:.5f}); use --beyond-bounds to grow outside it")
        x, y = city.projection.to_xy(lon, lat)
        return float(x), float(y)
    if checked.at is not None:
        x, y = checked.at
        x0, y0, x1, y1 = city.bounds_xy
        if not request.beyond_bounds and not (x0 <= x <= x1 and y0 <= y <= y1):
            raise OptionError(f"--at {x:g},{y:g} is outside the map (x {x0:.0f}..{x1:.0f}, y {y0:.0f}..{y1:.0f} m); "
                              "use --beyond-bounds to grow outside it")
        return x, y
    return None


# --- files: reading, outputs, writing ---------------------------------------------------------------------


def stem(path: Path) -> str:
    """An input's name without its OSM suffixes (``krems.osm.gz`` → ``krems``): outputs are named after it."""
    name = path.name
    for suffix in (".osm.gz", ".osm.bz2", ".osm.pbf", ".osm", ".pbf", ".gz", ".bz2", ".xml", ".geojson"):
        if name.lower().endswith(suffix):
            return name[: -len(suffix)]
    return path.stem


def shown(name: str) -> str:
    """A file name as a picture's title shows it: bytes that are not UTF-8 (kept by Python as lone
    surrogates, which matplotlib refuses) as U+FFFD."""
    return os.fsencode(name).decode("utf-8", "replace")


@contextlib.contextmanager
def read_from(city: Path, box: Any, clip: ClipOptions | None, what: str, scratch: Path, log: Log
              ) -> Iterator[tuple[Path, dict]]:
    """The file to read: the input, or its extract of ``box`` (described by ``what``) in a temporary folder in
    ``scratch``, removed on leaving."""
    if box is None:
        yield city, {}
        return
    from osm_expand.clip import clipped

    log(f"clipping {what} out of {city}")
    with clipped(city, box, scratch=scratch, what=what, options=clip) as (path, info):
        yield path, {"clip": info}


def clip_text(bbox: str | None, around: str | None, radius: float | None) -> str:
    """How the clipped box was asked for, as the messages name it."""
    return f"--bbox {bbox}" if bbox is not None else f"--around {around} --radius {radius:g}"


def output_path(city: Path, output: str | None, default_suffix: str, writers: dict[str, str]) -> tuple[Path, str]:
    """The output file and its writer's name, checked before any work (``-o``, or beside the input)."""
    path = Path(output) if output else city.with_name(stem(city) + default_suffix)
    if output == "":
        raise OptionError("-o needs a file name, got ''")
    try:
        return _checked_output(path, city, default_suffix, writers)
    except OSError as exc:  # a name or path too long, a loop of links, ...
        raise OutputError(f"{path}: cannot write there ({exc.strerror or exc})") from None


def _checked_output(path: Path, city: Path, default_suffix: str, writers: dict[str, str]) -> tuple[Path, str]:
    if path.is_dir():
        raise OutputError(f"{path}: is a directory; give an output file (-o DIR/NAME{default_suffix})")
    kind = writers.get(path.suffix.lower())
    if kind is None:
        raise OptionError(f"{path}: unsupported output type (use {' or '.join(sorted(writers))})")
    _not_the_input(path, city)
    writable(path)
    return path, kind


def _not_the_input(out: Path, city: Path) -> None:
    """Refuse an output that is the input itself (by inode, or by real path when it does not exist yet)."""
    try:
        same = os.path.samefile(out, city) if out.exists() and city.exists() else \
            os.path.realpath(out) == os.path.realpath(city)
    except OSError:
        same = False
    if same:
        raise OutputError(f"{out}: is the input file; choose another output (-o) so the town is not overwritten")


@contextlib.contextmanager
def writing(path: Path) -> Iterator[None]:
    """A write that fails (disk full, file-size limit, a folder gone) as one line naming the file, exit 2."""
    try:
        yield
    except OSError as exc:
        raise OutputError(f"{path}: cannot write it ({exc.strerror or exc}); nothing was written") from None


def writable(path: Path) -> None:
    """Fail before any work when ``path`` cannot be written."""
    from osm_expand.export.atomic import check_writable

    if path.is_dir():
        raise OutputError(f"{path}: is a directory")
    if not path.parent.exists() and str(path.parent) != "":
        raise OutputError(f"{path}: output directory does not exist")
    try:
        check_writable(path)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write there, the folder is not writable ({exc.strerror})") from None


def in_file(city: Path, exc: InputError, service: bool) -> InputError:
    """The error, naming the file (the same kind of error, :mod:`osm_expand.errors`); when nothing survived
    simplification, what might help."""
    from osm_expand.pipeline import NOTHING_LEFT

    hint = "; try --service" if str(exc) == NOTHING_LEFT and not service else ""
    return type(exc)(f"{city}: {exc}{hint}")


def _expand_outputs(request: ExpandRequest) -> tuple[Path, str, Path | None]:
    """The output path and format, and the preview path, all checked before any work."""
    city = Path(request.city)
    if request.format and request.output:
        suffix_kind = EXPAND_WRITERS.get(Path(request.output).suffix.lower())
        if suffix_kind is not None and suffix_kind != request.format:
            raise OptionError(f"--format {request.format} contradicts the output {request.output} "
                              f"(a {Path(request.output).suffix} file is {suffix_kind}); change one of them")
    default = FORMAT_SUFFIX[request.format or "urbanenvironment"]
    out, kind = output_path(city, request.output, ".expanded" + default, EXPAND_WRITERS)
    preview = None
    if request.preview:
        preview = Path(request.preview)
        if preview.suffix.lower() not in (".png", ".svg"):
            raise OptionError(f"{request.preview}: the preview must be .png or .svg")
        try:
            writable(preview)
        except OSError as exc:
            raise OutputError(f"{preview}: cannot write there ({exc.strerror or exc})") from None
    return out, request.format or kind, preview


def _snapshot_dir(request: ExpandRequest, years: int, history: History | None = None, name: str = ""
                  ) -> Path | None:
    """``--snapshots DIR``, checked before any work (made if missing), and the pictures' names with it."""
    try:
        return _checked_snapshot_dir(request, years, history, name)
    except OSError as exc:  # a name or path too long, ...
        raise OutputError(f"--snapshots {request.snapshots}: cannot write there ({exc.strerror or exc})") from None


def _checked_snapshot_dir(request: ExpandRequest, years: int, history: History | None, name: str) -> Path | None:
    if request.snapshot_every is not None and not request.snapshots:
        raise OptionError("--snapshot-every needs --snapshots DIR")
    if not request.snapshots:
        return None
    if years == 0:
        raise OptionError("--snapshots needs simulated years (--years 0 was given)")
    folder = Path(request.snapshots)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"--snapshots {folder}: exists and is not a directory")
    if request.snapshot_every == 0:
        raise OptionError("--snapshot-every must be 1 or more")
    existing = folder
    while not existing.exists() and existing != existing.parent:  # made with its parents when written
        existing = existing.parent
    if not existing.is_dir():
        raise OutputError(f"--snapshots {folder}: {existing} is not a directory")
    try:
        from osm_expand.export.atomic import check_writable

        check_writable(existing / "probe.png")
        if history is not None:  # the longest picture name: a six-digit year, the longest era name
            era = max((e.name for e in history.eras), key=len, default="")
            check_writable(existing / snapshot_name(name, 999999, era))
    except OSError as exc:
        raise OutputError(f"--snapshots {folder}: cannot write into {existing} ({exc.strerror})") from None
    return folder


def snapshot_name(name: str, year: int, era: str) -> str:
    """A snapshot picture's file name."""
    return f"{name}-{year}-{era}.png"


def write_result(result, out: Path, kind: str, preview: Path | None, title: str, *, snapshots: Path | None = None,
                 pictures: Sequence = (), name: str = "", debug: list | None = None) -> None:
    """The output, the preview and the snapshots, all or nothing."""
    from osm_expand.export import all_or_nothing, write_geojson, write_osm, write_urbanenvironment

    writer = {"urbanenvironment": write_urbanenvironment, "osm": write_osm, "geojson": write_geojson}[kind]
    with writing(out), all_or_nothing():  # a failure of the output's writing or of the final renames
        if debug is not None:
            write_geojson(result.city, out, debug=debug)
        else:
            writer(result.city, out)
        if preview is not None:
            from osm_expand.export.preview import write_preview

            with writing(preview):
                write_preview(result.city, preview, result.site.region, title=title)
        if snapshots is not None:
            from osm_expand.export.snapshot import write_snapshot

            with writing(snapshots):
                snapshots.mkdir(parents=True, exist_ok=True)
            for city, year, era, traffic in pictures:
                picture = snapshots / snapshot_name(name, year, era)
                with writing(picture):
                    write_snapshot(city, traffic, picture, title=f"{shown(name)} in {year}, end of era {era}")


# --- the run ----------------------------------------------------------------------------------------------


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
    out, kind, preview = _expand_outputs(request)
    if request.debug_layers and kind != "geojson":
        raise OptionError(f"--debug-layers needs a GeoJSON output (-o OUT.geojson), got {out.name}")
    checked = check_options(request)
    history, years = checked.history, checked.years
    name = stem(city_path)
    snapshots = _snapshot_dir(request, years, history, name)
    say = note or _say_note(city_path)
    what = clip_text(request.bbox, request.around, request.radius) if checked.box is not None else ""
    with read_from(city_path, checked.box, checked.clip, what, out.parent, progress) as (src, clip):
        # the extract stays until the output is written: the OSM output is the extract plus what grew
        progress(f"reading {city_path}" + (" (the extract)" if clip else ""))
        city = load(src, service=request.service, paths=request.paths)
        stages(len(history.eras_visited(city.year, years)))  # a stage per era the run passes
        pictures: list = []
        options = ExpandOptions(seed=request.seed, direction=None if request.direction == "auto" else request.direction,
                                at=_site_point(request, checked, city), area=request.area,
                                beyond_bounds=request.beyond_bounds, land=checked.land, pattern=request.pattern)
        try:
            result = expand(city, options, progress=progress)
            result = mature_result(result, history, MatureOptions(years=years, snapshot_every=request.snapshot_every),
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
                     debug=debug)
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
