"""Each engine district attempt its own random stream (:attr:`GrowthOptions.district_streams`, issue 20): with one
stream for the engine's growth, a refused attempt or an earlier district grown otherwise shifts every later
district's draws, so no rule changing one district can be judged on one seed."""
from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from osm_expand.district import Placement, Tried
from osm_expand.engine.growth import minor_streets
from osm_expand.engine.growth.minor_streets import GrowthMemory, GrowthOptions
from osm_expand.engine.growth.nuclei import Nucleus, NucleusKind
from osm_expand.engine.history import Era
from osm_expand.engine.loop import ENGINE_STREAM, STREAMS, EngineOptions, _grow_streets, district_stream
from osm_expand.errors import OptionError
from osm_expand.growth_patterns import make_pattern
from synth.patches import PatchOptions
from tests.test_engine_districts import town


def _attempt_draws(monkeypatch, *, streams: bool, first_draws: int, seed: int = 0, year: int = 2000) -> list:
    """The first three numbers each of three refused attempts of one engine district year draws, its first
    attempt having drawn ``first_draws`` numbers before (as a pattern growing more or less would)."""
    city, learned = town("krems.osm.gz")
    spacing = learned.example.spacing
    seen: list = []

    def refuse(city, sites, pattern, *, rng, **kwargs):
        for attempt in range(3):
            gen = rng(attempt)
            if attempt == 0:
                gen.random(first_draws)
            seen.append(gen.random(3))
        return Placement(None, tuple(Tried(k, None, 0, False) for k in range(3)))

    monkeypatch.setattr(minor_streets, "place_district", refuse)
    era = Era(name="now", start=2000, end=None, pattern="example", options=PatchOptions(), road_types=())
    state = SimpleNamespace(city=city, nuclei=[Nucleus(xy=tuple(city.network.xy[0]), strength=0.5,
                                                       kind=NucleusKind.CENTRE)],
                            growth=GrowthMemory(), patterns={})
    options = EngineOptions(growth=GrowthOptions(district_neighbourhoods=0.0, district_streams=streams))
    _grow_streets(state, era, SimpleNamespace(year=year), year, np.random.default_rng([seed, ENGINE_STREAM]),
                  40, spacing=spacing, district_pattern=lambda *a: make_pattern("example", learned.example),
                  bearing=0.0, options=options, seed=seed)
    return seen


def test_with_district_streams_an_attempt_draws_the_same_whatever_the_attempts_before_drew(monkeypatch):
    """On: a later attempt's numbers do not move when an earlier attempt draws more; off (one stream) they do."""
    few = _attempt_draws(monkeypatch, streams=True, first_draws=1)
    many = _attempt_draws(monkeypatch, streams=True, first_draws=500)
    assert all(np.array_equal(a, b) for a, b in zip(few[1:], many[1:], strict=True))
    assert not np.array_equal(few[1], few[2])  # each attempt its own stream
    off_few = _attempt_draws(monkeypatch, streams=False, first_draws=1)
    off_many = _attempt_draws(monkeypatch, streams=False, first_draws=500)
    assert not np.array_equal(off_few[1], off_many[1])


def test_a_district_attempts_stream_is_its_seeds_years_and_attempts(monkeypatch):
    """The stream is ``district_stream(seed, year, attempt)``: the same three give the same numbers (a run is
    repeatable), another seed or year others."""
    base = _attempt_draws(monkeypatch, streams=True, first_draws=0)
    assert np.array_equal(base[1], district_stream(0, 2000, 1).random(3))
    assert np.array_equal(base[2], _attempt_draws(monkeypatch, streams=True, first_draws=0)[2])
    assert not np.array_equal(base[1], _attempt_draws(monkeypatch, streams=True, first_draws=0, seed=1)[1])
    assert not np.array_equal(base[1], _attempt_draws(monkeypatch, streams=True, first_draws=0, year=2001)[1])


def test_district_streams_share_no_numbers_with_the_loops_stage_streams():
    firsts = {tuple(np.random.default_rng([0, ENGINE_STREAM, k]).random(4)) for k in range(len(STREAMS))}
    firsts.add(tuple(np.random.default_rng([0, ENGINE_STREAM]).random(4)))
    districts = {tuple(district_stream(0, year, attempt).random(4)) for year in (0, 1, 2000) for attempt in range(5)}
    assert len(districts) == 15 and not districts & firsts


@pytest.mark.parametrize("value", ["false", 1, None])
def test_district_streams_refuses_what_is_not_a_bool(value):
    """A string "false" from a config would read as on: refused with the project's one-line option error."""
    with pytest.raises(OptionError, match="district_streams must be a bool"):
        GrowthOptions(district_streams=value)


def test_the_benchmark_sets_a_growth_option_by_its_fields_type():
    path = Path(__file__).resolve().parent.parent / "benchmarks" / "engine_growth.py"
    spec = importlib.util.spec_from_file_location("engine_growth", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.growth_option("district_streams=true") == ("district_streams", True)
    assert module.growth_option("district_trim_blocked=False") == ("district_trim_blocked", False)
    assert module.growth_option("district_run_on=0.3") == ("district_run_on", 0.3)
    assert module.growth_option("sites_tried=7") == ("sites_tried", 7)
    for bad in ("district_streams=yes", "no_such_field=1", "sites_tried", "sites_tried=x"):
        with pytest.raises(argparse.ArgumentTypeError):
            module.growth_option(bad)


@pytest.mark.parametrize("value", ["false", 1, None])
def test_district_trim_blocked_refuses_what_is_not_a_bool(value):
    """Review 34: a history's string "false" was read as on."""
    with pytest.raises(OptionError, match="district_trim_blocked must be a bool"):
        GrowthOptions(district_trim_blocked=value)


@pytest.mark.parametrize("value", ["0.3", None, float("nan"), -1.0, float("inf")])
def test_district_run_on_refuses_what_is_not_a_finite_number_of_spacings(value):
    """Review 34: a string or None raised numpy's bare TypeError, not one clear line."""
    with pytest.raises(OptionError, match="district_run_on must be a finite number"):
        GrowthOptions(district_run_on=value)
