"""Every measure of a street network inside a window, in one call (definitions in :mod:`osm_expand.measures`)."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely

from osm_expand.measures.graph import _build_graph, two_core
from osm_expand.measures.kinds import Measure, MeasureOptions, NetworkMeasures, measure_named
from osm_expand.measures.lines import LineSet
from osm_expand.measures.shape import (
    _alignment,
    _blocks,
    _curvature,
    _edge_ends,
    _junction_angles,
    _rounded,
    _strokes,
    orientation_entropy,
    piece_labels,
)

__all__ = ["measure_network"]


def measure_network(lines: Sequence[np.ndarray] | LineSet, *, window: shapely.Geometry | None = None,
                    open_points: np.ndarray | None = None, options: MeasureOptions | None = None,
                    pieces: bool = True, wanted: Sequence[Measure | str] | None = None) -> NetworkMeasures:
    """Every measure of a street network inside ``window``.

    Parameters
    ----------
    lines : polylines, each ``(n_i, 2)`` float metres (or a :class:`LineSet`
        of them, to measure many windows on the same lines cheaply).
    window : shapely polygon, metres: the area measured; lines are clipped
        to it and ends made by the clip are open. Default: the lines' convex
        hull grown by ``options.hull_margin`` (nothing is clipped).
    open_points : ``(K, 2)`` metres: more open ends (where a district's
        streets end on the old town); nodes within ``open_tolerance``.
    options : :class:`MeasureOptions`.
    pieces : count the pieces (False for a whole town, where nobody asks and it costs most).
    wanted : the measures the caller reads (default: all). Of the others, the costly ones are left
        out (strokes, blocks — their count is then -1 — and alignment: half of a window's time,
        for a pattern ranking thousands of windows by five measures); they come back empty and
        :meth:`NetworkMeasures.value` refuses them. What is computed is the same either way.

    Returns
    -------
    :class:`NetworkMeasures`: eight distributions, six scalars and counts.
    """
    opts = options or MeasureOptions()
    asked = set(Measure) if wanted is None else {measure_named(m) for m in wanted}
    left_out = frozenset({Measure.STROKE_LENGTH, Measure.BLOCK_AREA, Measure.BLOCK_COMPACTNESS, Measure.ALIGNMENT}
                         - asked)
    blocks_left_out = {Measure.BLOCK_AREA, Measure.BLOCK_COMPACTNESS} <= left_out
    line_set = LineSet.from_lines(lines)
    if window is None:
        region = line_set.hull(opts.hull_margin)
        coords, label = line_set.coords, line_set.line_of
    else:
        region = window
        coords, label = line_set.clip(window)
    g = _build_graph(coords, label, window=window, open_points=open_points, opts=opts)
    area = float(region.area)
    total = float(g.seg_len.sum())
    junction = (g.degree >= 3) & ~g.is_open
    dead_end = (g.degree == 1) & ~g.is_open
    counted = int(junction.sum() + dead_end.sum())
    share = (lambda mask: float(mask.sum() / counted)) if counted else (lambda mask: float("nan"))

    cut = g.is_open[g.start_node] | g.is_open[g.end_node]
    chord = np.hypot(*(g.xy[g.end_node] - g.xy[g.start_node]).T)
    has_chord = chord >= opts.min_chord
    node, edge, angle = _edge_ends(g, opts.heading_reach)
    at_junction = junction[node]
    block_area, compactness = (np.zeros(0), np.zeros(0)) if blocks_left_out else _blocks(g, opts.min_block_area)
    vectors = g.xy[g.head] - g.xy[g.tail]
    core = two_core(g.start_node, g.end_node, len(g.xy), anchored=g.is_open)
    n_pieces = -1
    if pieces:
        dense = np.unique(label, return_inverse=True)[1].reshape(-1)
        geoms = shapely.linestrings(coords, indices=dense) if len(coords) else np.empty(0, dtype=object)
        labels = piece_labels(geoms, opts.piece_buffer)
        n_pieces = int(labels.max() + 1) if len(labels) else 0
    return NetworkMeasures(
        edge_length=g.length[~cut],
        circuity=g.length[~cut & has_chord] / chord[~cut & has_chord],
        stroke_length=np.zeros(0) if Measure.STROKE_LENGTH in left_out else
        _strokes(g, node[at_junction], edge[at_junction], angle[at_junction], opts.stroke_deflection),
        junction_angle=_rounded(_junction_angles(node[at_junction], angle[at_junction]), opts.angle_resolution),
        block_area=block_area,
        block_compactness=compactness,
        alignment=np.zeros(0) if Measure.ALIGNMENT in left_out else
        _rounded(_alignment(g, has_chord, opts.alignment_neighbours, opts.alignment_radius), opts.angle_resolution),
        curvature=_rounded(_curvature(g, opts.curvature_step), opts.angle_resolution),
        density=total * 1000.0 / area if area > 0 else float("nan"),
        orientation_entropy=orientation_entropy(vectors, bins=opts.orientation_bins),
        three_way_share=share(junction & (g.degree == 3)),
        four_way_share=share(junction & (g.degree == 4)),
        dead_end_share=share(dead_end),
        two_core_share=float(g.seg_len[core[g.edge_of]].sum() / total) if total > 0 else float("nan"),
        length=total, area=area,
        junctions=int(junction.sum()), dead_ends=int(dead_end.sum()), open_ends=int(g.is_open.sum()),
        edges=len(g.length), cut_edges=int(cut.sum()), blocks=-1 if blocks_left_out else len(block_area),
        pieces=n_pieces, left_out=left_out,
    )
