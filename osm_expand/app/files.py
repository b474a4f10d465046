"""The run's files: the input read (clipped when asked), the outputs' names checked before any work, and
every file written whole or not at all (the output, the preview, the snapshots).
"""
from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from osm_expand.app.request import ExpandRequest
from osm_expand.errors import InputError, OptionError, OutputError

if TYPE_CHECKING:
    from osm_expand.clip import ClipOptions
    from osm_expand.engine.history import History

#: Output writers by the output file's suffix: the main command's (urbanenvironment XML, OSM, GeoJSON).
EXPAND_WRITERS = {".xml": "urbanenvironment", ".osm": "osm", ".geojson": "geojson", ".json": "geojson"}
#: Each ``--format``'s output suffix.
FORMAT_SUFFIX = {"urbanenvironment": ".xml", "osm": ".osm", "geojson": ".geojson"}

#: Told a line: progress, or a note of the result.
Log = Callable[[str], None]


def stem(path: str | os.PathLike) -> str:
    """An input's name without the suffix of a file the tool reads (``krems.osm.gz`` → ``krems``, the longest
    of :data:`osm_expand.ingest.SUFFIXES` that leaves a name): the main command's outputs and a batch's jobs
    are named after it."""
    from osm_expand.ingest import SUFFIXES

    name = Path(path).name
    for suffix in sorted(SUFFIXES, key=len, reverse=True):
        if name.lower().endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)]
    return Path(path).stem


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


def expand_outputs(request: ExpandRequest) -> tuple[Path, str, Path | None]:
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


def snapshot_dir(request: ExpandRequest, years: int, history: History | None = None, name: str = ""
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
                 pictures: Sequence = (), name: str = "", debug: list | None = None, frame: str = "town") -> None:
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
                write_preview(result.city, preview, result.site.region, title=title, frame=frame)
        if snapshots is not None:
            from osm_expand.export.snapshot import write_snapshot

            with writing(snapshots):
                snapshots.mkdir(parents=True, exist_ok=True)
            for city, year, era, traffic in pictures:
                picture = snapshots / snapshot_name(name, year, era)
                with writing(picture):
                    write_snapshot(city, traffic, picture, title=f"{shown(name)} in {year}, end of era {era}")
