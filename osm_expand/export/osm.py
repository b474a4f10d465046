"""OSM XML output, readable by osmium and JOSM.

Original nodes and ways keep their ids. Ways that are not a single original
way get negative ids, as JOSM expects for new objects. New *nodes* cannot:
libosmium's node-location index ignores negative ids, so ways over them
could not be read back by osmium. They are numbered from
:data:`SYNTHETIC_NODE_BASE` instead, and the file says ``upload="never"`` so
JOSM will not send them to the OSM server as if they were real.
"""
from __future__ import annotations

import os

from lxml import etree

from osm_expand.export.atomic import atomic_write
from osm_expand.export.features import lonlat_of_used, street_tags
from osm_expand.model import StreetNetwork

GENERATOR = "osm-expand"
SYNTHETIC_NODE_BASE = 10**15


def write_osm(net: StreetNetwork, path: str | os.PathLike) -> None:
    used, lonlat = lonlat_of_used(net)
    node_id = _node_ids(net, used)
    with atomic_write(path, "wb") as fh, etree.xmlfile(fh, encoding="UTF-8") as xf:
        xf.write_declaration()
        with xf.element("osm", version="0.6", generator=GENERATOR, upload="never"):
            lon0, lat0, lon1, lat1 = net.context.bounds_lonlat
            xf.write(etree.Element("bounds", minlat=f"{lat0:.7f}", minlon=f"{lon0:.7f}",
                                   maxlat=f"{lat1:.7f}", maxlon=f"{lon1:.7f}"))
            for i, (lon, lat) in zip(used.tolist(), lonlat):
                xf.write(etree.Element("node", id=str(node_id[i]), version="1",
                                       lat=f"{lat:.7f}", lon=f"{lon:.7f}"))
            for way_id, street in zip(_way_ids(net), net.streets):
                way = etree.Element("way", id=str(way_id), version="1")
                for n in street.nodes:
                    etree.SubElement(way, "nd", ref=str(node_id[n]))
                for k, v in street_tags(street).items():
                    etree.SubElement(way, "tag", k=k, v=v)
                xf.write(way)


def _node_ids(net: StreetNetwork, used) -> dict[int, int]:
    ids, new = {}, SYNTHETIC_NODE_BASE
    for i in used.tolist():
        osm_id = int(net.node_ids[i])
        if osm_id > 0:
            ids[i] = osm_id
        else:
            new += 1
            ids[i] = new
    return ids


def _way_ids(net: StreetNetwork) -> list[int]:
    """A street made of exactly one original way, the first to claim it, keeps that id."""
    seen, out, new = set(), [], 0
    for s in net.streets:
        if len(s.osm_ids) == 1 and s.osm_ids[0] > 0 and s.osm_ids[0] not in seen:
            seen.add(s.osm_ids[0])
            out.append(s.osm_ids[0])
        else:
            new -= 1
            out.append(new)
    return out
