"""Named errors under one base (issue 23): each kind raised by the library itself, each one line and exit 2
at the command line, and every one still an ``InputError`` so old callers keep working."""
from __future__ import annotations

import pytest

from osm_expand import cli, errors
from osm_expand.errors import HistoryError, InputError, NoRoomError, OptionError, OutputError, UnreadableInputError
from tests.conftest import FIXTURES

NAMED = (UnreadableInputError, OptionError, HistoryError, NoRoomError, OutputError)


def test_every_named_error_is_an_input_error_and_exported():
    assert set(errors.__all__) == {"InputError", *(e.__name__ for e in NAMED)}
    for kind in NAMED:
        assert issubclass(kind, InputError) and kind is not InputError


def test_a_missing_or_empty_input_is_an_unreadable_input_error(tmp_path):
    from osm_expand.ingest import load

    with pytest.raises(UnreadableInputError, match="no such file"):
        load(tmp_path / "gone.osm")
    (tmp_path / "empty.osm").write_bytes(b"")
    with pytest.raises(UnreadableInputError, match="file is empty"):
        load(tmp_path / "empty.osm")


def test_a_bad_history_is_a_history_error(tmp_path):
    from osm_expand.engine.history import load_history

    with pytest.raises(HistoryError, match="not a bundled history"):
        load_history("atlantis")
    bad = tmp_path / "bad.toml"
    bad.write_text("[[era]\nname = ")
    with pytest.raises(HistoryError, match="not valid TOML"):
        load_history(bad)


def test_a_bad_option_is_an_option_error():
    from osm_expand.land import parse_rules

    with pytest.raises(OptionError, match="KEY=VALUE"):
        parse_rules("cemetery")


def test_no_room_for_a_district_is_a_no_room_error():
    from osm_expand import ExpandOptions, expand, load

    city = load(FIXTURES / "berlin-siegessaeule.osm.gz")
    with pytest.raises(NoRoomError, match="no room"):
        expand(city, ExpandOptions(beyond_bounds=False, fidelity=False))


@pytest.mark.parametrize(("argv", "needle"), [
    (["--history", "atlantis"], "not a bundled history"),                 # HistoryError
    (["--area", "-5"], "--area must be positive"),                         # OptionError
    (["-o", "/nonexistent-folder/x.xml"], "output directory does not exist"),  # OutputError
])
def test_each_named_error_is_one_line_and_exit_2_at_the_command_line(capsys, argv, needle):
    code = cli.main([str(FIXTURES / "West-Oakland.osm.bz2"), "-q", *argv])
    err = capsys.readouterr().err
    assert code == 2 and needle in err and len(err.strip().splitlines()) == 1


def test_the_file_named_in_a_wrapped_error_keeps_its_kind():
    """The command line prefixes the input's name to a pipeline error: the error keeps its class."""
    from osm_expand.app import in_file

    exc = in_file(FIXTURES / "krems.osm.gz", NoRoomError("no room"), service=False)
    assert isinstance(exc, NoRoomError) and str(exc).endswith("krems.osm.gz: no room")
