"""Batches of towns on Dask, and clipping towns out of a large input at read time.

The batch tests run the whole pipeline per job, on the small fixtures with
``--area 200000 --beyond-bounds``; each job's output must be byte for byte
the single command's with the job's derived seed.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import osmium
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from osm_expand import cli
from osm_expand.batch import (
    INSTALL_HINT,
    Job,
    JobResult,
    JobsFailed,
    add_batch_arguments,
    cmd_batch,
    derive_seed,
    read_towns,
    run_batch,
)
from osm_expand.batch.cluster import _gather, _local_cluster
from osm_expand.clip import ClipOptions, box_around, check_box, clip, clip_extracts, parse_bbox
from osm_expand.clip.boxes import _Boxes
from osm_expand.errors import InputError
from osm_expand.ingest import load
from tests.conftest import FIXTURES

REPO = Path(__file__).resolve().parent.parent
PIPELINE = ["--area", "200000", "--beyond-bounds", "--years", "0"]
THREE = ["monaco.osm.gz", "berlin-siegessaeule.osm.gz", "West-Oakland.osm.bz2"]  # the quickest fixtures to grow
SEED = 7
KREMS = FIXTURES / "krems.osm.gz"
KREMS_CENTRE = (15.6097, 48.4104)


def single_run(src: Path, out: Path, seed: int) -> bytes:
    """What ``osm-expand SRC -o OUT --seed SEED --area 200000 --beyond-bounds -q`` writes."""
    assert cli.main([str(src), "-o", str(out), "--seed", str(seed), *PIPELINE, "-q"]) == 0
    return out.read_bytes()


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> dict[str, bytes]:
    """The three fixtures run alone, each with the seed the batch derives for it."""
    out = tmp_path_factory.mktemp("single")
    return {name: single_run(FIXTURES / name, out / f"{name}.xml", derive_seed(SEED, name.split(".")[0]))
            for name in THREE}


def assert_matches_reference(out: Path, reference: dict[str, bytes]) -> None:
    summary = json.loads((out / "summary.json").read_text())
    assert summary["jobs_ok"] == 3 and summary["jobs_failed"] == 0
    for name in THREE:
        stem = name.split(".")[0]
        job = next(j for j in summary["jobs"] if j["name"] == stem)
        assert job["status"] == "ok" and job["seed"] == derive_seed(SEED, stem)
        assert job["outputs"] == [str(out / f"{stem}.expanded.xml")]
        assert (out / f"{stem}.expanded.xml").read_bytes() == reference[name], stem
        assert job["counts"]["grown_streets"] > 0 and job["counts"]["source_streets"] > 0
        assert "reading" in (out / "logs" / f"{stem}.log").read_text()  # the job's own stderr


def batch_main(argv: list[str]) -> tuple[int, dict]:
    """``osm-expand batch ARGV`` as the main command runs it (exit 2 when a job failed), and summary.json."""
    parser = argparse.ArgumentParser(prog="osm-expand batch")
    add_batch_arguments(parser)
    args = parser.parse_args([str(a) for a in argv])
    try:
        cmd_batch(args, lambda message: None)
        code = 0
    except JobsFailed as exc:
        code = exc.exit_code
    return code, json.loads((Path(args.out) / "summary.json").read_text())


# --- the three quoted tests ----------------------------------------------------------------------------


def _dask(*args: str) -> list[str]:
    script = Path(sys.executable).with_name("dask")
    return [str(script), *args] if script.exists() else [sys.executable, "-m", "dask", *args]


def test_batch_on_a_running_dask_cluster_matches_single_runs(tmp_path, reference):
    from distributed import Client

    scheduler_file = tmp_path / "scheduler.json"
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    procs = []
    try:
        procs.append(subprocess.Popen(_dask("scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                                            "--scheduler-file", str(scheduler_file)),
                                      cwd=tmp_path, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        deadline = time.monotonic() + 60
        while not scheduler_file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        for k in range(2):
            procs.append(subprocess.Popen(_dask("worker", "--scheduler-file", str(scheduler_file), "--nthreads", "1",
                                                "--host", "127.0.0.1", "--no-dashboard", "--name", f"w{k}"),
                                          cwd=tmp_path, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        address = json.loads(scheduler_file.read_text())["address"]
        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
        out = tmp_path / "out"
        code, _ = batch_main([*(FIXTURES / n for n in THREE), "--out", out, "--scheduler", address,
                              "--seed", SEED, *PIPELINE, "-q"])
        assert code == 0
        assert_matches_reference(out, reference)
        with Client(address, timeout="30s") as client:  # the user's cluster is still up, its workers too
            assert len(client.scheduler_info()["workers"]) == 2
    finally:
        for proc in reversed(procs):
            proc.terminate()
        for proc in reversed(procs):
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def test_batch_on_the_default_local_cluster_matches_single_runs(tmp_path, reference):
    out = tmp_path / "out"
    summary = run_batch([FIXTURES / n for n in THREE], out, workers=2, seed=SEED, pipeline_args=PIPELINE,
                        progress=True)
    assert summary.where == "a local cluster of 2 workers" and not summary.failed
    assert_matches_reference(out, reference)


def test_one_bad_input_fails_alone_and_the_batch_exits_non_zero(tmp_path):
    good = []
    for name in ("a", "b", "c"):
        good.append(tmp_path / f"{name}.osm.bz2")
        shutil.copy(FIXTURES / "West-Oakland.osm.bz2", good[-1])
    bad = tmp_path / "broken.osm"
    bad.write_text("<osm version='0.6'><node id='1' lat='48.0' lon='15.0'/>")  # cut off: not a readable file
    out = tmp_path / "out"
    code, summary = batch_main([*good, bad, "--out", out, "--workers", "2", *PIPELINE, "--json"])
    assert code == 2  # the failure was the input's
    assert code != 0
    assert (summary["jobs_ok"], summary["jobs_failed"]) == (3, 1)
    status = {j["name"]: j for j in summary["jobs"]}
    assert [j["name"] for j in summary["jobs"]] == ["a", "b", "broken", "c"]  # by name
    assert status["broken"]["status"] == "failed" and status["broken"]["exit_code"] == 2
    assert status["broken"]["error"].startswith(f"{bad}: ") and "\n" not in status["broken"]["error"]
    assert status["broken"]["outputs"] == [] and not (out / "broken.expanded.xml").exists()
    for name in ("a", "b", "c"):
        assert status[name]["status"] == "ok" and (out / f"{name}.expanded.xml").stat().st_size > 0
        assert set(status[name]) >= {"seconds", "counts", "outputs", "seed", "log", "error"}
    # different names, different seeds: the same town grows differently
    assert len({(out / f"{n}.expanded.xml").read_bytes() for n in "abc"}) == 3


# --- more of the batch ---------------------------------------------------------------------------------


def test_derived_seeds_are_stable_across_processes_and_hash_seeds():
    names = ["krems", "Zürich", "a b", ""]
    here = [derive_seed(3, n) for n in names]
    assert here[0] == derive_seed(3, "krems") != derive_seed(4, "krems") and all(0 <= s < 2 ** 31 for s in here)
    assert derive_seed(0, "krems") == 860260781  # pinned: changing the derivation changes every batch's outputs
    code = f"from osm_expand.batch import derive_seed; print([derive_seed(3, n) for n in {names!r}])"
    for hash_seed in ("0", "1", "4242"):
        out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True,
                             env={**os.environ, "PYTHONHASHSEED": hash_seed, "PYTHONPATH": str(REPO)}).stdout
        assert json.loads(out) == here


def test_without_dask_one_worker_runs_here_and_more_say_how_to_install(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # as if Dask were not installed
    src = FIXTURES / "West-Oakland.osm.bz2"
    with pytest.raises(InputError, match=r"needs Dask: pip install 'osm-expand\[cluster\]'"):
        run_batch([src], tmp_path / "x", pipeline_args=PIPELINE)
    with pytest.raises(InputError, match="needs Dask"):
        run_batch([src], tmp_path / "x", workers=2, pipeline_args=PIPELINE)
    assert INSTALL_HINT in str(pytest.raises(InputError, run_batch, [src], tmp_path / "x", scheduler="tcp://x:1").value)
    summary = run_batch([src], tmp_path / "out", workers=1, seed=SEED, pipeline_args=PIPELINE)
    assert summary.where == "this process" and not summary.failed
    expected = single_run(src, tmp_path / "single.xml", derive_seed(SEED, "West-Oakland"))
    assert (tmp_path / "out" / "West-Oakland.expanded.xml").read_bytes() == expected


def _die_on_boom(job: Job) -> JobResult:
    if job.name == "boom":
        os._exit(1)  # the worker dies under the job, as when the system kills it for memory
    return JobResult(name=job.name, input=job.input, status="ok", seconds=0.0, seed=job.seed)


def test_a_worker_dying_under_a_job_fails_that_job_only(tmp_path):
    from distributed import Client

    jobs = [Job(name=n, input="in", output="out", log=str(tmp_path / f"{n}.log"), seed=1) for n in ("a", "boom", "c")]
    cluster = _local_cluster(2)
    try:
        with Client(cluster) as client:
            results = {r.name: r for r in _gather(client, jobs, False, task=_die_on_boom)}
    finally:
        cluster.close()
    assert results["a"].status == results["c"].status == "ok"
    assert results["boom"].status == "failed" and "worker died" in results["boom"].error


def test_a_towns_table_clips_the_input_once_and_runs_a_job_per_town(tmp_path, monkeypatch):
    import osm_expand.clip as clip_module

    calls = []
    real = clip_module.clip_extracts

    def counting(path, boxes, out_dir, **kw):
        result = real(path, boxes, out_dir, **kw)
        calls.append((Path(path).name, sorted(boxes), result.reads))
        return result

    monkeypatch.setattr(clip_module, "clip_extracts", counting)
    towns = tmp_path / "towns.csv"
    towns.write_text("name,lon,lat,radius,note\n"
                     f"centre,{KREMS_CENTRE[0]},{KREMS_CENTRE[1]},900,old town\n"
                     "east,15.6250,48.4100,800,\n"
                     "far away,2.35,48.85,1000,Paris is not in the file\n")
    out = tmp_path / "out"
    summary = run_batch([KREMS], out, towns=towns, workers=1, seed=SEED, pipeline_args=PIPELINE)
    assert len(calls) == 1 and calls[0][1] == ["centre", "east", "far away"]  # one clip for all towns
    one = real(KREMS, {"centre": box_around(*KREMS_CENTRE, 900)}, tmp_path)
    assert calls[0][2] == one.reads  # as many reads of the file for three towns as for one
    jobs = {j.name: j for j in summary.jobs}
    assert jobs["far away"].status == "failed" and "box of far away" in jobs["far away"].error
    assert "lies outside the file's bounds" in jobs["far away"].error
    for name in ("centre", "east"):
        clip_path = out / "clips" / f"{name}.osm.pbf"
        assert jobs[name].input == str(clip_path) and jobs[name].status == "ok", jobs[name].error
        # the job is the single command on the town's extract
        expected = single_run(clip_path, tmp_path / f"{name}.xml", derive_seed(SEED, name))
        assert (out / f"{name}.expanded.xml").read_bytes() == expected
    report = json.loads((out / "summary.json").read_text())
    assert set(report["clips"]["extracts"]) == {"centre", "east"} and report["clips"]["reads"] == one.reads


@pytest.mark.parametrize("text, match", [
    ("lon,lat,radius\n1,2,3\n", "lacks name"),
    ("name,lon,lat,radius\na,x,48,100\n", "line 2: lon 'x' is not a number"),
    ("name,lon,lat,radius\na,15,48,100\na,15,48,100\n", "used twice"),
    ("name,lon,lat,radius\na,15,48,-5\n", "radius"),
    ("name,lon,lat,radius\na,35.7,139.7,100\n", "swapped"),
    ("name,lon,lat,radius\n", "no towns"),
    ("name,lon,lat,radius\na/b,15,48,100\n", "cannot name"),
])
def test_a_bad_towns_table_is_refused_before_any_work(tmp_path, text, match):
    towns = tmp_path / "towns.csv"
    towns.write_text(text)
    with pytest.raises(InputError, match=match):
        run_batch([KREMS], tmp_path / "out", towns=towns, workers=1)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("args, match", [
    (["-o", "x.xml"], "set per job"), (["--seed", "3"], "set per job"), (["--preview", "a.png"], "set per job"),
    (["--area", "lots"], "pipeline options"), (["--no-such-option"], "pipeline options"),
])
def test_pipeline_options_are_checked_before_any_work(tmp_path, args, match):
    with pytest.raises(InputError, match=match):
        run_batch([KREMS], tmp_path / "out", workers=1, pipeline_args=args)
    assert not (tmp_path / "out").exists()


def test_a_towns_table_refuses_clip_options(tmp_path):
    towns = tmp_path / "towns.csv"
    towns.write_text(f"name,lon,lat,radius\ncentre,{KREMS_CENTRE[0]},{KREMS_CENTRE[1]},900\n")
    with pytest.raises(InputError, match="clips each town out of the input itself; drop --bbox"):
        run_batch([KREMS], tmp_path / "out", towns=towns, workers=1, pipeline_args=["--bbox=15.6,48.4,15.61,48.41"])


def test_the_batch_parser_passes_pipeline_options_through():
    from osm_expand.batch import pipeline_argv

    parser = argparse.ArgumentParser()
    add_batch_arguments(parser)
    args = parser.parse_args(["a.osm", "b.osm", "--out", "d", "--area", "5000", "--beyond-bounds",
                              "--at-lonlat=-76.5,39.3", "--workers", "3"])
    assert args.inputs == ["a.osm", "b.osm"] and args.workers == 3 and args.seed == 0
    assert pipeline_argv(args) == ["--at-lonlat=-76.5,39.3", "--area=5000", "--beyond-bounds"]
    with pytest.raises(SystemExit):
        parser.parse_args(["a.osm", "--out", "d", "--workers", "2", "--scheduler", "tcp://h:1"])


def test_two_inputs_of_one_name_are_refused(tmp_path):
    (tmp_path / "x").mkdir()
    shutil.copy(KREMS, tmp_path / "x" / "krems.osm.gz")
    with pytest.raises(InputError, match="both be named 'krems'"):
        run_batch([KREMS, tmp_path / "x" / "krems.osm.gz"], tmp_path / "out", workers=1)


def test_read_towns_reads_names_and_numbers(tmp_path):
    towns = tmp_path / "t.csv"
    towns.write_text("Name,LAT,lon,radius\nKrems an der Donau,48.41,15.61,1500\n")
    assert [(t.name, t.lon, t.lat, t.radius) for t in read_towns(towns)] == [("Krems an der Donau", 15.61, 48.41, 1500)]


# --- clip ----------------------------------------------------------------------------------------------


def _read(path: Path) -> tuple[dict, dict, dict]:
    nodes, ways, rels = {}, {}, {}
    for o in osmium.FileProcessor(str(path)):
        if o.is_node():
            nodes[o.id] = (o.location.lon, o.location.lat, dict(o.tags))
        elif o.is_way():
            ways[o.id] = ([n.ref for n in o.nodes], dict(o.tags))
        else:
            rels[o.id] = ([(m.type, m.ref) for m in o.members], dict(o.tags))
    return nodes, ways, rels


@pytest.fixture(scope="module")
def krems_source():
    return _read(KREMS)


@pytest.mark.parametrize("strategy", ["two-pass", "one-pass"])
def test_a_clip_holds_the_box_whole_ways_and_their_relations(tmp_path, krems_source, strategy):
    box = box_around(*KREMS_CENTRE, 400)
    result = clip_extracts(KREMS, {"centre": box}, tmp_path, options=ClipOptions(strategy=strategy))
    nodes, ways, rels = _read(result.paths["centre"])
    src_nodes, src_ways, src_rels = krems_source
    w, s, e, n = box

    def inside(i):
        lon, lat, _ = src_nodes[i]
        return w <= lon <= e and s <= lat <= n

    # every node inside the box, and every way with a node inside, whole (all its nodes the file has)
    assert {i for i in src_nodes if inside(i)} <= set(nodes)
    entering = {i for i, (refs, _) in src_ways.items() if any(r in src_nodes and inside(r) for r in refs)}
    assert entering <= set(ways)
    for i, (refs, tags) in ways.items():
        assert (refs, tags) == src_ways[i]
        assert {r for r in refs if r in src_nodes} <= set(nodes)
    # every street node lies in the box or belongs to a way crossing into it
    for i, (refs, tags) in ways.items():
        if "highway" in tags:
            assert i in entering or any(rels[r][1].get("type") == "multipolygon" for r in rels
                                        if ("w", i) in rels[r][0])
    # nodes kept are those inside or referenced by a kept way; tags and coordinates as mapped
    referenced = {r for refs, _ in ways.values() for r in refs}
    assert all(inside(i) or i in referenced for i in nodes)
    # (one-pass writes the nodes outside the box from its location index: without tags)
    assert all(nodes[i] == src_nodes[i] for i in nodes if inside(i) or strategy == "two-pass")
    assert all(nodes[i][:2] == src_nodes[i][:2] for i in nodes)
    # relations with a kept member; multipolygons complete (every member way the file has)
    members_kept = {i for i, (members, _) in src_rels.items()
                    if any((t == "w" and r in entering) or (t == "n" and r in src_nodes and inside(r))
                           for t, r in members)}
    assert members_kept <= set(rels)
    for i, (members, tags) in rels.items():
        assert (members, tags) == src_rels[i]
        if tags.get("type") == "multipolygon":
            assert {r for t, r in members if t == "w" and r in src_ways} <= set(ways)
    assert result.counts["centre"] == {"nodes": len(nodes), "ways": len(ways), "relations": len(rels)}
    # the ingest reads it as an extract whose bounds are the box
    city = load(result.paths["centre"])
    assert city.network.context.bounds_lonlat == pytest.approx(box, abs=1e-7)
    assert city.network.context.bounds_from_header and len(city.network.streets) > 20


def test_both_strategies_keep_the_same_objects(tmp_path):
    boxes = {"centre": box_around(*KREMS_CENTRE, 500), "east": (15.64, 48.395, 15.66, 48.41)}
    (tmp_path / "two").mkdir()
    (tmp_path / "one").mkdir()
    two = clip_extracts(KREMS, boxes, tmp_path / "two")
    one = clip_extracts(KREMS, boxes, tmp_path / "one", options=ClipOptions(strategy="one-pass"))
    assert two.counts == one.counts
    for name in boxes:
        a, b = _read(two.paths[name]), _read(one.paths[name])
        assert a[1] == b[1] and a[2] == b[2] and a[0].keys() == b[0].keys()


def test_many_boxes_in_one_read_give_the_same_bytes_as_each_alone(tmp_path):
    boxes = {"centre": box_around(*KREMS_CENTRE, 500), "east": (15.64, 48.395, 15.66, 48.41),
             "overlap": box_around(15.612, 48.41, 300)}
    (tmp_path / "all").mkdir()
    together = clip(KREMS, boxes, tmp_path / "all")
    for name, box in boxes.items():
        (tmp_path / name).mkdir()
        alone = clip(KREMS, {name: box}, tmp_path / name)
        assert alone[name].read_bytes() == together[name].read_bytes()  # deterministic, independent of the others


def _reordered(tmp_path: Path, order: tuple[str, ...]) -> Path:
    """Krems with its elements in another order than nodes, ways, relations (a hand-made or merged file)."""
    import gzip

    from lxml import etree

    with gzip.open(KREMS) as fh:
        root = etree.parse(fh).getroot()
    kids = list(root)
    for k in kids:
        root.remove(k)
    rank = {tag: i for i, tag in enumerate(("bounds", *order))}
    for k in sorted(kids, key=lambda e: rank.get(e.tag, len(rank))):
        root.append(k)
    path = tmp_path / f"krems-{'-'.join(order)}.osm"
    etree.ElementTree(root).write(str(path), xml_declaration=True, encoding="UTF-8")
    return path


@pytest.mark.parametrize("strategy", ["two-pass", "one-pass"])
def test_relations_before_ways_are_clipped_as_from_a_sorted_file(tmp_path, strategy):
    """Issue 21, point 3: relations read before their ways kept 28 of 64 relations, silently."""
    box = {"t": (15.58, 48.40, 15.64, 48.43)}
    unsorted = _reordered(tmp_path, ("node", "relation", "way"))
    for name, src in (("sorted", KREMS), ("unsorted", unsorted)):
        (tmp_path / name).mkdir()
        clip_extracts(src, box, tmp_path / name, options=ClipOptions(strategy=strategy))
    a, b = _read(tmp_path / "sorted" / "t.osm.pbf"), _read(tmp_path / "unsorted" / "t.osm.pbf")
    assert len(a[2]) > 40 and a[2] == b[2] and a[1] == b[1] and a[0].keys() == b[0].keys()


def test_ways_before_nodes_clip_in_two_passes_and_the_one_pass_clip_refuses_in_one_line(tmp_path, capsys):
    box = {"t": (15.58, 48.40, 15.64, 48.43)}
    unsorted = _reordered(tmp_path, ("relation", "way", "node"))
    for name, src in (("sorted", KREMS), ("unsorted", unsorted)):
        (tmp_path / name).mkdir()
        clip_extracts(src, box, tmp_path / name)
    a, b = _read(tmp_path / "sorted" / "t.osm.pbf"), _read(tmp_path / "unsorted" / "t.osm.pbf")
    assert a[2] == b[2] and a[1] == b[1] and a[0].keys() == b[0].keys()
    code = cli.main(["simplify", str(unsorted), "--bbox", "15.58,48.40,15.64,48.43", "--clip-index", "flex_mem",
                     "-o", str(tmp_path / "x.osm"), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "not sorted" in err and not (tmp_path / "x.osm").exists()


def test_id_sets_tracked_group_by_group_give_the_same_extract(tmp_path):
    box = {"centre": box_around(*KREMS_CENTRE, 600)}
    (tmp_path / "one").mkdir()
    (tmp_path / "groups").mkdir()
    whole = clip_extracts(KREMS, box, tmp_path / "one", options=ClipOptions(max_id_set_mb=10_000))
    grouped = clip_extracts(KREMS, box, tmp_path / "groups", options=ClipOptions(max_id_set_mb=40))
    assert grouped.reads > whole.reads >= 3  # 10 blocks of ids at a time: more reads, less memory
    assert grouped.paths["centre"].read_bytes() == whole.paths["centre"].read_bytes()


def test_boxes_outside_the_file_empty_or_bad_are_input_errors(tmp_path):
    with pytest.raises(InputError, match="outside the file's bounds"):  # Krems declares its bounds
        clip(KREMS, {"paris": box_around(2.35, 48.85, 1000)}, tmp_path)
    with pytest.raises(InputError, match="no data inside the box of far"):  # Monaco declares none
        clip(FIXTURES / "monaco.osm.gz", {"far": (7.0, 43.0, 7.01, 43.01)}, tmp_path)
    result = clip_extracts(FIXTURES / "monaco.osm.gz", {"far": (7.0, 43.0, 7.01, 43.01)}, tmp_path)
    assert result.empty == ["far"] and result.paths == {} and not list(tmp_path.iterdir())
    for bad, match in [((15.7, 48.3, 15.6, 48.4), "empty box"), ((15.6, 48.4, 15.6, 48.5), "empty box"),
                       ((15.6, float("nan"), 15.7, 48.4), "not finite"), ((15.6, 48.3, 195, 48.4), "outside the globe"),
                       ((48.3, 15.6, 48.4, 15.7), "swapped"), ((1, 2, 3), "four numbers")]:
        with pytest.raises(InputError, match=match):
            clip(KREMS, {"x": bad}, tmp_path)
    with pytest.raises(InputError, match="cannot name"):
        clip(KREMS, {"../x": (15.6, 48.39, 15.61, 48.4)}, tmp_path)
    with pytest.raises(InputError, match="does not exist"):
        clip(KREMS, {"x": (15.6, 48.39, 15.61, 48.4)}, tmp_path / "missing")
    with pytest.raises(InputError, match="not one of"):
        clip(KREMS, {"x": (15.6, 48.39, 15.61, 48.4)}, tmp_path, strategy="three-pass")


def test_parse_bbox_and_box_around():
    assert parse_bbox("15.6,48.39,15.67,48.41") == (15.6, 48.39, 15.67, 48.41)
    for text in ("15.6,48.39,15.67", "a,b,c,d", "15.6;48.39;15.67;48.41"):
        with pytest.raises(InputError, match="four numbers"):
            parse_bbox(text)
    w, s, e, n = box_around(15.61, 48.41, 1000)
    # 1 km each way: 2 km across on the sphere at the centre's latitude
    assert (n - s) * np.pi / 180 * 6_371_008.8 == pytest.approx(2000)
    assert (e - w) * np.pi / 180 * 6_371_008.8 * np.cos(np.radians(48.41)) == pytest.approx(2000)
    assert check_box((w, s, e, n)) == (w, s, e, n)
    for args, match in [((15.6, 48.4, 0), "positive"), ((48.4, 95, 100), "swapped"), ((179.999, 0, 1000), "antimeridian"),
                        ((0, 89.999, 1000), "pole"), ((float("inf"), 0, 10), "longitude")]:
        with pytest.raises(InputError, match=match):
            box_around(*args)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(-1000, 1000), st.integers(-1000, 1000), st.integers(1, 400), st.integers(1, 400)),
                min_size=1, max_size=6),
       st.lists(st.tuples(st.integers(-1500, 1500), st.integers(-1500, 1500)), min_size=0, max_size=80))
def test_the_box_grid_finds_exactly_the_points_in_each_box(boxes, points):
    scale = 1e-5  # degrees per unit: libosmium's 1e-7 grid is finer
    grid = _Boxes([(x * scale, y * scale, (x + w) * scale, (y + h) * scale) for x, y, w, h in boxes])
    xy = np.array(points, dtype=np.int64).reshape(-1, 2) * 100
    point, box = grid.members(xy[:, 0], xy[:, 1])
    got = sorted(zip(point.tolist(), box.tolist()))
    want = sorted((i, k) for i, (px, py) in enumerate(xy.tolist()) for k, (x, y, w, h) in enumerate(boxes)
                  if x * 100 <= px <= (x + w) * 100 and y * 100 <= py <= (y + h) * 100)
    assert got == want


class _FakeClient:
    """A cluster's client as the pre-flight check sees it: workers and their probe answers."""

    def __init__(self, answers: dict):
        self.answers = answers

    def scheduler_info(self) -> dict:
        return {"workers": {address: {} for address in self.answers}}

    def run(self, function, *args, on_error="raise") -> dict:
        return self.answers


def test_the_preflight_says_in_one_line_which_worker_lacks_what(tmp_path):
    from osm_expand.batch import probe
    from osm_expand.batch.cluster import _preflight

    good = probe([str(KREMS)], str(tmp_path))
    assert good["unreadable"] == [] and good["out_dir_ok"]
    assert probe([str(tmp_path / "nowhere.osm")], str(tmp_path / "nowhere"))["unreadable"] == [str(tmp_path / "nowhere.osm")]
    _preflight(_FakeClient({"tcp://a:1": good, "tcp://b:1": good}), "tcp://s:1", [str(KREMS)], tmp_path)
    cases = [({}, "has no workers"),
             ({"tcp://b:1": {**good, "source": "0123456789abcdef"}}, "worker tcp://b:1 runs osm-expand"),
             ({"tcp://b:1": {**good, "unreadable": ["/data/x.osm"]}}, "cannot read /data/x.osm"),
             ({"tcp://b:1": {**good, "out_dir_ok": False}}, "cannot write to"),
             ({"tcp://b:1": ModuleNotFoundError("No module named 'osm_expand'")}, "cannot import osm-expand")]
    for answers, match in cases:
        with pytest.raises(InputError, match=match) as err:
            _preflight(_FakeClient(answers), "tcp://s:1", [str(KREMS)], tmp_path)
        assert "\n" not in str(err.value) and str(err.value).startswith("--scheduler tcp://s:1: ")


# --- clipping on the command line ------------------------------------------------------------------------


def test_simplify_and_grow_with_around_are_the_commands_on_the_clipped_extract(tmp_path, capsys):
    box = box_around(*KREMS_CENTRE, 700)
    extract = clip(KREMS, {"town": box}, tmp_path)["town"]
    around = ["--around", f"{KREMS_CENTRE[0]},{KREMS_CENTRE[1]}", "--radius", "700"]
    assert cli.main(["simplify", str(KREMS), *around, "-o", str(tmp_path / "a.osm"), "-q", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["input"] == str(KREMS) and report["clip"]["box"] == pytest.approx(list(box))
    assert report["clip"]["nodes"] > 0 and report["clip"]["ways"] > 0
    assert cli.main(["simplify", str(extract), "-o", str(tmp_path / "b.osm"), "-q"]) == 0
    assert (tmp_path / "a.osm").read_bytes() == (tmp_path / "b.osm").read_bytes()
    # the main command: --bbox gives the bytes of the command on the extract (no temporary path leaks in)
    bbox = ",".join(f"{v!r}" for v in box)
    grow = [*PIPELINE, "--seed", "3", "-q"]
    assert cli.main([str(KREMS), f"--bbox={bbox}", "-o", str(tmp_path / "a.xml"), *grow]) == 0
    assert cli.main([str(extract), "-o", str(tmp_path / "b.xml"), *grow]) == 0
    assert (tmp_path / "a.xml").read_bytes() == (tmp_path / "b.xml").read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.osm", "a.xml", "b.osm", "b.xml", "town.osm.pbf"]


@pytest.mark.parametrize("args, match", [
    (["--bbox", "15.7,48.3,15.6,48.4"], "empty box"),
    (["--bbox", "2.3,48.8,2.4,48.9"], "--bbox 2.3,48.8,2.4,48.9 .* lies outside the file's bounds"),
    (["--around", "15.61,48.41"], "--around needs --radius"),
    (["--radius", "500"], "--radius needs --around"),
    (["--around", "48.41,15.61", "--radius", "500"], "lies outside the file's bounds"),
    (["--bbox", "15.6,48.4,15.61,48.41", "--around", "15.61,48.41", "--radius", "5"], "not both"),
    (["--clip-index", "flex_mem"], "--clip-index needs --bbox or --around"),
    (["--bbox", "15.6,48.4,15.61,48.41", "--clip-index", "nope"], "--clip-index 'nope' is not one of"),
])
def test_bad_clip_options_are_one_line_errors(tmp_path, capsys, args, match):
    import re

    assert cli.main(["simplify", str(KREMS), "-o", str(tmp_path / "x.osm"), "-q", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and re.search(match, err), err
    assert not list(tmp_path.iterdir())  # nothing written, no temporary folder left


def test_clip_index_picks_the_one_pass_clip(tmp_path, capsys):
    args = ["--around", f"{KREMS_CENTRE[0]},{KREMS_CENTRE[1]}", "--radius", "500", "-q", "--json"]
    assert cli.main(["simplify", str(KREMS), "-o", str(tmp_path / "two.osm"), *args]) == 0
    two = json.loads(capsys.readouterr().out)
    assert cli.main(["simplify", str(KREMS), "-o", str(tmp_path / "one.osm"), "--clip-index", "sparse_mem_array",
                     *args]) == 0
    one = json.loads(capsys.readouterr().out)
    assert one["clip"]["reads"] < two["clip"]["reads"]
    assert {k: one["clip"][k] for k in ("nodes", "ways", "relations")} == \
        {k: two["clip"][k] for k in ("nodes", "ways", "relations")}
    assert (tmp_path / "one.osm").read_bytes() == (tmp_path / "two.osm").read_bytes()


def test_a_batch_job_runs_with_the_cyclic_collector_paused_and_gives_it_back(tmp_path, monkeypatch):
    """A worker runs one town at a time, as the main command does, so it pauses the cyclic collector for the
    job's run as the main command does (osm_expand.gcpause) and restores it whether the job ran or failed."""
    import gc

    import osm_expand.app
    from osm_expand.batch.jobs import run_job

    seen: list[bool] = []

    def fake(request, **kwargs):
        seen.append(gc.isenabled())
        if request.seed == 1:
            raise InputError("refused")
        return {"streets": 1}

    monkeypatch.setattr(osm_expand.app, "run_expand", fake)
    source = str(Path(__file__).resolve().parent.parent / "fixtures" / "krems.osm.gz")
    jobs = [Job(name=f"k{seed}", input=source, output=str(tmp_path / f"k{seed}.xml"),
                log=str(tmp_path / f"k{seed}.log"), seed=seed) for seed in (0, 1)]
    assert gc.isenabled()
    results = [run_job(job) for job in jobs]
    assert gc.isenabled() and seen == [False, False]
    assert [r.exit_code for r in results] == [0, 2]
