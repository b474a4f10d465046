"""The district's corners: how sharply its streets turn where no junction explains it, counted beside its
town's own rate (issue 20's count; the benchmarks and tests read it)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from osm_expand.model import City, StreetNetwork, polyline_length, turn_angles
from osm_expand.model.geometry import linestrings_of
from synth.patches.source import _neighbourhood_points, _source


def corner_turns(net: StreetNetwork, among: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The nodes where exactly two segments meet (of ``among`` only when given, e.g. the district's), in
    ascending order, and the turn (degrees, 0-180) at each: how sharply a street bends where no junction
    explains it.

    The fidelity yardstick reads streets as chains between junctions (:mod:`osm_expand.measures`), so
    a bend at a node of degree 2 is part of one street's curvature however it arose: an L left where a
    seam cut a tee's arm, a seam link zig-zagging between two cut streets, a perimeter street on the
    jagged edge of the free land (issue 20: Krems seed 0 had 41 turns over 45°, 13 of them such Ls).
    A district is judged by how many of these exceed 45° per km beside its town's own rate.
    """
    seg = np.array([(a, b) for s in net.streets for a, b in zip(s.nodes[:-1], s.nodes[1:]) if a != b],
                   dtype=np.int64).reshape(-1, 2)
    degree = np.bincount(seg.ravel(), minlength=len(net.xy))
    node, other = np.concatenate([seg[:, 0], seg[:, 1]]), np.concatenate([seg[:, 1], seg[:, 0]])
    two = degree[node] == 2
    if among is not None:
        two &= np.isin(node, among)
    order = np.argsort(node[two], kind="stable")
    node, other = node[two][order], other[two][order]
    at, before, after = node[0::2], other[0::2], other[1::2]
    return at, turn_angles(net.xy[at] - net.xy[before], net.xy[after] - net.xy[at])


#: degrees: a turn sharper than this at a node of degree 2 is a corner (issue 20's count).
SHARP = 45.0


def sharp_corners(net: StreetNetwork) -> tuple[int, float]:
    """The corners sharper than :data:`SHARP` at degree-2 nodes of ``net``'s new streets, and those
    streets' length in km: the count and the length it is read over, so that a district's rate per km
    can stand beside its town's (:func:`neighbourhood_corner_rates`)."""
    mine = [s for s in net.streets if s.is_new]
    if not mine:
        return 0, 0.0
    nodes = np.unique(np.concatenate([np.asarray(s.nodes) for s in mine]))
    km = sum(polyline_length(net.street_xy(s)) for s in mine) / 1000.0
    return int((corner_turns(net, nodes)[1] > SHARP).sum()), float(km)


@dataclass(frozen=True)
class MappedCorners:
    """The town's streets as mapped and their corners sharper than :data:`SHARP` at nodes of degree two:
    read once per network, then counted in any disc (:func:`corners_in_discs`).

    Every street as mapped, the motorways and ramps too (:data:`~synth.patches.options.NOT_COPIED`), which a
    district never copies: the neighbourhoods are read as the verdict reads them (its ``everything``
    source), so a rate here is the town's as the yardstick sees it, not only of what may be copied."""

    lines: np.ndarray  #: shapely LineStrings of the mapped streets
    tree: shapely.STRtree
    sharp: np.ndarray  #: (n, 2) the corners' positions

    @classmethod
    def of(cls, net: StreetNetwork) -> MappedCorners:
        mapped = [s for s in net.streets if not s.is_new]
        if not mapped:
            empty = np.zeros(0, dtype=object)
            return cls(lines=empty, tree=shapely.STRtree(empty), sharp=np.zeros((0, 2)))
        at, turns = corner_turns(net, np.unique(np.concatenate([np.asarray(s.nodes) for s in mapped])))
        lines = linestrings_of([net.street_xy(s) for s in mapped])
        return cls(lines=lines, tree=shapely.STRtree(lines), sharp=net.xy[at[turns > SHARP]])


def corners_in_discs(net: StreetNetwork | MappedCorners, centres: np.ndarray, radius: float) -> np.ndarray:
    """Corners sharper than :data:`SHARP` per km at degree-2 nodes of ``net``'s streets as mapped, in each disc
    of ``radius`` metres on ``centres`` (the town's neighbourhoods, drawn as the fidelity yardstick draws them):
    the rate a district of that area is read beside; NaN for a disc with no street.

    Read on the streets the district copies (the town as mapped, with its nodes), not on the simplified example:
    simplification drops nodes, merges ways and removes short streets, so a rate read there is not the same
    reading as the district's (whose pieces are the mapped ways, and whose links are laid every few metres).
    Krems: 1.03 per km on its simplified streets, 0.36 over the whole extract as mapped, 0.7-0.8 (median) in
    its neighbourhoods at the district's size; north-bayreuth 1.06, 0.74, 1.0-1.2.
    """
    read = net if isinstance(net, MappedCorners) else MappedCorners.of(net)
    out = np.full(len(centres), np.nan)
    for k, c in enumerate(np.asarray(centres, dtype=float).reshape(-1, 2)):
        disc = shapely.Point(c).buffer(radius, 16)
        near = read.lines[read.tree.query(disc, predicate="intersects")]
        km = float(shapely.length(shapely.intersection(near, disc)).sum()) / 1000.0
        if km > 0:
            out[k] = float((np.hypot(*(read.sharp - c).T) <= radius).sum()) / km
    return out


def neighbourhood_corner_rates(city: City, radius: float, n: int = 16, seed: int = 0) -> np.ndarray:
    """:func:`corners_in_discs` of ``city``'s streets as mapped in ``n`` of its neighbourhoods of ``radius``
    metres (the yardstick's draw, :func:`~synth.patches.source._neighbourhood_points`, on every street of the
    town with generator ``seed``): the rates a district of that radius is read beside (their median and 90th
    percentile in the benchmarks and tests). The source needs no example: the draw never reads its levels."""
    around = _neighbourhood_points(_source(city, None, everything=True), n, radius, np.random.default_rng(seed))
    return corners_in_discs(city.network, around, radius)
