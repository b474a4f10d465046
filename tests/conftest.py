"""Shared fixtures: the real OSM extracts, loaded and simplified once per session."""
from __future__ import annotations

import os
from functools import lru_cache
from pathlib import Path

import pytest
from hypothesis import settings

from osm_expand.ingest import load
from osm_expand.model import StreetNetwork
from simplify import SimplifyResult, simplify

# no per-example deadline: CI shares a 2-core machine, and a first example that waits for the CPU
# (or for a lazy import) is not a slow algorithm; the examples' count bounds the time instead
settings.register_profile("default", max_examples=100, deadline=None)
settings.register_profile("thorough", max_examples=2000, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))

FIXTURES = Path(__file__).resolve().parent.parent / "fixtures"
#: Fixtures with a drivable network that survives simplification.
TOWNS = ["krems.osm.gz", "campo-grande.osm.gz", "monaco.osm.gz", "andorra.osm.pbf",
         "north-bayreuth.osm.gz", "berlin-siegessaeule.osm.gz", "bautzen.osm", "West-Oakland.osm.bz2"]
ALL = TOWNS + ["circle-bug.osm.gz"]


@lru_cache(maxsize=None)
def loaded(name: str, service: bool = False) -> StreetNetwork:
    return load(FIXTURES / name, service=service, context=False).network


@lru_cache(maxsize=None)
def simplified(name: str, service: bool = False) -> SimplifyResult:
    return simplify(loaded(name, service))


@pytest.fixture
def fixtures_dir() -> Path:
    return FIXTURES


def pytest_terminal_summary(terminalreporter):
    """The fuzz suite's exit codes (tests/test_fuzz.py), when it ran."""
    import sys

    fuzz = sys.modules.get("tests.test_fuzz") or sys.modules.get("test_fuzz")
    if fuzz is None or not fuzz.EXIT_CODES:
        return
    counts = fuzz.EXIT_CODES
    tests = sorted({t for t, _ in counts})
    terminalreporter.section("fuzz: exit codes")
    for t in tests:
        row = {c: n for (name, c), n in counts.items() if name == t}
        terminalreporter.write_line(f"{t:>10}: " + ", ".join(f"exit {c}: {n}" for c, n in sorted(row.items())))
    total = sum(counts.values())
    by_code: dict[int, int] = {}
    for (_, c), n in counts.items():
        by_code[c] = by_code.get(c, 0) + n
    terminalreporter.write_line(f"{'all':>10}: {total} cases; "
                                + ", ".join(f"exit {c}: {n}" for c, n in sorted(by_code.items())))


def notes_only(err: str) -> bool:
    """Is every line of ``err`` one of the notes a successful run prints (the district grew beyond the
    map's bounds, or was joined across the town's presumed frontage), and nothing else?"""
    from osm_expand.pipeline import NOTES

    return all(line.startswith("osm-expand: ") and line.endswith(NOTES) for line in err.splitlines())


def expanded_and_matured(city, *, seed: int = 0, history: str = "example", years: int | None = None,
                         fidelity: bool = False, **options):
    """``expand`` then ``mature``, as the command line runs them: the expand result with the city after the
    years and the two reports merged (the command line's report)."""
    from osm_expand.engine.history import load_history
    from osm_expand.maturation import MatureOptions, mature_result
    from osm_expand.pipeline import ExpandOptions, expand

    result = expand(city, ExpandOptions(seed=seed, fidelity=fidelity, **options))
    return mature_result(result, load_history(history), MatureOptions(years=years, fidelity=fidelity), seed)
