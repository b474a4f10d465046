"""The build-out's view of the year's streets (:class:`_Streets`: centre lines, carriageways, what
changed since last year) and what they hit: lots and buildings a new or changed street now lies on,
and a lot's edges given again to the streets they face when one of its streets changed.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import cached_property
from typing import cast

import numpy as np
import shapely
from numpy.typing import NDArray

from osm_expand.engine.buildout.lots import NO_STREET
from osm_expand.engine.buildout.memory import LotState, StreetKey, _Memo
from osm_expand.model import Block, City, Lot, Status
from osm_expand.model.segments import street_width

# ============================================================================ the streets this year


@dataclass(frozen=True, eq=False)
class _Streets:
    """The city's streets as arrays (S,): id, centre line, carriageway, width, built, made by the tool."""

    ids: NDArray[np.int64]
    lines: NDArray[np.object_]
    carriageways: NDArray[np.object_]
    widths: NDArray[np.float64]
    built: NDArray[np.bool_]
    new: NDArray[np.bool_]
    #: ids of streets whose nodes or width changed since last year, or that are gone
    changed: frozenset[int] = frozenset()
    #: (S,) bool: streets new since last year, or whose nodes or width changed (all on the first year)
    recent: NDArray[np.bool_] | None = None

    @cached_property
    def line_tree(self) -> shapely.STRtree:
        """The tree over ``lines``, made when first asked (a year that places no lot and relabels none
        never asks)."""
        return shapely.STRtree(self.lines)

    @cached_property
    def carriageway_tree(self) -> shapely.STRtree:
        """The tree over ``carriageways``, made when first asked."""
        return shapely.STRtree(self.carriageways)

    def only_recent(self) -> _Streets:
        """The streets that are new or changed since last year: the only ones that can have come to lie
        over a lot or building, since lots and buildings are made clear of every street there is."""
        if self.recent is None or self.recent.all():
            return self
        keep = self.recent
        return _Streets(ids=self.ids[keep], lines=self.lines[keep], carriageways=self.carriageways[keep],
                        widths=self.widths[keep], built=self.built[keep], new=self.new[keep],
                        changed=self.changed, recent=None)

    @property
    def built_ids(self) -> frozenset[int]:
        return frozenset(self.ids[self.built].tolist())


def _streets(city: City, memo: _Memo, last: tuple[StreetKey, ...] | None
             ) -> tuple[_Streets, tuple[StreetKey, ...]]:
    """The streets as arrays, and their signature (each street's id, nodes and width, in order).

    What changed is measured against ``last``, the signature of the memory's year, never against the
    memo: the memo is shared by every memory made from one another (``dataclasses.replace``), so a
    year run again from an older memory finds it filled by a later year. The memo only lends the
    geometry of a street whose nodes and width it was made from. Comparing nodes (the same tuple
    objects, most years) costs less than hashing every street's nodes.
    """
    net = city.network
    streets = [s for s in net.streets if len(s.nodes) >= 2]
    widths = np.array([street_width(s) for s in streets], dtype=np.float64)
    signature = tuple((s.id, s.nodes, w) for s, w in zip(streets, widths.tolist()))
    lines = np.empty(len(streets), dtype=object)
    carriageways = np.empty(len(streets), dtype=object)
    before = {} if last is None else {k[0]: k for k in last}
    changed = set(before) - {s.id for s in streets}
    fresh, made = [], []
    for k, key in enumerate(signature):
        old = before.get(key[0])
        if old is None or old[1] is not key[1] and old[1] != key[1] or old[2] != key[2]:
            fresh.append(k)
            if old is not None:
                changed.add(key[0])
        hit = memo.streets.get(key[0])
        if hit is not None and (hit[0] is key[1] or hit[0] == key[1]) and hit[1] == key[2]:
            lines[k], carriageways[k] = hit[2], hit[3]
        else:
            made.append(k)
    recent = np.ones(len(streets), dtype=bool) if last is None else np.isin(np.arange(len(streets)), fresh)
    if made:
        sizes = np.array([len(streets[k].nodes) for k in made], dtype=np.int64)
        coords = net.xy[np.concatenate([np.asarray(streets[k].nodes, dtype=np.intp) for k in made])]
        geoms = shapely.linestrings(coords, indices=np.repeat(np.arange(len(made)), sizes))
        lines[made] = geoms
        carriageways[made] = shapely.buffer(geoms, 0.5 * widths[made], quad_segs=4)
    for sid in memo.streets.keys() - {key[0] for key in signature}:  # gone from this year's streets
        del memo.streets[sid]
    for k in made:  # the others' entries hold as they are
        memo.streets[streets[k].id] = (streets[k].nodes, float(widths[k]), lines[k], carriageways[k])
    table = _Streets(ids=np.array([s.id for s in streets], dtype=np.int64), lines=lines, carriageways=carriageways,
                     widths=widths, built=np.array([s.status == Status.BUILT for s in streets], dtype=bool),
                     new=np.array([s.is_new for s in streets], dtype=bool), changed=frozenset(changed),
                     recent=recent)
    return table, signature


# ============================================================================ demolition


def _on_streets(polys: NDArray[np.object_], streets: _Streets
                ) -> tuple[NDArray[np.bool_], NDArray[np.intp], NDArray[np.float64]]:
    """Which of ``polys`` a centre line crosses, (N,) bool, and each (polygon, carriageway) pair that
    meets: the polygon's index and the m² they share. One pass over the streets' two trees for both
    kinds of thing a widened or new street may take (lots and buildings)."""
    crossed = np.zeros(len(polys), dtype=bool)
    if not len(polys) or not len(streets.lines):
        return crossed, np.zeros(0, dtype=np.intp), np.zeros(0)
    idx, _ = streets.line_tree.query(polys, predicate="intersects")
    crossed[idx] = True
    idx, cw = streets.carriageway_tree.query(polys, predicate="intersects")
    on = shapely.area(shapely.intersection(polys[idx], streets.carriageways[cw])) if len(idx) else np.zeros(0)
    return crossed, idx, on


def _lots_hit(polys: NDArray[np.object_], streets: _Streets, overlap: float) -> NDArray[np.bool_]:
    """Lots a centre line crosses, or with more than ``overlap`` of their area on carriageways, (L,) bool."""
    hit, idx, on = _on_streets(polys, streets)
    if len(idx):
        share = np.bincount(idx, weights=on, minlength=len(polys)) / np.maximum(shapely.area(polys), 1e-9)
        hit |= share > overlap
    return hit


def _buildings_hit(polys: NDArray[np.object_], streets: _Streets, overlap: float) -> NDArray[np.bool_]:
    """Buildings (or new lots) crossed by a centre line or with more than ``overlap`` m² on a carriageway, (N,) bool."""
    hit, idx, on = _on_streets(polys, streets)
    hit[idx[on > overlap]] = True
    return hit


def _on_carriageway(polys: NDArray[np.object_], streets: _Streets, tolerance: float = 0.05) -> NDArray[np.bool_]:
    """Polygons closer than half its width (less ``tolerance`` m) to some street's centre line, (N,) bool."""
    hit = np.zeros(len(polys), dtype=bool)
    if not len(polys) or not len(streets.lines):
        return hit
    half = 0.5 * streets.widths
    idx, line = streets.line_tree.query(polys, predicate="dwithin", distance=float(half.max()))
    close = shapely.distance(polys[idx], streets.lines[line]) < half[line] - tolerance
    hit[idx[close]] = True
    return hit


def _block_keys(blocks: Sequence[Block], memo: _Memo | None = None) -> list[tuple[int, int, int]]:
    """Each block's identity across recomputations: area and centroid rounded to whole metres.

    With ``memo`` (the build-out's, kept from year to year) only the blocks
    whose polygon objects it has not seen are measured; the memo then holds
    this year's blocks alone.
    """
    if not blocks:
        if memo is not None:
            memo.block_keys = {}
        return []
    known = memo.block_keys if memo is not None else {}
    polys = [b.polygon for b in blocks]
    get = known.get
    hits = [get(id(p)) for p in polys]
    keys: list[tuple[int, int, int] | None] = [None if h is None or h[0] is not p else h[1]
                                               for p, h in zip(polys, hits)]
    todo = [k for k, key in enumerate(keys) if key is None]
    if todo:
        new = np.array([polys[k] for k in todo], dtype=object)
        area = np.rint(shapely.area(new)).astype(np.int64)
        centre = np.rint(shapely.get_coordinates(shapely.centroid(new))).astype(np.int64)
        for k, key in zip(todo, zip(area.tolist(), centre[:, 0].tolist(), centre[:, 1].tolist())):
            keys[k] = key
    known_keys = cast(list[tuple[int, int, int]], keys)  # every one measured now
    if memo is not None:
        memo.block_keys = dict(zip(map(id, polys), zip(polys, known_keys)))
    return known_keys


def _relabel(state: LotState, streets: _Streets, tolerance: float = 1.0) -> LotState | None:
    """The lot with its street-facing edges given again to the streets they lie on, when one of its
    streets changed (moved, was split, widened or is gone); None when it fronts no street any more.

    An edge that faced a street faces the street whose centre line is nearest to its ends and its
    midpoint (the largest of the three distances), if that is at most the street's half width plus
    ``tolerance`` m (a lot's edges lie half the width from the centre line; a widened street comes
    nearer); else it faces none. Edges that faced no street keep facing none.
    """
    if not any(s in streets.changed for s in state.streets):
        return state
    ring, lab = state.lot.ring, state.lot.edge_street.copy()
    front = np.flatnonzero(lab >= 0)
    lab[front] = NO_STREET
    if len(streets.lines):
        a, b = ring[front], ring[(front + 1) % len(ring)]
        half = 0.5 * streets.widths
        mids = shapely.points(0.5 * (a + b))
        edge, cand = streets.line_tree.query(mids, predicate="dwithin", distance=float(half.max()) + tolerance)
        lines = streets.lines[cand]
        worst = np.maximum.reduce([shapely.distance(shapely.points(a[edge]), lines),
                                   shapely.distance(mids[edge], lines),
                                   shapely.distance(shapely.points(b[edge]), lines)])
        ok = worst <= half[cand] + tolerance
        edge, cand, worst = edge[ok], cand[ok], worst[ok]
        order = np.lexsort((cand, worst, edge))  # per edge, the nearest street first
        edge, cand = edge[order], cand[order]
        first = np.ones(len(edge), dtype=bool)
        first[1:] = edge[1:] != edge[:-1]
        lab[front[edge[first]]] = streets.ids[cand[first]]
    if not (lab >= 0).any():
        return None
    return replace(state, lot=Lot(ring=ring, edge_street=lab, block=state.lot.block, land_use=state.lot.land_use),
                   tried=None)
