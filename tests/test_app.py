"""The application layer (issue 23): one function runs the main command, for the command line and for batch."""
from __future__ import annotations

import pytest

from osm_expand import cli
from osm_expand.app import EXPAND_ARGUMENTS, ExpandRequest, check_options, run_expand
from osm_expand.batch import PIPELINE_ARGUMENTS, add_batch_arguments, pipeline_argv, request_from_argv
from osm_expand.errors import HistoryError, OptionError
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
