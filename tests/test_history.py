"""Histories (003 §3.1, 000 §4.2.9, 002 §4): time functions, eras, the bundled files, and bad files."""
from __future__ import annotations

import json
import math
import re
import textwrap
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from osm_expand.engine.buildout.economy import DEFAULT_ECONOMY
from osm_expand.engine.buildout.landuse import runs_this_year
from osm_expand.engine.buildout.landuse_types import DEFAULT_TYPES, LandUseOptions
from osm_expand.engine.buildout.lots import DEFAULT_LOT_OPTIONS, LandUse, LotOptions
from osm_expand.engine.history import (
    DEFAULT_HISTORY,
    GROWTH_PATTERNS,
    Anchor,
    Clock,
    History,
    KernelOptions,
    bundled,
    history_from_mapping,
    load_history,
)
from osm_expand.engine.history.timefn import Interpolation, TimeFunction
from osm_expand.engine.roads.path_graph import EdgeCosts
from osm_expand.engine.roads.road_types import RoadType
from osm_expand.engine.roads.routing import RoutingOptions
from osm_expand.errors import InputError
from synth.colonisation import ColonisationOptions
from synth.patches import PatchOptions
from synth.patterns import GRID_NORTH_AMERICAN, MEDIEVAL, PATTERNS, PatternOptions
from synth.walk import WalkOptions

# --------------------------------------------------------------------------------------- time functions


def test_linear_interpolates_between_points_and_is_constant_outside():
    f = TimeFunction((2000.0, 2010.0, 2030.0), (0.0, 10.0, 0.0))
    assert f(2005) == 5.0
    assert f(2020) == 5.0
    assert f(1900) == 0.0 and f(2999) == 0.0  # first value before, last value after
    out = f(np.array([[1999, 2000], [2010, 2025]]))
    assert out.shape == (2, 2)
    np.testing.assert_allclose(out, [[0.0, 0.0], [10.0, 2.5]])


def test_step_holds_the_last_value_until_the_next_point():
    f = TimeFunction((0.0, 15.0, 30.0), (1.0, 2.0, 3.0), Interpolation.STEP)
    np.testing.assert_array_equal(f([-5, 0, 14, 14.999, 15, 29, 30, 100]), [1, 1, 1, 1, 2, 2, 3, 3])
    assert isinstance(f(15), float)


def test_constant_is_the_same_every_year():
    f = TimeFunction.from_toml(0.25, "growth")
    assert f(-1e6) == f(0) == f(1e6) == 0.25
    assert f.low == f.high == 0.25


def test_from_toml_reads_pairs_and_tables():
    assert TimeFunction.from_toml([[0, 1], [10, 3]], "k")(5) == 2.0
    step = TimeFunction.from_toml({"points": [[0, 1], [10, 3]], "interpolation": "step"}, "k")
    assert step(5) == 1.0 and step.interpolation is Interpolation.STEP
    assert TimeFunction.from_toml({"points": [[0, 1], [10, 3]]}, "k").interpolation is Interpolation.LINEAR
    for f in (step, TimeFunction.from_toml(7, "k"), TimeFunction.from_toml([[0, 1], [10, 3]], "k")):
        assert TimeFunction.from_toml(f.to_toml(), "k") == f


@pytest.mark.parametrize("value, message", [
    ([[10, 1], [5, 2]], r"^roads\.width\[1\]: years must increase"),
    ([[10, 1], [10, 2]], r"^roads\.width\[1\]: years must increase"),
    ([[10, 1, 3]], r"^roads\.width\[0\]: expected a \[year, value\] pair"),
    ([], r"^roads\.width: expected a non-empty list"),
    ("wide", r"^roads\.width: expected a number, a list"),
    (True, r"^roads\.width: expected a number"),
    ([[0, "x"]], r"^roads\.width\[0\]: expected a number"),
    ({"points": [[0, 1]], "interpolation": "cubic"}, r"^roads\.width\.interpolation: 'cubic' is not one of"),
    ({"points": [[0, 1]], "kind": "step"}, r"^roads\.width\.kind: unknown key"),
    ({"interpolation": "step"}, r"^roads\.width\.points: missing"),
])
def test_bad_time_functions_name_the_key(value, message):
    with pytest.raises(InputError, match=message):
        TimeFunction.from_toml(value, "roads.width")


# --------------------------------------------------------------------------------------- bundled histories


def test_the_bundled_histories_are_listed_and_example_is_the_default():
    assert {"example", "european", "north-american"} <= set(bundled())
    assert DEFAULT_HISTORY == "example"
    assert load_history().name == "example"


@pytest.mark.parametrize("name", ["example", "european", "north-american"])
def test_every_bundled_history_yields_kernel_objects_for_every_era_and_year(name):
    h = load_history(name)
    assert h.source == f"bundled:{name}"
    assert [e.start for e in h.eras] == sorted({e.start for e in h.eras})
    expected = {"example": PatchOptions, "walk": WalkOptions, "colonisation": ColonisationOptions}
    for era in h.eras:
        opts = h.pattern_options(era)
        assert isinstance(opts, expected.get(era.pattern, PatternOptions))
        assert math.isclose(sum(era.road_type_shares().values()), 1.0)
    # a default run from a 2016 map passes several eras, and every year has valid kernel values
    clock = h.clock(2016)
    seen = []
    for step in range(h.years):
        now = h.values_at(clock.history_year(step), traffic_factor=1.0)
        assert isinstance(now.costs, EdgeCosts) and isinstance(now.routing, RoutingOptions)
        assert now.growth >= 0 and now.road_width > 0 and now.avgprice > 0 and now.traffic_increase >= 0
        seen.append(now.era.name)
    assert len(set(seen)) >= 3, seen
    assert len(h.land_use_types) == len(h.economies) >= 5
    assert [t.name for t in h.land_use_types] == [e.name for e in h.economies]
    assert set(h.lot_options) == set(LandUse) == set(h.footprint_options)
    assert isinstance(h.options, KernelOptions)
    assert h.options.lattice.slope_weight == h.o1 and h.options.trade.o2 == h.o2
    assert json.loads(json.dumps(h.summary()))["eras"][0]["name"] == h.eras[0].name
    b = [h.traffic_factor(np.random.default_rng(s)) for s in range(50)]
    assert 0.7 <= min(b) and max(b) <= 1.3 and b[3] == h.traffic_factor(np.random.default_rng(3))


def test_example_writes_out_the_kernels_bundled_land_use_types():
    h = load_history("example")
    assert h.land_use_types == DEFAULT_TYPES
    assert h.economies == DEFAULT_ECONOMY
    assert h.lot_options == DEFAULT_LOT_OPTIONS
    assert h.anchor is Anchor.MAP
    assert all(e.pattern == "example" for e in h.eras)


def test_european_and_north_american_set_their_own_eras_and_rules():
    eu = load_history("european")
    assert [e.pattern for e in eu.eras] == ["medieval", "grid_19th_century", "suburban", "suburban"]
    assert eu.eras[0].options == MEDIEVAL
    assert dict(eu.eras[0].road_types) == {RoadType.CITY: 1.0}  # 000 §4.2.9: no bypasses in a medieval era
    assert eu.eras[-1].road_type_shares()[RoadType.BYPASS] > 0.5
    assert [eu.values_at(y).land_use_update for y in (15, 16, 25)] == [True, False, True]
    na = load_history("north-american")
    grid = [e for e in na.eras if e.name == "grid"]
    assert len(grid) == 2 and grid[0].options == grid[1].options == GRID_NORTH_AMERICAN  # the grid era recurs
    suburban = na.pattern_options("interstate")
    assert suburban.length_mean_m == 90.0 and suburban.max_degree == PATTERNS["suburban"].max_degree
    assert na.lot_options[LandUse.RESIDENTIAL_LOW].max_area == 1200.0
    assert na.lot_options[LandUse.INDUSTRIAL] == DEFAULT_LOT_OPTIONS[LandUse.INDUSTRIAL]
    assert na.footprint_options[LandUse.RESIDENTIAL_LOW].front_setback == (6.0, 9.0)


# --------------------------------------------------------------------------------------- eras and years

MINIMAL = """
start = 1200
[[eras]]
name = "medieval"
start = 1200
pattern = "medieval"
road_types = { city = 1 }
"""

RECURRING = """
name = "cycle"
start = 1000
growth = { points = [[1000, 0.01], [1100, 0.02]], interpolation = "step" }
traffic = [[1000, 0], [1010, 100]]

[[eras]]
name = "organic"
start = 1000
pattern = "organic"
road_types = { city = 3, smooth_city = 1 }
[eras.pattern_options]
length_mean_m = 50

[[eras]]
name = "grid"
start = 1050
pattern = "grid"
road_types = { bypass = 1 }
land_use_interval = 5

[[eras]]
name = "organic"
start = 1100
"""


def history(tmp_path: Path, text: str, name: str = "h.toml") -> History:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    return load_history(path)


def test_era_lookup_with_a_recurring_era(tmp_path):
    h = history(tmp_path, RECURRING)
    assert [(e.name, e.start, e.end) for e in h.eras] == [("organic", 1000, 1050), ("grid", 1050, 1100),
                                                           ("organic", 1100, None)]
    assert [h.era_at(y).start for y in (1000, 1049, 1050, 1099, 1100, 5000)] == [1000, 1000, 1050, 1050, 1100, 1100]
    assert h.era_at(1100).options == h.era_at(1000).options
    assert h.era_at(1100).options.length_mean_m == 50.0
    assert h.pattern_options("organic") is h.eras[0].options
    with pytest.raises(InputError, match=r"year 999 is before its first era \(1000\)"):
        h.era_at(999)
    with pytest.raises(InputError, match="no era 'gird'"):
        h.pattern_options("gird")


def test_values_at_gives_this_years_numbers(tmp_path):
    h = history(tmp_path, RECURRING)
    v = h.values_at(1005, traffic_factor=1.2)
    assert v.growth == 0.01 and v.era.name == "organic"
    assert v.traffic == pytest.approx(1.2 * 50) and v.traffic_increase == pytest.approx(1.2 * 10)
    assert h.values_at(1100).growth == 0.02
    assert h.values_at(1020).traffic_increase == 0.0  # constant after the last point
    # defaults come from the kernels: costs, turn penalty (degrees in the file, radians for the kernel), O1…O4
    assert v.costs == EdgeCosts()
    assert v.routing == RoutingOptions()
    assert (v.o1, v.o2, v.o3, v.o4) == (h.options.lattice.slope_weight, h.options.trade.o2, 1.0, 1.0)
    assert v.road_width == 11.0  # two lanes and sidewalks, the trip model's narrowest major road
    # land use: every year by default, every 5 years from the grid era's start in the grid era
    assert [h.values_at(y).land_use_update for y in (1001, 1050, 1051, 1055)] == [True, True, False, True]
    assert h.land_use_interval == 1


def test_new_streets_carries_the_fraction_to_next_year(tmp_path):
    v = history(tmp_path, RECURRING).values_at(1000)  # G = 1 %
    assert v.new_streets(150) == (1, pytest.approx(0.5))
    assert v.new_streets(150, 0.5) == (2, pytest.approx(0.0))
    total, carry = 0, 0.0
    for _ in range(10):
        n, carry = v.new_streets(230, carry)
        total += n
    assert total == 23  # 10 years × 2.3, nothing lost to rounding


def test_the_clock_maps_the_map_year_onto_the_history(tmp_path):
    cal = history(tmp_path, 'anchor = "map"\n' + MINIMAL)
    assert cal.anchor is Anchor.MAP
    assert cal.clock(2013) == Clock(first=2013, offset=0)
    assert cal.clock(None) == Clock(first=1200)
    assert cal.clock(1100) == Clock(first=1200)  # not before the history's start
    replay = history(tmp_path, 'anchor = "start"\n' + MINIMAL, "replay.toml")
    c = replay.clock(2013)
    assert (c.history_year(0), c.calendar_year(0), c.history_year(49), c.calendar_year(49)) == (1200, 2013, 1249, 2062)
    assert replay.clock(None).calendar_year(3) == 1203


def test_major_road_types_follow_the_eras_frequencies(tmp_path):
    h = history(tmp_path, RECURRING)
    rng = np.random.default_rng(7)
    draws = [h.major_road_type(rng, 1010) for _ in range(4000)]
    share = {t: draws.count(t) / len(draws) for t in RoadType}
    assert share[RoadType.CITY] == pytest.approx(0.75, abs=0.03)
    assert share[RoadType.SMOOTH_CITY] == pytest.approx(0.25, abs=0.03)
    assert share[RoadType.BYPASS] == share[RoadType.REBUILDING_CITY] == 0.0
    assert {h.major_road_type(rng, 1060) for _ in range(50)} == {RoadType.BYPASS}
    again = [h.major_road_type(np.random.default_rng(7), 1010) for _ in range(1)]
    assert again[0] == draws[0]  # the same generator state gives the same draw


def test_land_use_types_may_be_new_or_bundled_with_overrides(tmp_path):
    h = history(tmp_path, MINIMAL + textwrap.dedent("""
        [options.land_use]
        update_interval = 10

        [[land_use]]
        name = "park"
        goal = 0.7

        [[land_use]]
        name = "farm"
        goal = 0.3
        lot_size = "park"
        terms = [{ weight = 1.0, kind = "linear_up", attribute = "center_dist", low = 0.2, high = 0.6 }]
        economy = { visitors_per_area = 0.0001 }

        [lots.park]
        max_area = 50000.0
        """))
    park, farm = h.land_use_types
    assert park == replace(DEFAULT_TYPES[4], goal=0.7) and park.name == "park"
    assert farm.lot_size_key == "park" and farm.terms[0].attribute == "center_dist"
    assert h.economies[1].name == "farm" and h.economies[1].visitors_per_area == 0.0001
    assert h.economies[1].margin_mean == 0.0  # the rest from its lot class's economy (park)
    assert h.lot_options[LandUse.PARK] == LotOptions(**{**DEFAULT_LOT_OPTIONS[LandUse.PARK].__dict__,
                                                         "max_area": 50000.0})
    assert h.land_use_interval == 10
    assert runs_this_year(2010, 2000, options=h.options.land_use) and h.options.land_use == LandUseOptions(
        update_interval=10)


# --------------------------------------------------------------------------------------- bad files


def fails(tmp_path: Path, text: str, pattern: str, name: str = "bad.toml") -> str:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    with pytest.raises(InputError) as info:
        load_history(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: "), message
    assert re.search(pattern, message), message
    return message


def test_a_missing_key(tmp_path):
    fails(tmp_path, MINIMAL.replace("start = 1200\n[[eras]]", "[[eras]]"), r": start: missing$")
    fails(tmp_path, MINIMAL.replace('pattern = "medieval"\n', ""), r": eras\[0\]\.pattern: missing")
    fails(tmp_path, MINIMAL.replace("road_types = { city = 1 }\n", ""), r": eras\[0\]\.road_types: missing")
    fails(tmp_path, MINIMAL + '[[land_use]]\nname = "farm"\nlot_size = "park"\nterms = []\n',
          r": land_use\[0\]\.goal: missing")
    fails(tmp_path, MINIMAL + '[[land_use]]\nname = "park"\n[[land_use.terms]]\nweight = 1.0\nkind = "step"\n'
          'attribute = "traffic"\nlow = 0.0\n', r": land_use\[0\]\.terms\[0\]\.high: missing")


def test_an_unknown_key(tmp_path):
    fails(tmp_path, "grwoth = 0.01\n" + MINIMAL, r": grwoth: unknown key \(did you mean 'growth'\?\)")
    fails(tmp_path, MINIMAL + "[eras.pattern_options]\nlenght_mean_m = 40\n",
          r": eras\[0\]\.pattern_options\.lenght_mean_m: unknown key \(did you mean 'length_mean_m'\?\)")
    fails(tmp_path, MINIMAL.replace("city = 1", "city = 1, highway = 2"), r": eras\[0\]\.road_types\.highway: unknown")
    fails(tmp_path, MINIMAL + "[roads.costs]\nC7 = 1.0\n", r": roads\.costs\.C7: unknown key")
    fails(tmp_path, MINIMAL + "[options.lattice]\nslope_weight = 3.0\n",
          r": options\.lattice\.slope_weight: set by coefficients\.o1, not here")
    fails(tmp_path, MINIMAL + "[options.teleport]\nspeed = 3\n", r": options\.teleport: unknown key")
    fails(tmp_path, MINIMAL + "[lots.castle]\nmax_area = 3.0\n", r": lots\.castle: unknown key")


def test_a_wrong_type(tmp_path):
    fails(tmp_path, MINIMAL.replace("start = 1200\n[[eras]]", 'start = "1200"\n[[eras]]'),
          r": start: expected a whole number, got '1200'")
    fails(tmp_path, MINIMAL + "[eras.pattern_options]\nmax_degree = 3.5\n",
          r": eras\[0\]\.pattern_options\.max_degree: expected a whole number, got 3\.5")
    fails(tmp_path, MINIMAL + "[eras.pattern_options]\nsnap_enabled = 1\n",
          r": eras\[0\]\.pattern_options\.snap_enabled: expected true or false")
    fails(tmp_path, MINIMAL + "[eras.pattern_options]\nangle_pdf = [[0, 1], [90]]\n",
          r": eras\[0\]\.pattern_options\.angle_pdf\[1\]: expected a list of 2 values")
    fails(tmp_path, "growth = [[2000, 0.01], [1990, 0.02]]\n" + MINIMAL,
          r": growth\[1\]: years must increase, got 1990 after 2000")
    fails(tmp_path, "growth = -0.01\n" + MINIMAL, r": growth: values must be ≥ 0, got -0\.01")
    fails(tmp_path, MINIMAL + "[roads.costs]\nbridge = [[1200, 5], [1300, 0]]\n",
          r": roads\.costs\.bridge: EdgeCosts\.bridge must be positive, got 0")
    fails(tmp_path, MINIMAL + "[roads]\nturn_width_deg = [[1200, 60], [1250, -10]]\n",
          r": roads: in year 1250: RoutingOptions\.turn_width must be positive, got -0\.17")
    fails(tmp_path, MINIMAL + "[options.land_use]\nupdate_interval = 0\n",
          r": options\.land_use\.update_interval: must be at least 1 year, got 0")
    fails(tmp_path, MINIMAL + "[eras.pattern_options]\nmin_length_m = -1\n",
          r": eras\[0\]\.pattern_options: pattern option min_length_m: must be > 0")
    fails(tmp_path, 'anchor = "now"\n' + MINIMAL, r": anchor: 'now' is not one of map, start")
    fails(tmp_path, "eras = 3\nstart = 0\n", r": eras: expected a list of tables")


def test_an_unknown_pattern_lists_the_valid_ones(tmp_path):
    message = fails(tmp_path, MINIMAL.replace('"medieval"', '"gird"'), r": eras\[0\]\.pattern: unknown pattern 'gird'",
                    name="european.toml")
    valid = message.split("(valid: ")[1].rstrip(")").split(", ")
    assert valid[:3] == list(GROWTH_PATTERNS) == ["example", "walk", "colonisation"]
    assert set(PATTERNS) <= set(valid)


def test_eras_out_of_order_or_colliding(tmp_path):
    two = MINIMAL + '[[eras]]\nname = "grid"\nstart = START\npattern = "grid"\nroad_types = { city = 1 }\n'
    fails(tmp_path, two.replace("START", "1100"), r": eras\[1\]\.start: 1100 is not after eras\[0\]\.start \(1200\)")
    fails(tmp_path, two.replace("START", "1200"), r": eras\[1\]\.start: 1200 is not after eras\[0\]\.start \(1200\)")
    fails(tmp_path, MINIMAL.replace("start = 1200\n[[eras]]", "start = 1100\n[[eras]]"),
          r": start: 1100 is before the first era \(eras\[0\]\.start = 1200\)")
    fails(tmp_path, MINIMAL + '[[eras]]\nname = "medieval"\nstart = 1300\npattern = "organic"\n'
          'road_types = { city = 1 }\n',
          r": eras\[1\]\.name: era 'medieval' is already defined differently in eras\[0\]")
    fails(tmp_path, MINIMAL + '[[eras]]\nname = "modern"\nstart = 1300\n',
          r": eras\[1\]\.pattern: missing \(era 'modern' is defined nowhere")


def test_an_empty_era_list(tmp_path):
    fails(tmp_path, "start = 0\neras = []\n", r": eras: a history needs at least one era$")


def test_bad_land_use(tmp_path):
    fails(tmp_path, MINIMAL + '[[land_use]]\nname = "farm"\ngoal = 0.2\nterms = []\n',
          r": land_use\[0\]\.lot_size: 'farm' is not a lot class")
    fails(tmp_path, MINIMAL + '[[land_use]]\nname = "park"\n[[land_use.terms]]\nweight = 1.0\nkind = "ramp"\n'
          'attribute = "traffic"\nlow = 0.0\nhigh = 1.0\n', r": land_use\[0\]\.terms\[0\]\.kind: 'ramp' is not one of")
    fails(tmp_path, MINIMAL + '[[land_use]]\nname = "park"\n[[land_use]]\nname = "park"\n',
          r": land_use\[1\]\.name: type 'park' is already defined in land_use\[0\]")
    fails(tmp_path, MINIMAL + '[[land_use]]\nname = "park"\n[[land_use.terms]]\nweight = 1.0\nkind = "linear_up"\n'
          'attribute = "influence"\nof_type = "castle"\nlow = 0.0\nhigh = 1.0\n',
          r": land_use\[0\]\.terms\[0\]\.of_type: type 'castle' is not defined \(types: park\)")
    fails(tmp_path, MINIMAL + '[[land_use]]\nname = "residential_low"\n',
          r": land_use\[0\]\.name: the bundled terms of 'residential_low' weigh it; type 'industrial' is not defined")


def test_a_malformed_toml_file(tmp_path):
    fails(tmp_path, "start = 0\n[[eras]\nname = 'x'\n", r": not valid TOML: .*line 2")


def test_missing_files_and_names(tmp_path):
    with pytest.raises(InputError, match=r"^history 'medievil': not a bundled history \(european, example, "):
        load_history("medievil")
    with pytest.raises(InputError, match=r"nowhere\.toml: no such history file$"):
        load_history(tmp_path / "nowhere.toml")
    (tmp_path / "binary.toml").write_bytes(b"\xff\xfe\x00start")
    with pytest.raises(InputError, match=r"binary\.toml: not a text file"):
        load_history(tmp_path / "binary.toml")


def test_history_from_mapping_labels_errors_with_the_given_name():
    with pytest.raises(InputError, match=r"^mine\.toml: eras: missing$"):
        history_from_mapping({"start": 0}, label="mine.toml")
