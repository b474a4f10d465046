"""The application layer (issue 23): one function runs the main command, for the command line and for batch."""
from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from osm_expand import cli
from osm_expand.app import EXPAND_ARGUMENTS, EXPAND_WRITERS, ExpandRequest, check_options, run_expand, stem
from osm_expand.batch import PIPELINE_ARGUMENTS, add_batch_arguments, pipeline_argv, request_from_argv
from osm_expand.errors import HistoryError, OptionError
from osm_expand.ingest import SUFFIXES
from tests.conftest import FIXTURES

OAKLAND = FIXTURES / "West-Oakland.osm.bz2"


def test_run_expand_writes_what_the_command_line_writes(tmp_path, capsys):
    report = run_expand(ExpandRequest(city=str(OAKLAND), output=str(tmp_path / "app.xml"), seed=2, years=0))
    assert report["output"] == str(tmp_path / "app.xml") and report["seed"] == 2 and report["grown_streets"] > 0
    assert cli.main([str(OAKLAND), "-o", str(tmp_path / "cli.xml"), "--seed", "2", "--years", "0", "-q"]) == 0
    assert (tmp_path / "app.xml").read_bytes() == (tmp_path / "cli.xml").read_bytes()


def test_a_refused_request_raises_its_kind_and_writes_nothing(tmp_path):
    out = tmp_path / "x.xml"
    with pytest.raises(OptionError, match="--area must be positive"):
        run_expand(ExpandRequest(city=str(OAKLAND), output=str(out), area=-1.0))
    with pytest.raises(HistoryError, match="not a bundled history"):
        run_expand(ExpandRequest(city=str(OAKLAND), output=str(out), history="atlantis"))
    assert not out.exists()


def test_batch_and_the_command_line_read_the_same_options_into_the_same_request():
    argv = [str(OAKLAND), "--area", "5000", "--at-lonlat=-122.3,37.81", "--within-bounds", "--pattern", "walk",
            "--years", "3", "--history", "european", "--service", "--seed", "4", "-o", "x.osm"]
    from_cli = ExpandRequest.from_namespace(cli.build_expand_parser().parse_args(argv))
    assert request_from_argv(argv) == from_cli
    assert (from_cli.area, from_cli.beyond_bounds, from_cli.pattern, from_cli.years) == (5000.0, False, "walk", 3)
    checked = check_options(from_cli)
    assert checked.years == 3 and checked.history.name == "european" and checked.at_lonlat == (-122.3, 37.81)


def test_batch_offers_every_pipeline_option_of_the_main_command_and_passes_them_on():
    import argparse

    assert {a.dest for a in EXPAND_ARGUMENTS} - {a.dest for a in PIPELINE_ARGUMENTS} == {"output", "seed", "preview"}
    parser = argparse.ArgumentParser()
    add_batch_arguments(parser)
    args = parser.parse_args(["in.osm", "--out", "d", "--within-bounds", "--pattern", "colonisation", "--years=2"])
    assert pipeline_argv(args) == ["--pattern=colonisation", "--within-bounds", "--years=2"]
    with pytest.raises(SystemExit):
        parser.parse_args(["in.osm", "--out", "d", "--pattern", "grid"])  # the registry's choices, as text


@given(st.text(st.sampled_from("abcXYZ09-_ "), min_size=1, max_size=12), st.sampled_from(sorted(SUFFIXES)),
       st.booleans())
def test_the_main_command_and_the_batch_name_an_input_alike_without_its_suffix(base, suffix, upper):
    """One name of an input (issue 23): the main command's default output and a batch's job are named by
    ``stem``, which drops the longest suffix of a file the tool reads (``town.xml.gz`` → ``town``)."""
    name = base + (suffix.upper() if upper else suffix)
    assert stem(name) == stem(f"/some/folder/{name}") == base


def test_a_batch_names_its_jobs_as_the_main_command_names_its_outputs(tmp_path):
    from osm_expand.app import output_path
    from osm_expand.batch.jobs import Job
    from osm_expand.batch.run import _file_jobs

    inputs = [tmp_path / "town.xml.gz", tmp_path / "krems.osm.pbf", tmp_path / "Oakland.geojson"]
    for path in inputs:
        path.write_bytes(b"x")
    jobs = _file_jobs(inputs, lambda name, path: Job(name, str(path), "", "", 0))
    assert [j.name for j in jobs] == ["town", "krems", "Oakland"]
    assert [output_path(p, None, ".xml", EXPAND_WRITERS)[0].name for p in inputs] == [
        "town.xml", "krems.xml", "Oakland.xml"]


def test_the_main_command_runs_with_the_cyclic_collector_paused_and_restores_it(tmp_path, monkeypatch):
    """The engine's years make almost no cyclic garbage, and the collector's walks over the live town cost
    seconds on a large one: the main command pauses it for its run (as ``simplify`` does), and gives it back
    as it was however the run ends."""
    import gc

    seen: list[bool] = []

    def fake(request, **kwargs):
        seen.append(gc.isenabled())
        if request.seed == 1:
            raise OptionError("refused")
        return {}

    monkeypatch.setattr(cli, "run_expand", fake)
    assert gc.isenabled()
    assert cli.main([str(OAKLAND), "-o", str(tmp_path / "x.xml"), "--seed", "0", "-q"]) == 0
    assert gc.isenabled()
    assert cli.main([str(OAKLAND), "-o", str(tmp_path / "x.xml"), "--seed", "1", "-q"]) == 2
    assert gc.isenabled() and seen == [False, False]
