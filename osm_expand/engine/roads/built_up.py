"""The built-up area B (003 Eq. 1, §3.4.2) and which sides of a street it holds.

The streets are the model's :class:`~osm_expand.model.segments.SegmentTable`, read with the
trade capacity the year left (its optional ``available`` column).

**B** (003 Eq. 1) is ``FILL(S) \\ ∪ FILL(B_T) ∪ NB(S) ∪ ∪ NB(B_T)``: the
built-up blocks plus a neighbourhood of every street on the shell or on a
terrain block. Terrain blocks are those larger than ``terrain_block_area``
(003's "simple block-area classifier") or holding water (000's water
blocks). Streets between two built-up blocks lie inside built-up blocks, so
B is computed as the built-up blocks plus ``neighbourhood`` metres around
every street, and joined to the previous B: it never shrinks.
:meth:`~osm_expand.engine.roads.lattice.Lattice.with_built_up` removes every land edge that traverses B from
the lattice for good (003: "permanently remove all land edges that traverse
B"); water, harbour and bridge edges stay.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import shapely

from osm_expand.model.options import require_positive
from osm_expand.model.segments import SegmentTable

__all__ = ["segment_sides", "BuiltUpOptions", "BlocksChanged", "BuiltUpArea", "built_up_area"]


def segment_sides(segments: SegmentTable, built_blocks: shapely.Geometry | None) -> np.ndarray:
    """How many sides of each segment touch a built-up block.

    Tested half a width plus 2 m to the left and right of the midpoint. A
    segment with at most one built-up side is on the shell or a terrain
    block: *extendible* (003 §3.4.2, C6) and a place to stitch to.

    Parameters
    ----------
    segments
        The segment graph.
    built_blocks
        Union of the built-up blocks (:attr:`BuiltUpArea.blocks`); None: none.

    Returns
    -------
    numpy.ndarray
        ``(S,)`` int in {0, 1, 2}.
    """
    if built_blocks is None or built_blocks.is_empty or not len(segments.uv):
        return np.zeros(len(segments.uv), dtype=np.int64)
    a, b = segments.a, segments.b
    mid = 0.5 * (a + b)
    tangent = (b - a) / np.maximum(np.hypot(*(b - a).T), 1e-9)[:, None]
    normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1) * (0.5 * segments.width + 2.0)[:, None]
    shapely.prepare(built_blocks)
    left = shapely.contains_xy(built_blocks, *(mid + normal).T)
    right = shapely.contains_xy(built_blocks, *(mid - normal).T)
    return left.astype(np.int64) + right


# ---------------------------------------------------------------- the built-up area B


@dataclass(frozen=True)
class BuiltUpOptions:
    """Tunables of the built-up area B (003 Eq. 1)."""

    #: m², blocks larger than this are terrain (fields, forests): 003's block-area classifier.
    #: 000 §4.2.7 prints "95 m2" (garbled); town blocks rarely exceed a few hectares (Krems:
    #: 90 % of its blocks are under 2.3 ha), fields between villages do.
    terrain_block_area: float = 50_000.0
    #: share of a block under water above which it is a water block, i.e. terrain (000 §4.2.7)
    water_block_share: float = 0.05
    #: m, NB: the neighbourhood of the outlines (shell, terrain blocks) that B includes;
    #: 1.5 ℓ keeps new roads a lattice step clear of the streets they run beside
    neighbourhood: float = 30.0

    def __post_init__(self) -> None:
        require_positive(self, ("terrain_block_area", "neighbourhood"))


class BlocksChanged(NamedTuple):
    """Where the built-up blocks of a year differ from those of an earlier one: a test against the
    blocks ``since`` (e.g. a stitch's) holds now wherever it came near none of ``boxes``."""

    #: the earlier built-up blocks (:attr:`BuiltUpArea.blocks`, the very object: compared with ``is``)
    since: shapely.Geometry
    #: (C, 4) xmin, ymin, xmax, ymax of the blocks that became or stopped being built-up since
    boxes: np.ndarray


@dataclass(frozen=True)
class BuiltUpArea:
    """B and the blocks it came from."""

    area: shapely.Geometry  #: B, monotone over the years
    blocks: shapely.Geometry  #: union of the current built-up blocks B_B,i
    #: each block's normalised WKB → whether it is built-up (not terrain): a block the next
    #: year finds unchanged keeps its verdict (its water share is not measured again)
    verdicts: dict[bytes, bool] = field(default_factory=dict, repr=False, compare=False)
    #: what the verdicts were measured with (the water, the options): a year with other ones
    #: measures every block again
    basis: tuple = field(default=(None, None), repr=False, compare=False)
    #: the parts B took in since ``previous`` (the new built-up blocks and the new streets'
    #: neighbourhoods): B grew only inside them. None: B is new (no ``previous``)
    added: np.ndarray | None = field(default=None, repr=False, compare=False)
    #: the segments B was made with, one key a segment (:meth:`SegmentTable.end_keys`): each had
    #: its neighbourhood joined, or passed B's three-point test then (both ends and the midpoint
    #: in B, which only grows), so next year's segments with these keys are not tested again
    segments: frozenset[bytes] = field(default_factory=frozenset, repr=False, compare=False)
    #: ``blocks`` is ``changed.since`` (``previous.blocks``) but inside ``changed.boxes``; None: made
    #: afresh (what a stitch's test against the blocks may carry)
    changed: BlocksChanged | None = field(default=None, repr=False, compare=False)
    #: (K,) the block polygons B was made from (the very objects, kept alive) and their normalised WKB:
    #: next year's blocks that are these objects keep their keys (:func:`_block_keys`)
    polygons: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=object), repr=False, compare=False)
    keys: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=object), repr=False, compare=False)
    #: the segments' :meth:`SegmentTable.end_keys` array B was made with (the very object): a table
    #: sharing it has the same segments, all held by B
    segment_keys: np.ndarray | None = field(default=None, repr=False, compare=False)


def built_up_area(blocks: Sequence[shapely.Geometry], segments: SegmentTable, *,
                  water: shapely.Geometry | None = None, previous: BuiltUpArea | None = None,
                  options: BuiltUpOptions | None = None) -> BuiltUpArea:
    """The built-up area B of 003 Eq. 1, grown from ``previous`` (it never shrinks).

    Parameters
    ----------
    blocks
        Faces of the segment graph (shapely polygons, m), e.g. :func:`osm_expand.blocks.blocks`.
    segments
        The segment graph.
    water
        Water polygons; blocks with more than ``water_block_share`` water are terrain.
    previous
        Last year's B, joined into the result.
    options
        :class:`BuiltUpOptions`.

    Returns
    -------
    BuiltUpArea
        ``area`` = previous B ∪ built-up blocks ∪ ``neighbourhood`` m around every
        segment; ``blocks`` = the built-up blocks of now.
    """
    opts = options or BuiltUpOptions()
    polys, keys = _block_keys(blocks, previous)
    known = previous.verdicts if previous is not None and _same_basis(previous.basis, (water, opts)) else {}
    # a block as it was last year keeps its verdict: measuring every block's water share again
    # was a quarter of B's year on Campo Grande (5,500 blocks, a few dozen new a year)
    key_list = keys.tolist()
    told = [known.get(k) for k in key_list]  # one look-up a block: its verdict last year, None: not seen
    seen = np.array([v is not None for v in told], dtype=bool)
    built = np.array([v is None or v for v in told], dtype=bool)
    fresh = np.flatnonzero(~seen)
    if len(fresh):
        area = shapely.area(polys[fresh])
        ok = area <= opts.terrain_block_area
        if water is not None and not water.is_empty:
            shapely.prepare(water)
            # only a block the water touches has water in it: the overlay of every block with the whole
            # water was most of B's first year on Campo Grande (0.20 s for 4,738 blocks, 53 touch it);
            # the others' share is 0 as the overlay gave it
            wet = np.zeros(len(fresh))
            touch = np.flatnonzero(shapely.intersects(water, polys[fresh]))
            if len(touch):
                wet[touch] = shapely.area(shapely.intersection(polys[fresh[touch]], water))
            ok &= wet <= opts.water_block_share * area
        built[fresh] = ok
    verdicts = dict(zip(key_list, built.tolist()))
    # B grows by the built-up blocks it did not hold as such last year, and the new neighbourhoods
    was_built = np.array([v is not None and v for v in told], dtype=bool)
    added = list(polys[built & ~was_built])
    built_blocks, changed = _built_blocks(polys, built, was_built, keys, known, previous)
    grown: list[shapely.Geometry] = []
    key_array = segments.end_keys()
    same_segments = previous is not None and key_array is previous.segment_keys
    seg_keys = [] if same_segments else key_array.tolist()
    if len(segments.uv) and not same_segments:  # the very segments of last year's B: every one held
        lines = segments.lines()
        if previous is not None:  # B never shrinks: only segments it does not hold yet are buffered
            # a segment last year's B was made with (either way round) passed this test then, or its
            # neighbourhood was joined, and B only grew: only the others are tested (three points a segment in a
            # polygon of the whole town was a fifth of B's year on Campo Grande)
            held = np.array([k in previous.segments for k in seg_keys], dtype=bool)
            test = np.flatnonzero(~held)
            if len(test):
                shapely.prepare(previous.area)
                a, b = segments.a[test], segments.b[test]
                held[test] = (shapely.contains_xy(previous.area, *a.T) & shapely.contains_xy(previous.area, *b.T)
                              & shapely.contains_xy(previous.area, *(0.5 * (a + b)).T))
            lines = lines[~held]
        if len(lines):
            # each segment buffered, then one cascaded union: 5× faster than buffering the
            # multilinestring (Campo Grande's 17,978 segments: 1.7 s against 8.7 s), same polygon
            grown = shapely.buffer(lines, opts.neighbourhood, quad_segs=4).tolist()
            added.extend(grown)
    if previous is None:
        area = shapely.union_all([built_blocks, *grown])
    else:
        # last year's B already holds last year's built-up blocks and neighbourhoods: only what
        # the year added is joined to it (the whole union of every block and every new
        # neighbourhood again was 0.2 s a road year on Campo Grande; the same ground)
        area = shapely.union(previous.area, shapely.union_all(added)) if added else previous.area
    return BuiltUpArea(area=area, blocks=built_blocks, verdicts=verdicts, basis=(water, opts),
                       added=None if previous is None else np.array(added, dtype=object).reshape(-1),
                       segments=previous.segments if same_segments and previous is not None else frozenset(seg_keys),
                       changed=changed, polygons=polys, keys=keys, segment_keys=key_array)


def _block_keys(blocks: Sequence[shapely.Geometry], previous: BuiltUpArea | None) -> tuple[np.ndarray, np.ndarray]:
    """The non-empty ``blocks`` (an object array) and their normalised WKB, the key of a block's
    verdict: a polygon that is one of the very objects ``previous`` was made from keeps its key.

    The blocks stage hands an unchanged block on as the same object (on Campo Grande's road years
    all but the few dozen to few hundred new ones of ~6,000): normalising and writing every block's
    WKB again was a third of a road year's B. ``previous.polygons`` keeps those objects alive, so an
    ``id`` found among them is theirs.
    """
    known = {} if previous is None else dict(zip(map(id, previous.polygons.tolist()), previous.keys.tolist()))
    polys: list[shapely.Geometry] = []
    keys: list[bytes | None] = []
    for b in blocks:
        k = known.get(id(b))
        if k is None and (b is None or b.is_empty):
            continue
        polys.append(b)
        keys.append(k)
    out = np.empty(len(polys), dtype=object)
    out[:] = polys
    key_out = np.empty(len(keys), dtype=object)
    key_out[:] = keys
    fresh = np.array([i for i, k in enumerate(keys) if k is None], dtype=np.int64)
    if len(fresh):
        key_out[fresh] = shapely.to_wkb(shapely.normalize(out[fresh]))
    return out, key_out


def _built_blocks(polys: np.ndarray, built: np.ndarray, was_built: np.ndarray, keys: np.ndarray,
                  known: dict[bytes, bool], previous: BuiltUpArea | None
                  ) -> tuple[shapely.Geometry, BlocksChanged | None]:
    """The union of the built-up blocks ``polys[built]``: last year's union with the blocks that are
    no longer built-up taken out and the new ones joined, when last year's verdicts hold
    (``known`` not empty); else made afresh. With it :attr:`BuiltUpArea.changed` (None: afresh).

    A year changes a few hundred of Campo Grande's 5,500 blocks: the union of them all
    again was 0.18 s a road year, the two overlays with last year's are a tenth of that.
    Overlays are regularised, so a block taken out leaves its neighbours' shared edges
    standing; the result covers the same ground as the union made afresh.
    """
    if previous is None or not known:
        return (shapely.union_all(polys[built]) if built.any() else shapely.Polygon()), None
    now = set(keys[built].tolist())
    gone = shapely.from_wkb([k for k, v in known.items() if v and k not in now])
    blocks = previous.blocks
    if len(gone):  # the keys are the blocks' normalised WKB: the same ground as the polygons were
        blocks = shapely.difference(blocks, shapely.union_all(gone))
    new = polys[built & ~was_built]
    if len(new):
        blocks = shapely.union(blocks, shapely.union_all(new))
    return blocks, BlocksChanged(previous.blocks, shapely.bounds(np.concatenate([gone, new])).reshape(-1, 4))


def _same_basis(a: tuple, b: tuple) -> bool:
    """Whether block verdicts measured with ``a`` (water, options) hold with ``b``."""
    (water_a, opts_a), (water_b, opts_b) = a, b
    if opts_a != opts_b:
        return False
    if water_a is water_b:
        return True
    return water_a is not None and water_b is not None and bool(shapely.equals_exact(water_a, water_b, 0.0))
