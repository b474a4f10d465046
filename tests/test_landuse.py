"""Land use (seed 002 §4): valuation functions, attributes, the update, calibration, similarity."""
from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from osm_expand.engine.buildout import landuse as lu
from osm_expand.engine.buildout import landuse_osm as lo
from osm_expand.engine.buildout import landuse_types as lt
from osm_expand.engine.buildout import lot_values as lv
from osm_expand.engine.buildout import similarity as ls
from osm_expand.engine.buildout.landuse_types import LandUseOptions, LandUseType, ValuationTerm
from osm_expand.errors import InputError

# --------------------------------------------------------------------------- builders

def grid_lots(n: int, rng: np.random.Generator, spacing: float = 30.0):
    side = int(np.ceil(np.sqrt(n)))
    g = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2)[:n] * spacing
    return g + rng.normal(0, spacing / 8, g.shape), rng.uniform(400, 1200, n)


def layout_of(xy, area=None, *, traffic=None, options=lt.DEFAULT_OPTIONS, **kw):
    xy = np.asarray(xy, float)
    area = np.full(len(xy), 500.0) if area is None else np.asarray(area, float)
    attrs = lv.lot_attributes(xy, centres=xy.mean(0, keepdims=True), traffic=traffic, **kw)
    return lv.lot_layout(xy, area, attrs, options=options)


def probe_types():
    """A: valued by its cluster share; B: valued by the influence of A around it."""
    return (LandUseType("a", 0.5, (ValuationTerm(1.0, "linear_up", "cluster", 0.0, 1.0),)),
            LandUseType("b", 0.5, (ValuationTerm(1.0, "linear_up", "influence", 0.0, 1.0, of_type="a"),)))


# --------------------------------------------------------------------------- valuation functions

X = np.array([-1.0, 0.0, 0.25, 0.5, 0.75, 1.0, 2.0])


def test_step_is_one_inside_its_bounds_inclusive_and_one_sided_with_inf():
    assert lt.valuate("step", X, 0.0, 1.0).tolist() == [0, 1, 1, 1, 1, 1, 0]
    assert lt.valuate("step", X, 0.5, np.inf).tolist() == [0, 0, 0, 1, 1, 1, 1]
    assert lt.valuate("step", X, -np.inf, 0.25).tolist() == [1, 1, 1, 0, 0, 0, 0]


def test_linear_ramps_go_from_0_at_low_to_1_at_high_and_clip_beyond():
    up = lt.valuate("linear_up", X, 0.0, 1.0)
    np.testing.assert_allclose(up, [0, 0, 0.25, 0.5, 0.75, 1, 1])
    np.testing.assert_allclose(lt.valuate("linear_down", X, 0.0, 1.0), 1 - up)
    np.testing.assert_allclose(lt.valuate("linear_up", [10.0, 20.0, 30.0], 10.0, 30.0), [0, 0.5, 1])


def test_gain_ramps_are_s_curves_with_the_ramps_ends_and_midpoint():
    g = lt.valuate("gain_up", X, 0.0, 1.0, gain=0.75)
    np.testing.assert_allclose(g[[0, 1, 3, 5, 6]], [0, 0, 0.5, 1, 1])
    # Perlin's gain(0.75, t) = (2t)²/2 below ½: flat near the bounds, steep in the middle
    np.testing.assert_allclose(g[2], 0.125)
    np.testing.assert_allclose(g[4], 0.875)
    assert np.all(np.diff(lt.valuate("gain_up", np.linspace(0, 1, 101), 0, 1)) >= 0)
    np.testing.assert_allclose(lt.valuate("gain_up", X, 0.0, 1.0, gain=0.5), lt.valuate("linear_up", X, 0, 1))
    np.testing.assert_allclose(lt.valuate("gain_down", X, 0.0, 1.0), 1 - g)


def test_valuation_maps_nan_to_zero_and_rejects_unknown_kinds():
    for kind in lt.Valuation:
        assert lt.valuate(kind, np.array([np.nan]), 0.0, 1.0)[0] == 0.0
    with pytest.raises(InputError, match="step, linear_up, linear_down, gain_up, gain_down"):
        lt.valuate("ramp", X, 0, 1)


# --------------------------------------------------------------------------- type definitions

def test_types_from_config_builds_types_and_names_what_is_wrong():
    entry = {"name": "a", "goal": 1.0, "lot_size": "small",
             "terms": [{"weight": 1.0, "kind": "linear_up", "attribute": "traffic", "low": 0, "high": 1}]}
    (t,) = lt.types_from_config([entry])
    assert t.terms[0].attribute == "traffic" and t.lot_size_key == "small"
    bad_kind = dict(entry, terms=[dict(entry["terms"][0], kind="ramp")])
    with pytest.raises(InputError, match="kind: 'ramp' is not one of step"):
        lt.types_from_config([bad_kind])
    bad_type = dict(entry, terms=[dict(entry["terms"][0], attribute="influence", of_type="zz")])
    with pytest.raises(InputError, match="of_type: 'zz' is not one of a"):
        lt.types_from_config([bad_type])
    with pytest.raises(InputError, match="missing key 'goal'"):
        lt.types_from_config([{"name": "a"}])
    with pytest.raises(InputError, match="low must be below high"):
        lt.types_from_config([dict(entry, terms=[dict(entry["terms"][0], low=1, high=1)])])


def test_types_read_from_toml():
    tomllib = pytest.importorskip("tomllib")
    text = """
[[land_use]]
name = "industrial"
goal = 0.3
lot_size = "large"

[[land_use.terms]]
weight = 0.6
kind = "linear_up"
attribute = "traffic"
low = 0.3
high = 1.0

[[land_use.terms]]
weight = 0.4
kind = "linear_down"
attribute = "influence"
of_type = "housing"
low = 0.1
high = 0.6

[[land_use]]
name = "housing"
goal = 0.7
terms = [{ weight = 1, kind = "step", attribute = "center_dist", low = -inf, high = 0.2 }]
"""
    industrial, housing = lt.types_from_config(tomllib.loads(text)["land_use"])
    assert industrial.terms[1].of_type == "housing" and industrial.lot_size_key == "large"
    assert housing.terms[0].low == -np.inf and housing.lot_size_key == "housing"


def test_bundled_types_are_valid_with_goals_summing_to_one():
    assert {t.name for t in lt.DEFAULT_TYPES} >= {"residential_low", "residential_high", "commercial",
                                                 "industrial", "park"}
    assert lt.goal_shares(lt.DEFAULT_TYPES).sum() == pytest.approx(1.0)
    for t in lt.DEFAULT_TYPES:
        assert sum(term.weight for term in t.terms) == pytest.approx(1.0)
    with pytest.raises(InputError, match="goal"):
        lt.goal_shares([LandUseType("a", -1.0, ())])


# --------------------------------------------------------------------------- attributes

def test_cluster_is_the_share_of_the_nearest_lots_with_the_same_type():
    # 11 lots on a line; with k = 4 the first lot's neighbours are lots 1-4
    xy = np.column_stack([np.arange(11) * 10.0, np.zeros(11)])
    lay = layout_of(xy, options=LandUseOptions(cluster_neighbours=4))
    lut = np.array([0, 0, 1, 0, 1, 1, 1, 1, 1, 1, 1])
    values = lv.lot_values(lay, lut, types=probe_types(), options=LandUseOptions(cluster_neighbours=4))
    assert values[0, 0] == pytest.approx(2 / 4)  # lots 1, 3 of type a among 1..4
    assert values[10, 0] == pytest.approx(0.0)


def test_influence_counts_near_lots_more_than_far_ones_and_ignores_lots_beyond_r():
    # lot 0 at the origin, one lot of type a at 20 m and one of type b at 200 m, equal areas
    xy = np.array([[0.0, 0.0], [20.0, 0.0], [-200.0, 0.0], [1000.0, 0.0]])
    lay = layout_of(xy)
    near_a = lv.lot_values(lay, np.array([1, 0, 1, 0]), types=probe_types())[0, 1]
    far_a = lv.lot_values(lay, np.array([1, 1, 0, 0]), types=probe_types())[0, 1]
    w_near, w_far = 1 - 20 / 256, 1 - 200 / 256  # linear kernel, the lot at 1 km is outside r
    assert near_a == pytest.approx(w_near / (w_near + w_far))
    assert far_a == pytest.approx(w_far / (w_near + w_far))
    assert near_a > 0.5 > far_a
    # a neighbour's area weighs in: quadruple the far lot's area
    lay4 = layout_of(xy, area=[500, 500, 2000, 500])
    assert lv.lot_values(lay4, np.array([1, 1, 0, 0]), types=probe_types())[0, 1] == pytest.approx(
        4 * w_far / (w_near + 4 * w_far))


def test_centre_distance_is_a_share_of_the_extent_water_and_green_are_in_km():
    xy = np.array([[0.0, 0.0], [300.0, 400.0]])  # extent = 500 m
    water = [shapely.LineString([(0, 100), (300, 100)])]
    a = lv.lot_attributes(xy, centres=[[0.0, 0.0]], water=water)
    np.testing.assert_allclose(a[:, 0], [0.0, 1.0])
    np.testing.assert_allclose(a[:, 1], [0.1, 0.3])
    np.testing.assert_allclose(a[:, 2], [1.0, 1.0])  # no park or forest
    assert np.isnan(a[:, 4:]).all()  # no height source
    b = lv.lot_attributes(xy, centres=[[0.0, 0.0]], extent=1000.0, water_distance=[50.0, 5000.0])
    np.testing.assert_allclose(b[:, 1], [0.05, 1.0])


def test_traffic_is_divided_by_its_95th_percentile_and_clipped():
    xy = np.column_stack([np.arange(100.0), np.zeros(100)])
    traffic = np.arange(100.0)
    a = lv.lot_attributes(xy, centres=[[0, 0]], traffic=traffic)
    ref = np.quantile(traffic, 0.95)
    np.testing.assert_allclose(a[:50, 3], traffic[:50] / ref)
    assert a[-1, 3] == 1.0


def test_terms_on_missing_slope_drop_out_and_weights_renormalise():
    t = (LandUseType("a", 1.0, (ValuationTerm(0.5, "linear_down", "slope", 0.0, 0.2),
                                ValuationTerm(0.5, "linear_up", "traffic", 0.0, 1.0))),)
    xy = np.array([[0.0, 0.0], [50.0, 0.0]])
    without = layout_of(xy, traffic=[0.0, 10.0])
    np.testing.assert_allclose(lv.lot_values(without, np.zeros(2, int), types=t)[:, 0], [0.0, 1.0])
    with_slope = layout_of(xy, traffic=[0.0, 10.0], slope=[0.1, 0.0])
    np.testing.assert_allclose(lv.lot_values(with_slope, np.zeros(2, int), types=t)[:, 0], [0.25, 1.0])


# --------------------------------------------------------------------------- system value and acceptance

def test_global_term_is_minus_the_mean_squared_deviation_in_units_of_scale():
    xy = np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0], [30.0, 0.0]])
    lay = layout_of(xy, area=[100, 100, 100, 100])
    v = lv.system_value(lay, np.array([0, 0, 0, 1]), types=probe_types())
    np.testing.assert_allclose(v.shares, [0.75, 0.25])
    assert v.global_value == pytest.approx(-((0.25 / 0.05) ** 2 + (0.25 / 0.05) ** 2) / 2)
    assert v.value == pytest.approx(0.5 * v.global_value + 0.5 * v.local_value)
    assert lv.system_value(lay, np.array([0, 1, 0, 1]), types=probe_types()).global_value == 0.0


def test_acceptance_rule_takes_gains_and_rejects_losses_in_proportion_to_the_shortfall():
    opts = LandUseOptions(accept_threshold=0.0, reject_slope=10.0)
    p = lu.acceptance_probability([0.3, 0.0, -0.02, -0.05, -0.1, -1.0], options=opts)
    np.testing.assert_allclose(p, [1.0, 1.0, 0.8, 0.5, 0.0, 0.0])
    strict = LandUseOptions(accept_threshold=0.1, reject_slope=10.0)
    np.testing.assert_allclose(lu.acceptance_probability([0.2, 0.05], options=strict), [1.0, 0.5])


def test_decide_applies_the_rule_with_the_global_term_and_updates_shares():
    opts = LandUseOptions(reject_slope=10.0)
    area = np.array([1.0, 1e6])
    # shares at their goals (excess 0), a tiny lot, local loss 0.1 → Δ = 0.5·(−0.1) = −0.05 → p = 0.5
    for u, kept in ((0.49, 0), (0.51, 1)):
        excess = [0.0, 0.0]
        take = lu._decide(np.array([0]), np.array([0]), np.array([1]), np.array([-0.1]), np.array([u]),
                          excess, area, float(area.sum()), 2 / (2 * 0.05 ** 2), opts)
        assert len(take) == kept
        assert excess[1] == pytest.approx(kept * 1e-6, abs=1e-9)
    # a type far below its goal wins a lot despite a local loss
    excess = [0.2, -0.2]
    take = lu._decide(np.array([0]), np.array([0]), np.array([1]), np.array([-0.5]), np.array([0.99]),
                      excess, area, float(area.sum()), 2 / (2 * 0.05 ** 2), opts)
    assert len(take) == 1


def test_local_change_with_externalities_equals_the_change_of_the_system_value():
    rng = np.random.default_rng(5)
    xy, area = grid_lots(300, rng)
    lay = layout_of(xy, area, traffic=rng.gamma(1, 100, 300))
    types = lt.DEFAULT_TYPES
    ct = lt.compile_types(types, lay.available)
    lut = rng.integers(0, len(types), 300)
    state = lu._State(lay, lut, ct)
    lots = np.array([17, 150, 299])
    new = (lut[lots] + np.array([1, 2, 3])) % len(types)
    predicted = state.values[lots, new] - state.values[lots, lut[lots]] \
        + state.externalities(lots, lut[lots], new) / area[lots]
    before = lv.system_value(lay, lut, types=types).local_value
    for i, b, pred in zip(lots, new, predicted):
        after_lut = lut.copy()
        after_lut[i] = b
        after = lv.system_value(lay, after_lut, types=types).local_value
        assert (after - before) * area.sum() / area[i] == pytest.approx(pred, rel=1e-9, abs=1e-12)
    # incremental bookkeeping matches a recount from scratch
    state.apply(lots, new)
    lut2 = lut.copy()
    lut2[lots] = new
    counts, sums = lv.type_counts(lay, lut2, len(types))
    np.testing.assert_allclose(state.counts, counts)
    np.testing.assert_allclose(state.sums, sums)
    np.testing.assert_allclose(state.settled(), lv.lot_values(lay, lut2, types=types))


def test_values_read_after_changes_are_those_of_the_whole_town_valued_at_once():
    """The update recomputes a lot's values only when it reads them (``_State.of``); read in chunks of any
    size after changes all over the town, they are the bits of every lot valued in one batch."""
    rng = np.random.default_rng(11)
    xy, area = grid_lots(400, rng)
    lay = layout_of(xy, area, traffic=rng.gamma(1, 100, 400))
    types = lt.DEFAULT_TYPES
    ct = lt.compile_types(types, lay.available)
    state = lu._State(lay, rng.integers(0, len(types), 400), ct)
    for _ in range(6):
        lots = rng.choice(400, size=25, replace=False)
        state.of(lots[:7])  # some rows read (and recomputed) between the changes
        state.apply(lots, (state.lut[lots] + rng.integers(1, len(types), 25)) % len(types))
    assert state.stale.any()
    whole = lv.term_values(ct, lay.attributes, state.counts, state.sums, lay.weight_sums, state.k)
    read = np.concatenate([state.of(chunk) for chunk in np.array_split(rng.permutation(400), 9)])
    assert not state.stale.any()
    assert state.values.tobytes() == whole.tobytes()
    assert read.shape == (400, len(types))


def _externalities_layer_by_layer(state, lots, old, new):
    """``_State.externalities`` as it was: two ``valuate`` calls per layer and side (influence) and per
    layer (cluster), each added to the neighbours' deltas as it came."""
    lay, ct, lut = state.layout, state.ct, state.lut
    tab = ct.table
    total = np.zeros(len(lots))
    wt = lay.weights_by_source
    owner, pos = lv.ragged(wt.indptr, lots)
    v = wt.indices[pos]
    tv = lut[v]
    a, b = old[owner], new[owner]
    tvc = np.maximum(tv, 0)
    keep = (tv >= 0) & (state.listens[tvc, a] | state.listens[tvc, b])
    owner, v, a, b, w = owner[keep], v[keep], a[keep], b[keep], wt.data[pos][keep]
    if len(v):
        tv = tv[keep]
        ws = lay.weight_sums[v]
        ws = np.where(ws > 0, ws, 1.0)
        dw = w / ws
        delta = np.zeros(len(v))
        for src, sign in ((a, -1.0), (b, 1.0)):
            x0 = state.sums[v, np.maximum(src, 0)] / ws
            for layer in tab.influence:
                j = np.where(src >= 0, layer[tv, np.maximum(src, 0)], -1)
                m = np.flatnonzero(j >= 0)
                if len(m):
                    jm = j[m]
                    delta[m] += tab.term_weight[jm] * (tab.valuate(x0[m] + sign * dw[m], jm)
                                                       - tab.valuate(x0[m], jm))
        total += np.bincount(owner, weights=lay.area[v] * delta, minlength=len(lots))
    if state.k:
        owner, pos = lv.ragged(lay.reverse_knn_indptr, lots)
        v = lay.reverse_knn_indices[pos]
        tv = lut[v]
        step = ((tv == new[owner]).astype(float) - (tv == old[owner])) / state.k
        keep = (tv >= 0) & (step != 0)
        owner, v, tv, step = owner[keep], v[keep], tv[keep], step[keep]
        if len(v):
            c0 = state.counts[v, tv] / state.k
            delta = np.zeros(len(v))
            for layer in tab.cluster:
                j = layer[tv]
                m = np.flatnonzero(j >= 0)
                if len(m):
                    jm = j[m]
                    delta[m] += tab.term_weight[jm] * (tab.valuate(c0[m] + step[m], jm) - tab.valuate(c0[m], jm))
            total += np.bincount(owner, weights=lay.area[v] * delta, minlength=len(lots))
    return total


def test_the_externalities_value_every_term_in_one_call_to_the_same_bits(monkeypatch):
    """A chunk's externalities value all their terms in one call of ``valuate`` per kind (influence,
    cluster), not two per layer and side, and the sum is the same to the bit as valued layer by layer
    (the old loop, :func:`_externalities_layer_by_layer`, on the same state, lots and new types)."""
    rng = np.random.default_rng(5)
    xy, area = grid_lots(300, rng)
    lay = layout_of(xy, area, traffic=rng.gamma(1, 100, 300))
    ct = lt.compile_types(lt.DEFAULT_TYPES, lay.available)
    lut = rng.integers(0, len(lt.DEFAULT_TYPES), 300)
    state = lu._State(lay, lut, ct)
    lots = rng.choice(300, 40, replace=False)
    new = (lut[lots] + rng.integers(1, ct.n, 40)) % ct.n
    tab = ct.table
    calls: list[int] = []
    valuate = type(tab).valuate
    monkeypatch.setattr(type(tab), "valuate", lambda self, x, j: calls.append(len(x)) or valuate(self, x, j))
    got = state.externalities(lots, lut[lots], new)
    assert len(calls) == 2  # one for the influence terms, one for the cluster terms
    old_calls = len(calls)
    assert got.tobytes() == _externalities_layer_by_layer(state, lots, lut[lots], new).tobytes()
    assert len(calls) - old_calls > 2  # the old loop called it per layer and side
    terms = [(np.arange(5), np.array([0, 1, 0, 2, 1]), rng.random(5), rng.random(5)),
             (np.array([1, 3]), np.array([2, 2]), rng.random(2), rng.random(2))]
    one_by_one = np.zeros(5)
    for m, jm, after, before in terms:
        one_by_one[m] += tab.term_weight[jm] * (valuate(tab, after, jm) - valuate(tab, before, jm))
    assert lu._term_deltas(tab, terms, 5).tobytes() == one_by_one.tobytes()
    assert np.isfinite(got).all() and np.count_nonzero(got)


# --------------------------------------------------------------------------- the update

def test_update_moves_shares_to_within_0_05_of_the_goals():
    rng = np.random.default_rng(11)
    xy, area = grid_lots(2000, rng)
    lay = layout_of(xy, area, traffic=rng.gamma(1, 100, 2000),
                    water=[shapely.LineString([(0, 600), (1400, 700)])])
    goals = lt.goal_shares(lt.DEFAULT_TYPES)
    lut = np.zeros(2000, dtype=np.int64)  # everything low-density residential
    for _ in range(4):
        result = lu.update_land_use(lay, lut, types=lt.DEFAULT_TYPES, rng=rng)
        lut = result.lut
    assert np.abs(result.shares - goals).max() < 0.05
    assert result.proposed == 2000 and 0 < result.accepted < result.proposed
    # and clustering beats a random assignment with the same shares
    local = lv.system_value(lay, lut, types=lt.DEFAULT_TYPES).local_value
    shuffled = lv.system_value(lay, rng.permutation(lut), types=lt.DEFAULT_TYPES).local_value
    assert local > shuffled + 0.1


def test_update_follows_other_goals_too():
    rng = np.random.default_rng(2)
    xy, area = grid_lots(800, rng)
    lay = layout_of(xy, area)
    goals = [0.6, 0.1, 0.1, 0.05, 0.15]
    types = tuple(LandUseType(t.name, g, t.terms) for t, g in zip(lt.DEFAULT_TYPES, goals))
    lut = rng.integers(0, 5, 800)
    for _ in range(3):
        lut = lu.update_land_use(lay, lut, types=types, rng=rng, sample_share=1.0).lut
    np.testing.assert_allclose(lv.area_shares(area, lut, 5), goals, atol=0.05)


def test_update_is_deterministic_and_leaves_the_input_and_unassigned_lots_alone():
    rng = np.random.default_rng(0)
    xy, area = grid_lots(400, rng)
    lay = layout_of(xy, area)
    lut = rng.integers(-1, 5, 400)
    frozen = lut.copy()
    a = lu.update_land_use(lay, lut, types=lt.DEFAULT_TYPES, rng=np.random.default_rng(9))
    b = lu.update_land_use(lay, lut, types=lt.DEFAULT_TYPES, rng=np.random.default_rng(9))
    np.testing.assert_array_equal(a.lut, b.lut)
    np.testing.assert_array_equal(lut, frozen)
    assert (a.lut[lut < 0] == lt.UNASSIGNED).all()
    assert a.proposed == (lut >= 0).sum()
    assert lu.update_land_use(lay, lut, types=lt.DEFAULT_TYPES, rng=rng, sample_share=0.0).accepted == 0
    with pytest.raises(InputError, match="sample_share"):
        lu.update_land_use(lay, lut, types=lt.DEFAULT_TYPES, rng=rng, sample_share=-1)


def test_assign_types_fills_new_lots_towards_the_goals():
    rng = np.random.default_rng(4)
    xy, area = grid_lots(1000, rng)
    lay = layout_of(xy, area, traffic=rng.gamma(1, 100, 1000))
    lut = lu.assign_types(lay, np.full(1000, lt.UNASSIGNED), types=lt.DEFAULT_TYPES, rng=rng)
    assert (lut >= 0).all()
    np.testing.assert_allclose(lv.area_shares(area, lut, 5), lt.goal_shares(lt.DEFAULT_TYPES), atol=0.05)


def test_choose_types_gives_a_new_block_the_type_around_it():
    rng = np.random.default_rng(1)
    xy, _ = grid_lots(400, rng)
    lay = layout_of(xy)
    lut = np.where(xy[:, 0] < 285, 0, 1)  # type a west, b east, equal areas: shares at the goals
    types = (LandUseType("a", 0.5, (ValuationTerm(1.0, "linear_up", "cluster", 0.0, 1.0),)),
             LandUseType("b", 0.5, (ValuationTerm(1.0, "linear_up", "cluster", 0.0, 1.0),)))
    units = np.array([[60.0, 300.0], [540.0, 300.0]])
    attrs = lv.lot_attributes(units, centres=xy.mean(0, keepdims=True))
    np.testing.assert_array_equal(lu.choose_types(lay, lut, units, [1.0, 1.0], attrs, types=types), [0, 1])
    # many large new blocks share out by the goals instead of all taking the short type
    many = np.tile(units, (10, 1))
    chosen = lu.choose_types(lay, lut, many, np.full(20, 5e3), lv.lot_attributes(many, centres=[[0, 0]]),
                             types=types)
    assert 8 <= (chosen == 0).sum() <= 12


def test_block_type_is_the_type_with_most_lot_area():
    block = np.array([0, 0, 0, 1, 1, 2])
    area = np.array([100.0, 60.0, 60.0, 50.0, 50.0, 10.0])
    lut = np.array([2, 1, 1, 3, 0, lt.UNASSIGNED])
    np.testing.assert_array_equal(lu.block_types(block, area, lut, 4, 4), [1, 0, -1, -1])


def test_bad_options_name_their_key():
    with pytest.raises(InputError, match=r"LandUseOptions\.goal_scale must be positive"):
        LandUseOptions(goal_scale=0)
    with pytest.raises(InputError, match="traffic_quantile"):
        LandUseOptions(traffic_quantile=1.5)


def test_update_interval_makes_a_planned_city():
    opts = LandUseOptions(update_interval=10)
    assert [lu.runs_this_year(y, 2000, options=opts) for y in (2000, 2005, 2010)] == [True, False, True]
    with pytest.raises(InputError, match="update_interval"):
        lu.runs_this_year(2000, 2000, options=LandUseOptions(update_interval=0))


# --------------------------------------------------------------------------- calibration

def square(x0, y0, side):
    return shapely.box(x0, y0, x0 + side, y0 + side)


def test_calibration_takes_shares_from_the_towns_own_tags_with_nested_polygons():
    polygons = [(square(0, 0, 100), "residential"), (square(10, 10, 20), "park"),
                (square(200, 0, 50), "industrial"), (square(300, 0, 50), "retail"),
                (square(400, 0, 100), "forest"), (square(500, 0, 10), "farmland")]
    mapped = 10_000 + 2_500 + 2_500
    cal = lo.calibrate_landuse(polygons, town_area=mapped / 0.9)
    names = [t.name for t in lt.DEFAULT_TYPES]
    expect = {"residential_low": 9_600, "park": 400, "industrial": 2_500, "commercial": 2_500}
    for name, a in expect.items():
        assert cal.shares[names.index(name)] == pytest.approx(a / mapped)
    assert cal.coverage == pytest.approx(0.9) and cal.weight == 1.0
    np.testing.assert_allclose(cal.goals, cal.shares)
    assert dict(cal.ignored) == {"forest": 1, "farmland": 1}
    assert [t.goal for t in cal.with_goals(lt.DEFAULT_TYPES)] == pytest.approx(cal.goals.tolist())


def test_calibration_splits_dense_housing_and_blends_thin_coverage_with_the_defaults():
    houses = [square(5 + 20 * i, 5, 15) for i in range(5)]  # 5 × 225 m² on 1 ha: sparse
    blocks = [shapely.box(200, 0, 300, 25), shapely.box(200, 50, 300, 75)]  # half of the second hectare
    polygons = [(square(0, 0, 100), "residential"), (square(200, 0, 100), "residential")]
    cal = lo.calibrate_landuse(polygons, town_area=20_000.0, buildings=houses + blocks)
    names = [t.name for t in lt.DEFAULT_TYPES]
    assert cal.shares[names.index("residential_low")] == pytest.approx(0.5)
    assert cal.shares[names.index("residential_high")] == pytest.approx(0.5)
    thin = lo.calibrate_landuse(polygons, town_area=100_000.0)  # 20 % coverage → weight 0.25
    assert thin.weight == pytest.approx(0.25)
    np.testing.assert_allclose(thin.goals, 0.25 * thin.shares + 0.75 * lt.goal_shares(lt.DEFAULT_TYPES))
    # coverage by buildings: two houses in mapped land, two outside → half
    outside = [square(1000 + 20 * i, 0, 15) for i in range(2)]
    by_houses = lo.calibrate_landuse(polygons, town_area=1.0, buildings=houses[:2] + outside)
    assert by_houses.coverage == pytest.approx(0.5) and by_houses.weight == pytest.approx(0.5 / 0.8)
    none = lo.calibrate_landuse([(square(0, 0, 10), "forest")], town_area=1e6)
    np.testing.assert_allclose(none.goals, lt.goal_shares(lt.DEFAULT_TYPES))


def test_calibration_clips_land_use_to_the_town_outline():
    polygons = [(square(0, 0, 100), "residential"), (square(100, 0, 900), "industrial")]
    cal = lo.calibrate_landuse(polygons, square(0, 0, 200))  # the industrial valley is mostly outside
    names = [t.name for t in lt.DEFAULT_TYPES]
    assert cal.shares[names.index("residential_low")] == pytest.approx(10_000 / 30_000)  # not 10k / 820k
    assert cal.coverage == pytest.approx(30_000 / 40_000)


def test_types_from_polygons_reads_the_type_under_each_lot():
    polygons = [(square(0, 0, 100), "residential"), (square(10, 10, 20), "park")]
    lut = lo.types_from_polygons([[50, 50], [15, 15], [500, 500]], polygons)
    names = [t.name for t in lt.DEFAULT_TYPES]
    assert lut.tolist() == [names.index("residential_low"), names.index("park"), lt.UNASSIGNED]


# --------------------------------------------------------------------------- similarity

def blocky(rng, cells=20, size=10, k=5):
    return np.kron(rng.integers(0, k, (cells, cells)), np.ones((size, size), dtype=int))


def test_similarity_is_one_for_identical_images_and_lower_for_shuffled_ones():
    rng = np.random.default_rng(0)
    image = blocky(rng)
    shuffled = rng.permutation(image.ravel()).reshape(image.shape)
    assert ls.similarity(image, image, 8, samples=300) == 1.0
    s = ls.similarity(image, shuffled, 8, samples=300)
    assert s < 0.6
    # a shifted copy still finds every neighbourhood
    assert ls.similarity(image[5:, 5:], image, 8, samples=300) == 1.0
    # with all windows sampled the best match of a single-valued patch is exact
    flat = np.zeros((10, 10), dtype=int)
    half = np.zeros((10, 10), dtype=int)
    half[:, 5:] = 1
    assert ls.similarity(flat, half, 4) == 1.0
    assert ls.similarity(flat, np.ones((10, 10), dtype=int), 4) == 0.0


def test_similarity_skips_nodata_centres_and_checks_n():
    image = np.full((20, 20), -1)
    image[5:15, 5:15] = 2
    reference = np.full((20, 20), 2)
    assert ls.similarity(image, reference, 3) < 1.0  # windows at the rim hold -1, which Y lacks
    assert ls.similarity(image, reference, 3, nodata=-1) == 1.0
    reference[:, 10:] = 1
    assert ls.similarity(image, reference, 3, nodata=-1) == 1.0  # every tagged patch is all 2 somewhere
    with pytest.raises(InputError, match="n must lie"):
        ls.similarity(image, image, 0)


def test_rasterised_polygons_and_lots_agree_where_lots_sit_in_polygons():
    polygons = [(square(0, 0, 100), "industrial"), (square(100, 0, 100), "retail")]
    real = ls.rasterise_polygons(polygons, bounds=(0, 0, 200, 100), cell=10)
    names = [t.name for t in lt.DEFAULT_TYPES]
    xy = np.array([[50.0, 50.0], [150.0, 50.0]])
    lots = ls.rasterise_lots(xy, lo.types_from_polygons(xy, polygons), bounds=(0, 0, 200, 100), cell=10,
                             max_distance=200)
    assert real.shape == (10, 20)
    assert (real[:, :10] == names.index("industrial")).all() and (real[:, 10:] == names.index("commercial")).all()
    np.testing.assert_array_equal(real, lots)
    assert ls.similarity(lots, real, 4) == 1.0


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(4, 14), st.integers(4, 14), st.integers(1, 4), st.integers(1, 5),
       st.booleans())
def test_similarity_is_the_best_match_over_every_window_of_the_reference(seed, h, w, n, k, nodata):
    """The best match of each sampled window, counted over every window of Y (repeats included) by brute
    force, averaged: the matrix product over Y's distinct windows gives the same number."""
    rng = np.random.default_rng(seed)
    n = min(n, h, w)
    x = np.kron(rng.integers(-1 if nodata else 0, k, (h // 2 + 1, w // 2 + 1)), np.ones((2, 2), dtype=int))[:h, :w]
    y = np.kron(rng.integers(0, k, (h // 2 + 1, w // 2 + 1)), np.ones((2, 2), dtype=int))[:h, :w]
    if nodata and (x == -1).all():
        x[0, 0] = 0
    xw = np.lib.stride_tricks.sliding_window_view(x, (n, n)).reshape(-1, n * n)
    yw = np.lib.stride_tricks.sliding_window_view(y, (n, n)).reshape(-1, n * n)
    centre = np.lib.stride_tricks.sliding_window_view(x, (n, n))[:, :, n // 2, n // 2].ravel()
    rows = np.flatnonzero(centre != -1) if nodata else np.arange(len(xw))
    if not len(rows):
        return
    counted = xw[rows] != -1 if nodata else np.ones((len(rows), n * n), dtype=bool)
    same = ((xw[rows][:, None, :] == yw[None, :, :]) & counted[:, None, :]).sum(axis=2)
    expected = float((same.max(axis=1) / counted.sum(axis=1)).mean())
    got = ls.similarity(x, y, n, samples=10_000, nodata=-1 if nodata else None)
    assert got == pytest.approx(expected, rel=1e-12)


# --------------------------------------------------------------------------- the layout made from last year's

def _same_layout(a: lv.LotLayout, b: lv.LotLayout) -> None:
    """Every array of the two layouts the same, to the bit (the CSR structures too)."""
    for name in ("xy", "area", "attributes", "knn", "weight_sums", "reverse_knn_indptr", "reverse_knn_indices",
                 "kernel"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), name
    for name in ("weights", "weights_by_source"):
        x, y = getattr(a, name), getattr(b, name)
        for part in ("indptr", "indices", "data"):
            assert getattr(x, part).tobytes() == getattr(y, part).tobytes(), (name, part)


@pytest.mark.parametrize("order_kept", [True, False])
def test_relayout_equals_the_layout_made_afresh_on_krems_lots(order_kept, monkeypatch):
    """Krems' street nodes as lots; a year takes a few away (and moves one) and adds a few: the layout made
    from last year's measures only the rows that changed and is the one made afresh, bit for bit; one whose
    lots did not keep their order is made afresh."""
    from tests.conftest import loaded
    net = loaded("krems.osm.gz")
    rng = np.random.default_rng(3)
    xy = net.xy[net.used_nodes()][:3000]
    ids = np.arange(len(xy))
    area = rng.uniform(200, 1500, len(xy))
    last = lv.lot_layout(xy, area, lv.lot_attributes(xy, centres=xy.mean(0, keepdims=True)))
    stay = np.ones(len(xy), dtype=bool)
    stay[rng.choice(len(xy), 5, replace=False)] = False
    new_xy = xy[rng.choice(len(xy), 5)] + rng.normal(0, 20, (5, 2))
    now_ids = np.concatenate([ids[stay], len(xy) + np.arange(5)])
    now_xy = np.vstack([xy[stay], new_xy])
    now_area = np.concatenate([area[stay], rng.uniform(200, 1500, 5)])
    now_xy[7] += 0.5  # a lot that moved is a new one to the caller
    order = np.argsort(now_ids) if order_kept else rng.permutation(len(now_ids))
    now_ids, now_xy, now_area = now_ids[order], now_xy[order], now_area[order]
    old_row = np.where(now_ids < len(xy), now_ids, -1)
    old_row[(now_xy != np.vstack([xy, new_xy])[now_ids]).any(axis=1)] = -1
    attrs = lv.lot_attributes(now_xy, centres=xy.mean(0, keepdims=True))
    afresh = lv.lot_layout(now_xy, now_area, attrs)
    assert afresh.weights.nnz > 50 * len(now_xy)  # lots have neighbours to carry over
    made_afresh = []
    monkeypatch.setattr(lv, "lot_layout", lambda *a, **k: made_afresh.append(1) or afresh)
    _same_layout(lv.relayout(last, old_row, now_xy, now_area, attrs), afresh)
    assert len(made_afresh) == (0 if order_kept else 1)
