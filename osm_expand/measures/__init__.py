"""Measures of a street network: the numbers a fidelity verdict compares.

The input is any set of polylines in metres, so the same measures describe an
OSM file as read, a GeoJSON file, the tool's own XML (segments with
coordinates only) or a grown district. Nothing here reads the project's
model.

Graph, from the lines alone
---------------------------
*Nodes* are points identified by their coordinates rounded to
``node_precision`` (1 cm): two lines that share a point share a node; a
bridge crossing a street without a shared point is no junction. Repeated
segments (a street drawn twice) count once. The *degree* of a node is the
number of segment ends there (a street passing through counts 2). *Junctions* have degree ≥ 3, *dead ends*
degree 1; degree-2 nodes are shape points. *Edges* are the maximal chains of
segments between nodes that are not shape points; a closed chain of shape
points (a ring with no junction) is one edge too.

*Open* ends are neither dead ends nor junctions: ends made by clipping the
lines to the ``window`` (degree-1 nodes within ``open_tolerance`` of its
boundary) and the caller's ``open_points`` (where a grown district meets the
old town; any node there). An edge with an open end is *cut*.

The measures (the fidelity issue; seed 004 §5.2–5.3 asks a district to look like its town)
-----------------------------------------------------------------------------------------
Distributions (1-D arrays):

- ``edge_length`` (m): arc length of every edge that is not cut.
- ``circuity``: arc length / chord (straight end-to-end distance) of every
  edge that is not cut, not a loop and has a chord of at least
  ``min_chord``. A cut edge's inside piece is not a real edge, so it enters
  neither.
- ``stroke_length`` (m): at each junction the pairs of edge ends that
  deflect less than ``stroke_deflection`` (180° minus the angle between the
  two leaving directions) are joined, smallest deflection first, each end at
  most once (greedy; ties by position); the chains of joined edges are
  strokes. Cut edges count with their length inside the window: a stroke
  cut by a window of the district's area is what both the district and a
  real part of that area show, and dropping cut strokes would drop every
  through street.
- ``junction_angle`` (degrees): around each junction, the angles between
  angularly consecutive edge ends (they sum to 360°; a four-way grid
  junction gives 90° four times, a T gives 90°, 90°, 180°). An edge end's
  direction points to the point ``heading_reach`` metres along the edge
  (or its far end), not along its first shape segment.
- ``block_area`` (m²) and ``block_compactness`` (4πA/P², 1 for a disc,
  π/4 for a square): bounded faces of the edges
  (:func:`shapely.polygonize`; dangles and cut edges bound nothing) of at
  least ``min_block_area``. Faces cut by the window are not closed and are
  not counted.
- ``alignment`` (degrees, 0–45): for each edge with a chord (cut ones
  included: their inside chord), the chord's direction against those of its
  ``alignment_neighbours`` nearest edges by arc midpoint within
  ``alignment_radius``, one value per (edge, neighbour) pair: the absolute
  difference mod 90°, folded to [0°, 45°] (0 for parallel and for
  perpendicular streets).
- ``curvature`` (degrees): every edge (cut ones included) resampled every
  ``curvature_step`` metres from its start; the absolute heading change
  between consecutive steps. A circle of radius R gives step/R radians.

Scalars (floats, NaN when undefined):

- ``density`` (km per km²): street length inside the window / window area.
  Without a window, the window is the lines' convex hull grown by
  ``hull_margin``.
- ``orientation_entropy`` (nats): Boeing (2019), "Urban spatial order:
  street network orientation, configuration, and entropy", Applied Network
  Science 4:67: the Shannon entropy of compass bearings in 36 bins of 10°
  centred on 0°, 10°, … (as osmnx's ``orientation_entropy``), every
  segment counted in both directions and weighted by its length. A grid
  aligned with the axes has ln 4 ≈ 1.386, uniform bearings ln 36 ≈ 3.584.
  Boeing bins each edge's end-to-end bearing; segment bearings keep the
  shape of curved edges (as :mod:`simplify.statistics` does).
- ``three_way_share``, ``four_way_share``, ``dead_end_share``: the
  shares of degree-3 junctions, degree-4 junctions and dead ends among the
  junctions and dead ends (Boeing's node proportions; open ends and shape
  points are not counted). :mod:`simplify.statistics` reports the 3- and
  4-way shares among junctions only, on the simplified network.
- ``two_core_share``: the share of the street length left after pruning
  dead-end trees (issue 20): edges with a dead end are removed, then those
  that became dead ends, until none is left (:func:`two_core`). Open ends
  are never pruned: a street cut by the window runs on outside it, and a
  district's street ending on the old town is joined there. How much of the
  network forms blocks or runs through: 1 for a grid without stubs, 0 for a
  tree; NaN with no street.

Apart from the verdict, ``pieces`` counts what the network makes on the
map: its lines (clipped to the window) buffered ``piece_buffer`` metres each
side and merged, the number of polygons (issue 20: a neighbourhood is one
piece). Two lines are in one piece when they are within twice the buffer of
each other, so the count is the connected components of the lines' "within
2 × buffer" pairs (an STRtree query), not a union of buffers.
"""
from __future__ import annotations

from osm_expand.measures.graph import junction_points, two_core
from osm_expand.measures.kinds import DISTRIBUTIONS, SCALARS, Measure, MeasureOptions, NetworkMeasures, measure_named
from osm_expand.measures.lines import LineSet
from osm_expand.measures.network import measure_network
from osm_expand.measures.shape import count_pieces, orientation_entropy, piece_labels

__all__ = ["DISTRIBUTIONS", "SCALARS", "LineSet", "Measure", "MeasureOptions", "NetworkMeasures",
           "count_pieces", "junction_points", "measure_named", "measure_network", "orientation_entropy", "piece_labels",
           "two_core"]
