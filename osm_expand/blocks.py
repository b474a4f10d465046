"""City blocks: the faces of the street graph, found by wall following (004 §4.3).

Every junction-to-junction piece of a street is an edge with its full shape.
Walking an edge and, at each junction, turning onto the next edge clockwise
from the one just arrived on (always keeping the wall on the left) goes once
around a face; doing this from both directions of every edge finds every
face exactly once. Faces traced counter-clockwise are blocks; the clockwise
ones are the outer boundaries of connected pieces of the network.

Works on the town as mapped: dead-end streets (cul-de-sac trees) bound no
block, so the walk runs on the graph's 2-core, and a street touching itself
is cut where it does. Each block remembers the street under every edge of
its outline (``Block.street_ids``), which is the frontage lots need.

Kept as blocks: valid polygons of at least ``min_area`` and at most
``max_area`` square metres with at most ``max_edges`` edges (004 discards
"blocks with too many faces"). Bridges and tunnels make the graph
non-planar, so faces can overlap; of two partly overlapping faces the
larger goes, and a face around a separate piece of network gets it as a
hole, which leaves the blocks disjoint.

Known limitation: a face whose ring is not simple (a bridge crosses it, or
two streets cross on one layer without a shared node, a mapping error) is
left out, and then does not become a hole in the block around it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from osm_expand.model import Block, Origin, StreetNetwork
from osm_expand.model.topology import junction_mask, piece_table, split_self_touching


@dataclass(frozen=True)
class BlockOptions:
    min_area: float = 100.0  #: m²: slivers between near-parallel streets are not blocks
    max_area: float = 2_000_000.0  #: m²: bigger faces are fields and forests between villages
    max_edges: int = 60  #: junction-to-junction edges around a face (004: too many is no block)


@dataclass(frozen=True)
class _Pieces:
    """Junction-to-junction pieces of the 2-core: end nodes, polylines and street ids."""

    u: np.ndarray
    v: np.ndarray
    lines: list[np.ndarray]
    street_id: np.ndarray


def _pieces(net: StreetNetwork) -> _Pieces:
    streets = [p for s in net.streets for p in split_self_touching(s)]
    junction = junction_mask(streets, len(net.xy))
    table = piece_table(streets, junction)
    keep = _two_core(table["u"], table["v"], len(net.xy))
    lines = [net.xy[list(streets[k].nodes[a:b + 1])]
             for k, a, b in zip(table["street"][keep].tolist(), table["a"][keep].tolist(), table["b"][keep].tolist())]
    ids = np.array([streets[k].id for k in table["street"][keep].tolist()], dtype=np.int64)
    return _Pieces(u=table["u"][keep], v=table["v"][keep], lines=lines, street_id=ids)


def _two_core(u: np.ndarray, v: np.ndarray, n: int) -> np.ndarray:
    """Pieces that lie on a cycle or between cycles: dead-end trees peeled off, leaf by leaf."""
    keep = np.ones(len(u), dtype=bool)
    while True:
        degree = np.bincount(u[keep], minlength=n) + np.bincount(v[keep], minlength=n)
        leaf = keep & ((degree[u] == 1) | (degree[v] == 1))
        if not leaf.any():
            return keep
        keep &= ~leaf


def faces(net: StreetNetwork) -> list[tuple[np.ndarray, int, np.ndarray]]:
    """Every face of the street graph's 2-core.

    Returns
    -------
    list of (ring, edges, street_ids)
        ``ring`` a closed (k + 1, 2) array (counter-clockwise if the face is
        bounded), ``edges`` the number of junction-to-junction pieces around
        it, ``street_ids`` the (k,) street id under each ring edge.
    """
    pc = _pieces(net)
    n = len(pc.lines)
    if n == 0:
        return []
    # half-edge 2i goes u->v along lines[i], 2i+1 goes back
    start = np.empty(2 * n, dtype=np.int64)
    start[0::2], start[1::2] = pc.u, pc.v
    first_step = np.array([ln[1] - ln[0] for ln in pc.lines] + [ln[-2] - ln[-1] for ln in pc.lines])
    order = np.concatenate([np.arange(0, 2 * n, 2), np.arange(1, 2 * n, 2)])
    angle = np.empty(2 * n)
    angle[order] = np.arctan2(first_step[:, 1], first_step[:, 0])
    around: dict[int, list[int]] = {}
    for h in np.lexsort((angle, start)).tolist():  # per node, leaving half-edges counter-clockwise
        around.setdefault(int(start[h]), []).append(h)
    position = {h: i for hs in around.values() for i, h in enumerate(hs)}
    used = np.zeros(2 * n, dtype=bool)
    out = []
    for h0 in range(2 * n):
        if used[h0]:
            continue
        ring, ids, h = [], [], h0
        while not used[h]:
            used[h] = True
            pts = pc.lines[h // 2] if h % 2 == 0 else pc.lines[h // 2][::-1]
            ring.append(pts[:-1])
            ids.append(np.full(len(pts) - 1, pc.street_id[h // 2]))
            twin = h ^ 1
            hs = around[int(start[twin])]
            h = hs[(position[twin] - 1) % len(hs)]  # the next edge clockwise from the way back
        if h == h0:
            edges = len(ring)
            ring.append(ring[0][:1])
            out.append((np.vstack(ring), edges, np.concatenate(ids)))
    return out


def blocks(net: StreetNetwork, options: BlockOptions | None = None, *, origin: Origin = Origin.SOURCE,
           year: int | None = None) -> list[Block]:
    """The plausible, pairwise disjoint blocks of a network, from its streets' real shapes.

    Parameters
    ----------
    net : StreetNetwork
        Any network: the town as mapped (dead ends and all) or a simplified one.
    options : BlockOptions
    origin, year
        Stamped on every block.

    Returns
    -------
    list of Block
        Numbered 0, 1, ... in the order the faces were found.
    """
    opts = options or BlockOptions()
    bounded, edge_count, street_ids = [], [], []
    for ring, edges, ids in faces(net):
        if len(ring) >= 4 and _signed_area(ring) > 0:
            poly = shapely.Polygon(ring)
            if poly.is_valid:  # a face walking a street twice or crossing a bridge is left out
                bounded.append(poly)
                edge_count.append(edges)
                street_ids.append(ids)
    # holes first (a sliver inside a block is still a hole in it), plausibility after
    kept = [(k, p) for k, p in _disjoint(bounded)
            if edge_count[k] <= opts.max_edges and opts.min_area <= p.area <= opts.max_area]
    out = []
    for i, (k, p) in enumerate(kept):
        ids = street_ids[k] if not len(p.interiors) else _edge_streets(p, bounded[k], street_ids[k])
        out.append(Block(polygon=p, street_ids=tuple(ids.tolist()), id=i, origin=origin, year=year))
    return out


def _edge_streets(poly: shapely.Polygon, face: shapely.Polygon, ids: np.ndarray) -> np.ndarray:
    """Street ids under the exterior edges of ``poly`` (a face with holes cut), looked up by the face's edges."""
    coords = np.asarray(face.exterior.coords)
    lookup = {}
    for (a, b), k in zip(zip(map(tuple, coords[:-1].tolist()), map(tuple, coords[1:].tolist())), ids.tolist()):
        lookup[(a, b)] = lookup[(b, a)] = k
    ext = np.asarray(poly.exterior.coords)
    return np.array([lookup.get((a, b), -1) for a, b in zip(map(tuple, ext[:-1].tolist()), map(tuple, ext[1:].tolist()))],
                    dtype=np.int64)


def polygons(items: list[Block]) -> list[shapely.Polygon]:
    """The blocks' polygons."""
    return [b.polygon for b in items]


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
