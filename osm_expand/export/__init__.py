"""Writers for the formats osm-expand produces; each writes the whole city, atomically."""
from osm_expand.export.atomic import all_or_nothing, atomic_write
from osm_expand.export.geojson import write_geojson
from osm_expand.export.osm import write_osm
from osm_expand.export.urban import write_urbanenvironment

__all__ = ["all_or_nothing", "atomic_write", "write_geojson", "write_osm", "write_urbanenvironment"]
