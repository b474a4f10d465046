"""Pass 4 (004 §4.2.2): add the junctions OSM forgot.

Segments that cross, touch or overlap without sharing a node get one, but
only when both streets are on the same layer (same ``layer``, ``bridge`` and
``tunnel``): a bridge over a street is not a junction. Candidate pairs come
from an STRtree query, and the intersection arithmetic is vectorised.
"""
from __future__ import annotations

from collections import defaultdict

import numpy as np
import shapely

from osm_expand.model import Street, StreetNetwork, closest_on_segments, match_points
from osm_expand.model.components import UnionFind, close_pairs, component_labels
from osm_expand.model.topology import append_nodes, clean_nodes, flat_nodes, split_self_touching
from simplify.options import SimplifyOptions


def segment_table(net: StreetNetwork) -> dict[str, np.ndarray]:
    """One row per street segment: its nodes, street, position and layer key."""
    if not net.streets:
        empty = np.zeros(0, np.intp)
        return {"u": empty, "v": empty, "street": empty, "pos": empty, "layer": empty}
    nodes, owner = flat_nodes(net.streets)
    keys: dict[tuple, int] = {}
    street_layer = np.fromiter((keys.setdefault(s.layer_key, len(keys)) for s in net.streets), dtype=np.intp,
                               count=len(net.streets))
    last = np.flatnonzero(owner[1:] != owner[:-1])  # a street's last node starts no segment
    start = np.ones(len(nodes), dtype=bool)
    start[last] = False
    start[-1] = False
    first = np.concatenate([[0], last + 1])  # where each street with nodes begins in ``nodes``
    i = np.flatnonzero(start)
    street = owner[i]
    begin = np.zeros(len(net.streets), dtype=np.intp)
    begin[owner[first]] = first
    return {"u": nodes[i].astype(np.intp), "v": nodes[i + 1].astype(np.intp), "street": street.astype(np.intp),
            "pos": (i - begin[street]).astype(np.intp), "layer": street_layer[street]}


def segment_lines(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """LineStrings from ``a[i]`` to ``b[i]`` ((N, 2) each), made in one call."""
    coords = np.empty((2 * len(a), 2))
    coords[0::2], coords[1::2] = a, b
    return shapely.from_ragged_array(shapely.GeometryType.LINESTRING, coords, (np.arange(0, 2 * len(a) + 1, 2),))


def candidate_pairs(net: StreetNetwork, seg: dict[str, np.ndarray],
                    tolerance: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Same-layer segment pairs closer than ``tolerance``, and whether they share a node.

    Pairs that share a node still matter when they fold back over each other.
    """
    a, b = net.xy[seg["u"]], net.xy[seg["v"]]
    lines = segment_lines(a, b)
    zero = (a == b).all(axis=1)
    lines[zero] = shapely.points(a[zero])  # a zero-length line is invisible to the index; its point is not
    tree = shapely.STRtree(lines)
    p, q = tree.query(lines, predicate="dwithin", distance=tolerance)
    keep = (p < q) & (seg["layer"][p] == seg["layer"][q])
    p, q = p[keep], q[keep]
    up, vp, uq, vq = seg["u"][p], seg["v"][p], seg["u"][q], seg["v"][q]
    shared = (up == uq) | (up == vq) | (vp == uq) | (vp == vq)
    return p, q, shared


def add_missing_intersections(net: StreetNetwork, opts: SimplifyOptions) -> tuple[StreetNetwork, int]:
    """Returns the network and how many junctions were added or joined."""
    seg = segment_table(net)
    if len(seg["u"]) == 0:
        return net, 0
    p, q, shared = candidate_pairs(net, seg, opts.touch_tolerance)
    if len(p) == 0:
        return net, 0
    tol = opts.touch_tolerance
    xy = net.xy
    inserts: defaultdict[int, list[tuple[float, int]]] = defaultdict(list)
    merges: list[tuple[int, int]] = []

    # 1. a vertex touching another segment (T without a node, overlaps, duplicate nodes)
    for this, other in ((p, q), (q, p)):
        for end in ("u", "v"):
            node = seg[end][this]
            t, _, d = closest_on_segments(xy[node], xy[seg["u"][other]], xy[seg["v"][other]])
            close = (d <= tol) & (node != seg["u"][other]) & (node != seg["v"][other])
            seg_len = np.hypot(*(xy[seg["v"][other]] - xy[seg["u"][other]]).T)
            margin = tol / np.maximum(seg_len, 1e-12)
            interior = close & (t > margin) & (t < 1 - margin)
            for s, tt, n in zip(other[interior], t[interior], node[interior]):
                inserts[int(s)].append((float(tt), int(n)))
            at_u = close & (t <= margin)
            at_v = close & (t >= 1 - margin)
            merges += list(zip(node[at_u].tolist(), seg["u"][other][at_u].tolist()))
            merges += list(zip(node[at_v].tolist(), seg["v"][other][at_v].tolist()))

    # 2. proper crossings in both interiors: a new node
    p, q = p[~shared], q[~shared]
    t, s, ok = _crossing_params(xy[seg["u"][p]], xy[seg["v"][p]], xy[seg["u"][q]], xy[seg["v"][q]])
    len_p = np.hypot(*(xy[seg["v"][p]] - xy[seg["u"][p]]).T)
    len_q = np.hypot(*(xy[seg["v"][q]] - xy[seg["u"][q]]).T)
    ok &= (t * len_p > tol) & ((1 - t) * len_p > tol) & (s * len_q > tol) & ((1 - s) * len_q > tol)
    points = xy[seg["u"][p][ok]] + t[ok, None] * (xy[seg["v"][p][ok]] - xy[seg["u"][p][ok]])
    labels = _dedupe_points(points, tol)
    centres = _representatives(points, labels)
    existing = _existing_vertex(xy, np.unique(np.concatenate([seg["u"][p], seg["v"][p], seg["u"][q], seg["v"][q]])),
                                centres, tol)
    fresh = existing < 0
    xy2, ids2, first = append_nodes(net, centres[fresh])
    node_of = existing.copy()
    node_of[fresh] = first + np.arange(int(fresh.sum()))
    for sp, sq, tp, tq, label in zip(p[ok], q[ok], t[ok], s[ok], labels):
        inserts[int(sp)].append((float(tp), int(node_of[label])))
        inserts[int(sq)].append((float(tq), int(node_of[label])))

    streets = _apply(net.streets, seg, inserts, _merge_map(merges))
    changed = len(merges) + int(ok.sum()) + sum(len(v) for v in inserts.values())
    return net.replace(xy=xy2, node_ids=ids2, streets=streets), changed


def _crossing_params(a1, b1, a2, b2):
    d1, d2, w = b1 - a1, b2 - a2, a2 - a1
    den = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    scale = np.hypot(*d1.T) * np.hypot(*d2.T)
    ok = np.abs(den) > 1e-12 * np.maximum(scale, 1e-24)
    safe = np.where(ok, den, 1.0)
    t = (w[:, 0] * d2[:, 1] - w[:, 1] * d2[:, 0]) / safe
    s = (w[:, 0] * d1[:, 1] - w[:, 1] * d1[:, 0]) / safe
    ok &= (t >= 0) & (t <= 1) & (s >= 0) & (s <= 1)
    return t, s, ok


def _dedupe_points(points: np.ndarray, tol: float) -> np.ndarray:
    """Label crossing points so that coincident ones (three streets at a point) share a node."""
    pairs = close_pairs(points, tol)
    return component_labels(len(points), pairs[:, 0], pairs[:, 1])


def _existing_vertex(xy: np.ndarray, candidates: np.ndarray, points: np.ndarray, tol: float) -> np.ndarray:
    """For each crossing point, a vertex already there (a third street's node), or -1."""
    near = match_points(points, xy[candidates], tol)
    return np.where(near >= 0, candidates[near], -1) if len(candidates) else near


def _representatives(points: np.ndarray, labels: np.ndarray) -> np.ndarray:
    if len(points) == 0:
        return np.zeros((0, 2))
    out = np.zeros((labels.max() + 1, 2))
    np.add.at(out, labels, points)
    return out / np.bincount(labels)[:, None]


def _merge_map(pairs: list[tuple[int, int]]) -> dict[int, int]:
    """Node → representative (the smallest index) for coincident distinct nodes."""
    if not pairs:
        return {}
    ds: UnionFind[int] = UnionFind()
    for a, b in pairs:
        ds.add(a)
        ds.add(b)
        ds.merge(a, b)
    return {n: min(group) for group in ds.subsets() for n in group if n != min(group)}


def _apply(streets, seg, inserts, remap: dict[int, int]) -> tuple[Street, ...]:
    by_street: defaultdict[int, dict[int, list[tuple[float, int]]]] = defaultdict(dict)
    for s, items in inserts.items():
        by_street[int(seg["street"][s])][int(seg["pos"][s])] = sorted(items)
    out: list[Street] = []
    for k, street in enumerate(streets):
        nodes = street.nodes
        if k in by_street:
            extra = by_street[k]
            seq = []
            for i, n in enumerate(nodes):
                seq.append(n)
                seq.extend(m for _, m in extra.get(i, ()))
            nodes = tuple(seq)
        if remap:
            nodes = tuple(remap.get(n, n) for n in nodes)
        if nodes is not street.nodes:
            cleaned = clean_nodes(nodes)
            if cleaned is None:
                continue
            out.extend(split_self_touching(street.with_nodes(cleaned)))
        else:
            out.append(street)
    return tuple(out)
