"""osm-expand: grow a real OpenStreetMap town.

The Python API mirrors the command line::

    from osm_expand import load, expand
    result = expand(load("fixtures/krems.osm.gz"))

``simplify.simplify`` and ``synth.grow`` are the stages underneath;
``osm_expand.export`` holds the writers.
"""
from osm_expand.errors import InputError
from osm_expand.ingest import load
from osm_expand.model import Street, StreetNetwork, network_from_lines

__all__ = ["ExpandOptions", "ExpandResult", "InputError", "Street", "StreetNetwork", "expand", "load",
           "network_from_lines"]

_PIPELINE = {"expand", "ExpandOptions", "ExpandResult"}


def __getattr__(name: str):
    # simplify and synth build on this package's model; the pipeline that uses them is
    # imported on first use, so importing either of them never loops back here
    if name in _PIPELINE:
        from osm_expand import pipeline

        return getattr(pipeline, name)
    raise AttributeError(f"module 'osm_expand' has no attribute {name!r}")
