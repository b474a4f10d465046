"""The clip's entry points: :func:`clip_extracts` (every box's extract from one read of the input, boxes
without data listed), :func:`clip` (every box must hold data) and :func:`clipped` (one box, in a temporary
folder); the strategies themselves are :mod:`~osm_expand.clip.two_pass` and :mod:`~osm_expand.clip.one_pass`."""
from __future__ import annotations

import contextlib
import os
import re
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path

import osmium

from osm_expand.clip.boxes import Box, _Boxes, check_box
from osm_expand.clip.one_pass import _one_pass
from osm_expand.clip.options import ClipOptions, ClipResult, ClipStrategy
from osm_expand.clip.two_pass import ID_BLOCK_BYTES, _two_pass
from osm_expand.clip.writer import _Extracts
from osm_expand.errors import InputError, OptionError, OutputError, UnreadableInputError

__all__ = ["clip", "clip_extracts", "clipped"]

_NAME = re.compile(r"^[^/\\\x00-\x1f]+$")


@contextlib.contextmanager
def clipped(path: str | os.PathLike, box: Iterable[float], *, scratch: str | os.PathLike, what: str = "the box",
            options: ClipOptions | None = None) -> Iterator[tuple[Path, dict]]:
    """The extract of one box out of ``path``, in a temporary folder inside ``scratch``, removed on exit.

    Parameters
    ----------
    path : path
        A sorted OSM file.
    box : four floats
        (W, S, E, N) in degrees.
    scratch : path
        An existing folder with room for the extract and, with the default
        two-pass clip, the node store (16 bytes per node of the input).
    what : str
        How messages name the box (``"--bbox 15.5,48.3,15.7,48.5"``).
    options : ClipOptions, optional

    Yields
    ------
    (Path, dict)
        The extract, and what it holds: ``box``, ``nodes``, ``ways``,
        ``relations`` and ``reads`` of the input.

    Raises
    ------
    InputError
        The box holds no node of the file, or the clip's own errors.
    """
    box = check_box(box, what)
    with tempfile.TemporaryDirectory(prefix=".osm-expand-clip-", dir=scratch) as tmp:
        result = clip_extracts(path, {"town": box}, tmp, options=options or ClipOptions())
        if result.empty:
            raise InputError(result.why_empty["town"].replace("the box of town", what))
        yield result.paths["town"], {"box": list(box), **result.counts["town"], "reads": result.reads}


def _check_name(name: str) -> str:
    if not isinstance(name, str) or not _NAME.match(name) or name.strip() != name or name in (".", ".."):
        raise OptionError(f"{name!r} cannot name an extract (no slashes, control characters or surrounding spaces)")
    return name


def clip(path: str | os.PathLike, boxes: Mapping[str, Iterable[float]], out_dir: str | os.PathLike, *,
         index: str = "flex_mem", strategy: str = ClipStrategy.TWO_PASS.value) -> dict[str, Path]:
    """Write one extract per box from one read of ``path``; every box must hold data.

    Parameters
    ----------
    path : path
        A sorted OSM file (``.osm.pbf``, ``.osm``, ``.osm.gz``, ``.osm.bz2``).
    boxes : mapping name → (W, S, E, N)
        Degrees; the name names the extract ``out_dir/NAME.osm.pbf``.
    out_dir : path
        An existing, writable folder.
    index : str
        The node-location index of the ``one-pass`` strategy (see :class:`ClipOptions`).
    strategy : str
        ``two-pass`` (default) or ``one-pass``.

    Returns
    -------
    dict name → Path
        The extracts, in the order of ``boxes``.

    Raises
    ------
    InputError
        An unreadable file, a bad box, or a box with no node of the file inside.
    """
    result = clip_extracts(path, boxes, out_dir, options=ClipOptions(strategy=strategy, index=index))
    if result.empty:
        more = f" (and {len(result.empty) - 1} more boxes without data)" if len(result.empty) > 1 else ""
        raise InputError(result.why_empty[result.empty[0]] + more)
    return result.paths


def clip_extracts(path: str | os.PathLike, boxes: Mapping[str, Iterable[float]], out_dir: str | os.PathLike, *,
                  options: ClipOptions | None = None) -> ClipResult:
    """Like :func:`clip`, but boxes without data are listed in ``ClipResult.empty`` instead of failing.

    A box entirely outside the bounds the file's header declares is known
    empty before the read (and not searched). Bad boxes (not numbers, empty,
    outside the globe) and bad names raise :class:`InputError` before the
    file is read.
    """
    from osm_expand.ingest import OSM_SUFFIXES, check_readable

    options = options or ClipOptions()
    src = check_readable(path, OSM_SUFFIXES)
    out = Path(out_dir)
    if not out.is_dir():
        raise OutputError(f"{out}: output folder does not exist")
    if not os.access(out, os.W_OK):
        raise OutputError(f"{out}: output folder is not writable")
    try:
        strategy = ClipStrategy(options.strategy)
    except ValueError:
        raise OptionError(f"clip strategy {options.strategy!r} is not one of "
                          f"{', '.join(s.value for s in ClipStrategy)}") from None
    checked = {_check_name(name): check_box(box, f"box {name}") for name, box in boxes.items()}
    if not checked:
        raise OptionError("no boxes to clip")
    if strategy is ClipStrategy.ONE_PASS and options.index.split(",")[0] not in osmium.index.map_types():
        raise OptionError(f"node-location index {options.index!r} is not one of {', '.join(osmium.index.map_types())}")
    if options.max_id_set_mb < ID_BLOCK_BYTES >> 20:
        raise OptionError(f"max_id_set_mb must be at least {ID_BLOCK_BYTES >> 20}, got {options.max_id_set_mb}")
    result = ClipResult()
    try:
        result.why_empty.update(_outside_header_bounds(src, checked))
        names = [name for name in checked if name not in result.why_empty]
        if names:
            grid = _Boxes([checked[n] for n in names])
            extracts = _Extracts([out / f"{n}.osm.pbf" for n in names], [checked[n] for n in names])
            if strategy is ClipStrategy.TWO_PASS:
                max_blocks = options.max_id_set_mb * (1 << 20) // ID_BLOCK_BYTES
                result.reads = _two_pass(src, grid, extracts, out, options.complete_multipolygons, max_blocks)
            else:
                result.reads = _one_pass(src, grid, extracts, options.index, options.complete_multipolygons)
            for k, name in enumerate(names):
                if k in extracts.counts:
                    result.paths[name], result.counts[name] = extracts.paths[k], extracts.counts[k]
                else:
                    w, s, e, n = checked[name]
                    result.why_empty[name] = (f"{src}: no data inside the box of {name} "
                                              f"({w:.5f},{s:.5f},{e:.5f},{n:.5f})")
    except InputError:
        raise
    except (RuntimeError, ValueError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise UnreadableInputError(f"{src}: not a readable OSM file ({msg})") from None
    result.empty = [name for name in checked if name in result.why_empty]
    return result


def _outside_header_bounds(src: Path, boxes: dict[str, Box]) -> dict[str, str]:
    """Boxes entirely outside the bounds the file declares (known before any read): name → why."""
    with osmium.io.Reader(str(src), osmium.osm.NOTHING) as reader:
        hb = reader.header().box()
    if not hb.valid():
        return {}
    fw, fs, fe, fn = hb.bottom_left.lon, hb.bottom_left.lat, hb.top_right.lon, hb.top_right.lat

    def overlaps(w: float, s: float, e: float, n: float) -> bool:
        return not (e < fw or w > fe or n < fs or s > fn)

    outside = {}
    for name, (w, s, e, n) in boxes.items():
        if not overlaps(w, s, e, n):
            swapped = " (latitude and longitude swapped? the order is W,S,E,N)" if overlaps(s, w, n, e) else ""
            outside[name] = (f"{src}: the box of {name} ({w:.5f},{s:.5f},{e:.5f},{n:.5f}) lies outside the file's "
                             f"bounds ({fw:.5f},{fs:.5f},{fe:.5f},{fn:.5f}){swapped}")
    return outside
