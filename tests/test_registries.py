"""One place for each list (issue 23): the growth patterns' registry read by the command line, the pipeline and
the history; one enum parser; the named sets of highway classes in the model."""
from __future__ import annotations

import pytest

from osm_expand.errors import OptionError
from osm_expand.growth_patterns import PATTERN_NAMES, REGISTRY, era_defaults, growth_pattern, make_pattern
from osm_expand.model import highways


def test_the_command_line_the_pipeline_and_the_history_read_one_registry_of_growth_patterns():
    from osm_expand.cli import build_expand_parser
    from osm_expand.engine.history import GROWTH_PATTERNS

    pattern = next(a for a in build_expand_parser()._actions if a.dest == "pattern")
    assert tuple(pattern.choices) == PATTERN_NAMES == ("example", "walk", "colonisation")
    assert pattern.default == PATTERN_NAMES[0]
    assert tuple(GROWTH_PATTERNS) == PATTERN_NAMES
    assert {k: type(v) for k, v in GROWTH_PATTERNS.items()} == {k: type(v) for k, v in era_defaults().items()}
    with pytest.raises(OptionError, match="pattern must be one of example, walk, colonisation, got 'grid'"):
        growth_pattern("grid")


def test_each_registered_pattern_is_made_over_a_real_towns_example():
    from simplify.example import build_example
    from tests.conftest import simplified

    result = simplified("krems.osm.gz")
    example = build_example(result.network, result.dead_ends)
    names = {e.name: type(make_pattern(e.name, example)).__name__ for e in REGISTRY}
    assert names == {"example": "ExamplePatches", "walk": "RandomWalk", "colonisation": "Colonisation"}
    for entry in REGISTRY:  # an era's options reach the pattern
        options = entry.era_options()
        assert make_pattern(entry.name, example, options).options is options


def test_every_choice_is_refused_in_the_same_words():
    from osm_expand.engine.buildout.economy import EconomyOptions
    from osm_expand.engine.history.timefn import TimeFunction
    from osm_expand.export.preview import ColorBy
    from osm_expand.model import Status
    from synth.patterns import PatternOptions

    cases = [(lambda: Status.parse("built-ish"), "status: 'built-ish' is not one of built, planned"),
             (lambda: ColorBy.parse("height"), "color_by: 'height' is not one of origin, landuse, year"),
             (lambda: TimeFunction((0.0,), (1.0,), "cubic"), "time function: interpolation: 'cubic' is not one of"),
             (lambda: EconomyOptions(shape="cone"), "economy shape: 'cone' is not one of"),
             (lambda: PatternOptions(angle_space="polar"), "pattern option angle_space: 'polar' is not one of")]
    for make, message in cases:
        with pytest.raises(OptionError, match=message):
            make()


def test_the_named_sets_of_highway_classes_live_in_the_model():
    from osm_expand import sites
    from osm_expand.engine.traffic import neighbours
    from osm_expand.model import segments
    from synth import colonisation_pattern, patches

    assert sites.CORRIDORS is highways.CORRIDORS and patches.NOT_COPIED is highways.CORRIDORS
    assert segments.MAJOR is highways.MAJOR_AND_LINKS
    assert neighbours.NeighbourOptions().exit_classes is highways.MAJOR
    assert colonisation_pattern.CLASS_LADDER is highways.CLASS_LADDER
    assert highways.MAJOR_AND_LINKS == {*highways.MAJOR, *(c + "_link" for c in highways.MAJOR)}
    assert highways.CORRIDORS <= highways.MAJOR_AND_LINKS <= highways.DRIVABLE
    assert set(highways.CLASS_LADDER) <= highways.DRIVABLE and not set(highways.CLASS_LADDER) & highways.CORRIDORS
