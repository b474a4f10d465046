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

from osm_expand.clip.boxes import Box, box_around, check_box, parse_bbox, requested_box
from osm_expand.clip.extract import clip, clip_extracts, clipped
from osm_expand.clip.options import ClipOptions, ClipResult, ClipStrategy, options_for_index

__all__ = ["Box", "ClipOptions", "ClipResult", "ClipStrategy", "box_around", "check_box", "clip", "clip_extracts",
           "clipped", "options_for_index", "parse_bbox", "requested_box"]
