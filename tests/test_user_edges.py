"""What a new user hit at the edges of ``osm-expand CITY``: each case is one test.

Every failure is one line on stderr, exit code 2, and nothing written; the
checks run before any work, so a refusal is quick.
"""
from __future__ import annotations

import gzip
import json
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

import pytest

from osm_expand import cli
from tests.conftest import FIXTURES, notes_only

OAKLAND = FIXTURES / "West-Oakland.osm.bz2"  # bounds lon -122.30258..-122.29825, lat 37.80615..37.80914
KREMS = FIXTURES / "krems.osm.gz"


def run(argv, capsys):
    """The command's exit code, stdout and stderr; the main command without the engine unless
    ``--years`` is given (the engine has its own tests: tests/test_engine.py)."""
    argv = [str(a) for a in argv]
    if argv and argv[0] not in cli.COMMANDS and "--years" not in argv and not any(a.startswith("--years=") for a in argv):
        argv += ["--years", "0"]
    code = cli.main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def one_line(err: str) -> str:
    """The one error line (progress lines, which start with "[", may come before it)."""
    lines = [ln for ln in err.strip().splitlines() if ln.strip() and not ln.startswith("[")]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def test_a_huge_area_is_refused_up_front(tmp_path, capsys):
    out = tmp_path / "k.xml"
    t0 = time.perf_counter()
    code, _, err = run([KREMS, "--area", "1e12", "-o", out, "-q"], capsys)
    assert code == 2 and "--area" in one_line(err) and "at most" in err
    assert time.perf_counter() - t0 < 20 and not out.exists()


@pytest.mark.parametrize("form", [["--at-lonlat", "-122.3005,37.8076"], ["--at-lonlat=-122.3005,37.8076"]])
def test_negative_coordinates_work_in_both_forms(tmp_path, capsys, form):
    out = tmp_path / "o.xml"
    code, _, err = run([OAKLAND, *form, "--area", "200000", "--beyond-bounds", "-o", out, "-q"], capsys)
    assert code == 0, err
    assert out.exists()


@pytest.mark.parametrize("form", [["--at", "-300,-20"], ["--at=-300,-20"]])
def test_negative_metres_work_in_both_forms(tmp_path, capsys, form):
    code, _, err = run([OAKLAND, *form, "--area", "200000", "--beyond-bounds", "-o", tmp_path / "o.xml", "-q"],
                       capsys)
    assert code == 0, err


def test_a_point_outside_the_map_is_refused(tmp_path, capsys):
    code, _, err = run([OAKLAND, "--at-lonlat", "-76.50,39.28", "-o", tmp_path / "o.xml"], capsys)
    assert code == 2 and "outside" in one_line(err) and not (tmp_path / "o.xml").exists()


def test_latitude_and_longitude_swapped_is_refused_with_the_reason(tmp_path, capsys):
    code, _, err = run([OAKLAND, "--at-lonlat", "37.8076,-122.3005", "-o", tmp_path / "o.xml"], capsys)
    assert code == 2 and "swapped" in one_line(err)


NAN_NODE = """<?xml version='1.0' encoding='UTF-8'?>
<osm version="0.6">
 <node id="1" lat="48.0" lon="15.0"/><node id="2" lat="nan" lon="15.001"/>
 <node id="3" lat="48.001" lon="inf"/><node id="4" lat="48.002" lon="15.002"/>
 <way id="5"><nd ref="1"/><nd ref="2"/><nd ref="3"/><nd ref="4"/><tag k="highway" v="residential"/></way>
</osm>
"""


@pytest.mark.parametrize("command", [[], ["simplify"], ["stats"]])
def test_a_node_with_nan_or_inf_coordinates_is_an_input_error(tmp_path, capsys, command):
    bad = tmp_path / "nan.osm"
    bad.write_text(NAN_NODE)
    code, _, err = run([*command, bad, "-o", tmp_path / "x.osm"] if command == ["simplify"] else [*command, bad],
                       capsys)
    line = one_line(err)
    assert code == 2 and str(bad) in line and "invalid location" in line


def test_a_negative_seed_is_refused_before_any_work(tmp_path, capsys):
    out = tmp_path / "k.xml"
    t0 = time.perf_counter()
    code, _, err = run([KREMS, "--seed", "-1", "-o", out], capsys)
    assert code == 2 and "--seed" in one_line(err) and not out.exists()
    assert time.perf_counter() - t0 < 2.0


UNWRITABLE = Path("/proc/osm-expand-test-dir")  # exists for nobody, not even root


@pytest.mark.parametrize("where", ["output", "preview"])
def test_an_unwritable_output_is_refused_before_any_work_and_nothing_is_written(tmp_path, capsys, where):
    out, png = tmp_path / "k.xml", tmp_path / "k.png"
    if where == "output":
        out = Path("/proc/k.xml")
    else:
        png = Path("/proc/k.png")
    t0 = time.perf_counter()
    code, _, err = run([KREMS, "-o", out, "--preview", png], capsys)
    line = one_line(err)
    assert code == 2 and ("not writable" in line or "cannot write" in line)
    assert time.perf_counter() - t0 < 2.0
    assert not list(tmp_path.iterdir())  # the main output is not written when the preview cannot be


def test_help_shows_the_main_command_and_the_others(capsys):
    code, out, _ = run(["--help"], capsys)
    assert code == 0
    assert "osm-expand CITY" in out and "--seed" in out and "--preview" in out
    for command in ("simplify", "stats", "reproduce", "compare"):
        assert command in out


def test_version(capsys):
    from importlib.metadata import version

    code, out, _ = run(["--version"], capsys)
    assert code == 0 and version("osm-expand") in out


def test_the_area_suggested_by_a_refusal_is_accepted(tmp_path, capsys):
    oakland = FIXTURES / "West-Oakland.osm.bz2"
    code, _, err = run([oakland, "-o", tmp_path / "b.xml", "-q", "--area", "1000"], capsys)  # too small
    assert code == 2
    suggested = re.search(r"--area (\S+)", one_line(err)).group(1).rstrip(";,.")
    args = cli.build_expand_parser().parse_args([str(oakland), "--area", suggested])
    assert args.area > 0


def test_a_format_that_contradicts_the_output_suffix_is_refused(tmp_path, capsys):
    out = tmp_path / "x.osm"
    code, _, err = run([KREMS, "--format", "geojson", "-o", out], capsys)
    assert code == 2 and "--format" in one_line(err) and not out.exists()


def test_stats_reads_the_tools_own_urbanenvironment_output(tmp_path, capsys):
    out = tmp_path / "k.xml"
    assert run([KREMS, "-o", out, "-q"], capsys)[0] == 0
    code, stdout, err = run(["stats", out, "--json", "-q"], capsys)
    assert code == 0, err
    assert json.loads(stdout)["streets"] > 100


def test_the_svg_preview_is_the_same_bytes_for_the_same_seed(tmp_path, capsys):
    for name in ("a", "b"):
        assert run([OAKLAND, "--area", "200000", "--beyond-bounds", "-o", tmp_path / f"{name}.xml",
                    "--preview", tmp_path / f"{name}.svg", "-q"], capsys)[0] == 0
    assert (tmp_path / "a.svg").read_bytes() == (tmp_path / "b.svg").read_bytes()


def test_long_stages_show_a_progress_bar_and_quiet_silences_it(tmp_path):
    """On a terminal a tqdm bar; in a log a timed line per stage; with -q nothing."""
    import fcntl
    import os
    import pty
    import struct
    import termios

    exe = Path(sys.executable).with_name("osm-expand")
    argv = [str(exe), str(KREMS), "-o", str(tmp_path / "k.xml")]
    leader, follower = pty.openpty()
    fcntl.ioctl(follower, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))  # a 100-column terminal
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=follower)
    os.close(follower)
    seen = b""
    while True:  # read while it runs: a full terminal buffer would stall it
        try:
            chunk = os.read(leader, 65536)
        except OSError:  # the terminal closed with the process
            break
        if not chunk:
            break
        seen += chunk
    os.close(leader)
    assert proc.wait() == 0
    finished = re.findall(rb"(\d+)/(\d+)", seen)[-1]
    assert b"%|" in seen and finished[0] == finished[1] and int(finished[1]) >= 7  # six stages and the eras, done
    logged = subprocess.run(argv, capture_output=True, text=True)
    assert logged.returncode == 0 and "growing streets" in logged.stderr and "%|" not in logged.stderr
    quiet = subprocess.run(argv + ["-q"], capture_output=True, text=True)
    assert quiet.returncode == 0 and notes_only(quiet.stderr) and quiet.stdout == ""
