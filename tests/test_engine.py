"""The year loop on a real town: what the engine adds keeps the town whole, dry, planar and dated.

One Krems run per history is shared by the tests (module-scoped): the
``european`` history for 20 years (the medieval lanes and the first years of
the 19th-century grid), and the default ``example`` history for its own
30 years. The hand-built checks of each step (proposals, acceptance rules,
Algorithm 2, turn penalties, smoothing, rerouting, B, fallback neighbours)
are in test_patterns, test_traffic, test_majorroads and test_history.
"""
from __future__ import annotations

import functools
import json

import numpy as np
import pytest
import shapely

from osm_expand import cli
from osm_expand.engine.history import load_history
from osm_expand.ingest import load
from osm_expand.joins import MAX_BRIDGE
from osm_expand.model import Origin, Status
from osm_expand.model.segments import is_major
from osm_expand.pipeline import ExpandOptions, expand
from tests.conftest import FIXTURES, expanded_and_matured

KREMS = FIXTURES / "krems.osm.gz"
EUROPEAN_YEARS = 20
ERA_KEYS = {"era", "years", "streets_grown", "trips", "routes_over_capacity", "routes_at_capacity", "major_roads_built",
            "bridges_built", "buildings_built", "lots_made"}


@functools.lru_cache(maxsize=None)
def town():
    return load(KREMS)


@functools.lru_cache(maxsize=None)
def matured(history: str, years: int | None):
    return expanded_and_matured(town(), seed=0, history=history, years=years)


def runs():
    return [("european", EUROPEAN_YEARS), ("example", None)]


def _segments(net):
    segs, owner = [], []
    for k, s in enumerate(net.streets):
        for a, b in zip(s.nodes[:-1], s.nodes[1:]):
            segs.append((a, b))
            owner.append(k)
    return np.array(segs), np.array(owner)


@pytest.mark.parametrize("history,years", runs())
def test_streets_cross_only_at_shared_nodes_or_on_other_layers(history, years):
    net = matured(history, years).city.network
    segs, owner = _segments(net)
    lines = shapely.linestrings(net.xy[segs])
    length = shapely.length(lines)
    assert length.min() > 0.0  # no zero-length segment
    left, right = shapely.STRtree(lines).query(lines, predicate="intersects")
    keep = left < right
    for i, j in zip(left[keep].tolist(), right[keep].tolist()):
        if set(segs[i]) & set(segs[j]):
            assert {*segs[i]} != {*segs[j]}, "two streets on one segment"
            continue
        a, b = net.streets[owner[i]], net.streets[owner[j]]
        assert a.layer_key != b.layer_key, (a.id, b.id)


@pytest.mark.parametrize("history,years", runs())
def test_the_towns_own_streets_and_buildings_are_all_still_there(history, years):
    before, after = town(), matured(history, years).city
    assert not load_history(history).rebuild_old_town
    old = {s.id: s for s in before.network.streets}
    kept = {s.id: s for s in after.network.streets if s.origin == Origin.SOURCE}
    assert set(old) <= set(kept)
    for sid, s in old.items():
        t = kept[sid]
        assert t.osm_ids == s.osm_ids and t.highway in (s.highway, "primary", "secondary", "tertiary")
        # the mapped geometry is kept: every mapped point is still on the street (new tees may be added)
        got = after.network.xy[list(t.nodes)]
        want = before.network.xy[list(s.nodes)]
        assert len(got) >= len(want)
        assert np.abs(got[[0, -1]] - want[[0, -1]]).max() < 1e-6
    ids = {b.osm_id for b in after.buildings if b.origin == Origin.SOURCE}
    assert ids >= {b.osm_id for b in before.buildings}


@pytest.mark.parametrize("history,years", runs())
def test_everything_the_engine_made_has_a_year_an_era_and_stays_dry(history, years):
    result = matured(history, years)
    report = result.report["engine"]
    eras = {e.name for e in load_history(history).eras}
    first, last = report["first_year"], report["last_year"]
    net, water = result.city.network, town().water_geometry()
    engine = [s for s in net.streets if s.origin == Origin.ENGINE]
    assert engine, "the engine grew nothing"
    for s in engine:
        assert first <= s.year <= last and s.era in eras
        assert s.status in (Status.BUILT, Status.PLANNED) and s.width and s.width > 0
        wet = shapely.LineString(net.street_xy(s)).intersection(water).length
        # a street that touches the water's edge meets it in a point, which GEOS may return as a line of
        # 1e-13 m (Krems, default history: an engine district's street of 2024): dry, to a millimetre
        assert wet <= 1e-3 or (s.bridge and wet <= MAX_BRIDGE + 10.0), (s.id, wet)
    made = [b for b in result.city.buildings if b.origin == Origin.ENGINE]
    assert made and all(first <= b.year <= last for b in made)
    footprints = shapely.polygons([b.ring for b in made])
    assert not shapely.intersects(footprints, water).any()


@pytest.mark.parametrize("history,years", runs())
def test_the_report_has_every_era_with_its_counts(history, years):
    report = matured(history, years).report["engine"]
    assert report["history"] == history
    assert report["last_year"] - report["first_year"] + 1 == report["years"]
    covered = [y for era in report["eras"] for y in range(era["years"][0], era["years"][1] + 1)]
    assert covered == list(range(report["first_year"], report["last_year"] + 1))
    for era in report["eras"]:
        assert ERA_KEYS <= set(era), ERA_KEYS - set(era)
        assert era["trips"] >= 0 and era["routes_over_capacity"] >= 0
    assert sum(e["streets_grown"] for e in report["eras"]) > 0
    json.dumps(report)  # the --json report


def test_the_european_history_passes_from_organic_lanes_to_the_grid():
    report = matured("european", EUROPEAN_YEARS).report["engine"]
    grown = {e["era"]: e["streets_grown"] for e in report["eras"]}
    assert list(grown) == ["medieval", "gruenderzeit"]
    assert grown["gruenderzeit"] > grown["medieval"] > 0  # G(t) rises fivefold with the industrial era


def test_the_default_history_builds_a_major_road_in_krems():
    report = matured("example", None).report["engine"]
    assert report["years"] == load_history("example").years
    built = sum(n for e in report["eras"] for n in e["major_roads_built"].values())
    assert built >= 1
    # the road is new stretches or minor streets made major (Krems: 0.83 km of minor streets upgraded)
    assert sum(e["major_road_length_km"] + e["major_road_upgraded_km"] for e in report["eras"]) > 0.1
    majors = [s for s in matured("example", None).city.network.streets
              if s.origin == Origin.ENGINE and is_major(s)]
    assert majors and all(s.width >= 11.0 for s in majors)  # two lanes and sidewalks at least


def test_expand_grows_the_district_and_leaves_the_years_to_mature():
    result = expand(town(), ExpandOptions(seed=0, fidelity=False))
    assert "engine" not in result.report
    assert not [s for s in result.city.network.streets if s.origin == Origin.ENGINE]


def test_the_same_seed_writes_the_same_bytes(tmp_path):
    outs = []
    for k in range(2):
        out = tmp_path / f"run{k}.xml"
        assert cli.main([str(KREMS), "-o", str(out), "--history", "european", "--years", "3", "-q"]) == 0
        outs.append(out.read_bytes())
    assert outs[0] == outs[1]
    assert b'origin="engine"' in outs[0]


def test_snapshots_one_picture_per_era_and_every_n_years(tmp_path, capsys):
    per_era = tmp_path / "eras"
    code = cli.main([str(KREMS), "-o", str(tmp_path / "a.xml"), "--history", "european", "--years", "17",
                     "--snapshots", str(per_era), "-q", "--json"])
    assert code == 0
    report = json.loads(capsys.readouterr().out)
    pictures = sorted(p.name for p in per_era.glob("*.png"))
    assert len(pictures) == 2 and "medieval" in pictures[0] and "gruenderzeit" in pictures[1]
    assert all((per_era / p).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pictures)
    assert len(report["snapshots"]) == 2
    every = tmp_path / "every"
    assert cli.main([str(KREMS), "-o", str(tmp_path / "b.xml"), "--years", "4", "--snapshots", str(every),
                     "--snapshot-every", "2", "-q"]) == 0
    assert len(list(every.glob("*.png"))) == 2


def one_line_error(capsys) -> str:
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip() and not ln.startswith("[")]
    assert len(err) == 1, err
    return err[0]


@pytest.mark.parametrize("args,message", [
    (["--history", "byzantine"], "byzantine"),
    (["--years", "-3"], "--years"),
    (["--years", "ten"], "--years"),
    (["--snapshot-every", "0", "--snapshots", "SNAPS"], "--snapshot-every"),
    (["--snapshot-every", "5"], "--snapshots"),
])
def test_bad_engine_options_exit_2_with_one_line_and_no_output(tmp_path, capsys, args, message):
    out = tmp_path / "out.xml"
    args = [str(tmp_path / "snaps") if a == "SNAPS" else a for a in args]
    assert cli.main([str(KREMS), "-o", str(out), *args]) == 2
    assert message in one_line_error(capsys)
    assert not out.exists()


def test_a_bad_history_file_names_its_key(tmp_path, capsys):
    bad = tmp_path / "mine.toml"
    bad.write_text('name = "mine"\nstart = 0\nyears = "many"\n[[eras]]\nname = "a"\nstart = 0\npattern = "grid"\n')
    out = tmp_path / "out.xml"
    assert cli.main([str(KREMS), "-o", str(out), "--history", str(bad)]) == 2
    line = one_line_error(capsys)
    assert "mine.toml" in line and "years" in line
    assert not out.exists()
