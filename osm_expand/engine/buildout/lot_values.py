"""Lot attributes, the lots' layout, their values under each type and the system value (002 §4.1–4.3).

Lot attributes (002 §4.3), all vectorised over lots:

- ``cluster``: the share of the ``k`` (≈ 10) nearest other lots that have the
  type in question.
- ``influence`` of type *s*: the weighted share of lot area of type *s*
  within ``r`` (≈ 256 m). 002's Eq. 5–6 weight a neighbour by its distance
  times its area, which makes *far* lots count more, against its own text
  ("close lots are linearly weighted more"). We use the linear kernel the text
  describes: ``w(i, v) = area_v · (1 − d_iv / r)`` for ``0 < d_iv < r``, the lot
  itself excluded; ``influence_s(i) = Σ w [type_v = s] / Σ w`` (0 with no
  neighbour).
- ``center_dist``: the Euclidean distance to the nearest centre divided by
  the city's extent (002: "the longest distance in the urban configuration";
  here the diagonal of the lots' bounding box unless the caller gives one),
  clipped to [0, 1].
- ``water_dist``, ``green_dist`` (park/forest): distances in kilometres
  (``amenity_distance_unit``), clipped to [0, 1]; 1 when the town has no such
  feature. 002 divides these by the extent too, but being by the river is a
  matter of metres whatever the town's size: on a 15 km extract (north of
  Bayreuth) a quarter of the extent put every lot "by the water".
- ``traffic``: the summed traffic of a lot's adjacent streets (the caller's
  array) divided by its 95th percentile over the city's lots and clipped to
  [0, 1], so that bounds carry over between towns (002 uses raw volumes).
- ``slope`` (m/m, as given, Eq. 7) and ``elevation`` (rescaled to [0, 1]
  between the lowest and highest lot, Eq. 8), only when a height source
  exists; otherwise terms on them are dropped and each type's weights are
  renormalised over its remaining terms.

The *system value* (Eq. 1–3) is ``λ_g·luv_global + λ_l·luv_local`` with
``λ_g = λ_l = 0.5``; ``luv_local`` is the area-weighted mean lot value and

    luv_global = −(1/T) Σ_t ((share_t − goal_t) / scale)²,   scale ≈ 0.05,

with shares by lot area. 002's Eq. 2 has no ``1/T``: dividing by the number
of types makes ``luv_global`` the mean squared deviation in units of
``scale``, so that it lies in [−1, 0] exactly while every share is within
``scale`` of its goal — the same range as ``luv_local`` (a city whose shares
are off by one ``scale`` on average costs as much as a city where no lot suits
its type). Beyond that it stays unbounded below on purpose: its pull must not
fade far from the goals.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy import sparse
from scipy.spatial import cKDTree

from osm_expand.engine.buildout.landuse_types import (
    DEFAULT_OPTIONS,
    STATIC_ATTRIBUTES,
    UNASSIGNED,
    CompiledTypes,
    LandUseOptions,
    LandUseType,
    compile_types,
)
from osm_expand.errors import InputError


def distance_to(xy: NDArray[np.float64], geometries: Sequence[Any]) -> NDArray[np.float64]:
    """Distance (m) from each point to the nearest of some shapely geometries.

    Parameters
    ----------
    xy : ndarray, shape (L, 2)
        Points in metres.
    geometries : sequence of shapely geometries
        Water, park or forest areas and lines (metres).

    Returns
    -------
    ndarray, shape (L,)
        0 inside an area; ``inf`` for every point when there are no geometries.
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    geoms = [g for g in geometries if g is not None and not shapely.is_empty(g)]
    if not geoms or len(xy) == 0:
        return np.full(len(xy), np.inf)
    tree = shapely.STRtree(geoms)
    points = shapely.points(xy)
    (pi, _gi), dist = tree.query_nearest(points, return_distance=True, all_matches=False)
    out = np.full(len(xy), np.inf)
    out[pi] = dist
    return out


def lot_attributes(xy: NDArray[np.float64], *, centres: NDArray[np.float64],
                   extent: float | None = None,
                   water: Sequence[Any] = (), green: Sequence[Any] = (),
                   water_distance: NDArray[np.float64] | None = None,
                   green_distance: NDArray[np.float64] | None = None,
                   traffic: NDArray[np.float64] | None = None,
                   slope: NDArray[np.float64] | None = None,
                   elevation: NDArray[np.float64] | None = None,
                   options: LandUseOptions = DEFAULT_OPTIONS) -> NDArray[np.float64]:
    """The static lot attributes of 002 §4.3 as one matrix (columns :data:`STATIC_ATTRIBUTES`).

    Parameters
    ----------
    xy : ndarray, shape (L, 2)
        Lot centroids (m).
    centres : ndarray, shape (C, 2)
        The city centre(s) (m); ``center_dist`` is to the nearest.
    extent : float, optional
        The length (m) the centre distance is divided by; default the
        diagonal of the lots' bounding box (002: "the longest distance in the
        urban configuration").
    water, green : sequence of shapely geometries
        Water, and park/forest areas; ignored when the matching
        ``*_distance`` array (m, shape (L,)) is given.
    traffic : ndarray, shape (L,), optional
        Summed traffic of each lot's adjacent streets (002 §4.3); divided by
        its ``traffic_quantile`` over the lots and clipped to 1. None: 0.
    slope : ndarray, shape (L,), optional
        Mean terrain gradient magnitude in the lot (m/m, Eq. 7), kept as is.
    elevation : ndarray, shape (L,), optional
        Mean terrain height in the lot (m, Eq. 8), rescaled to [0, 1]
        between the lowest and the highest lot.

    Returns
    -------
    ndarray, shape (L, 6)
        ``center_dist, water_dist, green_dist, traffic, slope, elevation``;
        the last two columns are NaN without a height source.
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    n = len(xy)
    centres = np.asarray(centres, dtype=np.float64).reshape(-1, 2)
    if len(centres) == 0:
        raise InputError("land use: at least one city centre is needed")
    if extent is None:
        span = xy.max(axis=0) - xy.min(axis=0) if n else np.zeros(2)
        extent = float(np.hypot(*span))
    extent = max(float(extent), 1.0)
    out = np.full((n, len(STATIC_ATTRIBUTES)), np.nan)
    if n == 0:
        return out
    out[:, 0] = cKDTree(centres).query(xy)[0] / extent
    wd = distance_to(xy, water) if water_distance is None else np.asarray(water_distance, float)
    gd = distance_to(xy, green) if green_distance is None else np.asarray(green_distance, float)
    out[:, 1] = np.minimum(wd / options.amenity_distance_unit, 1.0)
    out[:, 2] = np.minimum(gd / options.amenity_distance_unit, 1.0)
    out[:, 0] = np.minimum(out[:, 0], 1.0)
    if traffic is None:
        out[:, 3] = 0.0
    else:
        tr = np.maximum(np.asarray(traffic, dtype=np.float64), 0.0)
        ref = np.quantile(tr, options.traffic_quantile) if n else 0.0
        ref = ref if ref > 0 else (tr.max() if n and tr.max() > 0 else 1.0)
        out[:, 3] = np.minimum(tr / ref, 1.0)
    if slope is not None:
        out[:, 4] = np.asarray(slope, dtype=np.float64)
    if elevation is not None:
        h = np.asarray(elevation, dtype=np.float64)
        lo, hi = np.nanmin(h), np.nanmax(h)
        out[:, 5] = (h - lo) / (hi - lo) if hi > lo else 0.0
    return out


# --------------------------------------------------------------------------- the lot layout

@dataclass(frozen=True)
class LotLayout:
    """The lots of one year with their spatial neighbourhoods (rebuild when lots change).

    ``knn`` (L, k) are each lot's ``k`` nearest other lots (cluster);
    ``weights`` is the sparse (L, L) influence kernel, row ``v`` holding
    ``w(v, u) = area_u · (1 − d/r)``, and ``weights_by_source`` its transpose;
    ``reverse_knn`` (CSR: ``indptr``, ``indices``) lists, per lot ``u``, the
    lots that count ``u`` among their ``k`` nearest.
    """

    xy: NDArray[np.float64]
    area: NDArray[np.float64]
    attributes: NDArray[np.float64]
    knn: NDArray[np.int64]
    weights: sparse.csr_matrix
    weights_by_source: sparse.csr_matrix
    weight_sums: NDArray[np.float64]
    reverse_knn_indptr: NDArray[np.int64]
    reverse_knn_indices: NDArray[np.int64]
    tree: cKDTree = field(repr=False)
    #: the distance kernel ``1 − d/r`` of every entry of ``weights`` (its structure), before the areas:
    #: what :func:`relayout` carries over for the lots that stay
    kernel: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0), repr=False)

    @property
    def n(self) -> int:
        return len(self.area)

    @property
    def available(self) -> tuple[bool, ...]:
        """Which static attribute columns have data (slope/elevation need a height source)."""
        if self.n == 0:
            return (True,) * 4 + (False, False)
        return tuple(bool(np.isfinite(self.attributes[:, j]).any()) for j in range(self.attributes.shape[1]))


def influence_kernel(d: NDArray[np.float64], area_u: NDArray[np.float64], radius: float) -> NDArray[np.float64]:
    return area_u * np.clip(1.0 - d / radius, 0.0, None)


def lot_layout(xy: NDArray[np.float64], area: NDArray[np.float64],
               attributes: NDArray[np.float64], *,
               options: LandUseOptions = DEFAULT_OPTIONS) -> LotLayout:
    """Index the lots for the cluster and influence attributes (cKDTree, sparse kernel).

    Parameters
    ----------
    xy : ndarray, shape (L, 2)
        Lot centroids (m).
    area : ndarray, shape (L,)
        Lot areas (m²), > 0.
    attributes : ndarray, shape (L, 6)
        From :func:`lot_attributes`.

    Returns
    -------
    LotLayout
    """
    xy, area, attributes = _check(xy, area, attributes)
    n = len(xy)
    tree = cKDTree(xy)
    r = options.influence_radius
    pairs = tree.query_pairs(r, output_type="ndarray") if n > 1 else np.zeros((0, 2), np.int64)
    kernel = _kernel(xy, pairs[:, 0], pairs[:, 1], r)
    # the distance kernel is symmetric: one CSR serves both directions (its columns sorted in each row)
    sym = sparse.coo_matrix((np.concatenate([kernel, kernel]),
                             (np.concatenate([pairs[:, 0], pairs[:, 1]]),
                              np.concatenate([pairs[:, 1], pairs[:, 0]]))), shape=(n, n)).tocsr()
    return _layout(xy, area, attributes, tree, sym.data, sym.indices, sym.indptr, options)


def relayout(prev: LotLayout, old_row: NDArray[np.int64], xy: NDArray[np.float64], area: NDArray[np.float64],
             attributes: NDArray[np.float64], *, options: LandUseOptions = DEFAULT_OPTIONS) -> LotLayout:
    """:func:`lot_layout` of this year's lots made from last year's layout ``prev``: the same arrays, the
    kernel measured again only in the rows whose neighbours changed (issue 22: a year costs what it changed).

    ``old_row`` (L,) gives each lot's row in ``prev``, −1 for a lot that is new (the caller's to know: the
    very same point and area as there). The rows to measure again are the new lots', those within
    ``influence_radius`` of a new lot and those that had a lot now gone among their neighbours; every other
    row holds the same neighbours as last year, renumbered (the lots keep their order, so each row's columns
    stay sorted) with the same kernel values, which depend on the two points alone (:func:`_kernel`). The
    weights, their sums and the nearest lots are then made from the kernel as :func:`lot_layout` makes them.
    Where more than half the rows change it is :func:`lot_layout` itself.
    """
    xy, area, attributes = _check(xy, area, attributes)
    n, r = len(xy), options.influence_radius
    old_row = np.asarray(old_row, dtype=np.int64)
    if old_row.shape != (n,) or len(prev.kernel) != prev.weights.nnz or n < 2:
        return lot_layout(xy, area, attributes, options=options)
    stay = old_row >= 0
    if not (np.diff(old_row[stay]) > 0).all():  # the lots that stay must keep their order
        return lot_layout(xy, area, attributes, options=options)
    new_of_old = np.full(prev.n, -1, dtype=np.int64)
    new_of_old[old_row[stay]] = np.flatnonzero(stay)
    tree = cKDTree(xy)
    redo = ~stay
    added = np.flatnonzero(~stay)
    if len(added):
        near = tree.query_ball_point(xy[added], r)
        redo[np.fromiter((j for x in near for j in x), dtype=np.int64)] = True
    gone = np.flatnonzero(new_of_old < 0)
    if len(gone):
        _, pos = ragged(prev.weights.indptr, gone)
        had = new_of_old[prev.weights.indices[pos]]
        redo[had[had >= 0]] = True
    if redo.sum() * 2 > n:
        return lot_layout(xy, area, attributes, options=options)
    kept, again = np.flatnonzero(~redo), np.flatnonzero(redo)
    found = tree.query_ball_point(xy[again], r, return_sorted=True)
    sizes = np.array([len(x) for x in found], dtype=np.int64)
    row = np.repeat(again, sizes)
    col = np.fromiter((j for x in found for j in x), dtype=np.int64, count=int(sizes.sum()))
    other = col != row  # a lot is not its own neighbour
    row, col = row[other], col[other]
    lengths = np.zeros(n, dtype=np.int64)
    was = old_row[kept]
    lengths[kept] = prev.weights.indptr[was + 1] - prev.weights.indptr[was]
    lengths[again] = np.bincount(row, minlength=n)[again]
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(lengths, out=indptr[1:])
    indices = np.empty(indptr[-1], dtype=np.int64)
    kernel = np.empty(indptr[-1], dtype=np.float64)
    # the kept rows' entries, in the same order in both (rows and their columns keep their order)
    stays = np.zeros(prev.n, dtype=bool)
    stays[was] = True
    src = np.repeat(stays, np.diff(prev.weights.indptr))
    dst = np.repeat(~redo, lengths)
    indices[dst] = new_of_old[prev.weights.indices[src]]
    kernel[dst] = prev.kernel[src]
    indices[~dst] = col
    kernel[~dst] = _kernel(xy, row, col, r)
    return _layout(xy, area, attributes, tree, kernel, indices, indptr, options)


def _check(xy: NDArray[np.float64], area: NDArray[np.float64], attributes: NDArray[np.float64]
           ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    area = np.asarray(area, dtype=np.float64)
    attributes = np.asarray(attributes, dtype=np.float64)
    n = len(xy)
    if area.shape != (n,) or attributes.shape != (n, len(STATIC_ATTRIBUTES)):
        raise InputError(f"land use: {n} lots need ({n},) areas and ({n}, 6) attributes, "
                         f"got {area.shape} and {attributes.shape}")
    if n and not (area > 0).all():
        raise InputError("land use: lot areas must be positive")
    return xy, area, attributes


def _kernel(xy: NDArray[np.float64], i: NDArray[np.int64], j: NDArray[np.int64], r: float) -> NDArray[np.float64]:
    """``1 − d/r`` (at least 0) of the pairs ``(i, j)``: the same number whichever of the two comes first
    (the difference only changes sign)."""
    d = np.hypot(*(xy[i] - xy[j]).T) if len(i) else np.zeros(0)
    return np.clip(1.0 - d / r, 0.0, None)


def _layout(xy: NDArray[np.float64], area: NDArray[np.float64], attributes: NDArray[np.float64], tree: cKDTree,
            kernel: NDArray[np.float64], indices: NDArray[np.int64], indptr: NDArray[np.int64],
            options: LandUseOptions) -> LotLayout:
    """The layout of the lots whose symmetric distance kernel is the CSR ``(kernel, indices, indptr)``: the
    weights scaled by the neighbour's area (rows of ``weights``) or the row lot's own (``by_source``), the
    k nearest lots and who counts whom among them."""
    n = len(xy)
    k = min(options.cluster_neighbours, max(n - 1, 0))
    if k > 0:
        _, idx = tree.query(xy, k=k + 1)
        idx = idx.reshape(n, k + 1)
        self_hit = idx == np.arange(n)[:, None]
        # drop the lot itself, or the farthest when a duplicate point hid it
        drop = np.where(self_hit.any(axis=1), self_hit.argmax(axis=1), k)
        keep = np.ones_like(idx, dtype=bool)
        keep[np.arange(n), drop] = False
        knn = idx[keep].reshape(n, k).astype(np.int64)
    else:
        knn = np.zeros((n, 0), dtype=np.int64)
    row_of = np.repeat(np.arange(n), np.diff(indptr))
    weights = sparse.csr_matrix((kernel * area[indices], indices, indptr), shape=(n, n))
    by_source = sparse.csr_matrix((kernel * area[row_of], indices, indptr), shape=(n, n))
    rows = knn.ravel()
    order = np.argsort(rows, kind="stable")
    rk_indices = np.repeat(np.arange(n, dtype=np.int64), k)[order]
    rk_indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=n), out=rk_indptr[1:])
    return LotLayout(xy=xy, area=area, attributes=attributes, knn=knn, weights=weights,
                     weights_by_source=by_source, weight_sums=np.asarray(weights.sum(axis=1)).ravel(),
                     reverse_knn_indptr=rk_indptr, reverse_knn_indices=rk_indices, tree=tree, kernel=kernel)


def ragged(indptr: NDArray[np.int64], rows: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """For CSR ``indptr`` and some rows: (which of ``rows`` each entry belongs to, entry positions)."""
    starts = indptr[rows]
    counts = indptr[rows + 1] - starts
    owner = np.repeat(np.arange(len(rows)), counts)
    offsets = np.cumsum(counts) - counts
    pos = np.repeat(starts - offsets, counts) + np.arange(counts.sum())
    return owner, pos


def type_counts(layout: LotLayout, lut: NDArray[np.int64], n_types: int
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per lot: how many of its k nearest lots have each type; kernel weight of each type nearby."""
    n = layout.n
    onehot = np.zeros((n, n_types))
    assigned = lut >= 0
    onehot[np.flatnonzero(assigned), lut[assigned]] = 1.0
    counts = onehot[layout.knn].sum(axis=1) if layout.knn.shape[1] else np.zeros((n, n_types))
    sums = layout.weights @ onehot
    return counts, np.asarray(sums)


def term_values(ct: CompiledTypes, static: NDArray[np.float64], counts: NDArray[np.float64],
            sums: NDArray[np.float64], wsum: NDArray[np.float64], k: int) -> NDArray[np.float64]:
    """Every row's value under every type, (N, T): :func:`valuate` of all terms at once (the update
    calls this for the neighbours of every accepted change)."""
    tab = ct.table
    n = len(static)
    cluster = counts / k if k else np.zeros((n, ct.n))
    influence = np.divide(sums, wsum[:, None], out=np.zeros((n, ct.n)), where=wsum[:, None] > 0)
    x = np.hstack([static, cluster, influence])[:, tab.column]  # (N, J)
    return tab.valuate(x, slice(None)) @ tab.weight


def check_lut(layout: LotLayout, lut: NDArray[np.int64], n_types: int) -> NDArray[np.int64]:
    lut = np.asarray(lut, dtype=np.int64)
    if lut.shape != (layout.n,):
        raise InputError(f"land use: {layout.n} lots need ({layout.n},) types, got {lut.shape}")
    if layout.n and (lut.max(initial=-1) >= n_types or lut.min(initial=0) < UNASSIGNED):
        raise InputError(f"land use: lot types must lie in -1..{n_types - 1}")
    return lut


def lot_values(layout: LotLayout, lut: NDArray[np.int64], *, types: Sequence[LandUseType],
               options: LandUseOptions = DEFAULT_OPTIONS) -> NDArray[np.float64]:
    """Every lot's value ``luv`` under every type, given its neighbours' types (002 Eq. 4).

    Parameters
    ----------
    layout : LotLayout
    lut : ndarray of int, shape (L,)
        Current type per lot (index into ``types``; ``UNASSIGNED`` = −1 lots
        count for no type).

    Returns
    -------
    ndarray, shape (L, T)
        Values in [0, 1]; ``values[i, lut[i]]`` is the lot's current ``luv``.
    """
    ct = compile_types(types, layout.available)
    lut = check_lut(layout, lut, ct.n)
    counts, sums = type_counts(layout, lut, ct.n)
    return term_values(ct, layout.attributes, counts, sums, layout.weight_sums, layout.knn.shape[1])


def area_shares(area: NDArray[np.float64], lut: NDArray[np.int64], n_types: int) -> NDArray[np.float64]:
    """Share of the assigned lot area per type (002 Eq. 3), shape (T,); zeros with none assigned."""
    lut = np.asarray(lut)
    assigned = lut >= 0
    per = np.asarray(np.bincount(lut[assigned], weights=np.asarray(area)[assigned], minlength=n_types),
                     dtype=np.float64)
    total = per.sum()
    return per / total if total > 0 else per


@dataclass(frozen=True)
class SystemValue:
    """The system value of Eq. 1 and its parts; ``shares`` (T,) by area."""

    value: float
    global_value: float
    local_value: float
    shares: NDArray[np.float64]


def _global(shares: NDArray[np.float64], goals: NDArray[np.float64], scale: float) -> float:
    return -float(np.mean(((shares - goals) / scale) ** 2))


def system_value(layout: LotLayout, lut: NDArray[np.int64], *, types: Sequence[LandUseType],
                 options: LandUseOptions = DEFAULT_OPTIONS) -> SystemValue:
    """The system value ``λ_g·luv_global + λ_l·luv_local`` (002 Eq. 1–3, normalised as in the module doc).

    Parameters
    ----------
    layout : LotLayout
    lut : ndarray of int, shape (L,)

    Returns
    -------
    SystemValue
        ``local_value`` is the area-weighted mean ``luv`` of the assigned lots;
        ``global_value = −mean_t((share_t − goal_t)/scale)²``.
    """
    ct = compile_types(types, layout.available)
    lut = check_lut(layout, lut, ct.n)
    values = lot_values(layout, lut, types=types, options=options)
    shares = area_shares(layout.area, lut, ct.n)
    assigned = np.flatnonzero(lut >= 0)
    a = layout.area[assigned]
    local = float((a * values[assigned, lut[assigned]]).sum() / a.sum()) if len(assigned) else 0.0
    glob = _global(shares, ct.goals, options.goal_scale)
    return SystemValue(options.global_weight * glob + options.local_weight * local, glob, local, shares)
