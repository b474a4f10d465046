"""Clip towns out of a large OSM file at read time: one read of the input for any number of boxes.

``clip(path, {"krems": (W, S, E, N), ...}, out_dir)`` writes one sorted
``.osm.pbf`` extract per box, each with the box as its ``<bounds>``, which
:func:`osm_expand.ingest.load` reads like any extract. What an extract holds:

1. every node inside the box;
2. every way with at least one node inside the box, *whole*, with all its
   nodes (also those outside the box), so streets that leave the town keep
   their shape and the ingest never sees a street cut at the box;
3. every relation with a kept member (node or way), its member list as
   mapped (members outside the extract stay referenced, as in any extract);
   member relations are not followed;
4. every ``type=multipolygon`` relation among them *completed*: all its
   member ways and their nodes, so water, buildings and land-use areas that
   cross the box edge are assembled whole by libosmium (the Danube's banks
   at Krems) instead of being lost or salvaged in pieces.

Objects keep their ids, tags, versions and timestamps. The input may come
in any order with the default two-pass clip (relations read before their
ways are matched again once every way is known, one more read); the
one-pass clip needs nodes before ways and refuses a file that has not.
Node ids must be positive (libosmium's location stores hold no negative ids).

PBF and XML have no spatial index, so every pass decodes the whole file in
C++; what reaches Python is chosen by C++ filters. Two strategies
(:class:`ClipStrategy`, measured by ``benchmarks/large_inputs.py
--clip-strategies``):

- ``two-pass`` (default): libosmium writes every node's location to a
  temporary file store next to the output (16 bytes a node, on disk), numpy
  finds the nodes inside the boxes, an :class:`osmium.IdTracker` of those
  nodes lets only the ways that reference them through to Python (C++
  filter), then the relations are matched against the kept ways in
  Python, and a last pass fetches the nodes the kept ways reference (C++
  id filter). Python touches only the clipped objects and the file's
  relations. Memory: the objects kept, plus pyosmium's id sets, which cost
  4 MB per block of 2**25 ids touched whatever the count (libosmium's
  dense id set: Krems' 15 042 node ids take 311 MB); they are capped at
  ``max_id_set_mb`` by tracking the ids group by group, one read each. At
  least three reads (nodes, ways, nodes), one more when a multipolygon
  lacks members.
- ``one-pass``: one read with a node-location index of every node
  (``index``, ``flex_mem`` by default) and every way tested in Python
  against the boxes; tagged nodes inside a box are kept as read, the other
  nodes are written from the index (id and location only: no tags, version
  or timestamp, which the ingest does not read). One read (two with a
  multipolygon to complete), less memory on small files, but Python work
  and the index grow with the file.

The location index of ``one-pass`` is any of
``osmium.index.map_types()``; for a file whose node index does not fit in
memory use a file-backed one, e.g. ``index="sparse_file_array,/big/disk/nodes.idx"``.
"""
from __future__ import annotations

import contextlib
import math
import os
import re
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path

import numpy as np
import osmium
from osmium.osm.mutable import Node, Relation, Way

from osm_expand.errors import InputError, OptionError, OutputError, UnreadableInputError

__all__ = ["Box", "ClipOptions", "ClipResult", "ClipStrategy", "box_around", "check_box", "clip", "clip_extracts",
           "clipped", "options_for_index", "parse_bbox", "requested_box"]

#: (west, south, east, north) in degrees (WGS84).
Box = tuple[float, float, float, float]
#: Mean Earth radius (m), IUGG; the same sphere the box of :func:`box_around` is drawn on.
EARTH_RADIUS_M = 6_371_008.8
#: Coordinates of libosmium's locations are integers of 1e-7 degree.
_COORDINATE_PRECISION = 10_000_000
#: One entry of libosmium's ``sparse_file_array`` store: node id, then x and y in 1e-7 degree.
_STORE_ENTRY = np.dtype([("id", "<u8"), ("x", "<i4"), ("y", "<i4")])
#: Entries of the store scanned at once (16 MB).
_SCAN_CHUNK = 1 << 20
#: libosmium's dense id sets (IdTracker, IdFilter) allocate ID_BLOCK_BYTES (one bit an id) per block
#: of ID_BLOCK consecutive ids holding one (measured: 4.19 MB per id for ids 3·2**24 apart; Krems'
#: 15 042 node ids fall in 74 blocks and take 311 MB).
ID_BLOCK = 1 << 25
ID_BLOCK_BYTES = 4 << 20
_NAME = re.compile(r"^[^/\\\x00-\x1f]+$")


class ClipStrategy(StrEnum):
    """How :func:`clip_extracts` finds the objects of the boxes (see the module's docstring)."""

    TWO_PASS = "two-pass"
    ONE_PASS = "one-pass"


@dataclass(frozen=True)
class ClipOptions:
    """Tunables of the clip."""

    #: ``two-pass`` or ``one-pass`` (:class:`ClipStrategy`); two-pass by default: on Krems' copy in
    #: the 3 M-node benchmark file 4.4 s and 289 MB peak against 11.2 s and 229 MB, and the only one
    #: whose Python work grows with the clip, not the file.
    strategy: str = ClipStrategy.TWO_PASS.value
    #: the node-location index of ``one-pass``: a name from ``osmium.index.map_types()``, file-backed
    #: ones with ``,PATH`` (libosmium's default for in-memory reading is ``flex_mem``).
    index: str = "flex_mem"
    #: complete ``type=multipolygon`` relations with a member in the box (all member ways and
    #: their nodes), so areas crossing the box edge are assembled whole.
    complete_multipolygons: bool = True
    #: MB, the most the id sets of ``two-pass`` hold at once (4 MB per block of 2**25 ids touched);
    #: more blocks are tracked group by group, one read of ways and one of nodes each, in ascending
    #: ids (the extract is the same). A town touches nearly every block of the ids of its time:
    #: Krems (2013, ids to 2.6e9) 74 blocks, a town today up to ~390 (ids to 1.3e10), 1.55 GB
    #: uncapped. 512 MB: at most four groups for any town today, one for Krems. On Krems' copy in
    #: the 3 M-node file (benchmarks/large_inputs.py): 64 MB 7.8 s / 224 MB peak, 128 MB 4.4 s / 289 MB,
    #: 256 MB 4.6 s / 429 MB, 512 MB 3.4 s / 442 MB.
    max_id_set_mb: int = 512


@dataclass
class ClipResult:
    """What :func:`clip_extracts` wrote: the extract of each box that holds data, and counts."""

    #: name → the extract written
    paths: dict[str, Path] = field(default_factory=dict)
    #: name → {"nodes", "ways", "relations"} written
    counts: dict[str, dict[str, int]] = field(default_factory=dict)
    #: names of boxes with no node of the file inside (nothing written for them), in input order
    empty: list[str] = field(default_factory=list)
    #: name → why it is empty, one line (outside the file's declared bounds, or no node inside)
    why_empty: dict[str, str] = field(default_factory=dict)
    #: how many times the input file was read
    reads: int = 0


# --- boxes ------------------------------------------------------------------------------------------


def check_box(box: Iterable[float], what: str = "box") -> Box:
    """A valid (W, S, E, N) box in degrees, or an :class:`InputError` saying what is wrong.

    Parameters
    ----------
    box : four numbers
        West, south, east, north in degrees (longitude first).
    what : str
        How the box is named in the message (``"--bbox"``, ``"town Krems"``).

    Returns
    -------
    tuple of four floats
    """
    try:
        values = tuple(float(v) for v in box)
    except (TypeError, ValueError):
        raise OptionError(f"{what}: expects four numbers W,S,E,N, got {box!r}") from None
    if len(values) != 4:
        raise OptionError(f"{what}: expects four numbers W,S,E,N, got {len(values)}")
    w, s, e, n = values
    text = f"{w:g},{s:g},{e:g},{n:g}"
    if not all(math.isfinite(v) for v in values):
        raise OptionError(f"{what} {text}: not finite numbers")
    if not (-180 <= w <= 180 and -180 <= e <= 180 and -90 <= s <= 90 and -90 <= n <= 90):
        raise OptionError(f"{what} {text}: outside the globe (longitudes -180..180, latitudes -90..90, W,S,E,N)")
    if w >= e or s >= n:
        swap = " (latitude and longitude swapped? the order is W,S,E,N)" if s < w and n < e and s < n else ""
        raise OptionError(f"{what} {text}: empty box, west must be less than east and south less than north{swap}")
    return values


def parse_bbox(text: str, what: str = "--bbox") -> Box:
    """``"W,S,E,N"`` → a checked box (see :func:`check_box`)."""
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) != 4:
        raise OptionError(f"{what} expects four numbers W,S,E,N separated by commas, got {text!r}")
    try:
        return check_box([float(p) for p in parts], what)
    except ValueError:
        raise OptionError(f"{what} expects four numbers W,S,E,N separated by commas, got {text!r}") from None


def box_around(lon: float, lat: float, radius_m: float) -> Box:
    """The box holding the circle of ``radius_m`` metres around a point.

    On a sphere of :data:`EARTH_RADIUS_M`: ``Δlat = r / R`` and
    ``Δlon = Δlat / cos(lat)`` (in radians), so the box spans ``2 r`` in
    both directions at the centre's latitude.

    Parameters
    ----------
    lon, lat : float
        The centre in degrees.
    radius_m : float
        Metres, > 0.

    Returns
    -------
    tuple of four floats
        (W, S, E, N) in degrees.
    """
    try:
        lon, lat, radius_m = float(lon), float(lat), float(radius_m)
    except (TypeError, ValueError):
        raise OptionError(f"--around expects numbers, got {lon!r},{lat!r} and radius {radius_m!r}") from None
    if not (math.isfinite(lon) and math.isfinite(lat) and -180 <= lon <= 180 and -90 < lat < 90):
        swapped = (" (latitude and longitude swapped? the order is LON,LAT)"
                   if -90 < lon < 90 and abs(lat) <= 180 else "")
        raise OptionError(f"--around {lon:g},{lat:g}: not a longitude,latitude{swapped}")
    if not (math.isfinite(radius_m) and radius_m > 0):
        raise OptionError(f"--radius must be a positive number of metres, got {radius_m:g}")
    dlat = math.degrees(radius_m / EARTH_RADIUS_M)
    if abs(lat) + dlat >= 90:
        raise OptionError(f"--around {lon:g},{lat:g} --radius {radius_m:g}: the box reaches a pole")
    dlon = dlat / math.cos(math.radians(lat))
    if not (-180 <= lon - dlon and lon + dlon <= 180):
        raise OptionError(f"--around {lon:g},{lat:g} --radius {radius_m:g}: the box crosses the antimeridian "
                          "(not supported)")
    return (lon - dlon, lat - dlat, lon + dlon, lat + dlat)


def requested_box(*, bbox: str | None = None, around: str | None = None, radius: float | None = None) -> Box | None:
    """The box of the command line's ``--bbox W,S,E,N`` or ``--around LON,LAT --radius M``.

    Parameters
    ----------
    bbox : str, optional
        ``"W,S,E,N"`` in degrees.
    around : str, optional
        ``"LON,LAT"`` in degrees; needs ``radius``.
    radius : float, optional
        Metres from ``around`` to the box's sides (:func:`box_around`).

    Returns
    -------
    tuple of four floats, or None
        (W, S, E, N) in degrees; None when neither option is given.

    Raises
    ------
    InputError
        Both options, ``--around`` without ``--radius`` (or the reverse), or a bad box.
    """
    if bbox is not None and (around is not None or radius is not None):
        raise OptionError("give --bbox or --around with --radius, not both")
    if bbox is not None:
        return parse_bbox(bbox)
    if around is None and radius is None:
        return None
    if around is None:
        raise OptionError("--radius needs --around LON,LAT")
    if radius is None:
        raise OptionError("--around needs --radius M (metres from the point to the box's sides)")
    parts = [p.strip() for p in str(around).split(",")]
    try:
        lon, lat = (float(p) for p in parts)
    except ValueError:
        raise OptionError(f"--around expects two numbers LON,LAT separated by a comma, got {around!r}") from None
    return box_around(lon, lat, radius)


def options_for_index(index: str | None) -> ClipOptions:
    """The clip's options for the command line's ``--clip-index``.

    None: the default two-pass clip (node locations in a temporary file
    store). A name from ``osmium.index.map_types()`` (``flex_mem``,
    ``sparse_mem_array``, ``dense_file_array,PATH``, ...): the one-pass clip
    with that location index of every node.
    """
    if index is None:
        return ClipOptions()
    kinds = osmium.index.map_types()
    if index.split(",")[0] not in kinds:
        raise OptionError(f"--clip-index {index!r} is not one of {', '.join(kinds)} "
                          "(file-backed ones take ,PATH: sparse_file_array,/big/disk/nodes.idx)")
    return ClipOptions(strategy=ClipStrategy.ONE_PASS.value, index=index)


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


class _Boxes:
    """The boxes in libosmium's integer coordinates, with a grid to find the boxes of many points at once."""

    def __init__(self, boxes: list[Box]):
        b = np.asarray(boxes, dtype=float).reshape(-1, 4)
        self.lo = np.round(b[:, :2] * _COORDINATE_PRECISION).astype(np.int64)  # (B, 2) W, S
        self.hi = np.round(b[:, 2:] * _COORDINATE_PRECISION).astype(np.int64)  # (B, 2) E, N
        self.union_lo, self.union_hi = self.lo.min(axis=0), self.hi.max(axis=0)  # (2,) all boxes
        self.cell = np.maximum((self.hi - self.lo).max(axis=0), 1)  # (2,) one box spans at most 2 cells a side
        first, last = self.lo // self.cell, self.hi // self.cell
        keys, owners = [], []
        for k in range(len(b)):
            cx, cy = np.meshgrid(np.arange(first[k, 0], last[k, 0] + 1), np.arange(first[k, 1], last[k, 1] + 1))
            keys.append(self._key(cx.ravel(), cy.ravel()))
            owners.append(np.full(cx.size, k))
        key, owner = np.concatenate(keys), np.concatenate(owners)
        order = np.argsort(key, kind="stable")
        self.key, self.owner = key[order], owner[order]

    @staticmethod
    def _key(cx: np.ndarray, cy: np.ndarray) -> np.ndarray:
        return cx.astype(np.int64) * (1 << 32) + cy.astype(np.int64)

    def members(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (point index, box index) of every point inside every box (edges included).

        Parameters
        ----------
        x, y : (N,) int arrays
            Longitudes and latitudes in 1e-7 degree.
        """
        x, y = np.asarray(x, dtype=np.int64), np.asarray(y, dtype=np.int64)
        key = self._key(x // self.cell[0], y // self.cell[1])
        start = np.searchsorted(self.key, key, side="left")
        stop = np.searchsorted(self.key, key, side="right")
        count = stop - start
        point = np.repeat(np.arange(len(x)), count)
        if point.size == 0:
            return point, point
        offset = np.arange(point.size) - np.repeat(np.cumsum(count) - count, count)
        box = self.owner[np.repeat(start, count) + offset]
        px, py = x[point], y[point]
        inside = ((px >= self.lo[box, 0]) & (px <= self.hi[box, 0]) & (py >= self.lo[box, 1])
                  & (py <= self.hi[box, 1]))
        return point[inside], box[inside]


# --- the clip ---------------------------------------------------------------------------------------


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
                  options: ClipOptions = ClipOptions()) -> ClipResult:
    """Like :func:`clip`, but boxes without data are listed in ``ClipResult.empty`` instead of failing.

    A box entirely outside the bounds the file's header declares is known
    empty before the read (and not searched). Bad boxes (not numbers, empty,
    outside the globe) and bad names raise :class:`InputError` before the
    file is read.
    """
    from osm_expand.ingest import OSM_SUFFIXES, check_readable

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


# --- which objects, in which boxes ---------------------------------------------------------------------
# An object's boxes are one int (nearly always) or a sorted tuple of ints: far less memory than sets.

BoxesOf = int | tuple[int, ...]


def _add(table: dict[int, BoxesOf], key: int, boxes: BoxesOf) -> None:
    """Add ``boxes`` to ``table[key]``."""
    old = table.get(key)
    if old is None or old == boxes:
        table[key] = boxes
        return
    merged = tuple(sorted({*_each(old), *_each(boxes)}))
    table[key] = merged[0] if len(merged) == 1 else merged


def _each(boxes: BoxesOf) -> tuple[int, ...]:
    return (boxes,) if isinstance(boxes, int) else boxes


@dataclass
class _Found:
    """The ways and relations kept, as plain values, and the boxes of every kept object."""

    ways: dict[int, tuple] = field(default_factory=dict)  # id → (refs, tags, meta)
    relations: dict[int, tuple] = field(default_factory=dict)  # id → (members, tags, meta)
    node_boxes: dict[int, BoxesOf] = field(default_factory=dict)  # nodes inside the boxes
    way_boxes: dict[int, BoxesOf] = field(default_factory=dict)
    rel_boxes: dict[int, BoxesOf] = field(default_factory=dict)
    reads: int = 0

    def take_way(self, way, boxes: BoxesOf) -> None:
        if way.id not in self.ways:
            self.ways[way.id] = ([n.ref for n in way.nodes], dict(way.tags), _meta(way))
        _add(self.way_boxes, way.id, boxes)

    def take_relation(self, rel) -> None:
        """The relation, if a member node or way is kept, in the boxes of its kept members."""
        boxes: set[int] = set()
        for m in rel.members:
            table = self.node_boxes if m.type == "n" else self.way_boxes if m.type == "w" else None
            if table is not None and m.ref in table:
                boxes.update(_each(table[m.ref]))
        if boxes:
            self.relations[rel.id] = ([(m.type, m.ref, m.role) for m in rel.members], dict(rel.tags), _meta(rel))
            ordered = tuple(sorted(boxes))
            self.rel_boxes[rel.id] = ordered[0] if len(ordered) == 1 else ordered

    def missing_members(self) -> dict[int, BoxesOf]:
        """Member ways of kept multipolygons that some of their boxes lack: way id → those boxes."""
        missing: dict[int, BoxesOf] = {}
        for rel_id, (members, tags, _) in self.relations.items():
            if tags.get("type") != "multipolygon":
                continue
            for mtype, ref, _ in members:
                if mtype == "w":
                    lack = set(_each(self.rel_boxes[rel_id])) - set(_each(self.way_boxes.get(ref, ())))
                    if lack:
                        _add(missing, ref, tuple(sorted(lack)) if len(lack) > 1 else lack.pop())
        return missing

    def needed_nodes(self) -> dict[int, BoxesOf]:
        """Node id → the boxes it is written to: the nodes inside, and every node of a kept way."""
        needed = dict(self.node_boxes)
        for way_id, boxes in self.way_boxes.items():
            for ref in self.ways[way_id][0]:
                _add(needed, ref, boxes)
        return needed


def _meta(obj) -> tuple:
    return (obj.version, obj.timestamp, obj.changeset, obj.uid, obj.user)


# --- two-pass ------------------------------------------------------------------------------------------


def _two_pass(src: Path, grid: _Boxes, extracts: _Extracts, scratch: Path, complete: bool, max_blocks: int) -> int:
    """The clip by C++ filters (see the module's docstring); returns the number of reads."""
    found = _Found()
    # Pass 1 (nodes, C++): every node's location into a file store; numpy finds those inside the boxes.
    with tempfile.TemporaryDirectory(prefix=".clip-", dir=scratch) as tmp:
        store_path = Path(tmp, "nodes.sparse")
        store = osmium.index.create_map(f"sparse_file_array,{store_path}")
        with osmium.io.Reader(str(src), osmium.osm.NODE) as reader:
            osmium.apply(reader, osmium.NodeLocationsForWays(store))
        found.reads += 1
        del store  # unmapped; its data stay in the file
        for ids, in_box in _scan_store(store_path, grid):
            for node_id, box in zip(ids.tolist(), in_box.tolist()):
                _add(found.node_boxes, node_id, box)
    if not found.node_boxes:
        return found.reads
    # Pass 2 (ways, then relations): C++ lets through only the ways referencing a node inside a box;
    # every relation comes through with the last group and is kept if a member is.
    order = _Order(src)
    for obj in _tracked(src, found.node_boxes, "node", osmium.osm.WAY, found, max_blocks, contains=True,
                        last_also=osmium.osm.RELATION):
        order.saw(obj)
        if obj.is_relation():
            found.take_relation(obj)
        elif obj.id not in found.ways:
            boxes: set[int] = set()
            for n in obj.nodes:
                if n.ref in found.node_boxes:
                    boxes.update(_each(found.node_boxes[n.ref]))
            ordered = tuple(sorted(boxes))
            found.take_way(obj, ordered[0] if len(ordered) == 1 else ordered)
    order.retake_relations(found)
    # Pass 2b (ways, only if a multipolygon lacks members): the missing member ways.
    missing = found.missing_members() if complete else {}
    for way in _tracked(src, missing, "way", osmium.osm.WAY, found, max_blocks):
        found.take_way(way, missing[way.id])
    # Pass 3 (nodes): those inside and those the kept ways reference, straight from the file into the
    # extracts (tags and metadata as read); as many extracts open at a time as files may be.
    needed = found.needed_nodes()
    for group in extracts.groups():
        wanted = needed if len(group) == len(extracts.paths) else {
            node_id: boxes for node_id, boxes in needed.items() if any(b in group for b in _each(boxes))}
        with extracts.open(group, found):
            for node in _tracked(src, wanted, "node", osmium.osm.NODE, found, max_blocks):
                if node.location.valid():
                    for b in _each(wanted[node.id]):
                        extracts.add_node(b, node)
    return found.reads


class _Order:
    """Files not sorted as usual (nodes, ways, relations): relations read before the ways they hold
    were matched against too few ways, so they are read again once every way is known; a way read
    before its nodes has no location in a one-read clip, which is refused in one line."""

    def __init__(self, src: Path) -> None:
        self.src = src
        self.relation_seen = self.way_seen = self.relations_early = False

    def saw(self, obj, *, nodes_first: bool = False) -> None:
        if obj.is_relation():
            self.relation_seen = True
        elif obj.is_way():
            self.way_seen = True
            self.relations_early |= self.relation_seen
        elif nodes_first and self.way_seen:
            raise UnreadableInputError(f"{self.src}: not sorted (a node after a way); the one-pass clip needs nodes "
                                       "first: sort it (osmium sort) or use the default two-pass clip")

    def retake_relations(self, found: _Found) -> None:
        """Every relation matched again against all kept ways (one more read), if any came early."""
        if not self.relations_early:
            return
        for rel in osmium.FileProcessor(str(self.src), osmium.osm.RELATION):
            found.take_relation(rel)
        found.reads += 1


def _tracked(src: Path, ids: Iterable[int], kind: str, entities, found: _Found, max_blocks: int, *,
             contains: bool = False, last_also=osmium.osm.NOTHING) -> Iterator:
    """The file's objects whose id is in ``ids`` (or, ``contains``, the ways referencing them), by C++ filters.

    pyosmium's id sets take :data:`ID_BLOCK_BYTES` for every block of
    :data:`ID_BLOCK` consecutive ids holding one of them (libosmium's dense
    id set), so the ids are tracked ``max_blocks`` blocks at a time: one
    read per group, in ascending ids. ``last_also`` adds entities, unfiltered,
    to the last read.
    """
    ids = np.unique(np.fromiter(ids, dtype=np.int64))
    if ids.size == 0:
        return
    block_starts = np.flatnonzero(np.diff(ids // ID_BLOCK, prepend=-1))
    cuts = [*block_starts[::max(1, max_blocks)].tolist(), ids.size]
    for g in range(len(cuts) - 1):
        tracker = osmium.IdTracker()
        add = tracker.add_node if kind == "node" else tracker.add_way
        for i in ids[cuts[g]:cuts[g + 1]].tolist():
            add(i)
        filt = tracker.contains_filter() if contains else tracker.id_filter()
        filt.enable_for(entities)
        last = g == len(cuts) - 2
        yield from osmium.FileProcessor(str(src),
                                        entities | (last_also if last else osmium.osm.NOTHING)).with_filter(filt)
        found.reads += 1
        del filt, tracker


def _scan_store(store_path: Path, grid: _Boxes) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """(node ids, box indices) of the store's nodes inside the boxes, chunk by chunk."""
    size = store_path.stat().st_size
    if size % _STORE_ENTRY.itemsize:
        raise RuntimeError(f"unexpected node store layout ({size} bytes)")
    total = size // _STORE_ENTRY.itemsize
    with open(store_path, "rb") as fh:
        for start in range(0, total, _SCAN_CHUNK):
            chunk = np.fromfile(fh, dtype=_STORE_ENTRY, count=min(_SCAN_CHUNK, total - start))
            x, y = chunk["x"], chunk["y"]  # the store's unused tail has undefined coordinates: outside
            near = np.flatnonzero((x >= grid.union_lo[0]) & (x <= grid.union_hi[0]) & (y >= grid.union_lo[1])
                                  & (y <= grid.union_hi[1]))
            if near.size:
                point, box = grid.members(x[near], y[near])
                yield chunk["id"][near[point]].astype(np.int64), box


# --- one-pass ------------------------------------------------------------------------------------------


def _one_pass(src: Path, grid: _Boxes, extracts: _Extracts, index: str, complete: bool) -> int:
    """The clip with a location index of every node, every way tested in Python; returns the reads."""
    found = _Found()
    locations = osmium.index.create_map(index)
    tagged_nodes = osmium.filter.EmptyTagFilter()
    tagged_nodes.enable_for(osmium.osm.NODE)
    tagged: dict[int, tuple] = {}
    order = _Order(src)
    # with_locations() is annotated as taking a str but takes a LocationTable too (pyosmium 4's file_processor.py)
    reader = osmium.FileProcessor(str(src)).with_locations(locations)  # type: ignore[arg-type]
    for obj in reader.with_filter(tagged_nodes):
        order.saw(obj, nodes_first=True)
        if isinstance(obj, osmium.osm.Node):  # obj.is_node(), in a form type checkers narrow on
            loc = obj.location
            _, box = grid.members(np.array([loc.x]), np.array([loc.y]))
            for b in box.tolist():
                _add(found.node_boxes, obj.id, b)
                tagged[obj.id] = (loc.lon, loc.lat, dict(obj.tags), _meta(obj))
        elif isinstance(obj, osmium.osm.Way):
            refs, xs, ys = [], [], []
            for nr in obj.nodes:
                refs.append(nr.ref)
                xs.append(nr.x)
                ys.append(nr.y)
            point, box = grid.members(np.array(xs), np.array(ys))
            if box.size:
                for p, b in zip(point.tolist(), box.tolist()):
                    _add(found.node_boxes, refs[p], b)
                ordered = tuple(sorted(set(box.tolist())))
                found.take_way(obj, ordered[0] if len(ordered) == 1 else ordered)
        else:
            found.take_relation(obj)
    found.reads += 1
    order.retake_relations(found)
    missing = found.missing_members() if complete else {}
    if missing:
        tracker = osmium.IdTracker()
        for way_id in missing:
            tracker.add_way(way_id)
        for way in osmium.FileProcessor(str(src), osmium.osm.WAY).with_filter(tracker.id_filter()):
            found.take_way(way, missing[way.id])
        found.reads += 1
    needed = found.needed_nodes()
    for group in extracts.groups():
        with extracts.open(group, found):
            for node_id in sorted(needed):
                boxes = [b for b in _each(needed[node_id]) if b in group]
                if not boxes:
                    continue
                if node_id in tagged:
                    lon, lat, tags, meta = tagged[node_id]
                    node = Node(id=node_id, location=(lon, lat), tags=tags, **_meta_attrs(meta))
                else:
                    try:
                        loc = locations.get(node_id)
                    except KeyError:
                        continue  # referenced, but not in the file
                    if not loc.valid():
                        continue
                    node = Node(id=node_id, location=(loc.lon, loc.lat))
                for b in boxes:
                    extracts.add_node(b, node)
    return found.reads


# --- writing -------------------------------------------------------------------------------------------


class _Extracts:
    """The extracts being written: nodes streamed in as read, then each box's ways and relations, sorted.

    Every extract is written to a temporary name and renamed when whole; a
    box that received no node inside it is not written at all.
    """

    #: extracts open at once (each a file and a 64 kB buffer); more boxes take more node reads
    MAX_OPEN = 128

    def __init__(self, paths: list[Path], boxes: list[Box]):
        self.paths, self.boxes = paths, boxes
        self.counts: dict[int, dict[str, int]] = {}
        self.writers: dict[int, osmium.SimpleWriter] = {}
        self.nodes: dict[int, int] = {}
        self.pool = osmium.io.ThreadPool(1, 8)

    def groups(self) -> list[set[int]]:
        limit = self.MAX_OPEN
        with contextlib.suppress(ValueError, OSError):
            import resource

            soft = resource.getrlimit(resource.RLIMIT_NOFILE)[0]
            if soft > 0:
                limit = max(1, min(limit, (soft - 64) // 2))
        ks = list(range(len(self.paths)))
        return [set(ks[i:i + limit]) for i in range(0, len(ks), limit)]

    def add_node(self, k: int, node) -> None:
        self.writers[k].add_node(node)
        self.nodes[k] += 1

    @contextlib.contextmanager
    def open(self, group: set[int], found: _Found) -> Iterator[None]:
        tmp = {k: self.paths[k].with_name(f".{self.paths[k].name[:-len('.osm.pbf')]}.part.osm.pbf") for k in group}
        try:
            for k in sorted(group):
                w, s, e, n = self.boxes[k]
                header = osmium.io.Header()
                header.add_box(osmium.osm.Box(osmium.osm.Location(w, s), osmium.osm.Location(e, n)))
                header.set("generator", "osm-expand clip")
                header.set("sorting", "Type_then_ID")
                self.writers[k] = osmium.SimpleWriter(str(tmp[k]), bufsz=64 * 1024, header=header, overwrite=True,
                                                      thread_pool=self.pool)
                self.nodes[k] = 0
            yield
            inside = {b for boxes in found.node_boxes.values() for b in _each(boxes)} & group
            ways = _by_box(found.way_boxes, inside)
            relations = _by_box(found.rel_boxes, inside)
            for k in sorted(group):
                writer = self.writers.pop(k)
                for way_id in ways.get(k, []):
                    refs, tags, meta = found.ways[way_id]
                    writer.add_way(Way(id=way_id, nodes=refs, tags=tags, **_meta_attrs(meta)))
                for rel_id in relations.get(k, []):
                    members, tags, meta = found.relations[rel_id]
                    writer.add_relation(Relation(id=rel_id, members=members, tags=tags, **_meta_attrs(meta)))
                writer.close()
                if k in inside:
                    os.replace(tmp[k], self.paths[k])
                    self.counts[k] = {"nodes": self.nodes[k], "ways": len(ways.get(k, [])),
                                      "relations": len(relations.get(k, []))}
                else:
                    tmp[k].unlink(missing_ok=True)
        finally:
            for writer in self.writers.values():
                writer.close()
            self.writers.clear()
            for path in tmp.values():
                path.unlink(missing_ok=True)


def _by_box(table: dict[int, BoxesOf], boxes: set[int]) -> dict[int, list[int]]:
    """Box → the ids filed under it, ascending."""
    out: dict[int, list[int]] = {}
    for key in sorted(table):
        for b in _each(table[key]):
            if b in boxes:
                out.setdefault(b, []).append(key)
    return out


def _meta_attrs(meta: tuple) -> dict:
    """The metadata the object has (a missing timestamp reads as 1970, a missing version as 0)."""
    version, timestamp, changeset, uid, user = meta
    attrs = {"version": version, "changeset": changeset, "uid": uid, "user": user,
             "timestamp": timestamp if timestamp is not None and timestamp.year > 1970 else None}
    return {k: v for k, v in attrs.items() if v}
