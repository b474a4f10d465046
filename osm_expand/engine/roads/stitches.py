"""The stitches of G′: short new-road edges from the streets to the lattice and between shell points.

003 Fig. 9 joins the town to the lattice G by *stitches*: from each street
point on the shell or on a terrain block to its nearest live land vertices
(:func:`nearest_pairs`), and between nearby shell points. A stitch is kept
only if it crosses no street away from its own ends, keeps ``clearance``
from every street, enters no built-up block and touches no water or
forbidden ground (:func:`stitch_ok`). :mod:`osm_expand.engine.roads.path_graph`
assembles G′ from the lattice, the streets and these stitches.

From year to year the verdicts are carried over (:class:`ShellVerdicts`,
:func:`carried_ok`): a year's G′ tests a stitch against the streets again
only if a segment was added or removed near it, against the built-up blocks
only if it comes near a block that became or stopped being built-up
(:attr:`BuiltUpArea.changed`), and for water and forbidden ground only if
the last verdicts do not hold it; the others keep the last G′'s verdicts, so
the result is the one a fresh check gives.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from scipy.ndimage import maximum_filter1d
from scipy.spatial import cKDTree

from osm_expand.engine.roads.built_up import BlocksChanged
from osm_expand.engine.roads.lattice import Lattice
from osm_expand.model.options import require_positive
from osm_expand.model.segments import SegmentTable

__all__ = ["GraphOptions", "ShellVerdicts", "carried_ok", "changed_keys", "lattice_verdicts", "nearest_pairs",
           "stitch_ok", "near_boxes", "within_reach"]


@dataclass(frozen=True)
class GraphOptions:
    """Tunables of G′: splitting streets and stitching them to the lattice (003 Fig. 9)."""

    #: m, a shell segment longer than 2ℓ gets a point every this many metres (003 §3.3: 1.25ℓ)
    split_spacing: float = 25.0
    #: m, street points connect to live land vertices this close (B's 30 m plus 2.5ℓ)
    stitch_radius: float = 80.0
    shell_stitch_radius: float = 120.0  #: m, shell points connect to each other this close (003 Fig. 9)
    #: m, a stitch keeps this far from every street except near its own end
    clearance: float = 5.0
    #: stitches per street point to its nearest live land vertices (000 joins all within the
    #: radius; the nearest 16 give every heading away from the street and keep G′ small)
    max_stitches: int = 16
    max_shell_stitches: int = 8  #: stitches per shell point to its nearest shell points

    def __post_init__(self) -> None:
        require_positive(self, ("split_spacing", "stitch_radius", "shell_stitch_radius", "clearance",
                         "max_stitches", "max_shell_stitches"))

@dataclass(frozen=True)
class ShellVerdicts:
    """Which candidate shell stitches cleared the streets in a year, for the next year's check.

    Whether a stitch crosses or grazes a street (:func:`_street_clear`) depends only on
    the segments within ``clearance`` of it. A year adds a few hundred segments to
    thousands: a candidate with the same two ends as last year and no segment added
    or removed within ``clearance`` of it has last year's verdict; only the others are
    checked again (the street tests were 60 % of :func:`street_part` on Campo
    Grande, 18 road years: 34 s of 58 s profiled). The test against the built-up blocks
    is carried too (``outside``, ``blocks``): a candidate clear of the streets then and now
    keeps its verdict unless it comes near a block that became or stopped being built-up
    since (:class:`~osm_expand.engine.roads.built_up.BlocksChanged`). Water and forbidden
    ground are checked only for candidates the verdicts do not hold, or when they were made
    on other rasters (``ground``).
    """

    segments: np.ndarray  #: (S,) the segments' :meth:`SegmentTable.end_keys`
    #: (M,) void keys of the candidates that touch no water or forbidden ground (both ends' coordinates,
    #: each end's kind): the others never need a street verdict, the ground does not change
    pairs: np.ndarray
    clear: np.ndarray  #: (M,) bool, the candidate crossed and grazed no street
    #: the rasters the candidates were found dry on (water, forbidden, stitch-only; the very arrays):
    #: on the same ones, a candidate held here is dry again without sampling them
    ground: tuple = ()
    #: (M,) bool, the candidate enters no built-up block (read only where ``clear``); None: not kept
    outside: np.ndarray | None = None
    #: the built-up blocks ``outside`` was tested against (:attr:`BuiltUpArea.blocks`, the very object)
    blocks: shapely.Geometry | None = None

def lattice_verdicts(stitches: dict) -> ShellVerdicts | None:
    """The street verdicts of the stitches to the lattice in an :attr:`ImplicitGraph.stitches`
    (filled as its windows are searched); None when none was checked."""
    done = stitches.get("verdicts", [])
    if not done:
        return None
    outside = None if any(v.outside is None for v in done) else np.concatenate([v.outside for v in done])
    return ShellVerdicts(segments=done[0].segments, pairs=np.concatenate([v.pairs for v in done]),
                         clear=np.concatenate([v.clear for v in done]), ground=done[0].ground,
                         outside=outside, blocks=done[0].blocks)

def nearest_pairs(from_xy: np.ndarray, to_xy: np.ndarray, from_id: np.ndarray, to_id: np.ndarray, k: int,
                   radius: float, keys: np.ndarray | None = None) -> np.ndarray:
    """Pairs (from, to) of each point and its ``k`` nearest candidates within ``radius``.

    Of equally near candidates the one with the smaller key (``to_id`` by
    default) wins, so the choice never depends on which other candidates
    exist: street points on a grid town are often equally far from several
    lattice vertices, and a window of the lattice must stitch a point to
    the same vertices as the whole map.
    """
    n = len(to_xy)
    k = min(k, n)
    if not k or not len(from_xy):
        return np.zeros((0, 2), dtype=np.int64)
    keys = to_id if keys is None else np.asarray(keys)
    tree = cKDTree(to_xy)
    kk = min(2 * k, n)
    dist, hit = tree.query(from_xy, k=kk, distance_upper_bound=radius)
    dist, hit = np.asarray(dist).reshape(len(from_xy), kk), np.asarray(hit).reshape(len(from_xy), kk)
    tied = np.flatnonzero(np.isfinite(dist[:, k - 1]) & (dist[:, kk - 1] == dist[:, k - 1]))
    while kk < n and len(tied):
        # a tie at the k-th nearest may go on past the candidates asked for: only those points are
        # asked again for more (a point without one has every candidate as near as its k-th already)
        more = min(2 * kk, n)
        d, i = tree.query(from_xy[tied], k=more, distance_upper_bound=radius)
        d, i = np.asarray(d).reshape(len(tied), more), np.asarray(i).reshape(len(tied), more)
        dist = np.concatenate([dist, np.full((len(dist), more - kk), np.inf)], axis=1)
        hit = np.concatenate([hit, np.full((len(hit), more - kk), n, dtype=hit.dtype)], axis=1)
        dist[tied], hit[tied] = d, i
        kk = more
        tied = tied[np.isfinite(d[:, k - 1]) & (d[:, kk - 1] == d[:, k - 1])]
    found = hit < n
    row = np.broadcast_to(np.arange(len(from_xy))[:, None], hit.shape)[found]
    cand, near = hit[found], dist[found]
    # each row comes nearest first: only the runs of equally near candidates are put in key order
    # (a sort of every candidate by row, distance and key was most of a year's shell stitches)
    same = np.zeros(len(row), dtype=bool)
    same[1:] = (row[1:] == row[:-1]) & (near[1:] == near[:-1])
    if same.any():
        run = np.cumsum(~same)
        tie = same.copy()
        tie[:-1] |= same[1:]
        at = np.flatnonzero(tie)
        cand = cand.copy()
        cand[at] = cand[at[np.lexsort((keys[cand[at]], run[at]))]]
    starts = np.flatnonzero(np.concatenate([[True], row[1:] != row[:-1]]))
    first = np.arange(len(row)) - np.repeat(starts, np.diff(np.append(starts, len(row)))) < k
    return np.stack([from_id[row[first]], to_id[cand[first]]], axis=1)

def within_reach(lattice: Lattice, points: np.ndarray, vertices: np.ndarray, radius: float) -> np.ndarray:
    """Whether each of ``lattice``'s ``vertices`` may lie within ``radius`` of one of ``points``
    (``(n, 2)`` m): a superset of those that do, from the vertex grid alone.

    Every vertex within ``radius`` of a point lies in the square of ``⌈radius / ℓ⌉ + 1``
    vertices around the point's nearest grid position; those squares are marked on the
    grid (one mark a point, then a running maximum along each axis), so the cost is the
    grid's size and the points', never their product. :func:`nearest_pairs` over the
    marked vertices gives the pairs it gives over them all.
    """
    ny, nx = lattice.shape
    if not len(points) or not len(vertices):
        return np.zeros(len(vertices), dtype=bool)
    reach = int(np.ceil(radius / lattice.spacing)) + 1
    col = np.rint((points[:, 0] - lattice.origin[0]) / lattice.spacing)
    row = np.rint((points[:, 1] - lattice.origin[1]) / lattice.spacing)
    # a point further off the grid than the square reaches no vertex: clipped, it marks a square
    # that may touch the grid's edge (a superset, as promised)
    col = np.clip(col, -reach - 1, nx + reach).astype(np.int64) + reach + 1
    row = np.clip(row, -reach - 1, ny + reach).astype(np.int64) + reach + 1
    grid = np.zeros((ny + 2 * reach + 2, nx + 2 * reach + 2), dtype=np.uint8)
    grid[row, col] = 1
    size = 2 * reach + 1
    grid = maximum_filter1d(maximum_filter1d(grid, size, axis=0, mode="constant"), size, axis=1, mode="constant")
    v = np.asarray(vertices, dtype=np.int64)
    return grid[v // nx + reach + 1, v % nx + reach + 1].astype(bool)


def stitch_ok(lattice: Lattice, segments: SegmentTable, xy: np.ndarray, pairs: np.ndarray, split_parent: np.ndarray,
               n_lat: int, opts: GraphOptions, tree: shapely.STRtree | None = None,
               inner: shapely.Geometry | None = None) -> np.ndarray:
    """Stitches that cross no street, keep ``clearance`` from every street away from
    their ends, enter no built-up block (``inner``: the blocks shrunk by 0.5 m) and touch
    no water or forbidden ground (but :attr:`Lattice.stitch_only`)."""
    ok = _dry(lattice, xy, pairs, opts)
    if len(segments.uv):
        # only the stitches still standing are made into lines and checked, each test on
        # fewer of them (most stitches of a window fail one test or another)
        tree = tree if tree is not None else segments.tree()
        live = np.flatnonzero(ok)
        ok[live] = _street_clear(segments, xy, pairs[live], split_parent, n_lat, opts, tree)
        if inner is not None:
            live = np.flatnonzero(ok)
            ok[live] = ~shapely.intersects(inner, _core(xy, pairs[live], opts))
    return ok


def _dry(lattice: Lattice, xy: np.ndarray, pairs: np.ndarray, opts: GraphOptions) -> np.ndarray:
    """Stitches of positive length that touch no water or forbidden ground (but
    :attr:`Lattice.stitch_only`), sampled at the fine raster's step."""
    a, b = xy[pairs[:, 0]], xy[pairs[:, 1]]
    ok = np.hypot(*(b - a).T) > 1e-6
    n_samples = max(int(np.ceil(opts.shell_stitch_radius / lattice.fine_step)) + 1, 2)
    t = np.linspace(0.0, 1.0, n_samples)
    samples = a[:, None, :] + t[None, :, None] * (b - a)[:, None, :]
    blocked = lattice.water | lattice.forbidden
    if lattice.stitch_only is not None:
        blocked &= ~lattice.stitch_only
    return ok & ~lattice.fine_lookup(blocked, samples).any(axis=1)


def _core(xy: np.ndarray, pairs: np.ndarray, opts: GraphOptions) -> np.ndarray:
    """The stitches as lines trimmed near their ends (by a quarter of their length, at most
    3 × clearance): what must keep clear of the streets and out of the built-up blocks."""
    a, b = xy[pairs[:, 0]], xy[pairs[:, 1]]
    length = np.hypot(*(b - a).T)
    trim = np.minimum(0.25 * length, 3.0 * opts.clearance) / np.maximum(length, 1e-9)
    return shapely.linestrings(np.stack([a + trim[:, None] * (b - a), b - trim[:, None] * (b - a)], axis=1))


def _street_clear(segments: SegmentTable, xy: np.ndarray, pairs: np.ndarray, split_parent: np.ndarray, n_lat: int,
                  opts: GraphOptions, tree: shapely.STRtree, cores: np.ndarray | None = None) -> np.ndarray:
    """Stitches (of positive length) that cross no street not incident to either end and keep
    ``clearance`` from every street away from their ends; with ``cores`` (``(len(pairs),)``
    objects), the :func:`_core` lines made are put there, for the test against the blocks."""
    ok = np.ones(len(pairs), dtype=bool)
    if not len(pairs) or not len(segments.uv):
        return ok
    a, b = xy[pairs[:, 0]], xy[pairs[:, 1]]
    stitch, seg = tree.query(shapely.linestrings(np.stack([a, b], axis=1)), predicate="intersects")
    incident = _incident(pairs[stitch], seg, segments, split_parent, n_lat, len(segments.xy))
    ok[stitch[~incident]] = False
    live = np.flatnonzero(ok)
    core = _core(xy, pairs[live], opts)
    if cores is not None:
        cores[live] = core
    stitch, _ = tree.query(core, predicate="dwithin", distance=opts.clearance)
    ok[live[stitch]] = False
    return ok


def _keys(values: np.ndarray) -> np.ndarray:
    """One void key per row of a 2-D array (rows compare equal exactly when their bytes do)."""
    v = np.ascontiguousarray(values)
    return v.view(np.dtype((np.void, v.dtype.itemsize * v.shape[1]))).ravel()


def carried_ok(lattice: Lattice, segments: SegmentTable, xy: np.ndarray, pairs: np.ndarray, split_parent: np.ndarray,
                n_lat: int, opts: GraphOptions, tree: shapely.STRtree, inner: shapely.Geometry | None,
                previous: ShellVerdicts | None, memo: dict | None = None, *,
                blocks: shapely.Geometry | None = None,
                changed: BlocksChanged | None = None) -> tuple[np.ndarray, ShellVerdicts]:
    """:func:`stitch_ok`, the street tests carried over from ``previous`` where nothing near a
    stitch changed (see :class:`ShellVerdicts`), and this call's street verdicts.

    Only the stitches that touch no water or forbidden ground are looked up, tested and
    remembered: the ground does not change from year to year, so a stitch that is not dry
    now never needs a street verdict (on Campo Grande most candidates of a window are not).
    ``memo`` (a dict kept for all the calls of a year with the same ``segments`` and
    ``previous``, e.g. :attr:`ImplicitGraph.stitches`) keeps what every call would work out
    again: the segments' keys, the last verdicts sorted, the segments added or removed.

    The test against the built-up blocks (``inner``, made from ``blocks``) is carried too: a
    stitch clear of the streets then and now, whose box comes near none of the blocks that
    became or stopped being built-up since (``changed``, :attr:`BuiltUpArea.changed`: the blocks
    they changed from and the boxes of the blocks that changed), keeps its verdict
    (making every clear stitch a line to test it again was a quarter of a year's stitches on
    Campo Grande).
    """
    carry = _carry(segments, previous, {} if memo is None else memo)
    n_nodes = len(segments.xy)
    end_kind = np.where(pairs < n_lat, 2, np.where(pairs - n_lat >= n_nodes, 1, 0))  # lattice, split, node
    every_key = _keys(np.concatenate([xy[pairs[:, 0]], xy[pairs[:, 1]], end_kind.astype(np.float64)], axis=1))
    keys = carry.keys if carry.keys is not None and carry.clear is not None and len(pairs) else None
    last_clear = carry.clear if carry.clear is not None else np.zeros(0, dtype=bool)
    dry = np.zeros(len(pairs), dtype=bool)
    every_at = np.zeros(len(pairs), dtype=np.int64)
    held = np.zeros(len(pairs), dtype=bool)  # the last verdicts hold the stitch (its very key)
    if keys is not None and len(keys):
        # found by hash (a void key's sort and search compare bytes one call at a time), then
        # compared whole: a hash shared by two keys at worst sends a stitch to be checked again
        assert carry.hashes is not None  # made with the keys
        every_at = np.minimum(np.searchsorted(carry.hashes, _hash(every_key)), len(keys) - 1)
        held = keys[every_at] == every_key  # compared once: the byte comparison is read three times below
        if previous is not None and _same_ground(previous.ground, lattice):
            # a stitch the last verdicts hold was dry then, on the same ground: it is dry now (its samples
            # along the fine rasters were a third of a year's shell check on Campo Grande)
            dry = held.copy()
    if (~dry).any():  # _dry combines the map's fine rasters whole, even for no stitch
        dry[~dry] = _dry(lattice, xy, pairs[~dry], opts)
    live = np.flatnonzero(dry)
    pair_keys = every_key[live]
    clear = np.zeros(len(pairs), dtype=bool)
    todo = live
    if keys is not None and len(keys) and len(live):
        at = every_at[live]
        known = np.flatnonzero(held[live])
        near = np.zeros(len(known), dtype=bool)
        if carry.changed is not None and carry.boxes is not None and len(known):
            # a stitch a segment was added or removed near (as many times as it was) is checked again;
            # only those whose box comes near a changed segment's are made into lines and measured
            k = live[known]
            ends = np.stack([xy[pairs[k, 0]], xy[pairs[k, 1]]], axis=1)
            box = near_boxes(ends, carry.boxes, opts.clearance + 1.0)
            hit, _ = carry.changed.query(shapely.linestrings(ends[box]), predicate="dwithin",
                                         distance=opts.clearance + 1.0)
            near[np.flatnonzero(box)[hit]] = True
        reuse = known[~near]
        clear[live[reuse]] = last_clear[at[reuse]]
        again = np.ones(len(live), dtype=bool)
        again[reuse] = False
        todo = live[again]
    made = np.full(len(todo), None, dtype=object)  # the stitches' cores the street test makes, for the blocks'
    clear[todo] = _street_clear(segments, xy, pairs[todo], split_parent, n_lat, opts, tree, made)
    cores = np.full(len(pairs), None, dtype=object)
    cores[todo] = made
    ok = dry & clear
    outside = np.ones(len(pairs), dtype=bool)
    if inner is not None:
        live = np.flatnonzero(ok)
        test = live
        boxes = _changed_boxes(previous, blocks, changed)
        if boxes is not None and keys is not None and len(keys) and carry.outside is not None and len(live):
            at = every_at[live]
            known = held[live] & last_clear[at]  # tested then (clear then), clear now
            k = live[known]
            near = near_boxes(np.stack([xy[pairs[k, 0]], xy[pairs[k, 1]]], axis=1), boxes, 1.0)
            reuse = np.flatnonzero(known)[~near]
            outside[live[reuse]] = carry.outside[at[reuse]]
            again = np.ones(len(live), dtype=bool)
            again[reuse] = False
            test = live[again]
        missing = test[shapely.is_missing(cores[test])]
        cores[missing] = _core(xy, pairs[missing], opts)
        outside[test] = ~shapely.intersects(inner, cores[test])
        ok &= outside
    return ok, ShellVerdicts(segments=carry.segments, pairs=pair_keys, clear=clear[dry], ground=_ground(lattice),
                             outside=outside[dry], blocks=blocks if inner is not None else None)


def _changed_boxes(previous: ShellVerdicts | None, blocks: shapely.Geometry | None,
                   changed: BlocksChanged | None) -> np.ndarray | None:
    """Boxes ``(C, 4)`` outside which the built-up blocks are as ``previous`` tested its stitches
    against (none: the very same blocks); None when that is not known."""
    if previous is None or previous.blocks is None or blocks is None:
        return None
    if previous.blocks is blocks:
        return np.zeros((0, 4))
    if changed is not None and changed.since is previous.blocks:
        return np.asarray(changed.boxes, dtype=float).reshape(-1, 4)
    return None


def _ground(lattice: Lattice) -> tuple[np.ndarray | None, ...]:
    """The rasters a stitch's dryness is read from (:func:`_dry`): the map's, shared by its windows."""
    return (lattice.water, lattice.forbidden, lattice.stitch_only)


def _same_ground(ground: tuple, lattice: Lattice) -> bool:
    """Whether verdicts made on ``ground`` (:func:`_ground`) were made on ``lattice``'s very rasters."""
    return len(ground) == 3 and all(a is b for a, b in zip(ground, _ground(lattice)))


def near_boxes(ends: np.ndarray, boxes: np.ndarray, distance: float) -> np.ndarray:
    """Whether the box of each segment ``ends`` (``(n, 2, 2)`` m) comes within ``distance`` of
    one of ``boxes`` (``(C, 4)`` xmin, ymin, xmax, ymax): a superset of the segments within
    ``distance`` of what the boxes bound (a segment that near has its box that near).

    The boxes, grown by ``distance``, are counted on a grid over their extent (a corner
    mark each and two running sums), and each segment's box asks for the count over its
    cells (a summed-area table): the cost is the grid's and the segments', not their
    product, where making every one of a year's ~10⁵ carried stitches a line to query the
    changed segments' tree was most of :func:`carried_ok`.
    """
    n = len(ends)
    if not n or not len(boxes):
        return np.zeros(n, dtype=bool)
    grown = boxes + np.array([-distance, -distance, distance, distance])
    lo, hi = grown[:, :2].min(axis=0), grown[:, 2:].max(axis=0)
    cell = max(float((hi - lo).max()) / 256.0, distance, 1e-6)
    shape = np.floor((hi - lo) / cell).astype(np.int64) + 1  # (nx, ny)

    def cells(xy: np.ndarray) -> np.ndarray:  # (m, 2) column, row; clipped to one beyond the grid each side
        return np.clip(np.floor((xy - lo) / cell), -1, shape).astype(np.int64) + 1

    a, b = cells(grown[:, :2]), cells(grown[:, 2:])
    count = np.zeros((shape[1] + 3, shape[0] + 3), dtype=np.int64)  # a row and column of slack each side
    np.add.at(count, (a[:, 1], a[:, 0]), 1)
    np.add.at(count, (a[:, 1], b[:, 0] + 1), -1)
    np.add.at(count, (b[:, 1] + 1, a[:, 0]), -1)
    np.add.at(count, (b[:, 1] + 1, b[:, 0] + 1), 1)
    covered = (count.cumsum(axis=0).cumsum(axis=1) > 0).astype(np.int64)
    table = np.zeros((covered.shape[0] + 1, covered.shape[1] + 1), dtype=np.int64)
    table[1:, 1:] = covered.cumsum(axis=0).cumsum(axis=1)
    p, q = cells(ends.min(axis=1)), cells(ends.max(axis=1)) + 1
    inside = table[q[:, 1], q[:, 0]] - table[p[:, 1], q[:, 0]] - table[q[:, 1], p[:, 0]] + table[p[:, 1], p[:, 0]]
    return inside > 0


@dataclass(frozen=True)
class _Carry:
    """What :func:`carried_ok` reads from the last verdicts, worked out once for a year's calls."""

    segments: np.ndarray  #: (S,) this year's segment keys
    keys: np.ndarray | None  #: the last verdicts' pair keys, in the order of their hashes (None: no last verdicts)
    clear: np.ndarray | None  #: their verdicts in that order
    changed: shapely.STRtree | None  #: the segments added or removed since (None: none)
    boxes: np.ndarray | None = None  #: (C, 4) their bounding boxes (xmin, ymin, xmax, ymax)
    outside: np.ndarray | None = None  #: the last verdicts' ``outside`` in ``keys``' order
    hashes: np.ndarray | None = None  #: the keys' :func:`_hash`, sorted


def _carry(segments: SegmentTable, previous: ShellVerdicts | None, memo: dict) -> _Carry:
    """The :class:`_Carry` of ``segments`` and ``previous``, from ``memo`` when it was made for them."""
    made = memo.get("carry")
    if made is not None and made[0] is previous and made[1] is segments:
        return made[2]
    a, b = segments.a, segments.b
    seg_keys = segments.end_keys()
    carry = _Carry(segments=seg_keys, keys=None, clear=None, changed=None)
    if previous is not None and len(previous.pairs):
        hashes = _hash(previous.pairs)
        order = np.argsort(hashes, kind="stable")
        # segments added or removed (as many times as they were)
        changed = changed_keys(seg_keys, previous.segments)
        ends = np.concatenate([np.stack([a, b], axis=1), SegmentTable.ends_of_keys(previous.segments)])[changed]
        carry = _Carry(segments=seg_keys, keys=previous.pairs[order], clear=previous.clear[order],
                       changed=shapely.STRtree(shapely.linestrings(ends)) if len(ends) else None,
                       boxes=np.concatenate([ends.min(axis=1), ends.max(axis=1)], axis=1),
                       outside=None if previous.outside is None else previous.outside[order],
                       hashes=hashes[order])
    memo["carry"] = (previous, segments, carry)
    return carry


def changed_keys(new: np.ndarray, old: np.ndarray) -> np.ndarray:
    """The keys of ``new`` and of ``old`` (two arrays of :func:`_keys`-like void keys of whole 8-byte
    words) that are not in the other as many times: their indices, ``new``'s first, then ``old``'s
    shifted by ``len(new)``, each part ascending.

    A key found ``n`` times in both is unchanged; every copy of any other key is changed (a segment
    added or removed near a stitch, as many times as it was). The keys are compared as their words
    in one sort, exactly: counting them in Python sets of bytes took 0.02-0.04 s a call on Campo
    Grande's later road years (24,000 segments), this 0.01 s; numpy's ``unique``/``isin`` of void
    keys were slower still.
    """
    n = len(new) + len(old)
    if not n:
        return np.zeros(0, dtype=np.int64)
    words = _words(np.concatenate([new, old]))
    order = np.lexsort(words.T[::-1])
    ranked = words[order]
    start = np.ones(n, dtype=bool)
    start[1:] = (ranked[1:] != ranked[:-1]).any(axis=1)
    group = np.cumsum(start) - 1
    is_new = order < len(new)
    in_new = np.bincount(group, weights=is_new, minlength=group[-1] + 1)
    in_old = np.bincount(group, weights=~is_new, minlength=group[-1] + 1)
    changed = np.zeros(n, dtype=bool)
    changed[order] = (in_new != in_old)[group]
    return np.flatnonzero(changed).astype(np.int64)


def _words(keys: np.ndarray) -> np.ndarray:
    """``(n, w)`` uint64: each void key (of whole 8-byte words) as its words, what :func:`_hash` mixes and
    :func:`changed_keys` sorts."""
    keys = np.ascontiguousarray(keys)
    assert keys.dtype.itemsize % 8 == 0, f"a key of {keys.dtype.itemsize} bytes is not whole 8-byte words"
    return np.frombuffer(keys.tobytes(), dtype=np.uint64).reshape(len(keys), keys.dtype.itemsize // 8)


def _hash(keys: np.ndarray) -> np.ndarray:
    """A uint64 hash of each void key (its 8-byte words, mixed one after another)."""
    out = np.zeros(len(keys), dtype=np.uint64)
    for column in _words(keys).T:
        out = (out ^ column) * np.uint64(0x9E3779B97F4A7C15)  # wraps modulo 2⁶⁴
        out ^= out >> np.uint64(29)
    return out


def _incident(pairs: np.ndarray, seg: np.ndarray, segments: SegmentTable, split_parent: np.ndarray,
              n_lat: int, n_nodes: int) -> np.ndarray:
    """Whether segment ``seg`` touches a street end of the stitch ``pairs`` (node or split point)."""
    out = np.zeros(len(seg), dtype=bool)
    for end in (0, 1):
        node = pairs[:, end] - n_lat
        is_node = (node >= 0) & (node < n_nodes)
        out |= is_node & ((segments.uv[seg, 0] == node) | (segments.uv[seg, 1] == node))
        split = node - n_nodes
        is_split = split >= 0
        if is_split.any():
            out |= is_split & (split_parent[np.where(is_split, split, 0)] == seg)
    return out
