"""The growth patterns that grow whole districts, in one registry: name → pattern and its options.

``--pattern`` (its choices and help), the pipeline (the district it grows
first) and the history's eras (``pattern = "walk"``, with
``pattern_options``; :data:`osm_expand.engine.history.GROWTH_PATTERNS`) all
read this registry, so a pattern is added in one place. The Beneš street
patterns (:data:`synth.patterns.PATTERNS`), which grow from starts rather
than into a district, are apart.

This module imports nothing heavy at its top: the command line's parser
reads :data:`PATTERN_NAMES` and :data:`PATTERN_HELP` without loading NumPy;
a pattern's classes are imported when one is made.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from osm_expand.errors import OptionError

if TYPE_CHECKING:
    import shapely

    from osm_expand.measures import NetworkMeasures
    from simplify.example import Example
    from synth.growth import GrowthPattern

__all__ = ["PATTERN_HELP", "PATTERN_NAMES", "GrowthPatternEntry", "era_defaults", "growth_pattern", "make_pattern"]


def measure_in_windows(lines: list) -> Callable[[shapely.Geometry], NetworkMeasures]:
    """The measures of ``lines`` in any window, the lines indexed once (what the example patches compare
    their candidate patches with; ``synth`` knows only the model, so the caller hands it in).

    Only what the example patches read (:data:`synth.patches.TYPICAL`, the dead-end and 2-core shares):
    the pieces, strokes, blocks and alignment of Campo Grande's 2,800 windows in 30 years were
    two thirds of their 25 s.
    """
    from osm_expand.measures import LineSet, measure_network
    from synth.patches import TYPICAL

    indexed = LineSet.from_lines(lines)
    wanted = (*TYPICAL, "dead_end_share", "two_core_share")
    return lambda window: measure_network(indexed, window=window, pieces=False, wanted=wanted)


def _example(example: Example, options: Any) -> GrowthPattern:
    from synth.patches import ExamplePatches

    if options is None:
        return ExamplePatches(example, measure=measure_in_windows)
    return ExamplePatches(example, options=options, measure=measure_in_windows)


def _walk(example: Example, options: Any) -> GrowthPattern:
    from synth.growth import RandomWalk

    return RandomWalk(example) if options is None else RandomWalk(example, options=options)


def _colonisation(example: Example, options: Any) -> GrowthPattern:
    from synth.colonisation_pattern import Colonisation

    return Colonisation(example) if options is None else Colonisation(example, options=options)


def _example_era() -> Any:
    """The example pattern's options in a history's era: the district's, but a transplant that falls short of
    the town's density is not replaced by the quilt (``PatchOptions.transplant_fallback`` off).

    Why: where the transplant cannot fill an era's site at the town's density, the era without the fallback
    grows no district there (it grows elsewhere or later); with it, it kept a 9–11.5 km quilt on 9 of 18 of
    Monaco's seeds. With the fallback on the pipeline's district only, Monaco's engine verdict over 18 seeds
    (transplant on) was 2.8 mean off of 14 with both shares in range on 11, against 3.5 (11) with it everywhere
    (docs/growth-log.md, session 42). With ``transplant`` off the fallback does nothing."""
    import dataclasses

    from osm_expand.model.options import field_default
    from synth.patches import ExamplePatches

    return dataclasses.replace(field_default(ExamplePatches, "options"), transplant_fallback=False)


def _walk_era() -> Any:
    from osm_expand.model.options import field_default
    from synth.growth import RandomWalk

    return field_default(RandomWalk, "options")


def _colonisation_era() -> Any:
    # the kernel's own defaults, not the pattern's TOWN_OPTIONS: what history eras have always started from
    from synth.colonisation import ColonisationOptions

    return ColonisationOptions()


@dataclass(frozen=True)
class GrowthPatternEntry:
    """One district growth pattern: its name, what ``--help`` says of it, how to make it, its era options."""

    name: str
    #: what ``osm-expand --help`` says of it
    help: str
    #: ``make(example, options)``: the pattern over the town's example; ``options`` None: the pattern's own
    #: defaults (what ``--pattern`` grows)
    make: Callable[[Example, Any], GrowthPattern]
    #: the options a history era starts from before its ``pattern_options`` (the kernel's options class)
    era_options: Callable[[], Any]


#: Every district growth pattern, in ``--help``'s order (the first is the default).
REGISTRY: tuple[GrowthPatternEntry, ...] = (
    GrowthPatternEntry("example", "patches of the town, seams walked; default", _example, _example_era),
    GrowthPatternEntry("walk", "004's random walk over the town's junctions", _walk, _walk_era),
    GrowthPatternEntry("colonisation", "001's space colonisation, the town's junction spacing as segment length",
                       _colonisation, _colonisation_era),
)
#: The patterns' names (``--pattern``'s choices).
PATTERN_NAMES: tuple[str, ...] = tuple(e.name for e in REGISTRY)
#: What ``--help`` says of each.
PATTERN_HELP: dict[str, str] = {e.name: e.help for e in REGISTRY}
_BY_NAME = {e.name: e for e in REGISTRY}


def growth_pattern(name: str) -> GrowthPatternEntry:
    """The registry's entry for ``name``; :class:`~osm_expand.errors.OptionError` listing the valid ones."""
    try:
        return _BY_NAME[name]
    except KeyError:
        raise OptionError(f"pattern must be one of {', '.join(PATTERN_NAMES)}, got {name!r}") from None


def make_pattern(name: str, example: Example, options: Any = None) -> GrowthPattern:
    """The growth pattern ``name`` over the town's ``example`` (with an era's ``options``, or its own)."""
    return growth_pattern(name).make(example, options)


def era_defaults() -> dict[str, Any]:
    """Each pattern's options a history era starts from, by name."""
    return {e.name: e.era_options() for e in REGISTRY}


def pattern_help() -> str:
    """``--pattern``'s help: each pattern with what it does."""
    parts = [f"{name} ({text})" for name, text in PATTERN_HELP.items()]
    return "how streets grow: " + ", ".join(parts[:-1]) + " or " + parts[-1]
