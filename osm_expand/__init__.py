"""osm-expand: grow a real OpenStreetMap town.

The Python API mirrors the command line::

    import osm_expand
    city = osm_expand.load("fixtures/krems.osm.gz")      # the town as mapped
    result = osm_expand.expand(city, osm_expand.ExpandOptions(seed=1))   # a district grown and joined
    history = osm_expand.load_history("example")        # a bundled name or a TOML file
    grown = osm_expand.mature(result.city, history, osm_expand.MatureOptions(years=30), 1,
                              learned=result.learned, join_points=result.joins.at)   # the years
    osm_expand.export.write_osm(grown.city, "krems.expanded.osm")

``mature`` is one ``osm_expand.engine.loop.step`` per year (City → City);
``simplify.simplify`` and ``synth.grow`` are the stages underneath;
``osm_expand.export`` holds the writers.

Every name is imported when first used (PEP 562): ``import osm_expand`` and
``osm-expand --help`` cost no NumPy, SciPy or Matplotlib, and each command
imports only what it needs. (The lazy pipeline also breaks the import loop
simplify/synth → this package's model → pipeline → simplify/synth.)
"""
from osm_expand.errors import InputError

__all__ = ["Block", "Building", "City", "ExpandOptions", "ExpandResult", "InputError", "Maturation", "MatureOptions",
           "Origin", "Status", "Street", "StreetNetwork", "expand", "export", "load", "load_history", "mature",
           "network_from_lines"]

#: name → the module that defines it
_LAZY = {
    "load": "osm_expand.ingest",
    "expand": "osm_expand.pipeline", "ExpandOptions": "osm_expand.pipeline", "ExpandResult": "osm_expand.pipeline",
    "mature": "osm_expand.maturation", "MatureOptions": "osm_expand.maturation", "Maturation": "osm_expand.maturation",
    "load_history": "osm_expand.engine.history",
    **{name: "osm_expand.model" for name in ("Block", "Building", "City", "Origin", "Status", "Street",
                                             "StreetNetwork", "network_from_lines")},
}


def __getattr__(name: str):
    import importlib

    if name == "export":
        return importlib.import_module("osm_expand.export")
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'osm_expand' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
