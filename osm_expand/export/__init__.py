"""Writers for the formats osm-expand produces; each writes the whole city, atomically.

Each writer is imported when first used (PEP 562), so ``osm-expand simplify``
loads the OSM writer alone, not the urbanenvironment one and the engine
modules it needs.
"""
__all__ = ["all_or_nothing", "atomic_write", "write_geojson", "write_osm", "write_urbanenvironment"]

#: name → the module that defines it
_LAZY = {"all_or_nothing": "osm_expand.export.atomic", "atomic_write": "osm_expand.export.atomic",
         "write_geojson": "osm_expand.export.geojson", "write_osm": "osm_expand.export.osm",
         "write_urbanenvironment": "osm_expand.export.urban"}


def __getattr__(name: str):
    import importlib

    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'osm_expand.export' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
