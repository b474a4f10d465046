"""Histories: the eras and time functions a city lives through (003 §3.1, 000 §4.2.9, 002 §4).

Two modules: :mod:`~osm_expand.engine.history.model` holds the history (eras,
time functions, the clock, the values of a year) and
:mod:`~osm_expand.engine.history.reader` reads one from TOML
(``docs/histories.md``). Every public name of both is importable from here,
as it was when they were one module.
"""
from osm_expand.engine.history.model import (
    DEFAULT_HISTORY,
    DEFAULT_YEARS,
    GROWTH_PATTERNS,
    MAX_YEARS,
    Anchor,
    Clock,
    Era,
    History,
    KernelOptions,
    PatternSettings,
    YearValues,
)
from osm_expand.engine.history.reader import MAX_HISTORY_BYTES, bundled, history_from_mapping, load_history

__all__ = [
    "Anchor", "Clock", "DEFAULT_HISTORY", "DEFAULT_YEARS", "MAX_HISTORY_BYTES", "MAX_YEARS", "Era", "GROWTH_PATTERNS",
    "History", "KernelOptions", "PatternSettings", "YearValues", "bundled", "history_from_mapping", "load_history",
]
