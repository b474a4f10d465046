"""osm-expand: grow a real OpenStreetMap town.

The Python API mirrors the command line::

    import osm_expand
    city = osm_expand.load("fixtures/krems.osm.gz")      # the town as mapped
    result = osm_expand.expand(city, osm_expand.ExpandOptions(seed=1))
    osm_expand.export.write_osm(result.city, "krems.expanded.osm")

``simplify.simplify`` and ``synth.grow`` are the stages underneath;
``osm_expand.export`` holds the writers.
"""
from osm_expand import export
from osm_expand.errors import InputError
from osm_expand.ingest import load
from osm_expand.model import Block, Building, City, Origin, Status, Street, StreetNetwork, network_from_lines

__all__ = ["Block", "Building", "City", "ExpandOptions", "ExpandResult", "InputError", "Origin", "Status", "Street",
           "StreetNetwork", "expand", "export", "load", "network_from_lines"]


def __getattr__(name: str):
    # The one lazy import: simplify and synth import this package's model, and the pipeline imports
    # them, so importing the pipeline here eagerly would loop whenever simplify or synth is imported first.
    if name in ("expand", "ExpandOptions", "ExpandResult"):
        from osm_expand import pipeline

        return getattr(pipeline, name)
    raise AttributeError(f"module 'osm_expand' has no attribute {name!r}")
