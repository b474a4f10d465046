"""The engine as City → City (issue 23): ``mature`` is its own step after ``expand``, built on ``step``.

On Krems (seed 0) with its district grown: a step lives one year and its city says so; ``mature`` of no
years gives the very city back; ``mature`` over N years writes the same bytes as N steps of its own.
"""
from __future__ import annotations

import functools

import numpy as np
import pytest

from osm_expand.engine.history import load_history
from osm_expand.engine.loop import EngineContext, EngineState, start, step
from osm_expand.export import write_urbanenvironment
from osm_expand.ingest import load
from osm_expand.maturation import Maturation, MatureOptions, mature
from osm_expand.model import Origin
from osm_expand.pipeline import ExpandOptions, district_pattern, expand
from tests.conftest import FIXTURES

YEARS = 3


@functools.lru_cache(maxsize=None)
def krems():
    return expand(load(FIXTURES / "krems.osm.gz"), ExpandOptions(seed=0, fidelity=False))


def started() -> tuple[EngineState, EngineContext]:
    result = krems()
    return start(result.city, load_history("example"), seed=0, spacing=result.learned.example.spacing,
                 patterns=district_pattern(result.learned), join_points=result.joins.at)


@functools.lru_cache(maxsize=None)
def stepped() -> tuple[list[int | None], EngineState]:
    """The city's year before and after each of :data:`YEARS` steps, and the last state."""
    state, context = started()
    seen = [state.city.year]
    for k in range(YEARS):
        state, done = step(state, context, context.clock.calendar_year(k))
        assert done.year == context.clock.calendar_year(k)
        seen.append(state.city.year)
    return seen, state


def test_a_step_lives_one_year_and_the_city_says_which():
    state, context = started()
    first = context.clock.calendar_year(0)
    seen, last = stepped()
    assert seen[1:] == [first + k for k in range(YEARS)]
    assert seen[0] == krems().city.year  # the map's year, until the first step
    dated = [x.year for x in (*last.city.network.streets, *last.city.buildings)
              if x.origin != Origin.SOURCE and x.year is not None]
    assert dated and max(dated) <= last.city.year  # nothing is dated after the year the city has lived
    assert first in {b.year for b in last.city.buildings if b.origin == Origin.ENGINE}  # the first year built


def test_mature_of_no_years_is_the_identity():
    result = krems()
    grown = mature(result.city, load_history("example"), MatureOptions(years=0), 0, learned=result.learned)
    assert grown == Maturation(result.city, {}) and grown.city is result.city


def test_mature_over_n_years_writes_the_bytes_of_n_steps(tmp_path):
    result = krems()
    grown = mature(result.city, load_history("example"), MatureOptions(years=YEARS, fidelity=False), 0,
                   learned=result.learned, join_points=result.joins.at)
    _, state = stepped()
    write_urbanenvironment(grown.city, tmp_path / "mature.xml")
    write_urbanenvironment(state.city, tmp_path / "steps.xml")
    assert (tmp_path / "mature.xml").read_bytes() == (tmp_path / "steps.xml").read_bytes()
    assert grown.city.year == state.city.year
    engine = grown.report["engine"]
    assert engine["years"] == YEARS and engine["last_year"] == grown.city.year
    assert sum(e["years"][1] - e["years"][0] + 1 for e in engine["eras"]) == YEARS


def test_mature_takes_a_snapshot_at_the_end_of_each_era_or_every_n_years():
    result = krems()
    history = load_history("example")
    per_era, every = [], []
    kw = {"learned": result.learned, "join_points": result.joins.at}
    mature(result.city, history, MatureOptions(years=2, fidelity=False), 0,
           snapshot=lambda c, year, era, traffic: per_era.append((year, era, c.year)), **kw)
    mature(result.city, history, MatureOptions(years=2, fidelity=False, snapshot_every=1), 0,
           snapshot=lambda c, year, era, traffic: every.append((year, traffic)), **kw)
    first = history.clock(result.city.year).calendar_year(0)
    assert per_era == [(first + 1, history.era_at(history.clock(result.city.year).history_year(1)).name, first + 1)]
    assert [y for y, _ in every] == [first, first + 1]
    assert all(v >= 0 for _, traffic in every for v in traffic.values()) and every[-1][1]


@pytest.mark.parametrize("years", [-1, 0])
def test_no_years_need_no_history_numbers(years):
    """``years <= 0`` returns before the engine starts: the city and an empty report."""
    city = krems().city
    assert mature(city, load_history("european"), MatureOptions(years=years), 0).report == {}
    assert np.array_equal(city.network.xy, mature(city, load_history("european"), MatureOptions(years=years)).city
                          .network.xy)
