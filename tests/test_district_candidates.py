"""The engine's candidate districts (issue 20, ``GrowthOptions.district_candidates``): a placed district judged
against the town's neighbourhoods on density, dead-end and 2-core share; one out of range followed by another
candidate (a second draw at its site, then the next sites), the best kept; and a placed district finished
(``stubs.finish_district``) when the run-on or trim options ask for it."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

from osm_expand.district import Placed, Placement
from osm_expand.engine.growth import minor_streets
from osm_expand.engine.growth.minor_streets import GrowthMemory, GrowthOptions, grow_district
from osm_expand.engine.growth.nuclei import Nucleus, NucleusKind
from osm_expand.engine.growth.yardstick import JUDGED, DistrictScore, DistrictYardstick, growth_lines
from osm_expand.errors import OptionError
from osm_expand.growth_patterns import make_pattern
from osm_expand.joins import JoinReport, add_streets
from osm_expand.model import Origin, Status
from synth.growth import Growth
from tests.test_engine_districts import town

ATTRS = {"highway": "residential", "hierarchy": 9, "origin": Origin.ENGINE, "status": Status.PLANNED,
         "year": 2000, "era": "now", "bridge": False, "layer": 0}


class Scripted:
    """A yardstick whose scores are given in turn (the k-th district judged gets ``scores[k]``)."""

    def __init__(self, scores):
        self.scores, self.judged = list(scores), []

    def score(self, lines, open_points):
        self.judged.append(lines)
        return self.scores[len(self.judged) - 1]


def _placing(calls: list):
    """A ``place_district`` that places the first site of the order it is given, one street there (a street
    numbered by the call, so the kept city tells which call's district it was), and records the order."""

    def place(city, sites, pattern, *, order, rng, **kwargs):
        calls.append(list(order))
        rng(0)
        rank = order[0]
        x, y = sites[rank].centre
        line = np.array([[x, y], [x + 10.0 * len(calls), y]])
        grown = add_streets(city, [line], [ATTRS])
        return Placement(Placed(rank, sites[rank], Growth(streets=()), grown,
                                JoinReport(joins=2, links=0, tees=0, at=np.zeros((0, 2))), crossed=False), ())

    return place


def _grow(monkeypatch, options, memory, calls):
    city, learned = town("krems.osm.gz")
    spacing = learned.example.spacing
    monkeypatch.setattr(minor_streets, "place_district", _placing(calls))
    nuclei = [Nucleus(xy=tuple(city.network.xy[0]), strength=0.5, kind=NucleusKind.CENTRE)]
    before = len(city.network.streets)
    grown, year = grow_district(city, make_pattern("example", learned.example), 30.0 * spacing, 2.0 / spacing,
                                nuclei, memory, np.random.default_rng(0), spacing=spacing, year=2000, era="now",
                                options=options)
    return grown, year, before


def _kept_call(grown, before) -> int:
    """Which call's district ``grown`` holds: its street's length is 10 m per call number."""
    xy = grown.network.street_xy(grown.network.streets[before])
    return round(float(np.hypot(*(xy[-1] - xy[0]))) / 10.0)


OUT2, OUT1, WITHIN = DistrictScore(2, 1.5), DistrictScore(1, 0.2), DistrictScore(0, 0.0)


def test_one_candidate_keeps_the_first_placed_district_without_judging_it(monkeypatch):
    calls: list = []
    memory = GrowthMemory(yardstick=Scripted([OUT2]))
    grown, year, before = _grow(monkeypatch, GrowthOptions(sites_tried=3), memory, calls)
    assert len(calls) == 1 and memory.yardstick.judged == [] and year.districts == 1
    assert _kept_call(grown, before) == 1


def test_a_district_out_of_range_is_followed_by_another_draw_at_its_site_then_the_next_sites(monkeypatch):
    calls: list = []
    memory = GrowthMemory(yardstick=Scripted([OUT2, OUT2, OUT1]))
    grown, year, before = _grow(monkeypatch, GrowthOptions(sites_tried=3, district_candidates=3), memory, calls)
    first = calls[0]
    assert calls == [first, first, first[1:]]  # the same site twice, then the sites after it
    assert len(memory.yardstick.judged) == 3
    assert _kept_call(grown, before) == 3  # the best: one measure out, not two
    assert year.districts == 1 and year.streets == 1


def test_the_first_candidate_in_range_ends_the_search(monkeypatch):
    calls: list = []
    memory = GrowthMemory(yardstick=Scripted([OUT1, WITHIN, OUT2]))
    grown, _, before = _grow(monkeypatch, GrowthOptions(sites_tried=3, district_candidates=3), memory, calls)
    assert len(calls) == 2 and _kept_call(grown, before) == 2


def test_among_candidates_equally_far_out_the_nearer_is_kept(monkeypatch):
    calls: list = []
    memory = GrowthMemory(yardstick=Scripted([DistrictScore(1, 0.9), DistrictScore(1, 0.1), DistrictScore(1, 0.5)]))
    grown, _, before = _grow(monkeypatch, GrowthOptions(sites_tried=3, district_candidates=3), memory, calls)
    assert len(calls) == 3 and _kept_call(grown, before) == 2


def test_each_candidate_attempt_draws_its_own_stream_with_district_streams(monkeypatch):
    """With ``streams`` every attempt of the year has its own number, across the candidates' calls."""
    city, learned = town("krems.osm.gz")
    spacing = learned.example.spacing
    calls: list = []
    asked: list[int] = []
    monkeypatch.setattr(minor_streets, "place_district", _placing(calls))
    memory = GrowthMemory(yardstick=Scripted([OUT2, OUT2, OUT2]))
    nuclei = [Nucleus(xy=tuple(city.network.xy[0]), strength=0.5, kind=NucleusKind.CENTRE)]
    grow_district(city, make_pattern("example", learned.example), 30.0 * spacing, 2.0 / spacing, nuclei, memory,
                  np.random.default_rng(0), spacing=spacing, year=2000, era="now",
                  options=GrowthOptions(sites_tried=3, district_candidates=3),
                  streams=lambda attempt: asked.append(attempt) or np.random.default_rng(attempt))
    assert asked == [0, 1, 2]


@pytest.mark.parametrize("options", [GrowthOptions(district_run_on=0.3), GrowthOptions(district_trim_blocked=True)])
def test_a_placed_district_is_finished_when_run_on_or_trim_is_on(monkeypatch, options):
    """Session 34's review finding 7: ``grow_district`` hands the placed district to ``finish_district`` with the
    options' run-on and trim, from the district's first street (and not when both are off)."""
    seen = []

    def finish(city, first, *, spacing, run_on, trim_blocked, year, era):
        seen.append((first, run_on, trim_blocked, year, era))
        return city, None

    monkeypatch.setattr(minor_streets, "finish_district", finish)
    _, _, before = _grow(monkeypatch, options, GrowthMemory(), [])
    assert seen == [(before, options.district_run_on, options.district_trim_blocked, 2000, "now")]
    seen.clear()
    _grow(monkeypatch, GrowthOptions(), GrowthMemory(), [])
    assert seen == []


@pytest.mark.parametrize("value", [0, -1, 2.5, True, "3"])
def test_district_candidates_must_be_a_whole_number_of_at_least_one(value):
    with pytest.raises(OptionError, match="district_candidates"):
        GrowthOptions(district_candidates=value)


def test_the_towns_own_neighbourhood_is_in_range_and_a_comb_is_not():
    """The yardstick on Krems: the town's own streets around a dense junction are within the neighbourhoods'
    density, dead-end and 2-core ranges (or one measure out, as a real part may be); a comb of dead-end
    streets hung on one street is out on the dead-end and 2-core shares."""
    city, learned = town("krems.osm.gz")
    stick = DistrictYardstick.of_town(city, seed=0)
    spacing = learned.example.spacing
    # the town's streets in one of its own neighbourhood discs, open where they leave it
    from osm_expand.fidelity import real_parts

    disc = real_parts(stick.town, 0.4e6, n=1, rng=1)[0]
    cut = shapely.get_parts(shapely.intersection(stick.town.geoms, disc))
    inside = [np.asarray(g.coords) for g in cut if g.geom_type == "LineString" and g.length > 0]
    ends = np.array([xy for line in inside for xy in (line[0], line[-1])])
    rim = ends[shapely.distance(shapely.points(ends), disc.boundary) < 1.0]
    own = stick.score(inside, rim)
    assert own.out <= 1 and len(own.values) == len(JUDGED)
    # a comb: a spine with teeth a spacing long, in the fields, open at the spine's one end
    x0, y0 = city.network.xy.min(axis=0) - 2000.0
    spine = np.array([[x0, y0], [x0 + 20 * spacing, y0]])
    teeth = [np.array([[x0 + k * spacing, y0], [x0 + k * spacing, y0 + spacing]]) for k in range(1, 20)]
    comb = stick.score([spine, *teeth], spine[:1])
    assert comb.out >= 2 and comb > own
    assert len(stick.discs) >= 1  # measured once per bin of area, kept for the run


def test_the_growth_is_the_engines_streets_open_where_they_meet_the_others():
    city, _ = town("krems.osm.gz")
    net = city.network
    a = net.xy[net.streets[0].nodes[0]]
    grown = add_streets(city, [np.array([a, a + [0.0, 50.0], a + [50.0, 50.0]])], [ATTRS])
    lines, open_points = growth_lines(grown)
    assert len(lines) == 1 and np.allclose(open_points, [a])


def test_pooled_discs_narrow_the_range():
    """Two pieces of a bin pool two discs a part: the 10th-90th percentile range of the pooled dead-end share
    is no wider than one disc's (the verdict's pooled references, issue 20)."""
    city, _ = town("krems.osm.gz")
    stick = DistrictYardstick.of_town(city, seed=0)
    one, two = stick.limits([0.3e6]), stick.limits([0.3e6, 0.3e6])
    assert len(stick.discs) == 1
    width = one[:, 1] - one[:, 0]
    assert (two[:, 1] - two[:, 0] <= width + 1e-9).sum() >= 2
