"""The command line: outputs, JSON report, exit codes and bad input."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from osm_expand import cli
from tests.conftest import FIXTURES

GOOD = FIXTURES / "krems.osm.gz"

ONLY_A_BUILDING = """<?xml version='1.0' encoding='UTF-8'?>
<osm version="0.6">
 <node id="1" lat="48.0" lon="15.0"/><node id="2" lat="48.0001" lon="15.0"/>
 <node id="3" lat="48.0001" lon="15.0001"/>
 <way id="4"><nd ref="1"/><nd ref="2"/><nd ref="3"/><nd ref="1"/><tag k="building" v="yes"/></way>
</osm>
"""
OUT_OF_RANGE = """<?xml version='1.0' encoding='UTF-8'?>
<osm version="0.6">
 <node id="1" lat="95.0" lon="15.0"/><node id="2" lat="48.0" lon="15.001"/>
 <way id="3"><nd ref="1"/><nd ref="2"/><tag k="highway" v="residential"/></way>
</osm>
"""


def run(argv, capsys):
    """The command's exit code, stdout and stderr; the main command without the engine unless
    ``--years`` is given (the engine has its own tests: tests/test_engine.py)."""
    argv = [str(a) for a in argv]
    if argv and argv[0] not in cli.COMMANDS and "--years" not in argv and not any(a.startswith("--years=") for a in argv):
        argv += ["--years", "0"]
    code = cli.main(argv)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("suffix", [".osm", ".geojson"])
def test_simplify_writes_the_network_and_a_json_report(tmp_path, capsys, suffix):
    out = tmp_path / f"krems{suffix}"
    code, stdout, stderr = run(["simplify", GOOD, "-o", out, "--json"], capsys)
    assert code == 0 and out.stat().st_size > 0
    report = json.loads(stdout)  # stdout is exactly one JSON object
    assert report["output"] == str(out) and report["junctions"] > 100
    assert [p["pass"] for p in report["passes"]][-1] == "final"
    assert "reading" in stderr and "done" in stderr
    assert not list(tmp_path.glob(".*tmp"))  # no temporary file left behind
    assert out.stat().st_mode & 0o044  # readable by others, like any file the user writes


def test_quiet_prints_nothing(tmp_path, capsys):
    code, stdout, stderr = run(["simplify", GOOD, "-o", tmp_path / "k.osm", "-q"], capsys)
    assert code == 0 and stdout == "" and stderr == ""


def test_default_output_goes_beside_the_input(tmp_path, capsys):
    city = tmp_path / "West-Oakland.osm.bz2"
    shutil.copy(FIXTURES / "West-Oakland.osm.bz2", city)
    assert run(["simplify", city, "-q"], capsys)[0] == 0
    assert (tmp_path / "West-Oakland.simplified.osm").exists()


def test_same_input_same_bytes(tmp_path, capsys):
    for name in ("a", "b"):
        for suffix in (".osm", ".geojson"):
            assert run(["simplify", FIXTURES / "monaco.osm.gz", "-o", tmp_path / f"{name}{suffix}", "-q"], capsys)[0] == 0
    assert (tmp_path / "a.osm").read_bytes() == (tmp_path / "b.osm").read_bytes()
    assert (tmp_path / "a.geojson").read_bytes() == (tmp_path / "b.geojson").read_bytes()


def test_geojson_is_rfc7946(tmp_path, capsys):
    out = tmp_path / "m.geojson"
    run(["simplify", FIXTURES / "monaco.osm.gz", "-o", out, "-q"], capsys)
    doc = json.loads(out.read_text())
    assert doc["type"] == "FeatureCollection" and "crs" not in doc
    lon, lat = doc["features"][0]["geometry"]["coordinates"][0]
    assert 7.3 < lon < 7.5 and 43.6 < lat < 43.8  # lon/lat order, WGS 84
    assert {"highway", "layer"} <= set(doc["features"][0]["properties"])


def test_osm_output_keeps_ids_and_tags(tmp_path, capsys):
    import osmium

    out = tmp_path / "m.osm"
    run(["simplify", FIXTURES / "monaco.osm.gz", "-o", out, "-q"], capsys)
    ways = [(w.id, dict(w.tags)) for w in osmium.FileProcessor(str(out), osmium.osm.WAY)]
    assert any(i > 0 for i, _ in ways) and any(i < 0 for i, _ in ways)
    assert all("highway" in t for _, t in ways)
    assert any(t.get("tunnel") == "yes" for _, t in ways) and any("layer" in t for _, t in ways)
    assert 'upload="never"' in out.read_text()[:300]


def test_service_flag_rescues_a_service_only_town(tmp_path, capsys):
    out = tmp_path / "c.osm"
    code, _, err = run(["simplify", FIXTURES / "circle-bug.osm.gz", "-o", out], capsys)
    assert code == 2 and "no streets left" in err and "--service" in err and not out.exists()
    assert run(["simplify", FIXTURES / "circle-bug.osm.gz", "-o", out, "--service", "-q"], capsys)[0] == 0
    assert out.exists()


def _bad_inputs(tmp: Path) -> dict[str, Path]:
    files = {
        "missing": tmp / "nothing-here.osm",
        "directory": tmp / "adir.osm",
        "empty": tmp / "empty.osm",
        "text": tmp / "notes.osm",
        "truncated_gz": tmp / "cut.osm.gz",
        "truncated_pbf": tmp / "cut.osm.pbf",
        "no_streets": tmp / "building.osm",
        "out_of_range": tmp / "range.osm",
        "wrong_type": tmp / "city.csv",
    }
    files["directory"].mkdir()
    files["empty"].write_bytes(b"")
    files["text"].write_text("this is not OpenStreetMap data\n")
    files["truncated_gz"].write_bytes((FIXTURES / "krems.osm.gz").read_bytes()[:200_000])
    files["truncated_pbf"].write_bytes((FIXTURES / "andorra.osm.pbf").read_bytes()[:200_000])
    files["no_streets"].write_text(ONLY_A_BUILDING)
    files["out_of_range"].write_text(OUT_OF_RANGE)
    files["wrong_type"].write_text("a,b\n1,2\n")
    return files


EXPECTED = {
    "missing": "no such file", "directory": "is a directory", "empty": "file is empty",
    "text": "not a readable OSM file", "truncated_gz": "not a readable OSM file",
    "truncated_pbf": "not a readable OSM file", "no_streets": "no streets",
    "out_of_range": "out of range", "wrong_type": "unsupported file type",
}


@pytest.mark.parametrize("case", sorted(EXPECTED))
def test_bad_input_gives_one_line_exit_2_and_no_output(tmp_path, capsys, case):
    path = _bad_inputs(tmp_path)[case]
    out = tmp_path / "out.osm"
    code, stdout, stderr = run(["simplify", path, "-o", out], capsys)
    assert code == 2
    lines = [ln for ln in stderr.splitlines() if not ln.startswith("[")]  # progress lines start with [
    assert len(lines) == 1, stderr
    assert str(path) in lines[0] and EXPECTED[case] in lines[0]
    assert "Traceback" not in stderr and stdout == ""
    assert not out.exists() and not list(tmp_path.glob(".out.osm*"))


def test_a_failed_run_never_overwrites_a_good_output(tmp_path, capsys):
    out = tmp_path / "k.osm"
    run(["simplify", GOOD, "-o", out, "-q"], capsys)
    good = out.read_bytes()
    bad = tmp_path / "bad.osm.gz"
    bad.write_bytes(GOOD.read_bytes()[:100_000])
    assert run(["simplify", bad, "-o", out, "-q"], capsys)[0] == 2
    assert out.read_bytes() == good


@pytest.mark.parametrize("argv,needle", [
    (["simplify"], "required"),
    (["simplify", GOOD, "--cluster-radius", "-3"], "must be positive"),
    (["simplify", GOOD, "--cluster-radius", "abc"], "invalid float"),
    (["simplify", GOOD, "-o", "/nonexistent-dir/x.osm"], "output directory does not exist"),
    (["simplify", GOOD, "-o", "out.txt"], "unsupported output type"),
    (["frobnicate"], "no such file"),
])
def test_usage_errors_are_one_line_exit_2(capsys, argv, needle):
    code, _, stderr = run(argv, capsys)
    assert code == 2 and needle in stderr and len(stderr.strip().splitlines()) == 1


def test_internal_error_is_exit_1_without_traceback(monkeypatch, tmp_path, capsys):
    import simplify

    def broken(*_a, **_k):
        raise ZeroDivisionError("boom")

    monkeypatch.setattr(simplify, "simplify", broken)  # what `osm-expand simplify` calls (without the pipeline)
    code, _, stderr = run(["simplify", GOOD, "-o", tmp_path / "x.osm", "-q"], capsys)
    assert code == 1 and "internal error" in stderr and "Traceback" not in stderr
    assert not (tmp_path / "x.osm").exists()


def test_console_script_is_installed(tmp_path):
    exe = Path(sys.executable).with_name("osm-expand")
    proc = subprocess.run([str(exe), "simplify", str(FIXTURES / "West-Oakland.osm.bz2"), "-o",
                           str(tmp_path / "w.geojson"), "--json"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["streets"] > 0


def test_expand_writes_a_valid_district_and_a_preview(tmp_path, capsys):
    from osm_expand.export.urban import validate

    out, png = tmp_path / "krems.xml", tmp_path / "krems.png"
    code, stdout, _ = run([FIXTURES / "krems.osm.gz", "-o", out, "--preview", png, "--json", "-q"], capsys)
    assert code == 0 and validate(out) == [] and png.stat().st_size > 10_000
    report = json.loads(stdout)
    assert report["grown_streets"] > 20 and report["format"] == "urbanenvironment"


def test_expand_default_output_is_beside_the_input(tmp_path, capsys):
    """And an expand run in-process (a caller's list of arguments, not the process's own command line)
    freezes nothing: only the command line's own process, which exits next, freezes what the run
    leaves alive (``cmd_expand``'s ``last``, :func:`osm_expand.cli._leave`); a caller keeps its collector."""
    import gc

    city = tmp_path / "West-Oakland.osm.bz2"
    shutil.copy(FIXTURES / "West-Oakland.osm.bz2", city)
    frozen, enabled = gc.get_freeze_count(), gc.isenabled()
    assert run([city, "-q", "--area", "200000", "--beyond-bounds"], capsys)[0] == 0
    assert (tmp_path / "West-Oakland.expanded.xml").exists()
    assert gc.get_freeze_count() == frozen and gc.isenabled() == enabled


def test_expand_same_seed_same_bytes_other_seed_other_district(tmp_path, capsys):
    for name, seed in (("a", 3), ("b", 3), ("c", 4)):
        for fmt in ("xml", "osm", "geojson"):
            assert run([FIXTURES / "monaco.osm.gz", "-o", tmp_path / f"{name}.{fmt}", "--seed", seed, "-q"], capsys)[0] == 0
    for fmt in ("xml", "osm", "geojson"):
        assert (tmp_path / f"a.{fmt}").read_bytes() == (tmp_path / f"b.{fmt}").read_bytes()
    assert (tmp_path / "a.xml").read_bytes() != (tmp_path / "c.xml").read_bytes()


@pytest.mark.parametrize("argv,needle", [
    (["--area", "-5"], "must be positive"),
    (["--at", "12"], "two numbers"),
    (["--at-lonlat", "500,10"], "not a longitude,latitude"),
    (["--preview", "x.pdf"], "must be .png or .svg"),
    (["--direction", "UP"], "invalid choice"),
    (["--preview", "x.png", "--preview-frame", "county"], "invalid choice"),
    (["-o", "out.txt"], "unsupported output type"),
])
def test_expand_bad_options_are_one_line_exit_2(tmp_path, capsys, argv, needle):
    code, _, stderr = run([FIXTURES / "West-Oakland.osm.bz2", *argv], capsys)
    assert code == 2 and needle in stderr and len(stderr.strip().splitlines()) == 1


def test_expand_explains_towns_it_cannot_grow(tmp_path, capsys):
    # the small towns grow by default (beyond their bounds, issue 20); kept inside them they are refused
    for name, needle, extra in (("circle-bug.osm.gz", "no streets left", []),
                                ("berlin-siegessaeule.osm.gz", "no room", ["--within-bounds"]),
                                ("West-Oakland.osm.bz2", "no room", ["--within-bounds"])):
        out = tmp_path / "x.xml"
        code, _, stderr = run([FIXTURES / name, "-o", out, "-q", *extra], capsys)
        assert code == 2 and needle in stderr and name in stderr and not out.exists()
        assert len(stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("module", ["simplify", "synth", "osm_expand", "osm_expand.model.topology", "synth.walk",
                                    "synth.growth", "osm_expand.pipeline", "osm_expand.cli"])
def test_every_package_imports_first_without_a_cycle(module):
    """simplify and synth build on osm_expand's model; the pipeline must not loop back at import."""
    proc = subprocess.run([sys.executable, "-c", f"import {module}"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-300:]


def test_simplify_and_synth_import_only_the_model_from_osm_expand():
    """DESIGN's layering: the stages underneath know the model (and the error type), nothing else."""
    import ast

    allowed = ("osm_expand.model", "osm_expand.errors")
    root = Path(__file__).resolve().parent.parent
    for package in ("simplify", "synth"):
        for path in (root / package).glob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                names = [node.module or ""] if isinstance(node, ast.ImportFrom) else \
                    [a.name for a in node.names] if isinstance(node, ast.Import) else []
                for name in names:
                    if name == "osm_expand" or name.startswith("osm_expand."):
                        assert name.startswith(allowed), f"{path.name} imports {name}"


def test_the_python_api_mirrors_the_cli(tmp_path, capsys):
    """osm_expand.load + expand + mature + export write the same bytes as the command with the same seed."""
    import osm_expand
    from osm_expand.export import write_osm

    city = osm_expand.load(FIXTURES / "West-Oakland.osm.bz2")
    result = osm_expand.expand(city, osm_expand.ExpandOptions(seed=2, area=200_000.0, beyond_bounds=True))
    grown = osm_expand.mature(result.city, osm_expand.load_history("example"), osm_expand.MatureOptions(years=5), 2,
                              learned=result.learned, join_points=result.joins.at)
    assert grown.city.year == grown.report["engine"]["last_year"]
    write_osm(grown.city, tmp_path / "api.osm")
    code, _, err = run([FIXTURES / "West-Oakland.osm.bz2", "--seed", "2", "--area", "200000", "--beyond-bounds",
                        "--years", "5", "-o", tmp_path / "cli.osm", "-q"], capsys)
    assert code == 0, err
    assert (tmp_path / "api.osm").read_bytes() == (tmp_path / "cli.osm").read_bytes()


def test_the_process_own_command_line_freezes_what_it_leaves_alive_at_its_end():
    """Python's exit walks every live object with the cyclic collector; the command line's own process
    freezes them first (:func:`osm_expand.cli._leave`)."""
    script = ("import gc, sys; from osm_expand.cli import main; sys.argv = ['osm-expand', '--version']; "
              "rc = main(); print(rc, gc.get_freeze_count())")
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    rc, frozen = proc.stdout.split()[-2:]
    assert rc == "0" and int(frozen) > 1000


def test_a_caller_in_the_same_process_keeps_its_collector_unfrozen(capsys):
    import gc

    before = gc.get_freeze_count()
    assert cli.main(["--version"]) == 0
    capsys.readouterr()
    assert gc.get_freeze_count() == before and gc.isenabled()


def test_a_pause_the_process_ends_with_freezes_what_outlives_it():
    import gc

    from osm_expand.gcpause import cyclic_gc_paused

    before = gc.get_freeze_count()
    try:
        with cyclic_gc_paused(freeze=True):
            kept = [[] for _ in range(100)]
            assert not gc.isenabled()
        assert gc.isenabled() and gc.get_freeze_count() >= before + len(kept)
    finally:
        gc.unfreeze()
    with cyclic_gc_paused():  # without: nothing is frozen
        kept = [[] for _ in range(100)]
    assert gc.get_freeze_count() == 0
