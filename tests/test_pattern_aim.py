"""A street pattern's era aims its connectedness at its town's neighbourhoods, as the district does (issue 20:
"eras with a named pattern may differ from the town in orientation and angles, but not in connectedness")."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

from osm_expand.engine.growth import minor_streets
from osm_expand.engine.growth.minor_streets import GrowthOptions, _kept_nodes, _withheld
from osm_expand.engine.growth.stubs import StubReport, close_stubs
from osm_expand.engine.history import load_history
from osm_expand.engine.loop import EngineOptions
from osm_expand.errors import OptionError
from osm_expand.growth_fidelity import city_growth_fidelity
from osm_expand.ingest import load
from osm_expand.joins import add_streets
from osm_expand.maturation import MatureOptions, mature_result
from osm_expand.model import Origin, Status, match_points
from osm_expand.pipeline import ExpandOptions, expand, prepare
from tests.conftest import FIXTURES

TOWN = np.array([shapely.LineString([(0, 0), (1000, 0)])], dtype=object)
TOWN_NODES = np.array([[0.0, 0.0], [1000.0, 0.0]])
NOTHING = shapely.GeometryCollection()
#: a street joined to the town at both ends (a loop), with a 270 m stub 30 m short of it and a 40 m stub off it
CROSS = np.array([[0.0, 300], [400, 300]])
LEGS = [np.array([[0.0, 0], [0, 300]]), np.array([[400.0, 0], [400, 300]])]
LONG = np.array([[200.0, 0], [200, 270]])
SHORT = np.array([[100.0, 300], [100, 340]])
LINES = [CROSS, *LEGS, LONG, SHORT]


def _close(**aim):
    return close_stubs(LINES, [False] * len(LINES), TOWN, TOWN_NODES, NOTHING, reach=60.0, **aim)


def test_the_report_names_the_run_ons_the_short_stubs_dropped_and_the_culs_de_sac_kept():
    kept, _, report = _close()
    assert report.ran == ((3, 1),) and report.short == (4,) and report.stubs == ()
    assert report.source == (0, 1, 2, 3, 3)  # the short stub went, the long one ran on (its link last)


def test_a_run_on_withheld_leaves_its_stub_a_cul_de_sac():
    kept, _, report = _close(withhold=frozenset({(3, 1)}))
    assert report.ran == () and report.tees == 0
    assert report.source == (0, 1, 2, 3) and report.stubs == (3,)
    assert np.allclose(kept[3], LONG)


def test_a_short_stub_kept_stays_and_a_cul_de_sac_dropped_goes():
    _, _, report = _close(keep=frozenset({4}))
    assert 4 in report.source and report.stubs == (4,)
    _, _, report = _close(withhold=frozenset({(3, 1)}), drop=frozenset({3}))
    assert report.source == (0, 1, 2) and report.stubs == ()


@pytest.mark.parametrize("value", ["false", 1, None])
def test_pattern_aim_refuses_what_is_not_a_bool(value):
    """A history's string "false" would read as on."""
    with pytest.raises(OptionError, match="pattern_aim"):
        GrowthOptions(pattern_aim=value)


def test_krems_european_grid_era_is_no_more_connected_than_krems_neighbourhoods():
    """Krems, ``european``, seed 0, with :attr:`GrowthOptions.pattern_aim`: the gründerzeit grid's run-ons and
    dropped stubs left it 13.1 km with a 2-core share of 0.973 against its neighbourhoods' 0.885-0.959, and the
    growth's 0.968 above 0.885-0.967; aimed at the neighbourhoods' medians, the grid and the growth have dead-end
    and 2-core shares in range."""
    engine = EngineOptions(growth=GrowthOptions(pattern_aim=True))
    result = expand(load(FIXTURES / "krems.osm.gz"), ExpandOptions(seed=0, fidelity=False))
    city = mature_result(result, load_history("european"), MatureOptions(fidelity=False, engine=engine), 0).city
    g = city_growth_fidelity(city, rng=0)
    assert g is not None and g.overall is not None
    for report in (g.overall, g.per_era["gruenderzeit"]):
        assert report is not None
        measures = report.to_dict()["measures"]
        assert measures["two_core_share"]["ok"] and measures["dead_end_share"]["ok"]


def test_a_kept_stubs_new_nodes_are_spent_as_growth_starts_but_not_the_street_it_hangs_from():
    """A stub kept by the aim stays a cul-de-sac: its own nodes never start a street in a later year (else a grid
    extends the kept stubs year after year: north-bayreuth's gründerzeit grew 8.8 -> 30 km), while the node it hangs
    from, the town's, stays a start."""
    city = prepare(load(FIXTURES / "krems.osm.gz", context=False))
    net = city.network
    tee = net.xy[net.used_nodes()[0]]
    stub = np.array([tee, tee + [0.0, 37.0], tee + [0.0, 74.0]])
    grown = add_streets(city, [stub], [{"highway": "residential", "hierarchy": 9, "origin": Origin.ENGINE,
                                        "status": Status.PLANNED, "year": 2000, "era": "grid", "bridge": False,
                                        "layer": 0}])
    spent = _kept_nodes(city, grown, [stub])
    new = match_points(stub[1:], grown.network.xy)
    assert (new >= 0).all() and spent == set(new.tolist())
    assert int(match_points(stub[:1], grown.network.xy)[0]) not in spent
    assert _kept_nodes(city, grown, []) == set()


class _Aim:
    """An era's counts (length m, area m², dead ends, junctions and dead ends, 2-core length m) and the town's
    medians (density, dead-end share, 2-core share), as :meth:`DistrictYardstick.aim` gives them."""

    def __init__(self, counts, medians):
        self.got = (np.array(counts, dtype=float), np.array(medians, dtype=float))

    def aim(self, lines, open_points):
        return self.got


#: the town's neighbourhoods: dead-end share median 0.15, 2-core median 0.90
MEDIANS = (10.0, 0.15, 0.90)


@pytest.fixture
def _no_lines(monkeypatch):
    monkeypatch.setattr(minor_streets, "growth_lines", lambda grown, era=None: ([], np.zeros((0, 2))))


def test_more_connected_than_both_medians_takes_back_a_run_on(_no_lines):
    """Dead ends 0.1 and 2-core 0.96, both on the connected side of their medians: the 270 m run-on is taken back
    (a dead end more, 0.2, above the median: then it stops). With the dead ends above the median already nothing
    is taken back: the rule acts only while both shares sit on one side."""
    report = StubReport(ran=((3, 1),))
    assert _withheld(None, "grid", _Aim((1000.0, 1e5, 1, 10, 960.0), MEDIANS), LINES, report, 60.0) == (
        frozenset({(3, 1)}), frozenset(), frozenset())
    assert _withheld(None, "grid", _Aim((1000.0, 1e5, 2, 10, 960.0), MEDIANS), LINES, report, 60.0) == (
        frozenset(), frozenset(), frozenset())


def test_less_connected_than_both_medians_drops_a_cul_de_sac_of_a_pattern_that_never_closes_its_trees(_no_lines):
    """Dead ends 0.4 and 2-core 0.80, both on the tree side: a pattern that never closes its trees loses the 40 m
    cul-de-sac; one that closes them in later years keeps it (a young grid is all trees)."""
    report = StubReport(stubs=(4,))
    aim = _Aim((1000.0, 1e5, 4, 10, 800.0), MEDIANS)
    assert _withheld(None, "suburban", aim, LINES, report, 60.0, closes=False) == (frozenset(), frozenset(),
                                                                                   frozenset({4}))
    assert _withheld(None, "grid", aim, LINES, report, 60.0) == (frozenset(), frozenset(), frozenset())
