"""The economy (seed 002 §5.2–5.4) and the height shape (004 §4.3.4)."""
from __future__ import annotations

import numpy as np
import pytest

from osm_expand.engine.buildout import economy as ec
from osm_expand.engine.buildout.economy import EconomyOptions, HeightCalibration, HeightScale, TypeEconomy
from osm_expand.errors import InputError

#: Deterministic economics: no margin spread.
FIXED = (TypeEconomy("house", 0.005, 0.0, floor_per_resident=50.0, max_floors=4),
         TypeEconomy("shop", 0.01, 0.0, floor_per_job=25.0, max_floors=10),
         TypeEconomy("park", 0.0, 0.0, visitors_per_area=0.002, max_floors=0))
ECONOMY_ONLY = EconomyOptions(shape="economy")


def test_price_floor_space_and_floors_worked_by_hand():
    area = np.array([400.0, 800.0])
    luv = np.array([0.25, 0.75])  # mean 0.5 → value ratios 0.5 and 1.5
    price = ec.lot_prices(area, luv, avgprice=100.0)
    np.testing.assert_allclose(price, [400 * 100 * 0.5, 800 * 100 * 1.5])  # Eq. 9
    margin = ec.sample_margins(np.array([0, 0]), economies=FIXED, rng=np.random.default_rng(0))
    np.testing.assert_allclose(margin, [0.005, 0.005])
    floor_space = price * margin  # Eq. 10
    np.testing.assert_allclose(floor_space, [100.0, 600.0])
    np.testing.assert_allclose(ec.floors_from_floor_space(floor_space, [100.0, 200.0]), [1.0, 3.0])  # Eq. 11
    assert ec.floors_from_floor_space(np.array([50.0]), np.array([0.0]))[0] == 0.0
    # all values zero: every lot is worth the average price
    np.testing.assert_allclose(ec.lot_prices(area, [0.0, 0.0], 10.0), area * 10)


def test_expected_floor_space_is_the_price_times_the_mean_margin():
    area, luv = np.array([400.0, 800.0, 1000.0]), np.array([0.25, 0.75, 0.5])
    got = ec.expected_floor_space(area, luv, np.array([0, 1, 2]), 100.0, economies=FIXED)
    np.testing.assert_allclose(got, [400 * 100 * 0.5 * 0.005, 800 * 100 * 1.5 * 0.01, 0.0])  # parks: none


def test_lot_economy_end_to_end_by_hand():
    cal = HeightCalibration(3.0, 6.0, (3.0, 9.0), 0, 0, False)
    result = ec.lot_economy(np.array([400.0, 800.0, 1000.0]), np.array([100.0, 200.0, 0.0]),
                            np.array([0.25, 0.75, 0.5]), np.array([0, 0, 2]), np.zeros(3), avgprice=100.0,
                            calibration=cal, scale=HeightScale(1.0), economies=FIXED,
                            rng=np.random.default_rng(0), options=ECONOMY_ONLY)
    mean = 0.5
    np.testing.assert_allclose(result.price, [400 * 100 * 0.25 / mean, 800 * 100 * 0.75 / mean, 1000 * 100])
    np.testing.assert_allclose(result.floor_space, [100.0, 600.0, 0.0])
    np.testing.assert_array_equal(result.floors, [1, 3, 0])
    np.testing.assert_allclose(result.height, [3.0, 9.0, 0.0])
    np.testing.assert_allclose(result.occupants.residents, [100 / 50, 600 / 50, 0])
    np.testing.assert_allclose(result.occupants.visitors, [0, 0, 1000 * 0.002])
    np.testing.assert_allclose(result.occupants.people, [2, 12, 2])


def test_margins_are_truncated_gaussians_per_type_and_deterministic():
    lut = np.repeat([0, 1, 3, 4, -1], 4000)
    a = ec.sample_margins(lut, rng=np.random.default_rng(1))
    b = ec.sample_margins(lut, rng=np.random.default_rng(1))
    np.testing.assert_array_equal(a, b)
    for t, econ in enumerate(ec.DEFAULT_ECONOMY[:2]):
        m = a[lut == t]
        assert m.min() >= econ.margin_mean - 2 * econ.margin_sd
        assert m.max() <= econ.margin_mean + 2 * econ.margin_sd
        assert m.mean() == pytest.approx(econ.margin_mean, rel=0.02)
        assert m.std() == pytest.approx(econ.margin_sd * 0.88, rel=0.1)  # sd of N truncated at ±2σ
    assert (a[lut == 4] == 0).all() and (a[lut == -1] == 0).all()  # parks and unassigned build nothing
    wide = (TypeEconomy("x", 1.0, 2.0),)
    assert ec.sample_margins(np.zeros(1000, int), economies=wide, rng=np.random.default_rng(0)).min() >= 0


def test_centre_falloff_is_004s_gaussian_from_one_to_the_edge_factor():
    opts = EconomyOptions(falloff_sigma=0.25, falloff_edge=0.5)
    s = ec.centre_falloff(np.array([0.0, 0.25, 1.0, 5.0]), options=opts)
    np.testing.assert_allclose(s, [1.0, 0.5 + 0.5 * np.exp(-0.5), 0.5 + 0.5 * np.exp(-8), 0.5])


def test_raw_floors_double_more_often_near_the_centre_and_shapes_select_the_model():
    n = 20000
    econ = np.full(n, 2.0)
    opts = EconomyOptions(noise_sd=0.0, double_chance=0.5, falloff_edge=1.0)
    near = ec.raw_floors(econ, np.zeros(n), rng=np.random.default_rng(0), options=opts)
    far = ec.raw_floors(econ, np.full(n, 1.0), rng=np.random.default_rng(0), options=opts)
    assert set(np.unique(near)) == {2.0, 4.0}
    assert (near == 4).mean() == pytest.approx(0.5, abs=0.02)
    assert (far == 4).mean() < 0.01
    econ = np.array([0.0, 1.0, 3.0])
    only = ec.raw_floors(econ, np.zeros(3), rng=np.random.default_rng(0), options=ECONOMY_ONLY)
    np.testing.assert_array_equal(only, econ)
    shape = ec.raw_floors(econ, np.zeros(3), rng=np.random.default_rng(0),
                          options=EconomyOptions(shape="falloff", noise_sd=0.0, double_chance=0.0))
    np.testing.assert_array_equal(shape, [0.0, 1.0, 1.0])  # 004 alone: only where something is built
    with pytest.raises(InputError, match="economy_falloff, economy, falloff"):
        EconomyOptions(shape="tall")
    with pytest.raises(InputError, match="double_chance"):
        EconomyOptions(double_chance=1.5)


def test_calibrate_heights_from_tags():
    heights = np.array([6.0, 9.0, 12.0, 6.5, 9.5, np.nan, np.nan, 20.0, 7.0, 8.0, 10.0, np.nan])
    levels = np.array([2, 3, 4, 2, 3, 5, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan])
    cal = ec.calibrate_heights(heights, levels)
    pairs = heights[:5] / levels[:5]
    assert cal.storey_height == pytest.approx(np.median(pairs))
    assert cal.n_storey_pairs == 5 and cal.n_tagged == 10 and cal.from_tags
    tagged = np.concatenate([heights[np.isfinite(heights)], [5 * cal.storey_height]])
    assert cal.median == pytest.approx(np.median(tagged))
    assert cal.quartiles == pytest.approx(tuple(np.quantile(tagged, [0.25, 0.75])))


def test_calibrate_heights_falls_back_to_defaults_without_tags():
    cal = ec.calibrate_heights(np.full(1195, np.nan), np.full(1195, np.nan))  # Krems: no height tags
    assert not cal.from_tags and cal.storey_height == 3.0 and cal.median == 9.0
    odd = ec.calibrate_heights(np.full(10, 40.0), np.full(10, 2.0))  # 20 m storeys: a tagging error
    assert odd.storey_height == 5.0
    with pytest.raises(InputError, match="differ in shape"):
        ec.calibrate_heights(np.zeros(3), np.zeros(2))


def test_fitted_scale_puts_the_generated_median_on_the_tagged_one():
    rng = np.random.default_rng(3)
    tagged = rng.lognormal(np.log(10.0), 0.4, 500)  # a town of 10 m median
    cal = ec.calibrate_heights(tagged, np.full(500, np.nan))
    n = 5000
    econ = rng.lognormal(0.0, 0.5, n) * 2.0
    raw = ec.raw_floors(econ, rng.uniform(0, 1, n), rng=rng)
    scale = ec.fit_height_scale(raw, cal)
    floors = ec.building_floors(raw, np.ones(n, int), scale)
    heights = floors * cal.storey_height
    assert abs(np.median(heights) / cal.median - 1) < 0.25
    q = np.quantile(heights, [0.25, 0.75])
    assert q[1] / q[0] == pytest.approx(cal.quartiles[1] / cal.quartiles[0], rel=0.35)
    # without tags: the default median and quartiles (2, 3, 4 floors)
    default = ec.calibrate_heights(np.full(3, np.nan), np.full(3, np.nan))
    s = ec.fit_height_scale(raw, default)
    assert s.a * np.median(raw[raw > 0]) ** s.b == pytest.approx(3.0)
    q = np.quantile(ec.building_floors(raw, np.ones(n, int), s), [0.25, 0.5, 0.75])
    np.testing.assert_allclose(q, [2, 3, 4], atol=0.5)
    assert ec.fit_height_scale(raw, default, options=EconomyOptions(match_spread=False)).b == 1.0


def test_the_scale_is_fitted_on_the_standing_buildings_and_the_new_ones_together():
    cal = HeightCalibration(3.0, 9.0, (6.0, 12.0), 0, 0, False)
    args = (np.array([400.0, 800.0, 600.0]), np.array([100.0, 200.0, 150.0]), np.array([0.25, 0.75, 0.5]),
            np.array([0, 0, 0]), np.zeros(3))
    kw = dict(avgprice=100.0, calibration=cal, economies=FIXED, options=ECONOMY_ONLY)
    alone = ec.lot_economy(*args, rng=np.random.default_rng(0), **kw)
    assert alone.raw is not None and alone.scale == ec.fit_height_scale(alone.raw, cal, options=ECONOMY_ONLY)
    assert np.median(alone.floors) == 3  # fitted on themselves, they take the target median
    standing = np.full(50, 10.0 * alone.raw.max())  # a district of much dearer buildings already stands
    joint = ec.lot_economy(*args, reference_raw=standing, rng=np.random.default_rng(0), **kw)
    np.testing.assert_array_equal(joint.raw, alone.raw)
    assert joint.scale == ec.fit_height_scale(np.concatenate([alone.raw, standing]), cal, options=ECONOMY_ONLY)
    assert (joint.floors <= alone.floors).all() and joint.floors.sum() < alone.floors.sum()  # lower beside them


def test_building_floors_are_whole_at_least_one_and_capped_per_type():
    raw = np.array([0.0, 0.2, 2.4, 2.6, 50.0, 50.0, 5.0])
    lut = np.array([0, 0, 0, 0, 0, 1, 2])
    floors = ec.building_floors(raw, lut, HeightScale(1.0), economies=FIXED)
    np.testing.assert_array_equal(floors, [0, 1, 2, 3, 4, 10, 0])


def test_occupants_from_floor_space_by_type():
    occ = ec.occupants(np.array([500.0, 500.0, 0.0]), np.array([1000.0, 1000.0, 5000.0]), np.array([0, 1, 2]),
                       economies=FIXED)
    np.testing.assert_allclose(occ.residents, [10.0, 0.0, 0.0])
    np.testing.assert_allclose(occ.jobs, [0.0, 20.0, 0.0])
    np.testing.assert_allclose(occ.visitors, [0.0, 0.0, 10.0])


def test_substitution_probability_adds_age_and_price_terms():
    opts = EconomyOptions(age_bounds=(40.0, 120.0), age_weight=0.02, price_bounds=(0.25, 0.75), price_weight=0.05)
    new = np.array([1000.0, 1000.0, 1000.0, 1000.0, 1000.0, 0.0])
    existing = np.array([1000.0, 500.0, 250.0, 1500.0, 1000.0, 300.0])
    age = np.array([80.0, 10.0, 10.0, 200.0, np.nan, 10.0])
    p = ec.substitution_probability(age, new, existing, options=opts)
    expected = [0.02 * 0.5 + 0.0,  # half-way through the age ramp; as big as a new building would be
                0.0 + 0.05 * 0.5,  # Δprice = 1 - 500/1000 = 0.5
                0.0 + 0.05 * 1.0,  # Δprice = 0.75
                0.02,  # older than 120 years; bigger than a new one (Δprice < 0)
                0.0,  # unknown age
                0.05]  # the lot became a park: Δprice = 1
    np.testing.assert_allclose(p, expected)


def test_a_new_building_is_not_replaced_for_price_whatever_the_height_scale():
    rng = np.random.default_rng(0)
    n = 500
    args = (rng.uniform(400, 1200, n), rng.uniform(100, 300, n), rng.uniform(0.2, 0.9, n),
            rng.integers(0, 4, n), rng.uniform(0, 1, n))
    cal = ec.calibrate_heights(np.full(1, np.nan), np.full(1, np.nan))
    for scale in (HeightScale(0.3), HeightScale(3.0)):
        now = ec.lot_economy(*args, avgprice=100.0, calibration=cal, scale=scale, economies=FIXED[:2] * 2,
                             rng=np.random.default_rng(1), options=EconomyOptions(noise_sd=0, double_chance=0))
        built = now.floors * args[1]
        p = ec.substitution_probability(np.zeros(n), built, built)
        assert (p == 0).all()


def test_substitute_samples_replacements_deterministically_and_dates_them():
    n = 20000
    year_built = np.full(n, 1900.0)
    fs = np.full(n, 500.0)
    fs[:10] = 0.0  # empty lots are never "replaced"
    opts = EconomyOptions(age_weight=0.3, price_weight=0.0)
    a = ec.substitute(year_built, np.full(n, 500.0), fs, year=2020, rng=np.random.default_rng(8), options=opts)
    b = ec.substitute(year_built, np.full(n, 500.0), fs, year=2020, rng=np.random.default_rng(8), options=opts)
    np.testing.assert_array_equal(a.replaced, b.replaced)
    assert not a.replaced[:10].any()
    assert a.replaced.mean() == pytest.approx(0.3, abs=0.015)
    assert (a.year_built[a.replaced] == 2020).all() and (a.year_built[~a.replaced] == 1900).all()
