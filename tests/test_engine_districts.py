"""The engine's districts are sized by the town's own street density (issue 20): an engine district's site holds
its owed street length at the density of the town's built-up land, not a square grid's 2/s (a site smaller than
one patch cell, so each district was one piece of dense fabric cut to a disc)."""
from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from osm_expand.district import Placement
from osm_expand.engine.growth import minor_streets
from osm_expand.engine.growth.minor_streets import GrowthMemory, GrowthOptions, built_up_density, grow_district
from osm_expand.engine.growth.nuclei import Nucleus, NucleusKind, rank_candidates
from osm_expand.errors import OptionError
from osm_expand.growth_fidelity import city_growth_fidelity
from osm_expand.growth_patterns import make_pattern
from osm_expand.ingest import load
from osm_expand.pipeline import _margin, learn, prepare
from osm_expand.sites import SiteOptions, distance_maps
from tests.conftest import FIXTURES, expanded_and_matured


@functools.cache
def town(name: str):
    city = load(FIXTURES / name, context=False)
    learned = learn(city)
    return prepare(city), learned


@pytest.mark.parametrize("name", ["krems.osm.gz", "monaco.osm.gz", "north-bayreuth.osm.gz"])
def test_a_towns_built_up_land_holds_fewer_streets_than_a_grid_of_its_spacing(name):
    """Blocks are not squares and not every block side is a street: the towns hold 1.3–1.8 spacings' worth of
    street per square spacing of built-up land, never a grid's 2 (nor under 1)."""
    city, learned = town(name)
    maps = distance_maps(city, SiteOptions(), margin=_margin(city))
    density = built_up_density(city, maps) * learned.example.spacing
    assert 1.0 < density < 2.0


def test_an_engine_district_site_holds_its_owed_length_at_the_towns_density(monkeypatch):
    city, learned = town("krems.osm.gz")
    spacing = learned.example.spacing
    asked = []

    def record(city, sites, pattern, **kwargs):
        asked.append(sites)
        return Placement(None, ())

    monkeypatch.setattr(minor_streets, "place_district", record)
    owed = 30.0 * spacing
    nuclei = [Nucleus(xy=tuple(city.network.xy[0]), strength=0.5, kind=NucleusKind.CENTRE)]
    grow_district(city, make_pattern("example", learned.example), owed, 2.0 / spacing, nuclei,
                  np.random.default_rng(0), spacing=spacing, year=2000, era="now")
    assert asked and asked[0]
    area = asked[0][0].area
    # larger than a grid's site (owed / (2/s)) by the grid's density over the town's
    assert area > 1.1 * owed / (2.0 / spacing)
    assert area == pytest.approx(owed * spacing / 1.47, rel=0.1)  # Krems: 1.47 spacings of street per spacing²


@pytest.mark.xfail(strict=True, reason="issue 20 open: with the transplant (session 43's default) Monaco's seed-0 "
                   "engine grows one transplanted district whose 2-core share is 0.988 against the neighbourhoods' "
                   "0.872-0.976 (dead-end share 0.04 in range)")
def test_monacos_engine_streets_form_no_more_blocks_than_its_neighbourhoods():
    """Monaco, default history, seed 0: with sites at 2/s each engine district was one patch cut to a disc, its
    2-core share 0.971 above the town's 0.88–0.967; at the town's density (the quilt), 0.926 in 0.871–0.970. With
    the transplant its one district (the consolidation era's, 50 streets) is 0.988 against 0.872–0.976: marked as
    the known failure it is until the engine's Monaco meets issue 20's bar (strict: passing would be news)."""
    city = expanded_and_matured(load(FIXTURES / "monaco.osm.gz"), seed=0).city
    g = city_growth_fidelity(city, rng=0)
    assert g is not None and g.overall is not None
    measures = g.overall.to_dict()["measures"]
    assert measures["two_core_share"]["ok"] and measures["dead_end_share"]["ok"]




def _districts_owed(city, spacing, yearly: float, years: int, *, era_end: int | None, neighbourhoods: float,
                    monkeypatch, last_year: int | None = None, grow=None, memory: GrowthMemory | None = None,
                    trace: list | None = None, growth: dict | None = None) -> list[float]:
    """The lengths (m) the engine's loop asks districts of, a town owing ``yearly`` metres a year for ``years``
    years of one era (from 2000, ending at ``era_end``), every district placed as owed (or as ``grow(call, length)``
    says: the length placed, 0 for refused). ``trace`` gets ``(year, owed, due)`` after each year."""
    from types import SimpleNamespace

    from osm_expand.engine import loop
    from osm_expand.engine.history import Era
    from osm_expand.engine.loop import EngineOptions, _grow_streets
    from synth.patches import PatchOptions

    asked: list[float] = []

    def placed(city, pattern, length, *args, **kwargs):
        asked.append(length)
        got = length if grow is None else grow(len(asked), length)
        return city, minor_streets.GrowthYear(streets=int(got > 0), length_m=got, districts=int(got > 0))

    monkeypatch.setattr(loop, "grow_district", placed)
    era = Era(name="now", start=2000, end=era_end, pattern="example", options=PatchOptions(), road_types=())
    state = SimpleNamespace(city=city, nuclei=[Nucleus(xy=tuple(city.network.xy[0]), strength=0.5,
                                                       kind=NucleusKind.CENTRE)],
                            growth=memory or GrowthMemory(), patterns={})
    options = EngineOptions(growth=GrowthOptions(district_neighbourhoods=neighbourhoods, **(growth or {})))
    for year in range(2000, 2000 + years):
        _grow_streets(state, era, SimpleNamespace(year=year), year, np.random.default_rng(0),
                      round(yearly / spacing), spacing=spacing, district_pattern=lambda *a: None, bearing=0.0,
                      options=options, last_year=last_year)
        if trace is not None:
            trace.append((year, state.growth.owed, state.growth.due))
    return asked


def test_a_towns_neighbourhood_is_a_district_discs_streets():
    """One neighbourhood's street length: the pipeline's district area (Perry's 0.65 km² on Krems, whose quarter
    of the built-up land is larger) at the town's built-up density (about 0.010–0.012 m/m²): 6–8 km."""
    city, learned = town("krems.osm.gz")
    assert 5_500 < minor_streets.neighbourhood_length(city) < 9_000


def test_a_large_towns_yearly_growth_waits_for_districts_of_several_neighbourhoods(monkeypatch):
    """A town owing about one neighbourhood a year (as Campo Grande does; run here on Krems with Krems' own
    neighbourhood as the yearly length): with the floor off (``min_district`` alone) every year
    is a district of one neighbourhood; with a floor of 5 neighbourhoods a district comes every 5–6 years (the
    yearly count is whole streets), of 5 or more, and the era's last year grows what is left. The floor alone:
    ``district_town_share`` off (half of Krems' settlement is about 4 of its neighbourhoods)."""
    city, learned = town("krems.osm.gz")
    spacing = learned.example.spacing
    one = minor_streets.neighbourhood_length(city)
    alone = {"district_town_share": math.inf}
    off = _districts_owed(city, spacing, one, 20, era_end=2020, neighbourhoods=0.0, monkeypatch=monkeypatch,
                          growth=alone)
    on = _districts_owed(city, spacing, one, 20, era_end=2020, neighbourhoods=5.0, monkeypatch=monkeypatch,
                         growth=alone)
    assert len(off) == 20 and max(off) < 1.1 * one
    assert len(on) == 4 and min(on[:-1]) >= 5 * one and on[-1] < 5 * one
    assert sum(on) == pytest.approx(sum(off), rel=0.01)  # the same length, in fewer districts


def test_a_small_towns_growth_still_grows_a_district_when_its_era_ends(monkeypatch):
    """Krems owes about 0.6 km a year, a tenth of a neighbourhood: with a floor of 5 neighbourhoods it never
    owes one, and the era's owed length is grown in its last year instead of being lost."""
    city, learned = town("krems.osm.gz")
    spacing = learned.example.spacing
    one = minor_streets.neighbourhood_length(city)
    yearly = 0.1 * one
    on = _districts_owed(city, spacing, yearly, 8, era_end=2008, neighbourhoods=5.0, monkeypatch=monkeypatch)
    assert len(on) == 1 and on[0] == pytest.approx(8 * round(yearly / spacing) * spacing)
    # an era too short to owe min_district spacings grows nothing, as without the floor
    short = _districts_owed(city, spacing, yearly, 2, era_end=2002, neighbourhoods=5.0, monkeypatch=monkeypatch)
    assert short == []
    # an era the run ends in: its owed length is grown in the run's last year
    open_era = _districts_owed(city, spacing, yearly, 8, era_end=None, neighbourhoods=5.0, monkeypatch=monkeypatch,
                               last_year=2007)
    assert open_era == on
    assert _districts_owed(city, spacing, yearly, 8, era_end=None, neighbourhoods=5.0, monkeypatch=monkeypatch) == []


def test_a_due_district_refused_is_tried_every_year_at_min_district_until_one_is_placed(monkeypatch):
    """The floor reached, a refused district stays due: it is tried again every following year as soon as
    ``min_district`` spacings are owed (below the floor too), each refusal giving back ``min_district`` spacings;
    once one is placed (half its length here) the floor holds again until it is owed anew."""
    city, learned = town("krems.osm.gz")
    spacing = learned.example.spacing
    m = GrowthOptions().min_district  # 30 spacings
    yearly, floor = 0.5 * m, 100.0  # spacings a year; the floor in spacings (one neighbourhood of 100)
    trace: list = []
    asked = _districts_owed(city, spacing, yearly * spacing, 16, era_end=None, neighbourhoods=1.0,
                            monkeypatch=monkeypatch, memory=GrowthMemory(neighbourhood=floor * spacing),
                            grow=lambda call, length: 0.0 if call <= 2 else 0.5 * length, trace=trace)
    # 7 years to owe 105 ≥ 100: refused (105 → 75); 90 < 100 but due: refused (→ 60); 75: half placed (→ 37.5);
    # then the floor again: 52.5 … 97.5 wait, 112.5 in year 13: half placed (→ 56.25)
    assert [a / spacing for a in asked] == pytest.approx([105.0, 90.0, 75.0, 112.5])
    owed = [o / spacing for _, o, _ in trace]
    due = [d for _, _, d in trace]
    assert owed == pytest.approx([15, 30, 45, 60, 75, 90, 75, 60, 37.5, 52.5, 67.5, 82.5, 97.5, 56.25, 71.25,
                                  86.25])
    assert due == [False] * 6 + [True, True] + [False] * 8


def test_with_a_town_share_the_floor_is_at_most_that_share_of_the_towns_settlement(monkeypatch):
    """A town owing a tenth of a neighbourhood a year whose settlement holds 4 neighbourhoods of street: with the
    floor of 5 neighbourhoods alone its first district waits for 5; with ``district_town_share`` 0.25 it is due at
    one (a quarter of the town), and the same length is grown in five districts instead of one."""
    city, learned = town("krems.osm.gz")
    spacing = learned.example.spacing
    one = 100.0 * spacing  # a neighbourhood of 100 spacings, the settlement 4 of them

    def asked(share: float) -> list[float]:
        return _districts_owed(city, spacing, 0.1 * one, 50, era_end=2050, neighbourhoods=5.0,
                               monkeypatch=monkeypatch, growth={"district_town_share": share},
                               memory=GrowthMemory(neighbourhood=one, settlement=4 * one))

    alone, capped = asked(float("inf")), asked(0.25)
    assert [a / one for a in alone] == pytest.approx([5.0])
    assert len(capped) == 5 and all(a == pytest.approx(one) for a in capped)
    assert sum(capped) == pytest.approx(sum(alone))


@pytest.mark.parametrize("value", [0.0, -0.25, float("nan"), "0.25"])
def test_the_town_share_refuses_what_is_not_a_positive_share(value):
    with pytest.raises(OptionError, match="district_town_share"):
        GrowthOptions(district_town_share=value)


def test_north_bayreuths_town_without_its_buildings_holds_fewer_streets_than_the_district_floor():
    """Why the floor needs the town's share (issue 20): the floor's neighbourhood is the extract's (Perry's unit,
    the extract holding 15 km² of built-up land with the villages), while the town itself, its buildings taken
    out, is a settlement of about 2.9 km²: its whole street length is less than 5 neighbourhoods, so one district
    at the floor was larger than the town it grew from, and its region reached 1.2 km into the fields."""
    bare, _ = _bare_bayreuth()
    whole = minor_streets.settlement_length(bare)
    assert whole < GrowthOptions().district_neighbourhoods * minor_streets.neighbourhood_length(bare)


@functools.cache
def _bare_bayreuth():
    city = load(FIXTURES / "north-bayreuth.osm.gz", context=False)
    learned = learn(city)
    return prepare(city.replace(buildings=())), learned


def _sites_offered(monkeypatch, edit=None, **growth) -> tuple[list, np.ndarray]:
    """The sites the engine offers a district of 13.6 km (north-bayreuth without its buildings, seed 0's first
    engine district on main) and, per site, metres from its centre to the town's settlement; ``edit`` changes the
    site rasters the engine reads."""
    from osm_expand.sites import settlement_distance

    city, learned = _bare_bayreuth()
    spacing = learned.example.spacing
    asked: list = []
    maps_seen: list = []
    real_maps = minor_streets.settlement_maps

    def keep_maps(*args, **kwargs):
        maps = real_maps(*args, **kwargs)
        maps_seen.append(maps if edit is None else edit(maps))
        return maps_seen[-1]

    def record(city, sites, pattern, **kwargs):
        asked.append(list(sites))
        return Placement(None, ())

    monkeypatch.setattr(minor_streets, "settlement_maps", keep_maps)
    monkeypatch.setattr(minor_streets, "place_district", record)
    nuclei = [Nucleus(xy=tuple(city.network.xy[0]), strength=1.0, kind=NucleusKind.CENTRE)]
    grow_district(city, make_pattern("example", learned.example), 13_600.0, 2.0 / spacing, nuclei,
                  np.random.default_rng(0), spacing=spacing, year=2029, era="now", options=GrowthOptions(**growth))
    sites = asked[0] if asked else []
    far = settlement_distance(maps_seen[0], np.array([s.centre for s in sites]).reshape(-1, 2))
    return sites, far


def test_with_a_town_reach_the_engine_tries_no_site_by_a_hamlet_far_from_the_town(monkeypatch):
    """Without its buildings north-bayreuth's best sites for an engine district include one by a village 4-5 km
    east of the town (a site's closeness and contact count any built-up land): with ``district_town_reach`` 1.5
    every site tried lies within 1.5 district radii of the town's settlement (the default), and there are still
    five."""
    sites, far = _sites_offered(monkeypatch, district_town_reach=math.inf)
    assert len(sites) == 5 and far.max() > 2_000.0
    near_sites, near = _sites_offered(monkeypatch)
    radius = np.sqrt(near_sites[0].area / np.pi)
    assert len(near_sites) == 5 and near.max() <= 1.5 * radius


def test_without_built_up_land_the_town_reach_still_offers_sites(monkeypatch):
    """A town whose rasters hold no built-up land has no settlement to measure from (every distance infinite):
    the reach offers the sites as without it, not none every year (the review of session 36)."""
    from dataclasses import replace

    def bare(maps):
        return replace(maps, city=np.zeros_like(maps.city))

    sites, _ = _sites_offered(monkeypatch, edit=bare)
    everywhere, _ = _sites_offered(monkeypatch, edit=bare, district_town_reach=math.inf)
    assert len(sites) == len(everywhere) == 5
    assert np.array_equal([s.centre for s in sites], [s.centre for s in everywhere])


def test_with_no_settlement_gap_the_reach_measures_from_every_piece_of_built_up_land():
    """``settlement_gap`` 0 reads every piece of built-up land as the town's: a point by north-bayreuth's hamlet
    4-5 km east of the town is far from the town's settlement by default, and on built-up land with a gap of 0."""
    city, _ = _bare_bayreuth()
    maps = distance_maps(city, SiteOptions(cell=45.0), margin=_margin(city))
    rows, cols = np.nonzero(maps.city)
    xy = maps.origin + (np.column_stack([cols, rows]) + 0.5) * maps.cell  # every built-up cell's centre
    town = minor_streets._from_the_town(maps, xy, GrowthOptions())
    every = minor_streets._from_the_town(maps, xy, GrowthOptions(settlement_gap=0))
    assert town.max() > 2_000.0  # some built-up land lies far from the town's settlement
    assert np.all(every == 0.0)  # each is built-up land itself


@pytest.mark.parametrize("value", [0.0, -1.0, float("nan"), "1.5"])
def test_the_town_reach_refuses_what_is_not_a_positive_count_of_radii(value):
    with pytest.raises(OptionError, match="district_town_reach"):
        GrowthOptions(district_town_reach=value)


@pytest.mark.parametrize("value", [-1.0, -0.001, float("nan"), float("inf"), float("-inf")])
def test_the_district_floor_refuses_a_negative_or_not_finite_count(value):
    """A negative or NaN floor would silently turn it off, an infinite one would stop districts but at an era's
    end: the options refuse them with the project's one-line option error."""
    from osm_expand.errors import OptionError

    with pytest.raises(OptionError, match="district_neighbourhoods"):
        GrowthOptions(district_neighbourhoods=value)


@pytest.mark.parametrize("value", [0.0, 0.5, 5.0])
def test_the_district_floor_takes_zero_and_positive_counts(value):
    assert GrowthOptions(district_neighbourhoods=value).district_neighbourhoods == value


def test_the_runs_last_year_is_a_history_year_derived_once_by_start():
    """The district floor's run end (:attr:`EngineContext.last_year`) is the last step's history year, derived by
    ``start`` from the run's length beside the clock: with ``anchor = "start"`` and a map dated otherwise, it is
    the history's start plus the years less one, not a calendar year; without the run's length it is unknown."""
    from dataclasses import replace

    from osm_expand.engine.history import Anchor, load_history
    from osm_expand.engine.loop import start
    from osm_expand.pipeline import district_pattern

    city, learned = town("krems.osm.gz")
    history = replace(load_history("example"), anchor=Anchor.START)
    dated = replace(city, year=history.start + 40)
    kwargs = {"seed": 0, "spacing": learned.example.spacing, "patterns": district_pattern(learned)}
    _, context = start(dated, history, years=7, **kwargs)
    assert context.clock.offset == 40
    assert context.last_year == history.start + 6 == context.clock.calendar_year(6) - 40
    assert start(dated, history, **kwargs)[1].last_year is None


def _orders(city, learned, nuclei, options, monkeypatch):
    """The sites :func:`grow_district` asks :func:`place_district` to try, and the order it tries them in."""
    spacing = learned.example.spacing
    asked = []

    def record(city, sites, pattern, **kwargs):
        asked.append(([np.array(s.centre) for s in sites], list(kwargs["order"])))
        return Placement(None, ())

    monkeypatch.setattr(minor_streets, "place_district", record)
    grow_district(city, make_pattern("example", learned.example), 30.0 * spacing, 2.0 / spacing, nuclei,
                  np.random.default_rng(0), spacing=spacing, year=2000, era="now", options=options)
    return asked[-1]


def test_the_engine_tries_its_sites_in_the_nuclei_rank(monkeypatch):
    """003 §3.3.2: the sites a district is tried at are ranked by distance to the nearest nucleus × (1 − its
    strength), nearest first; a centre nucleus beside the last-scored site puts that one first."""
    city, learned = town("krems.osm.gz")
    probe = [Nucleus(xy=tuple(city.network.xy[0]), strength=0.5, kind=NucleusKind.CENTRE)]
    sites, _ = _orders(city, learned, probe, GrowthOptions(), monkeypatch)
    assert len(sites) >= 2
    nuclei = [Nucleus(xy=tuple(sites[-1]), strength=0.5, kind=NucleusKind.CENTRE)]
    sites, order = _orders(city, learned, nuclei, GrowthOptions(), monkeypatch)
    assert sorted(order) == list(range(len(sites)))
    assert order == rank_candidates(np.array(sites), nuclei, take=len(sites)).tolist()
    assert order[0] == len(sites) - 1
