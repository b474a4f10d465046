"""The ``two-pass`` clip (the default): node locations in a file store, then C++ id filters, so that Python
touches only the clipped objects and the file's relations (see :mod:`osm_expand.clip`)."""
from __future__ import annotations

import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np
import osmium

from osm_expand.clip.boxes import _Boxes
from osm_expand.clip.found import _add, _boxes_of, _each, _Found, _Order
from osm_expand.clip.writer import _Extracts

__all__ = ["ID_BLOCK", "ID_BLOCK_BYTES"]

#: One entry of libosmium's ``sparse_file_array`` store: node id, then x and y in 1e-7 degree.
_STORE_ENTRY = np.dtype([("id", "<u8"), ("x", "<i4"), ("y", "<i4")])
#: Entries of the store scanned at once (16 MB).
_SCAN_CHUNK = 1 << 20
#: libosmium's dense id sets (IdTracker, IdFilter) allocate ID_BLOCK_BYTES (one bit an id) per block
#: of ID_BLOCK consecutive ids holding one (measured: 4.19 MB per id for ids 3·2**24 apart; Krems'
#: 15 042 node ids fall in 74 blocks and take 311 MB).
ID_BLOCK = 1 << 25
ID_BLOCK_BYTES = 4 << 20


def _two_pass(src: Path, grid: _Boxes, extracts: _Extracts, scratch: Path, complete: bool, max_blocks: int) -> int:
    """The clip by C++ filters (see :mod:`osm_expand.clip`); returns the number of reads."""
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
            found.take_way(obj, _boxes_of(boxes))
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
