"""The land-use update (seed 002 §4.1, Table 3): the sampling update, new lots' and blocks' types.

The *update* (002 §4.1, Table 3) samples ``m = sample_share · (assigned
lots)`` lots, tries a random *other* type for each and accepts by the
threshold rule: with ``Δ`` the change of the system value (new − old; Table
3 writes ``last − new``, which contradicts its own rule), the change is
always accepted when ``Δ > thresh``, else rejected with probability
``min(1, slope · (thresh − Δ))``. ``Δ`` is measured per unit of the changed
lot's area share (``Δ_system · A / area_i``), so the threshold and slope do
not depend on the city's size: a lot's own value changes by at most 1 on that
scale. ``Δ`` counts the lot's own value, the change it causes in its
neighbours' values (their ``influence`` and ``cluster``) and the global term.
No annealing: the same rule every year (002's dynamic disequilibrium).

For speed the proposals run in chunks of ``chunk_share`` of the lots: inside
a chunk every proposal's local change is computed against the state at the
chunk's start (vectorised), then the proposals are decided one after another
with the *global* term kept exact (shares are updated after each acceptance),
and the accepted changes are applied together. Proposals of one chunk do
not see each other's effect on their neighbourhoods (about ``chunk ×
neighbours / lots`` of them, ~4, lie within a proposal's 256 m). Measured on
2,000 synthetic lots over 10 years, 3 seeds: the mean lot value ends at 0.673
with 2 % chunks against 0.675 fully sequential (chunks of one), shares within
0.0014 of the goals either way, 9× faster.

New lots (type ``UNASSIGNED``) take the type that gives the highest system
value (002 §4.1), :func:`assign_types`; new blocks and quarters (no lots yet)
likewise, evaluated as one unit against the surrounding lots
(:func:`choose_types`): a block's type sets its lots' sizes and they inherit
it. Afterwards a block's type is the type of the largest share of its lots'
area (:func:`block_types`).

The types are :mod:`~osm_expand.engine.buildout.landuse_types`, the valuation
:mod:`~osm_expand.engine.buildout.valuation`, the lot attributes and the system value
:mod:`~osm_expand.engine.buildout.lot_values`; calibration from the map
:mod:`~osm_expand.engine.buildout.landuse_osm`, the similarity raster
:mod:`~osm_expand.engine.buildout.similarity`.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from osm_expand.engine.buildout.landuse_types import (
    DEFAULT_OPTIONS,
    INFLUENCE_CODE,
    UNASSIGNED,
    CompiledTypes,
    LandUseOptions,
    LandUseType,
    TermTable,
    compile_types,
)
from osm_expand.engine.buildout.lot_values import (
    LotLayout,
    area_shares,
    check_lut,
    influence_kernel,
    ragged,
    term_values,
    type_counts,
)
from osm_expand.errors import InputError


@dataclass(frozen=True)
class LandUseUpdate:
    """The result of one update: new types (L,), counts, shares (T,) and each lot's ``luv`` (L,)."""

    lut: NDArray[np.int64]
    proposed: int
    accepted: int
    shares: NDArray[np.float64]
    luv: NDArray[np.float64]


class _State:
    """Mutable working copy of the lots' types with their neighbour tallies and values."""

    def __init__(self, layout: LotLayout, lut: NDArray[np.int64], ct: CompiledTypes) -> None:
        self.layout, self.ct = layout, ct
        self.lut = lut.copy()
        self.k = layout.knn.shape[1]
        self.counts, self.sums = type_counts(layout, self.lut, ct.n)
        #: (type, influencing type, term) of every influence term; listens[t, s]: t has one on s
        self.influence_terms = [(t, term.code - INFLUENCE_CODE, term) for t, terms in enumerate(ct.terms)
                                for term in terms if term.code >= INFLUENCE_CODE]
        self.listens = np.zeros((ct.n, ct.n), dtype=bool)
        for t, s_, _ in self.influence_terms:
            self.listens[t, s_] = True
        #: hears[t, a, b]: t has an influence term on a or on b (one look-up per neighbour, not two)
        self.hears = self.listens[:, :, None] | self.listens[:, None, :]
        #: rows whose tallies an applied change moved since their values were computed (see :meth:`of`)
        self.stale = np.zeros(layout.n, dtype=bool)
        self.refresh()

    def refresh(self, rows: NDArray[np.int64] | None = None) -> None:
        """Recompute the lots' values under every type (all lots, or only ``rows``)."""
        lay = self.layout
        if rows is None:
            self.values = term_values(self.ct, lay.attributes, self.counts, self.sums, lay.weight_sums, self.k)
            self.stale[:] = False
        elif len(rows):
            self.values[rows] = term_values(self.ct, lay.attributes[rows], self.counts[rows], self.sums[rows],
                                        lay.weight_sums[rows], self.k)
            self.stale[rows] = False

    def of(self, lots: NDArray[np.int64]) -> NDArray[np.float64]:
        """The values of ``lots`` under every type, (len(lots), T), their stale rows recomputed first.

        A row's values are a function of its own tallies alone, so a row is recomputed when it is next
        read, not after every change that moves its tallies: a chunk reads its own few dozen lots, while
        an accepted change in Krems moves the tallies of hundreds (every lot within ``influence_radius``),
        most of them moved again before they are read. :func:`term_values` values each row on its own,
        so a row gets the same bits in any batch (Krems' 30 default years replayed: the same types and
        values; the checksums of Krems and Monaco the same, Krems' 150 north-american and european years
        the same bytes). Krems' 30 updates replayed, four
        back-to-back pairs: 0.60 → 0.55 s CPU (the rows valued fall, the calls rise: 628 → 795)."""
        due = np.unique(lots[self.stale[lots]])
        self.refresh(due)
        return self.values[lots]

    def settled(self) -> NDArray[np.float64]:
        """Every lot's values, (L, T), the stale rows recomputed first."""
        self.refresh(np.flatnonzero(self.stale))
        return self.values

    def externalities(self, lots: NDArray[np.int64], old: NDArray[np.int64],
                      new: NDArray[np.int64]) -> NDArray[np.float64]:
        """Σ_v area_v Δluv_v over the neighbours v whose attributes change when lots go old → new."""
        lay, ct, lut = self.layout, self.ct, self.lut
        total = np.zeros(len(lots))
        # influence: v's kernel sums of old and new type shift by w(v, i); only
        # neighbours whose type has a term on the influence of either count
        wt = lay.weights_by_source
        owner, pos = ragged(wt.indptr, lots)
        v = wt.indices[pos]
        tv = lut[v]
        a, b = old[owner], new[owner]
        tvc = np.maximum(tv, 0)
        keep = (tv >= 0) & self.hears[tvc, a, b]
        owner, v, a, b, w = owner[keep], v[keep], a[keep], b[keep], wt.data[pos][keep]
        tab = ct.table
        if len(v):
            tv = tv[keep]
            ws = lay.weight_sums[v]
            ws = np.where(ws > 0, ws, 1.0)
            dw = w / ws
            terms = []
            for src, sign in ((a, -1.0), (b, 1.0)):  # v's share of src falls (the old type) or rises (the new)
                x0 = self.sums[v, np.maximum(src, 0)] / ws
                for layer in tab.influence:
                    j = np.where(src >= 0, layer[tv, np.maximum(src, 0)], -1)  # an unassigned lot held no share
                    m = np.flatnonzero(j >= 0)
                    if len(m):
                        terms.append((m, j[m], x0[m] + sign * dw[m], x0[m]))
            total += np.bincount(owner, weights=lay.area[v] * _term_deltas(tab, terms, len(v)), minlength=len(lots))
        # cluster: v's count of its own type moves by ±1 when i is among its k nearest
        if self.k:
            owner, pos = ragged(lay.reverse_knn_indptr, lots)
            v = lay.reverse_knn_indices[pos]
            tv = lut[v]
            step = ((tv == new[owner]).astype(float) - (tv == old[owner])) / self.k
            keep = (tv >= 0) & (step != 0)
            owner, v, tv, step = owner[keep], v[keep], tv[keep], step[keep]
            if len(v):
                c0 = self.counts[v, tv] / self.k
                terms = []
                for layer in tab.cluster:
                    j = layer[tv]
                    m = np.flatnonzero(j >= 0)
                    if len(m):
                        terms.append((m, j[m], c0[m] + step[m], c0[m]))
                total += np.bincount(owner, weights=lay.area[v] * _term_deltas(tab, terms, len(v)),
                                     minlength=len(lots))
        return total

    def apply(self, lots: NDArray[np.int64], new: NDArray[np.int64]) -> None:
        lay, n_t = self.layout, self.ct.n
        old = self.lut[lots]
        wt = lay.weights_by_source
        owner, pos = ragged(wt.indptr, lots)
        v, w = wt.indices[pos], wt.data[pos]
        flat = self.sums.reshape(-1)
        was = old[owner] >= 0
        _add(flat, v[was] * n_t + old[owner][was], -1.0, w[was])
        _add(flat, v * n_t + new[owner], 1.0, w)
        touched = [lots, v]
        if self.k:
            owner, pos = ragged(lay.reverse_knn_indptr, lots)
            v = lay.reverse_knn_indices[pos]
            cflat = self.counts.reshape(-1)
            was = old[owner] >= 0
            _add(cflat, v[was] * n_t + old[owner][was], -1.0)
            _add(cflat, v * n_t + new[owner], 1.0)
            touched.append(v)
        self.lut[lots] = new
        self.stale[np.concatenate(touched)] = True  # recomputed when next read (:meth:`of`)


def _add(flat: NDArray[np.float64], at: NDArray[np.int64], sign: float,
         weights: NDArray[np.float64] | None = None) -> None:
    """``flat ± np.bincount(at, weights, minlength=flat.size)`` to the same bits, touching only the bins in
    ``at``: each bin's weights are summed in the same order from 0 (a ``bincount`` over the bins' ranks), and
    the other bins would only have had 0 added. An accepted change moves a few hundred neighbours' tallies;
    the whole-length counts were lots × types long, four for every chunk that accepted one (Krems' last
    north-american year: 13,048 lots; the tallies of its 50 chunks 53 → 23–36 ms, the same types and values)."""
    if not len(at):
        return
    bins, rank = np.unique(at, return_inverse=True)
    total = np.bincount(rank, weights=weights, minlength=len(bins))
    if sign < 0:
        flat[bins] -= total
    else:
        flat[bins] += total


def _term_deltas(tab: TermTable, terms: list[tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64],
                                                     NDArray[np.float64]]], n: int) -> NDArray[np.float64]:
    """Σ over ``terms`` of ``term_weight · (valuate(after) − valuate(before))`` per neighbour (n,).

    ``terms`` holds (neighbours, term, after, before) per layer. Every value
    is valued in one call (:meth:`TermTable.valuate` works element by
    element, so each is the same number as valued alone) and the layers are
    added in their order, as one call per layer and side did: a land-use
    update asks this of every chunk of lots, and the calls on arrays of a
    few dozen values were most of its time (Krems: 6,000 calls).
    """
    delta = np.zeros(n)
    if not terms:
        return delta
    values = tab.valuate(np.concatenate([x for _, _, after, before in terms for x in (after, before)]),
                         np.concatenate([jm for _, jm, _, _ in terms for _ in (0, 1)]))
    start = 0
    for m, jm, _, _ in terms:
        k = len(m)
        delta[m] += tab.term_weight[jm] * (values[start:start + k] - values[start + k:start + 2 * k])
        start += 2 * k
    return delta


def _chunks(order: NDArray[np.int64], size: int) -> Iterable[NDArray[np.int64]]:
    for start in range(0, len(order), size):
        yield order[start:start + size]


def _chunk_size(n: int, options: LandUseOptions) -> int:
    return max(options.min_chunk, int(np.ceil(options.chunk_share * n)), 1)


def update_land_use(layout: LotLayout, lut: NDArray[np.int64], *, types: Sequence[LandUseType],
                    rng: np.random.Generator, sample_share: float | None = None,
                    allowed: NDArray[np.bool_] | None = None,
                    options: LandUseOptions = DEFAULT_OPTIONS) -> LandUseUpdate:
    """One land-use update (002 §4.1, Table 3): sample lots, try a random other type, accept by threshold.

    Parameters
    ----------
    layout : LotLayout
        The current lots (:func:`lot_layout`).
    lut : ndarray of int, shape (L,)
        Current type per lot; ``UNASSIGNED`` lots are left alone (give them a
        type with :func:`assign_types` first).
    types : sequence of LandUseType
    rng : numpy.random.Generator
        All randomness (lot sample, proposed types, acceptance draws).
    sample_share : float, optional
        ``m`` as a share of the assigned lots (default ``options.sample_share``);
        each lot is sampled at most once per pass over the lots.
    allowed : ndarray of bool, shape (L, T), optional
        Which types each lot may take (a lot whose area lies outside a lot
        class's bounds cannot take that class's types); a proposal of a type
        not allowed is dropped before it is valued (it counts as neither
        proposed nor accepted). The random draws are the same with or
        without it. None: every type.

    Returns
    -------
    LandUseUpdate
        The new types (a copy), how many changes were proposed and accepted,
        the area shares and each lot's ``luv`` after the update.

    Notes
    -----
    Acceptance (Table 3, §4.1): ``Δ`` = system value after − before, per unit
    of the lot's area share; accept when ``Δ > accept_threshold``, otherwise
    reject with probability ``min(1, reject_slope · (accept_threshold − Δ))``.
    """
    ct = compile_types(types, layout.available)
    lut = check_lut(layout, lut, ct.n)
    share = options.sample_share if sample_share is None else float(sample_share)
    if share < 0 or not np.isfinite(share):
        raise InputError(f"land_use sample_share: must be ≥ 0, got {share}")
    if allowed is not None:
        allowed = np.asarray(allowed, dtype=bool)
        if allowed.shape != (layout.n, ct.n):
            raise InputError(f"land use: allowed types must have shape ({layout.n}, {ct.n}), got {allowed.shape}")
    state = _State(layout, lut, ct)
    assigned = np.flatnonzero(lut >= 0)
    m = int(round(share * len(assigned)))
    proposed = accepted = 0
    if ct.n > 1 and m > 0:
        total_area = float(layout.area[assigned].sum())
        excess = list(area_shares(layout.area, lut, ct.n) - ct.goals)
        coef = 2.0 / (ct.n * options.goal_scale ** 2)
        size = _chunk_size(layout.n, options)
        n_passes = -(-m // len(assigned))
        order_all = np.concatenate([rng.permutation(assigned) for _ in range(n_passes)])[:m]
        for p in range(n_passes):  # a lot is sampled at most once per pass, hence once per chunk
            order = order_all[p * len(assigned):(p + 1) * len(assigned)]
            for lots in _chunks(order, size):
                old = state.lut[lots]
                new = (old + rng.integers(1, ct.n, size=len(lots))) % ct.n
                u = rng.random(len(lots))
                if allowed is not None:
                    ok = allowed[lots, new]
                    lots, old, new, u = lots[ok], old[ok], new[ok], u[ok]
                    if not len(lots):
                        continue
                values = state.of(lots)
                own = values[np.arange(len(lots)), new] - values[np.arange(len(lots)), old]
                local = own + state.externalities(lots, old, new) / layout.area[lots]
                take = _decide(lots, old, new, local, u, excess, layout.area, total_area, coef, options)
                proposed += len(lots)
                accepted += len(take)
                if len(take):
                    state.apply(lots[take], new[take])
    luv = np.where(state.lut >= 0, state.settled()[np.arange(layout.n), np.maximum(state.lut, 0)], 0.0)
    return LandUseUpdate(state.lut, proposed, accepted, area_shares(layout.area, state.lut, ct.n), luv)


def acceptance_probability(delta: NDArray[np.float64] | float, *,
                           options: LandUseOptions = DEFAULT_OPTIONS) -> NDArray[np.float64]:
    """Probability of keeping a proposed change (002 §4.1, Table 3's ``accept``).

    Parameters
    ----------
    delta : array_like
        Change of the system value, new − old, per unit of the changed lot's
        area share (see the module docstring).

    Returns
    -------
    ndarray
        1 where ``delta > accept_threshold``; otherwise
        ``max(0, 1 − reject_slope · (accept_threshold − delta))``: the
        rejection probability grows in proportion to the shortfall.
    """
    d = np.asarray(delta, dtype=np.float64)
    thresh = options.accept_threshold
    return np.where(d > thresh, 1.0, np.clip(1.0 - options.reject_slope * (thresh - d), 0.0, 1.0))


def _decide(lots: NDArray[np.int64], old: NDArray[np.int64], new: NDArray[np.int64],
            local: NDArray[np.float64], u: NDArray[np.float64], excess: list[float],
            area: NDArray[np.float64], total_area: float, coef: float,
            options: LandUseOptions) -> NDArray[np.int64]:
    """Table 3's sequential accept/reject with the global term kept exact; mutates ``excess``."""
    thresh, slope = options.accept_threshold, options.reject_slope
    lg, ll = options.global_weight, options.local_weight
    share = (area[lots] / total_area).tolist()
    olds, news, locs, draws = old.tolist(), new.tolist(), local.tolist(), u.tolist()
    take = []
    for q in range(len(olds)):
        a, b, d = olds[q], news[q], share[q]
        # d(luv_global)/d(share moved a → b) per unit share: −(2/(T·scale²))·(e_b − e_a + d)
        delta = lg * -coef * (excess[b] - excess[a] + d) + ll * locs[q]
        if delta > thresh or draws[q] >= slope * (thresh - delta):  # = u < acceptance_probability
            excess[a] -= d
            excess[b] += d
            take.append(q)
    return np.asarray(take, dtype=np.int64)


def assign_types(layout: LotLayout, lut: NDArray[np.int64], *, types: Sequence[LandUseType],
                 rng: np.random.Generator,
                 options: LandUseOptions = DEFAULT_OPTIONS) -> NDArray[np.int64]:
    """Give every ``UNASSIGNED`` lot the type that raises the system value most (002 §4.1).

    New lots are visited in random order, in chunks; each takes
    ``argmax_t λ_l·luv_t(i) − λ_g·(2/(T·scale²))·(share_t − goal_t)`` (its own
    value plus the marginal global term of adding its area to type ``t``),
    shares updated after every lot, neighbour tallies after every chunk.

    Parameters
    ----------
    layout : LotLayout
    lut : ndarray of int, shape (L,)
    types : sequence of LandUseType
    rng : numpy.random.Generator
        Orders the new lots.

    Returns
    -------
    ndarray of int, shape (L,)
        A copy of ``lut`` with no ``UNASSIGNED`` left (unchanged where assigned).
    """
    ct = compile_types(types, layout.available)
    lut = check_lut(layout, lut, ct.n)
    state = _State(layout, lut, ct)
    new_lots = rng.permutation(np.flatnonzero(lut < 0))
    if len(new_lots) == 0:
        return state.lut
    per = np.asarray(np.bincount(lut[lut >= 0], weights=layout.area[lut >= 0], minlength=ct.n), dtype=np.float64)
    for lots in _chunks(new_lots, _chunk_size(layout.n, options)):
        state.apply(lots, _greedy(state.of(lots), layout.area[lots], per, ct, options))
    return state.lut


def choose_types(layout: LotLayout, lut: NDArray[np.int64], xy: NDArray[np.float64],
                 area: NDArray[np.float64], attributes: NDArray[np.float64], *,
                 types: Sequence[LandUseType],
                 options: LandUseOptions = DEFAULT_OPTIONS) -> NDArray[np.int64]:
    """The best type for new blocks or quarters that have no lots yet (002 §2.2, §4.1).

    Each unit is valued like a lot against the current lots (its ``k``
    nearest lots, the lots within ``r``), with the marginal global term of
    adding its area; units are decided in the given order, each adding its
    area to the shares the next one sees (their neighbourhoods do not see one
    another).

    Parameters
    ----------
    layout : LotLayout
        The existing lots.
    lut : ndarray of int, shape (L,)
    xy : ndarray, shape (U, 2)
        Unit centroids (m).
    area : ndarray, shape (U,)
        Unit areas (m²).
    attributes : ndarray, shape (U, 6)
        From :func:`lot_attributes` (use the same ``extent`` as the lots).

    Returns
    -------
    ndarray of int, shape (U,)
        A type index per unit (the lot sizes of its subdivision follow it).
    """
    ct = compile_types(types, layout.available)
    lut = check_lut(layout, lut, ct.n)
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    u = len(xy)
    if u == 0:
        return np.zeros(0, dtype=np.int64)
    onehot = np.zeros((layout.n, ct.n))
    ok = lut >= 0
    onehot[np.flatnonzero(ok), lut[ok]] = 1.0
    k = min(options.cluster_neighbours, layout.n)
    counts = np.zeros((u, ct.n))
    if k:
        _, idx = layout.tree.query(xy, k=k)
        counts = onehot[np.asarray(idx).reshape(u, k)].sum(axis=1)
    r = options.influence_radius
    near = layout.tree.query_ball_point(xy, r)
    owner = np.repeat(np.arange(u), [len(x) for x in near])
    other = np.fromiter((j for x in near for j in x), dtype=np.int64, count=len(owner))
    d = np.hypot(*(xy[owner] - layout.xy[other]).T) if len(other) else np.zeros(0)
    w = influence_kernel(d, layout.area[other], r)
    sums = np.zeros((u, ct.n))
    if len(other):
        np.add.at(sums, owner, w[:, None] * onehot[other])
    wsum = np.asarray(np.bincount(owner, weights=w, minlength=u), dtype=np.float64)
    values = term_values(ct, np.asarray(attributes, dtype=np.float64).reshape(u, -1), counts, sums, wsum, k)
    per = np.asarray(np.bincount(lut[ok], weights=layout.area[ok], minlength=ct.n), dtype=np.float64)
    return _greedy(values, np.asarray(area, dtype=np.float64).reshape(u), per, ct, options)


def _greedy(values: NDArray[np.float64], area: NDArray[np.float64], per: NDArray[np.float64],
            ct: CompiledTypes, options: LandUseOptions) -> NDArray[np.int64]:
    """Units in order each take ``argmax_t λ_l·value_t − λ_g·(2/(T·scale²))·(share_t − goal_t)``.

    ``per`` (T,) is the area per type so far; it grows by each unit's area
    (mutated), so a batch of new units does not all rush to one short type.
    """
    coef = 2.0 / (ct.n * options.goal_scale ** 2)
    chosen = np.empty(len(values), dtype=np.int64)
    for q in range(len(values)):
        total = per.sum() + area[q]
        excess = per / total - ct.goals if total > 0 else -ct.goals
        t = int(np.argmax(options.local_weight * values[q] - options.global_weight * coef * excess))
        chosen[q] = t
        per[t] += area[q]
    return chosen


def block_types(block: NDArray[np.int64], area: NDArray[np.float64], lut: NDArray[np.int64],
                n_blocks: int, n_types: int) -> NDArray[np.int64]:
    """A block's (or quarter's) type: the type holding the largest share of its lots' area.

    Parameters
    ----------
    block : ndarray of int, shape (L,)
        Block index per lot.
    area : ndarray, shape (L,)
    lut : ndarray of int, shape (L,)
    n_blocks, n_types : int

    Returns
    -------
    ndarray of int, shape (B,)
        Ties go to the lower type index; ``UNASSIGNED`` for a block without
        assigned lots.
    """
    block, lut = np.asarray(block, dtype=np.int64), np.asarray(lut, dtype=np.int64)
    ok = lut >= 0
    table = np.bincount(block[ok] * n_types + lut[ok], weights=np.asarray(area)[ok],
                        minlength=n_blocks * n_types).reshape(n_blocks, n_types)
    out = np.argmax(table, axis=1).astype(np.int64)
    out[table.sum(axis=1) <= 0] = UNASSIGNED
    return out


def runs_this_year(year: int, first_year: int, *, options: LandUseOptions = DEFAULT_OPTIONS) -> bool:
    """Whether the update runs in ``year`` (every ``update_interval`` years from ``first_year``)."""
    if options.update_interval < 1:
        raise InputError(f"land_use update_interval: must be ≥ 1, got {options.update_interval}")
    return (year - first_year) % options.update_interval == 0
