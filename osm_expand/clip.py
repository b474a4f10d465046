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

Objects keep their ids, tags, versions and timestamps. The input must be
sorted as usual (nodes, ways, relations); node ids must be positive
(libosmium's location stores hold no negative ids).

Memory and Python work grow with the clip, not the file. PBF and XML have
no spatial index, so every pass decodes the whole file in C++; what Python
sees is chosen by C++ filters. Two strategies (:class:`ClipStrategy`,
measured by ``benchmarks/large_inputs.py --clip-strategies``):

- ``two-pass`` (default): libosmium writes every node's location to a
  temporary file store next to the output (16 bytes a node, on disk), numpy
  finds the nodes inside the boxes, an :class:`osmium.IdTracker` of those
  nodes lets only the ways and relations that reference them through to
  Python (C++ filter), and a last pass fetches the nodes those ways
  reference. Three reads of the file (four when a multipolygon needs
  completing); Python touches only clipped objects.
- ``one-pass``: one read with a node-location index of every node
  (``index``, ``flex_mem`` by default) and every way tested in Python
  against the boxes; tagged nodes inside a box are kept as read, the other
  nodes are written from the index (id and location only: no tags, version
  or timestamp, which the ingest does not read). One read (two with a
  multipolygon to complete), but Python work grows with the file's ways.

The location index of ``one-pass`` is any of
``osmium.index.map_types()``; for a file whose node index does not fit in
memory use a file-backed one, e.g. ``index="sparse_file_array,/big/disk/nodes.idx"``.
"""
from __future__ import annotations

import math
import os
import re
import tempfile
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path

import numpy as np
import osmium
from osmium.osm.mutable import Node, Relation, Way

from osm_expand.errors import InputError

__all__ = ["Box", "ClipOptions", "ClipResult", "ClipStrategy", "box_around", "check_box", "clip", "clip_extracts",
           "parse_bbox"]

#: (west, south, east, north) in degrees (WGS84).
Box = tuple[float, float, float, float]
#: Mean Earth radius (m), IUGG; the same sphere the box of :func:`box_around` is drawn on.
EARTH_RADIUS_M = 6_371_008.8
#: Coordinates of libosmium's locations are integers of 1e-7 degree.
_COORDINATE_PRECISION = 10_000_000
#: One entry of libosmium's ``sparse_file_array`` store: node id, then x and y in 1e-7 degree.
_STORE_ENTRY = np.dtype([("id", "<u8"), ("x", "<i4"), ("y", "<i4")])
#: Entries of the store scanned at once (64 MB).
_SCAN_CHUNK = 1 << 22
_NAME = re.compile(r"^[^/\\\x00-\x1f]+$")


class ClipStrategy(StrEnum):
    """How :func:`clip_extracts` finds the objects of the boxes (see the module's docstring)."""

    TWO_PASS = "two-pass"
    ONE_PASS = "one-pass"


@dataclass(frozen=True)
class ClipOptions:
    """Tunables of the clip."""

    #: ``two-pass`` or ``one-pass`` (:class:`ClipStrategy`); two-pass by default: on the 3 M-node
    #: benchmark file it is the faster one and the only one whose Python work grows with the clip.
    strategy: str = ClipStrategy.TWO_PASS.value
    #: the node-location index of ``one-pass``: a name from ``osmium.index.map_types()``, file-backed
    #: ones with ``,PATH`` (libosmium's default for in-memory reading is ``flex_mem``).
    index: str = "flex_mem"
    #: complete ``type=multipolygon`` relations with a member in the box (all member ways and
    #: their nodes), so areas crossing the box edge are assembled whole.
    complete_multipolygons: bool = True


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
        raise InputError(f"{what}: expects four numbers W,S,E,N, got {box!r}") from None
    if len(values) != 4:
        raise InputError(f"{what}: expects four numbers W,S,E,N, got {len(values)}")
    w, s, e, n = values
    text = f"{w:g},{s:g},{e:g},{n:g}"
    if not all(math.isfinite(v) for v in values):
        raise InputError(f"{what} {text}: not finite numbers")
    if not (-180 <= w <= 180 and -180 <= e <= 180 and -90 <= s <= 90 and -90 <= n <= 90):
        raise InputError(f"{what} {text}: outside the globe (longitudes -180..180, latitudes -90..90, W,S,E,N)")
    if w >= e or s >= n:
        swap = " (latitude and longitude swapped? the order is W,S,E,N)" if s < w and n < e and s < n else ""
        raise InputError(f"{what} {text}: empty box, west must be less than east and south less than north{swap}")
    return values  # type: ignore[return-value]


def parse_bbox(text: str, what: str = "--bbox") -> Box:
    """``"W,S,E,N"`` → a checked box (see :func:`check_box`)."""
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) != 4:
        raise InputError(f"{what} expects four numbers W,S,E,N separated by commas, got {text!r}")
    try:
        return check_box([float(p) for p in parts], what)
    except ValueError:
        raise InputError(f"{what} expects four numbers W,S,E,N separated by commas, got {text!r}") from None


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
        raise InputError(f"--around expects numbers, got {lon!r},{lat!r} and radius {radius_m!r}") from None
    if not (math.isfinite(lon) and math.isfinite(lat) and -180 <= lon <= 180 and -90 < lat < 90):
        swapped = " (latitude and longitude swapped? the order is LON,LAT)" if -90 < lon < 90 and abs(lat) <= 180 else ""
        raise InputError(f"--around {lon:g},{lat:g}: not a longitude,latitude{swapped}")
    if not (math.isfinite(radius_m) and radius_m > 0):
        raise InputError(f"--radius must be a positive number of metres, got {radius_m:g}")
    dlat = math.degrees(radius_m / EARTH_RADIUS_M)
    if abs(lat) + dlat >= 90:
        raise InputError(f"--around {lon:g},{lat:g} --radius {radius_m:g}: the box reaches a pole")
    dlon = dlat / math.cos(math.radians(lat))
    if not (-180 <= lon - dlon and lon + dlon <= 180):
        raise InputError(f"--around {lon:g},{lat:g} --radius {radius_m:g}: the box crosses the antimeridian "
                         "(not supported)")
    return (lon - dlon, lat - dlat, lon + dlon, lat + dlat)


def _check_name(name: str) -> str:
    if not isinstance(name, str) or not _NAME.match(name) or name.strip() != name or name in (".", ".."):
        raise InputError(f"{name!r} cannot name an extract (no slashes, control characters or surrounding spaces)")
    return name


class _Boxes:
    """The boxes in libosmium's integer coordinates, with a grid to find the boxes of many points at once."""

    def __init__(self, boxes: list[Box]):
        b = np.asarray(boxes, dtype=float).reshape(-1, 4)
        self.lo = np.round(b[:, :2] * _COORDINATE_PRECISION).astype(np.int64)  # (B, 2) W, S
        self.hi = np.round(b[:, 2:] * _COORDINATE_PRECISION).astype(np.int64)  # (B, 2) E, N
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
        raise InputError(f"{out}: output folder does not exist")
    if not os.access(out, os.W_OK):
        raise InputError(f"{out}: output folder is not writable")
    try:
        strategy = ClipStrategy(options.strategy)
    except ValueError:
        raise InputError(f"clip strategy {options.strategy!r} is not one of {', '.join(s.value for s in ClipStrategy)}") from None
    checked = {_check_name(name): check_box(box, f"box {name}") for name, box in boxes.items()}
    if not checked:
        raise InputError("no boxes to clip")
    if strategy is ClipStrategy.ONE_PASS and options.index.split(",")[0] not in osmium.index.map_types():
        raise InputError(f"node-location index {options.index!r} is not one of {', '.join(osmium.index.map_types())}")
    result = ClipResult()
    try:
        result.why_empty.update(_outside_header_bounds(src, checked))
        names = [name for name in checked if name not in result.why_empty]
        if names:
            grid = _Boxes([checked[n] for n in names])
            if strategy is ClipStrategy.TWO_PASS:
                found = _two_pass(src, grid, len(names), out, options.complete_multipolygons)
            else:
                found = _one_pass(src, grid, len(names), options.index, options.complete_multipolygons)
            result.reads = found.reads
    except InputError:
        raise
    except (RuntimeError, ValueError, OSError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{src}: not a readable OSM file ({msg})") from None
    for k, name in enumerate(names):
        if not found.box_nodes[k]:
            w, s, e, n = checked[name]
            result.why_empty[name] = f"{src}: no data inside the box of {name} ({w:.5f},{s:.5f},{e:.5f},{n:.5f})"
            continue
        target = out / f"{name}.osm.pbf"
        result.counts[name] = _write(found, k, checked[name], target)
        result.paths[name] = target
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


@dataclass
class _Found:
    """What the passes collected, as plain values (one copy per object, shared by the boxes)."""

    nodes: dict[int, tuple] = field(default_factory=dict)  # id → (lon, lat, tags, meta)
    ways: dict[int, tuple] = field(default_factory=dict)  # id → (refs, tags, meta)
    relations: dict[int, tuple] = field(default_factory=dict)  # id → (members, tags, meta)
    box_nodes: list[set[int]] = field(default_factory=list)  # per box: nodes written
    box_ways: list[set[int]] = field(default_factory=list)
    box_relations: list[set[int]] = field(default_factory=list)
    reads: int = 0


def _meta(obj) -> tuple:
    return (obj.version, obj.timestamp, obj.changeset, obj.uid, obj.user)


def _relation_boxes(rel, node_boxes: dict[int, frozenset], way_boxes: dict[int, set]) -> set[int]:
    boxes: set[int] = set()
    for m in rel.members:
        if m.type == "n":
            boxes |= node_boxes.get(m.ref, frozenset())
        elif m.type == "w":
            boxes |= way_boxes.get(m.ref, frozenset())
    return boxes


def _take_relation(rel, boxes: set[int], found: _Found, rel_boxes: dict[int, set]) -> None:
    found.relations[rel.id] = ([(m.type, m.ref, m.role) for m in rel.members], dict(rel.tags), _meta(rel))
    rel_boxes[rel.id] = boxes


def _missing_members(found: _Found, rel_boxes: dict[int, set], way_boxes: dict[int, set]) -> dict[int, set[int]]:
    """Member ways of kept multipolygons that a box lacks: way id → those boxes."""
    missing: dict[int, set[int]] = {}
    for rel_id, (members, tags, _) in found.relations.items():
        if tags.get("type") != "multipolygon":
            continue
        for mtype, ref, _ in members:
            if mtype == "w":
                lack = rel_boxes[rel_id] - way_boxes.get(ref, set())
                if lack:
                    missing.setdefault(ref, set()).update(lack)
    return missing


def _two_pass(src: Path, grid: _Boxes, n_boxes: int, scratch: Path, complete: bool) -> _Found:
    found = _Found(box_nodes=[set() for _ in range(n_boxes)], box_ways=[set() for _ in range(n_boxes)],
                   box_relations=[set() for _ in range(n_boxes)])
    # Pass 1 (nodes, C++): every node's location into a file store; numpy finds those inside the boxes.
    node_boxes: dict[int, frozenset] = {}
    with tempfile.TemporaryDirectory(prefix=".clip-", dir=scratch) as tmp:
        store_path = Path(tmp, "nodes.sparse")
        store = osmium.index.create_map(f"sparse_file_array,{store_path}")
        with osmium.io.Reader(str(src), osmium.osm.NODE) as reader:
            osmium.apply(reader, osmium.NodeLocationsForWays(store))
        found.reads += 1
        for ids, boxes in _scan_store(store_path, grid):
            for node_id, box in zip(ids.tolist(), boxes.tolist()):
                node_boxes[node_id] = node_boxes.get(node_id, frozenset()) | {box}
        del store
    # Pass 2 (ways and relations): C++ lets through only those referencing a node inside or a kept way.
    tracker = osmium.IdTracker()
    for node_id in node_boxes:
        tracker.add_node(node_id)
    way_boxes: dict[int, set] = {}
    rel_boxes: dict[int, set] = {}
    fp = osmium.FileProcessor(str(src), osmium.osm.WAY | osmium.osm.RELATION).with_filter(tracker.contains_filter())
    for obj in fp:
        if obj.is_way():
            refs = [n.ref for n in obj.nodes]
            boxes: set[int] = set()
            for ref in refs:
                boxes |= node_boxes.get(ref, frozenset())
            found.ways[obj.id] = (refs, dict(obj.tags), _meta(obj))
            way_boxes[obj.id] = boxes
            tracker.add_way(obj.id)
        else:
            boxes = _relation_boxes(obj, node_boxes, way_boxes)
            if boxes:
                _take_relation(obj, boxes, found, rel_boxes)
    found.reads += 1
    # Pass 2b (ways, only if a multipolygon lacks members): the missing member ways.
    missing = _missing_members(found, rel_boxes, way_boxes) if complete else {}
    if missing:
        for way_id in missing:
            tracker.add_way(way_id)
        for way in osmium.FileProcessor(str(src), osmium.osm.WAY).with_filter(tracker.id_filter()):
            lack = missing.get(way.id)
            if lack is None:
                continue
            if way.id not in found.ways:
                found.ways[way.id] = ([n.ref for n in way.nodes], dict(way.tags), _meta(way))
            way_boxes.setdefault(way.id, set()).update(lack)
        found.reads += 1
    # Pass 3 (nodes): the nodes inside and those the kept ways reference, with tags and metadata.
    needed = _needed_nodes(found, node_boxes, way_boxes, rel_boxes)
    for node_id in needed:
        tracker.add_node(node_id)
    for node in osmium.FileProcessor(str(src), osmium.osm.NODE).with_filter(tracker.id_filter()):
        boxes_of_node = needed.get(node.id)
        if boxes_of_node is None or not node.location.valid():
            continue
        loc = node.location
        found.nodes[node.id] = (loc.lon, loc.lat, dict(node.tags), _meta(node))
        for b in boxes_of_node:
            found.box_nodes[b].add(node.id)
    found.reads += 1
    return found


def _scan_store(store_path: Path, grid: _Boxes):
    """(node ids, box indices) of the store's nodes inside the boxes, chunk by chunk."""
    size = store_path.stat().st_size
    if size % _STORE_ENTRY.itemsize:
        raise RuntimeError(f"unexpected node store layout ({size} bytes)")
    total = size // _STORE_ENTRY.itemsize
    with open(store_path, "rb") as fh:
        for start in range(0, total, _SCAN_CHUNK):
            chunk = np.fromfile(fh, dtype=_STORE_ENTRY, count=min(_SCAN_CHUNK, total - start))
            chunk = chunk[chunk["id"] != 0]  # the store's unused tail
            if chunk.size:
                point, box = grid.members(chunk["x"], chunk["y"])
                yield chunk["id"][point].astype(np.int64), box


def _needed_nodes(found: _Found, node_boxes: dict[int, frozenset], way_boxes: dict[int, set],
                  rel_boxes: dict[int, set]) -> dict[int, set[int]]:
    """Node id → the boxes it is written to; also files the ways and relations under their boxes."""
    needed: dict[int, set[int]] = {node_id: set(boxes) for node_id, boxes in node_boxes.items()}
    for way_id, boxes in way_boxes.items():
        for b in boxes:
            found.box_ways[b].add(way_id)
        for ref in found.ways[way_id][0]:
            needed.setdefault(ref, set()).update(boxes)
    for rel_id, boxes in rel_boxes.items():
        for b in boxes:
            found.box_relations[b].add(rel_id)
    return needed


def _one_pass(src: Path, grid: _Boxes, n_boxes: int, index: str, complete: bool) -> _Found:
    found = _Found(box_nodes=[set() for _ in range(n_boxes)], box_ways=[set() for _ in range(n_boxes)],
                   box_relations=[set() for _ in range(n_boxes)])
    locations = osmium.index.create_map(index)
    tagged_nodes = osmium.filter.EmptyTagFilter()
    tagged_nodes.enable_for(osmium.osm.NODE)
    node_boxes: dict[int, frozenset] = {}
    way_boxes: dict[int, set] = {}
    rel_boxes: dict[int, set] = {}
    tagged: dict[int, tuple] = {}
    for obj in osmium.FileProcessor(str(src)).with_locations(locations).with_filter(tagged_nodes):
        if obj.is_node():
            loc = obj.location
            point, box = grid.members(np.array([loc.x]), np.array([loc.y]))
            if box.size:
                node_boxes[obj.id] = frozenset(box.tolist())
                tagged[obj.id] = (loc.lon, loc.lat, dict(obj.tags), _meta(obj))
        elif obj.is_way():
            refs, xs, ys = [], [], []
            for nr in obj.nodes:
                refs.append(nr.ref)
                xs.append(nr.x)
                ys.append(nr.y)
            point, box = grid.members(np.array(xs), np.array(ys))
            if box.size:
                for p, b in zip(point.tolist(), box.tolist()):
                    node_boxes[refs[p]] = node_boxes.get(refs[p], frozenset()) | {b}
                found.ways[obj.id] = (refs, dict(obj.tags), _meta(obj))
                way_boxes[obj.id] = set(box.tolist())
        else:
            boxes = _relation_boxes(obj, node_boxes, way_boxes)
            if boxes:
                _take_relation(obj, boxes, found, rel_boxes)
    found.reads += 1
    missing = _missing_members(found, rel_boxes, way_boxes) if complete else {}
    if missing:
        tracker = osmium.IdTracker()
        for way_id in missing:
            tracker.add_way(way_id)
        for way in osmium.FileProcessor(str(src), osmium.osm.WAY).with_filter(tracker.id_filter()):
            if way.id not in found.ways:
                found.ways[way.id] = ([n.ref for n in way.nodes], dict(way.tags), _meta(way))
            way_boxes.setdefault(way.id, set()).update(missing[way.id])
        found.reads += 1
    for node_id, boxes in _needed_nodes(found, node_boxes, way_boxes, rel_boxes).items():
        if node_id in tagged:
            found.nodes[node_id] = tagged[node_id]
        else:
            try:
                loc = locations.get(node_id)
            except KeyError:
                continue  # referenced but not in the file
            if not loc.valid():
                continue
            found.nodes[node_id] = (loc.lon, loc.lat, {}, (None, None, None, None, None))
        for b in boxes:
            found.box_nodes[b].add(node_id)
    return found


def _write(found: _Found, k: int, box: Box, target: Path) -> dict[str, int]:
    """Box ``k``'s extract, sorted (nodes, ways, relations; ascending ids), written then renamed."""
    w, s, e, n = box
    header = osmium.io.Header()
    header.add_box(osmium.osm.Box(osmium.osm.Location(w, s), osmium.osm.Location(e, n)))
    header.set("generator", "osm-expand clip")
    header.set("sorting", "Type_then_ID")
    tmp = target.with_name(f".{target.name[:-len('.osm.pbf')]}.part.osm.pbf")
    try:
        with osmium.SimpleWriter(str(tmp), header=header, overwrite=True) as writer:
            for node_id in sorted(found.box_nodes[k]):
                lon, lat, tags, meta = found.nodes[node_id]
                writer.add_node(Node(id=node_id, location=(lon, lat), tags=tags, **_meta_attrs(meta)))
            for way_id in sorted(found.box_ways[k]):
                refs, tags, meta = found.ways[way_id]
                writer.add_way(Way(id=way_id, nodes=refs, tags=tags, **_meta_attrs(meta)))
            for rel_id in sorted(found.box_relations[k]):
                members, tags, meta = found.relations[rel_id]
                writer.add_relation(Relation(id=rel_id, members=members, tags=tags, **_meta_attrs(meta)))
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return {"nodes": len(found.box_nodes[k]), "ways": len(found.box_ways[k]),
            "relations": len(found.box_relations[k])}


def _meta_attrs(meta: tuple) -> dict:
    """The metadata the object has (a missing timestamp reads as 1970, a missing version as 0)."""
    version, timestamp, changeset, uid, user = meta
    attrs = {"version": version, "changeset": changeset, "uid": uid, "user": user,
             "timestamp": timestamp if timestamp is not None and timestamp.year > 1970 else None}
    return {k: v for k, v in attrs.items() if v}
