"""The OSM output is the input plus what grew, and opens in the tools users have (issue 21, points 16, 17).

Checked by those tools themselves: GDAL's OSM driver through pyogrio (what QGIS and geopandas
use) and pyosmium (libosmium, as the ``osmium`` command line and JOSM's importers read).
"""
from __future__ import annotations

import functools
import itertools
import warnings
from pathlib import Path

import numpy as np
import osmium
import pytest
import shapely
from conftest import FIXTURES

from osm_expand import cli
from osm_expand.clip import box_around, clip
from osm_expand.export import write_osm
from osm_expand.export.features import ORIGIN_KEY
from osm_expand.export.osm import SYNTHETIC_NODE_BASE, laid_over
from osm_expand.ingest import load
from osm_expand.model import demolished_ways
from osm_expand.pipeline import ExpandOptions, expand

pyogrio = pytest.importorskip("pyogrio")
pytest.importorskip("geopandas")

#: GDAL's OSM driver, with its default indexing, refuses node ids from about here on (measured: 2**47 - 65537).
GDAL_NODE_ID_LIMIT = 2**47 - 2**16
KREMS = FIXTURES / "krems.osm.gz"


def objects(path: str | Path) -> dict:
    """Every object of an OSM file by (type, id): (tags without the origin, version, refs or members), and
    each type's ids in file order."""
    out: dict = {"n": {}, "w": {}, "r": {}}
    order: dict = {"n": [], "w": [], "r": []}
    for obj in osmium.FileProcessor(str(path)):
        kind = obj.type_str()
        tags = {t.k: t.v for t in obj.tags if t.k != ORIGIN_KEY}
        if kind == "n":
            body: object = (obj.location.lon, obj.location.lat)
        elif kind == "w":
            body = [n.ref for n in obj.nodes]
        else:
            body = [(m.type, m.ref, m.role) for m in obj.members]
        out[kind][obj.id] = (tags, obj.version, body)
        order[kind].append(obj.id)
    return {**out, "order": order}


def missing_refs(objs: dict) -> tuple[set[int], set[tuple[str, int]]]:
    """What ``osmium check-refs -r`` reports: way nodes and relation members the file lacks."""
    nodes = {r for _, _, refs in objs["w"].values() for r in refs if r not in objs["n"]}
    members = {(t, r) for _, _, ms in objs["r"].values() for t, r, _ in ms if r not in objs[t]}
    return nodes, members


def layer(path: Path | str, name: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # pyogrio's "layer ... is not the first" notes
        return pyogrio.read_dataframe(path, layer=name)


@functools.cache
def default_run(tmp: str) -> Path:
    """Krems, the default command (a district and the default history), as OSM."""
    out = Path(tmp) / "krems.osm"
    assert cli.main([str(KREMS), "-o", str(out), "-q", "--seed", "0"]) == 0
    return out


@pytest.fixture(scope="module")
def krems_osm(tmp_path_factory) -> Path:
    return default_run(str(tmp_path_factory.mktemp("faithful")))


# --------------------------------------------------------------------------- point 16: GDAL, osmium


def test_the_osm_output_opens_in_gdal_with_every_new_street_and_building(krems_osm):
    """GDAL reads the new ways too (it refused ids ≥ 10**15 and dropped what referenced them)."""
    out = objects(krems_osm)
    new_streets = sum(1 for i, (tags, _, _) in out["w"].items() if i < 0 and "highway" in tags)
    new_areas = sum(1 for i, (tags, _, _) in out["w"].items() if i < 0 and ("building" in tags or "landuse" in tags
                                                                           or "leisure" in tags))
    assert new_streets > 20 and new_areas > 20
    lines = layer(krems_osm, "lines")
    assert (lines.osm_id.astype(np.int64) < 0).sum() == new_streets
    polygons = layer(krems_osm, "multipolygons")
    assert (polygons.osm_way_id.dropna().astype(np.int64) < 0).sum() == new_areas
    assert polygons.geometry.is_valid.mean() > 0.99
    assert len(layer(krems_osm, "points")) > 0


def test_node_ids_are_positive_increasing_and_below_gdals_limit(krems_osm):
    nodes = np.array(objects(krems_osm)["order"]["n"], dtype=np.int64)
    assert (nodes > 0).all() and (np.diff(nodes) > 0).all() and nodes.max() < GDAL_NODE_ID_LIMIT
    assert (nodes > SYNTHETIC_NODE_BASE).sum() > 100  # the new nodes, after the input's


def test_new_ways_and_relations_come_first_with_negative_ids_as_osmium_sorts(krems_osm):
    order = objects(krems_osm)["order"]
    for kind in ("w", "r"):
        ids = np.array(order[kind], dtype=np.int64)
        negative = ids < 0
        assert not (negative[1:] & ~negative[:-1]).any()  # no new object after one of the input's
        assert (np.diff(ids[negative]) == -1).all()


def test_the_osm_output_reads_back_with_node_locations_and_areas(krems_osm):
    """pyosmium with a location index and libosmium's multipolygon assembly (which refuses
    unsorted files): every way located, the town's and the new buildings assembled."""
    ways = areas = 0
    fp = osmium.FileProcessor(str(krems_osm)).with_locations().with_areas()
    for obj in fp:
        if obj.is_way():
            ways += 1
            assert all(n.location.valid() for n in obj.nodes), obj.id
        elif obj.is_area():
            areas += 1
    assert ways and areas > 1000


# --------------------------------------------------------------------------- point 17: the input plus what grew


def assert_input_plus_growth(src: dict, out: dict, gone: frozenset[int] = frozenset(),
                             cut: frozenset[int] = frozenset()) -> None:
    """Every object of ``src`` in ``out`` (but the demolished ways) with its tags, version and order; the
    mapped ways' nodes as mapped (but those ``cut``), with only new nodes put in; nothing missing that
    the input has."""
    for kind in "nwr":
        lost = set(src[kind]) - set(out[kind]) - (gone if kind == "w" else set())
        assert not lost, (kind, sorted(lost)[:5])
        for i, (tags, version, _) in src[kind].items():
            if i in out[kind]:
                assert out[kind][i][0] == tags and out[kind][i][1] == (version or 1), (kind, i)
        kept = [i for i in out["order"][kind] if i in src[kind]]
        assert kept == [i for i in src["order"][kind] if i in out[kind]]
    for i, (_, _, refs) in src["w"].items():
        if i in out["w"] and i not in cut:
            assert [r for r in out["w"][i][2] if r in src["n"] or r < SYNTHETIC_NODE_BASE] == refs, i
    for i, (_, _, members) in src["r"].items():
        assert out["r"][i][2] == [m for m in members if not (m[0] == "w" and m[1] in gone)], i
    nodes, members = missing_refs(out)
    src_nodes, src_members = missing_refs(src)
    assert nodes <= src_nodes and members <= src_members | {("w", w) for w in gone}


def test_the_osm_output_is_the_input_plus_what_grew(krems_osm):
    """All 2,402 ways, 73 relations and 15,042 nodes of Krems (843 ways, every relation and 6,458
    nodes were lost before), each as mapped."""
    src, out = objects(KREMS), objects(krems_osm)
    assert (len(src["n"]), len(src["w"]), len(src["r"])) == (15042, 2402, 73)
    assert_input_plus_growth(src, out)
    assert not missing_refs(out)[0]  # osmium check-refs: no way refers to a node the file lacks


def test_a_clipped_run_gives_back_the_whole_extract(tmp_path):
    """With ``--around`` the extract is the input: all of it comes back, plus the district."""
    box = box_around(15.6086, 48.4116, 1500)
    extract = clip(KREMS, {"town": box}, tmp_path)["town"]
    out = tmp_path / "clipped.osm"
    code = cli.main([str(KREMS), "--around", "15.6086,48.4116", "--radius", "1500", "--years", "0", "-o", str(out),
                     "-q"])
    assert code == 0
    src, written = objects(extract), objects(out)
    assert_input_plus_growth(src, written)
    assert any(i < 0 for i in written["w"])
    assert not list(tmp_path.glob(".osm-expand-clip-*"))  # the extract is gone once written


def test_demolished_ways_are_left_out_and_reported(tmp_path):
    """A way the city no longer holds (a history demolished it) is the only thing missing, and
    relations lose it as a member."""
    city = load(KREMS)
    result = expand(city, ExpandOptions(seed=0, fidelity=False))
    net = result.city.network
    src = objects(KREMS)
    member_ways = {r for _, _, ms in src["r"].values() for t, r, _ in ms if t == "w"}
    victim = next(s.osm_ids[0] for s in net.streets if s.osm_ids and s.osm_ids[0] in member_ways
                  and sum(1 for t in net.streets if t.osm_ids == s.osm_ids) == 1)
    # and one cut in two: its middle stretch demolished (a rebuilding road on the old town)
    cut_k = next(k for k, s in enumerate(net.streets) if len(s.nodes) >= 6 and s.osm_ids and s.osm_ids[0] != victim
                 and sum(1 for t in net.streets if t.osm_ids == s.osm_ids) == 1)
    cut = net.streets[cut_k]
    halves = (cut.with_nodes(cut.nodes[:3]), cut.with_nodes(cut.nodes[4:]))
    streets = [s for k, s in enumerate(net.streets) if s.osm_ids != (victim,) and k != cut_k] + list(halves)
    razed = result.city.replace(network=net.replace(streets=tuple(streets)))
    assert demolished_ways(razed) == [victim] and demolished_ways(result.city) == []
    write_osm(razed, tmp_path / "razed.osm")
    out = objects(tmp_path / "razed.osm")
    assert victim not in out["w"]
    ids = net.node_ids
    gone_edge = {int(ids[cut.nodes[2]]), int(ids[cut.nodes[3]])}
    assert out["w"][cut.osm_ids[0]][2] == ids[list(cut.nodes[:3])].tolist()  # the first half keeps the id
    assert not any(gone_edge <= set(zip_) for _, _, refs in out["w"].values() for zip_ in itertools.pairwise(refs))
    assert [refs for i, (_, _, refs) in out["w"].items() if i < 0 and refs == ids[list(cut.nodes[4:])].tolist()]
    assert_input_plus_growth(src, out, gone=frozenset({victim}), cut=frozenset(cut.osm_ids))


def test_a_street_is_laid_back_onto_its_mapped_way():
    refs = [1, 2, 3, 4, 5, 6]
    assert laid_over(refs, [[1, 2, -1, 3, 4, 5, 6]]) == [1, 2, -1, 3, 4, 5, 6]  # a tee put in
    assert laid_over(refs, [[2, 3], [4, -2, 5]]) == [1, 2, 3, 4, -2, 5, 6]  # cut at gaps, ends kept
    assert laid_over(refs, [[1, 2, 3], [3, -1, 4]]) == [1, 2, 3, -1, 4, 5, 6]  # parts sharing a node
    assert laid_over(refs, [[3, -1, 2]]) == [1, 2, -1, 3, 4, 5, 6]  # held reversed
    assert laid_over(refs, [[1, 9]]) is None and laid_over(refs, [[-1, 2, 3]]) is None
    # a gap of the extract (3, 4 missing) is kept; a stretch between two nodes the file has is not
    gap = [True, True, False, False, True, True]
    assert laid_over(refs, [[1, 2], [5, 6]], gap) == refs
    assert laid_over(refs, [[1, 2, 3], [4, 5, 6]], [True] * 6) is None  # 3-4 demolished
    assert laid_over(refs, [[2, -1, 3, 4, 5, 6]], [True] * 6) is None  # 1-2 demolished


def test_an_output_grown_again_keeps_its_new_objects_and_their_ids(krems_osm, tmp_path):
    """The output fed back in (the next tool may be osm-expand itself): its negative ids and new nodes
    come back as they were, and the newer objects get ids of their own."""
    out = tmp_path / "again.osm"
    assert cli.main([str(krems_osm), "--years", "0", "-o", str(out), "-q", "--seed", "1"]) == 0
    src, again = objects(krems_osm), objects(out)
    assert_input_plus_growth(src, again)
    for kind in "nwr":
        assert len(set(again["order"][kind])) == len(again["order"][kind])  # no id twice
    assert len(again["w"]) > len(src["w"]) and min(again["w"]) < min(src["w"])
    lines = layer(out, "lines")
    assert (lines.osm_id.astype(np.int64) < 0).sum() > (layer(krems_osm, "lines").osm_id.astype(np.int64) < 0).sum()


def test_the_simplified_network_opens_in_gdal(tmp_path):
    """``osm-expand simplify`` writes the simplified streets alone (no source to give back): GDAL reads
    every way, the nodes the simplifier made included."""
    out = tmp_path / "s.osm"
    assert cli.main(["simplify", str(KREMS), "-o", str(out), "-q"]) == 0
    objs = objects(out)
    nodes = np.array(objs["order"]["n"], dtype=np.int64)
    assert (np.diff(nodes) > 0).all() and nodes.max() < GDAL_NODE_ID_LIMIT
    assert len(layer(out, "lines")) == len(objs["w"])
    assert not missing_refs(objs)[0]


def test_gdal_reads_every_feature_of_the_input_back_as_it_reads_the_input(krems_osm):
    """What QGIS shows of the town is unchanged: each of GDAL's layers holds every feature it reads from
    the input, with the same attributes (an origin tag on an old-style multipolygon, whose tags are on
    its outer way, once made GDAL lose its ``building``)."""
    for name in ("points", "lines", "multipolygons"):
        src, out = layer(f"/vsigzip/{KREMS}", name), layer(krems_osm, name)
        for df in (src, out):
            way = "/" + df.osm_way_id.fillna("").astype(str) if "osm_way_id" in df else ""
            df.index = df.osm_id.fillna("").astype(str) + way
        assert set(src.index) <= set(out.index), name
        columns = [c for c in src.columns if c not in ("other_tags", "geometry")]
        mine = out.loc[src.index, columns]
        assert mine.fillna("").equals(src[columns].fillna("")), name
        # the same shapes, but for the junction nodes the tool put on the town's streets (within 10 cm)
        assert (shapely.hausdorff_distance(out.loc[src.index].geometry.values, src.geometry.values) < 1e-6).all()
