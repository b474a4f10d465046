"""City blocks: the faces of the street graph, found by wall following (004 §4.3).

Every junction-to-junction piece of a street is an edge with its full shape.
Walking an edge and, at each junction, turning onto the next edge clockwise
from the one just arrived on (always keeping the wall on the left) goes once
around a face; doing this from both directions of every edge finds every
face exactly once. Faces traced counter-clockwise are blocks; the clockwise
ones are the outer boundaries of connected pieces of the network.

Kept as blocks: valid polygons of at least ``min_area`` and at most
``max_area`` square metres with at most ``max_edges`` edges (004 discards
"blocks with too many faces"). Bridges and tunnels make the graph
non-planar, so faces can overlap; of two partly overlapping faces the
larger goes, and a face around a separate piece of network gets it as a
hole, which leaves the blocks disjoint.

Known limitation (for the site and lots stages): a face whose ring is not
simple (it walks a street twice, or a bridge crosses it) is left out, and
then does not become a hole in the block around it; on north-bayreuth about
1 km of street runs through such a block's interior.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from osm_expand.model import StreetNetwork
from simplify.topology import junction_mask, piece_table


@dataclass(frozen=True)
class BlockOptions:
    min_area: float = 100.0  # m²: slivers between near-parallel streets are not blocks
    max_area: float = 2_000_000.0  # m²: bigger faces are fields and forests between villages
    max_edges: int = 60


def _half_edges(net: StreetNetwork):
    """Per junction-to-junction piece: its polyline; per direction: start node and leaving angle."""
    junction = junction_mask(net.streets, len(net.xy))
    table = piece_table(net.streets, junction)
    lines = []
    for k, a, b in zip(table["street"].tolist(), table["a"].tolist(), table["b"].tolist()):
        lines.append(net.xy[list(net.streets[k].nodes[a:b + 1])])
    return table["u"], table["v"], lines


def faces(net: StreetNetwork) -> list[tuple[np.ndarray, int]]:
    """Every face of the street graph: a closed ring (counter-clockwise if bounded) and its edge count."""
    u, v, lines = _half_edges(net)
    n = len(lines)
    if n == 0:
        return []
    # half-edge 2i goes u->v along lines[i], 2i+1 goes back
    start = np.empty(2 * n, dtype=np.int64)
    start[0::2], start[1::2] = u, v
    first_step = np.array([ln[1] - ln[0] for ln in lines] + [ln[-2] - ln[-1] for ln in lines])
    order = np.concatenate([np.arange(0, 2 * n, 2), np.arange(1, 2 * n, 2)])
    angle = np.empty(2 * n)
    angle[order] = np.arctan2(first_step[:, 1], first_step[:, 0])
    around: dict[int, list[int]] = {}
    for h in np.lexsort((angle, start)).tolist():  # per node, leaving half-edges counter-clockwise
        around.setdefault(int(start[h]), []).append(h)
    position = {h: i for hs in around.values() for i, h in enumerate(hs)}
    used = np.zeros(2 * n, dtype=bool)
    rings = []
    for h0 in range(2 * n):
        if used[h0]:
            continue
        ring, h = [], h0
        while not used[h]:
            used[h] = True
            pts = lines[h // 2] if h % 2 == 0 else lines[h // 2][::-1]
            ring.append(pts[:-1])
            twin = h ^ 1
            hs = around[int(start[twin])]
            h = hs[(position[twin] - 1) % len(hs)]  # the next edge clockwise from the way back
        if h == h0:
            edges = len(ring)
            ring.append(ring[0][:1])
            rings.append((np.vstack(ring), edges))
    return rings


def blocks(net: StreetNetwork, options: BlockOptions | None = None) -> list[shapely.Polygon]:
    """The plausible, pairwise disjoint blocks of a network, from its streets' real shapes."""
    opts = options or BlockOptions()
    bounded, edge_count = [], []
    for ring, edges in faces(net):
        if len(ring) >= 4 and _signed_area(ring) > 0:
            poly = shapely.Polygon(ring)
            if poly.is_valid:  # a face walking a street twice or crossing a bridge is left out
                bounded.append(poly)
                edge_count.append(edges)
    # holes first (a sliver inside a block is still a hole in it), plausibility after
    return [p for k, p in _disjoint(bounded)
            if edge_count[k] <= opts.max_edges and opts.min_area <= p.area <= opts.max_area]


def _signed_area(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.dot(x[:-1], y[1:]) - np.dot(x[1:], y[:-1]))


def _disjoint(polys: list[shapely.Polygon]) -> list[tuple[int, shapely.Polygon]]:
    """Make the faces pairwise disjoint; returns (index, polygon) of those kept.

    A face that contains another (a separate piece of network inside a
    block) gets it as a hole; of two faces that partly overlap (a bridge or
    tunnel crossing without a junction) the larger goes.
    """
    if not polys:
        return []
    polys = list(polys)
    tree = shapely.STRtree(polys)
    # faces that only share edges touch; overlapping or nested ones are the pairs to settle
    pairs = np.unique(np.concatenate([np.stack(tree.query(polys, predicate=p), axis=1)
                                      for p in ("overlaps", "contains", "within")]), axis=0)
    drop, holes = set(), {}
    for i, j in pairs.tolist():
        if i >= j:
            continue
        shared = polys[i].intersection(polys[j]).area
        if shared <= 1.0:
            continue
        small, large = (i, j) if polys[i].area <= polys[j].area else (j, i)
        if shared >= polys[small].area - 1.0:
            holes.setdefault(large, []).append(small)
        else:
            drop.add(large)
    for large, inner in holes.items():
        polys[large] = polys[large].difference(shapely.union_all([polys[k] for k in inner]))
    return [(k, p) for k, p in enumerate(polys)
            if k not in drop and not p.is_empty and p.geom_type == "Polygon"]
