"""Issue 21, hardening: nothing lost, nothing misreported, whatever the input.

Each test names the point of the issue it holds. A bad input or option ends
in exit 2 with one line on stderr naming the file and the problem, before
any work where it can be known before; never a traceback, never an internal
error, never a partial or clobbered file. Signals (SIGINT, SIGTERM, SIGHUP)
clean up as Ctrl-C does, with exit 128 + the signal's number.
"""
from __future__ import annotations

import bz2
import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from lxml import etree

from osm_expand import cli
from osm_expand.engine import history
from tests.conftest import FIXTURES, notes_only

MAX_YEARS = getattr(history, "MAX_YEARS", 1000)  # (getattr: this file also runs against the code before it)

ROOT = Path(__file__).resolve().parent.parent
#: West-Oakland grows in about a second with these (its map is too small for the default area).
GROW = ["--years", "0", "--area", "200000", "--beyond-bounds", "-q"]


def run(argv, capsys):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "internal error" not in lines[0] and "Traceback" not in err
    return lines[0]


@pytest.fixture(scope="module")
def oakland(tmp_path_factory) -> Path:
    """West-Oakland as plain OSM XML (the fixture is bz2), for edits by text."""
    path = tmp_path_factory.mktemp("oakland") / "oakland.osm"
    path.write_bytes(bz2.decompress((FIXTURES / "West-Oakland.osm.bz2").read_bytes()))
    return path


@pytest.fixture(scope="module")
def oakland_outputs(tmp_path_factory, oakland) -> dict[str, Path]:
    """The grown town as GeoJSON and urbanenvironment XML, to read back."""
    folder = tmp_path_factory.mktemp("outputs")
    out = {}
    for suffix in (".geojson", ".xml"):
        out[suffix] = folder / f"grown{suffix}"
        assert cli.main([str(oakland), *GROW, "-o", str(out[suffix])]) == 0
    return out


def subprocess_main(script: str, cwd: Path, timeout: float = 120, **kwargs) -> subprocess.CompletedProcess:
    """``script`` (which calls ``osm_expand.cli.main``) in a fresh interpreter on this worktree, with Ctrl-C
    raising and SIGTERM and SIGHUP at their defaults, as in a terminal (a background job, a CI runner, inherits
    SIGINT ignored; a suite run under ``nohup`` inherits SIGHUP ignored, which the CLI rightly leaves alone)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    script = ("import signal; signal.signal(signal.SIGINT, signal.default_int_handler)\n"
              "signal.signal(signal.SIGTERM, signal.SIG_DFL); signal.signal(signal.SIGHUP, signal.SIG_DFL)\n"
              + textwrap.dedent(script))
    return subprocess.run([sys.executable, "-c", script], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=timeout, **kwargs)


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


# --- 1: the input is never an output -------------------------------------------------------------------


@pytest.mark.parametrize("command", ["expand", "simplify", "geojson"])
def test_point1_the_input_is_never_the_output(tmp_path, capsys, oakland, oakland_outputs, command):
    src = tmp_path / ("town.geojson" if command == "geojson" else "town.osm")
    shutil.copy(oakland_outputs[".geojson"] if command == "geojson" else oakland, src)
    before = src.read_bytes()
    link = tmp_path / f"link{src.suffix}"
    link.symlink_to(src)
    for out in (src, link, tmp_path / "." / src.name):
        argv = ["simplify", src, "-o", out, "-q"] if command == "simplify" else [src, *GROW, "-o", out]
        code, _, err = run(argv, capsys)
        assert code == 2 and "is the input file" in one_line(err)
    assert src.read_bytes() == before


# --- 4: SIGTERM and SIGHUP clean up as Ctrl-C does -----------------------------------------------------

_SIGNAL_WHILE_WRITING = """
    import os, signal, sys
    from lxml import etree
    from osm_expand import cli
    real = etree.xmlfile
    class Killing:
        def __init__(self, fh, **kw):
            self.inner = real(fh, **kw)
        def __enter__(self):
            xf = self.inner.__enter__()
            os.kill(os.getpid(), {signum})  # mid-write: the temporary file exists
            return xf
        def __exit__(self, *exc):
            return self.inner.__exit__(*exc)
    etree.xmlfile = Killing
    sys.exit(cli.main(sys.argv[1:] or {argv!r}))
"""


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_point4_signals_while_writing_leave_nothing_behind(tmp_path, oakland, signum):
    out = tmp_path / "out.xml"  # the urbanenvironment writer streams through lxml's xmlfile, where the signal comes
    out.write_text("the user's earlier file")
    argv = [str(oakland), *GROW, "-o", str(out)]
    proc = subprocess_main(_SIGNAL_WHILE_WRITING.format(signum=int(signum), argv=argv), tmp_path)
    assert proc.returncode == 128 + signum, proc.stderr
    assert proc.stderr.strip().splitlines()[-1].startswith("osm-expand: interrupted")
    assert out.read_text() == "the user's earlier file"  # never clobbered
    assert leftovers(tmp_path) == []  # no temporary file


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP])
def test_point4_signals_while_clipping_remove_the_node_store(tmp_path, oakland, signum):
    script = f"""
        import os, sys
        from osm_expand import cli
        from osm_expand.clip import two_pass
        real = two_pass._scan_store
        def scan(path, grid):
            assert path.exists()  # the node store is on disk now
            os.kill(os.getpid(), {int(signum)})
            return real(path, grid)
        two_pass._scan_store = scan
        sys.exit(cli.main(["simplify", {str(oakland)!r}, "-q", "-o", "out.osm", "--bbox", "-122.31,37.80,-122.29,37.82"]))
    """
    proc = subprocess_main(script, tmp_path)
    assert proc.returncode == 128 + signum, proc.stderr
    assert leftovers(tmp_path) == [] and not (tmp_path / "out.osm").exists()


# --- 5: compare's text report --------------------------------------------------------------------------


def test_point5_compare_prints_its_text_report(capsys, oakland, oakland_outputs):
    code, out, err = run(["compare", oakland_outputs[".geojson"], oakland, "-q"], capsys)
    assert code == 0 and notes_only(err)
    assert "as a district of" in out and "a typical real neighbourhood" in out and len(out.splitlines()) == 15  # + 14 measures


# --- 6: bad input read back, and odd but valid input -----------------------------------------------------


def _geojson_variant(doc: dict, how: str) -> dict:
    doc = json.loads(json.dumps(doc))
    street = next(f for f in doc["features"] if f["geometry"]["type"] == "LineString")
    building = next(f for f in doc["features"] if f["geometry"]["type"] == "Polygon")
    if how == "origin":
        building["properties"]["origin"] = "nowhere"
    elif how == "osm_id":
        building["properties"]["osm_id"] = "abc"
    elif how == "empty ring":
        building["geometry"]["coordinates"] = [[]]
    elif how == "nan street":
        street["geometry"]["coordinates"][0][0] = float("nan")
    elif how == "nan building":
        building["geometry"]["coordinates"][0][1][0] = float("nan")
    elif how == "short street":
        street["geometry"]["coordinates"] = [[1.0]]
    return doc


@pytest.mark.parametrize("how", ["origin", "osm_id", "empty ring", "nan street", "nan building", "short street",
                                 "deep"])
def test_point6_bad_geojson_read_back_is_exit_2(tmp_path, capsys, oakland_outputs, how):
    path = tmp_path / "bad.geojson"
    if how == "deep":
        path.write_text("[" * 200_000 + "]" * 200_000)
    else:
        path.write_text(json.dumps(_geojson_variant(json.loads(oakland_outputs[".geojson"].read_text()), how)))
    for argv in (["stats", path, "-q"], [path, *GROW, "-o", tmp_path / "out.xml"]):
        code, _, err = run(argv, capsys)
        assert code == 2 and one_line(err).startswith(f"osm-expand: {path}")
    assert not (tmp_path / "out.xml").exists()


@pytest.mark.parametrize("old,new", [('lat0="', 'lat0="abc'), ('lat0="', 'lat0="inf'), ('lat0="', 'lat0="9'),
                                     ('lon0="', 'lon0="nan'), ('osm_id="', 'osm_id="x'),
                                     ('origin="source"', 'origin="elsewhere"'), ('x1="', 'x1="nan')])
def test_point6_bad_urbanenvironment_read_back_is_exit_2(tmp_path, capsys, oakland_outputs, old, new):
    path = tmp_path / "bad.xml"
    path.write_text(oakland_outputs[".xml"].read_text().replace(old, new, 1))
    code, _, err = run(["stats", path, "-q"], capsys)
    assert code == 2 and one_line(err).startswith(f"osm-expand: {path}")


def test_point6_a_building_without_nodes_is_exit_2(tmp_path, capsys, oakland_outputs):
    path = tmp_path / "bad.xml"
    path.write_text(re.sub(r"(<building [^>]*>)(<node [^>]*/>)+", r"\1", oakland_outputs[".xml"].read_text(), count=1))
    code, _, err = run(["stats", path, "-q"], capsys)
    assert code == 2 and "building 0" in one_line(err)


@pytest.mark.parametrize("suffix", [".xml", ".osm", ".geojson"])
def test_point6_control_characters_in_names_are_written_safely(tmp_path, capsys, oakland_outputs, suffix):
    doc = json.loads(oakland_outputs[".geojson"].read_text())
    street = next(f for f in doc["features"] if f["geometry"]["type"] == "LineString")
    street["properties"]["name"] = "Goss\u0001Street\ufffe\ud800"
    src = tmp_path / "odd.geojson"
    src.write_text(json.dumps(doc))  # JSON escapes: \u0001, \ufffe and a lone surrogate are all legal there
    out = tmp_path / f"out{suffix}"
    code, _, err = run([src, *GROW, "-o", out], capsys)
    assert code == 0 and notes_only(err)
    text = out.read_bytes().decode("utf-8")  # valid UTF-8
    if suffix == ".geojson":  # JSON holds control characters escaped; a lone surrogate becomes "?"
        names = {f["properties"].get("name") for f in json.loads(text)["features"]}
        assert "Goss\u0001Street\ufffe?" in names
    else:
        etree.fromstring(out.read_bytes())  # well-formed XML
        assert "Goss\ufffdStreet\ufffd\ufffd" in text


def test_point6_the_whole_globe_as_the_bbox(tmp_path, capsys):
    out = tmp_path / "m.xml"
    code, _, err = run([FIXTURES / "monaco.osm.gz", "--years", "0", "-q", "--bbox", "-180,-90,180,90", "-o", out],
                       capsys)
    assert code == 0 and notes_only(err) and out.exists()


def test_point6_latin1_towns_table(tmp_path, capsys, oakland):
    table = tmp_path / "towns.csv"
    table.write_bytes("name,lon,lat,radius\nK\xf6ln,-122.30,37.81,500\n".encode("latin-1"))
    code, _, err = run(["batch", oakland, "--out", tmp_path / "out", "--towns", table, "-q"], capsys)
    assert code == 2 and "not UTF-8" in one_line(err)


def _history(tmp_path: Path, **replace: str) -> Path:
    """The bundled example history with top-level keys replaced (TOML text)."""
    text = (ROOT / "osm_expand" / "histories" / "example.toml").read_text()
    for key, value in replace.items():
        text, n = re.subn(rf"(?ms)^{key} = (\[.*?^\]|[^\n]*)", f"{key} = {value}", text, count=1)
        assert n == 1, key
    path = tmp_path / "h.toml"
    path.write_text(text)
    return path


def test_point6_growth_1e308_in_a_history(tmp_path, capsys, oakland):
    code, _, err = run([oakland, *GROW, "--history", _history(tmp_path, growth="1e308"), "-o", tmp_path / "o.xml"],
                       capsys)
    assert code == 2 and "growth: values must be ≤ 1" in one_line(err)


# --- 7: write failures ---------------------------------------------------------------------------------


def test_point7_a_long_output_name_is_written(tmp_path, capsys, oakland):
    out = tmp_path / ("n" * 246 + ".xml")  # 250 characters: the temporary name would be too long
    code, _, err = run([oakland, *GROW, "-o", out], capsys)
    assert code == 0 and notes_only(err) and out.exists() and leftovers(tmp_path) == []


def test_point7_a_name_too_long_is_refused_before_the_work(tmp_path, capsys, oakland):
    out = tmp_path / ("n" * 300 + ".xml")
    code, _, err = run([oakland, *GROW[:-1], "-o", out], capsys)  # without -q: nothing may have started
    assert code == 2 and "File name too long" in one_line(err) and "reading" not in err


@pytest.mark.parametrize("where", ["input", "simplify", "preview", "snapshots", "snapshot names", "path"])
def test_point7_names_and_paths_too_long_are_one_line_before_the_work(tmp_path, capsys, oakland, where):
    long = "n" * 300
    city, argv = oakland, ["-o", tmp_path / "o.xml"]
    if where == "input":
        city = tmp_path / f"{long}.osm"
    elif where == "simplify":
        argv = ["simplify", oakland, "-o", tmp_path / f"{long}.osm"]
    elif where == "preview":
        argv += ["--preview", tmp_path / f"{long}.png"]
    elif where == "snapshots":
        argv += ["--years", "1", "--snapshots", tmp_path / long]
    elif where == "snapshot names":  # NAME-YEAR-ERA.png: fits for the output, not for the pictures
        city = tmp_path / ("w" * 235 + ".osm")
        shutil.copy(oakland, city)
        argv += ["--years", "1", "--snapshots", tmp_path / "pictures"]
    else:
        argv = ["-o", Path("/tmp", *["d" * 200] * 25, "o.xml")]
    if where != "simplify":
        argv = [city, *argv] + ([] if "--years" in argv else GROW[:2])
    code, _, err = run([*argv, "-q"], capsys)
    assert code == 2 and "too long" in one_line(err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ([city.name] if where == "snapshot names" else [])


def test_point7_a_full_disk_is_one_line_exit_2(tmp_path, oakland):
    out = tmp_path / "out.xml"
    out.write_text("the user's earlier file")
    limit = 20_000  # bytes: the output is larger; writing past it fails with EFBIG, as on a full disk

    def small_files():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    proc = subprocess_main(f"import sys; from osm_expand import cli; sys.exit(cli.main({[str(oakland), *GROW, '-o', str(out)]!r}))",
                           tmp_path, preexec_fn=small_files)
    assert proc.returncode == 2, proc.stderr
    assert one_line(proc.stderr) == f"osm-expand: {out}: cannot write it (File too large); nothing was written"
    assert out.read_text() == "the user's earlier file" and leftovers(tmp_path) == []


def test_point7_a_read_only_batch_out_is_refused(capsys, oakland):
    """``--out DIR`` in a folder nobody can write, not even root (/proc): one line, exit 2, before any job."""
    code, _, err = run(["batch", oakland, "--out", "/proc/osm-expand-batch-out", "-q"], capsys)
    assert code == 2 and "cannot be made or written" in one_line(err)


# --- 8: coordinates never silently corrupted -----------------------------------------------------------


def test_point8_lat_1e400_is_refused(tmp_path, capsys, oakland):
    text = oakland.read_text()
    first = re.search(r'<node id="(\d+)"[^>]* lat="([^"]+)"', text)
    bad = tmp_path / "bad.osm"
    bad.write_text(text.replace(f'lat="{first.group(2)}"', 'lat="1e400"', 1))
    code, _, err = run([bad, *GROW, "-o", tmp_path / "o.xml"], capsys)
    assert code == 2 and f"node {first.group(1)} has lat 0" in one_line(err)


def test_point8_a_node_without_lat_is_refused(tmp_path, capsys, oakland):
    text = oakland.read_text()
    first = re.search(r'<node id="(\d+)"', text).group(1)
    bad = tmp_path / "bad.osm"
    bad.write_text(re.sub(r' lat="[^"]+"', "", text, count=1))
    code, _, err = run(["simplify", bad, "-q", "-o", tmp_path / "o.osm"], capsys)
    assert code == 2 and f"node {first} has no valid lat/lon" in one_line(err)


# --- 9: upper bounds ------------------------------------------------------------------------------------


def test_point9_years_beyond_the_bound_are_refused(tmp_path, capsys, oakland):
    code, _, err = run([oakland, "--years", str(MAX_YEARS + 1), "-o", tmp_path / "o.xml"], capsys)
    assert code == 2 and f"at most {MAX_YEARS}" in one_line(err) and not (tmp_path / "o.xml").exists()
    code, _, err = run([oakland, "--history", _history(tmp_path, years="100000"), "-o", tmp_path / "o.xml"], capsys)
    assert code == 2 and "years: must be 0 to" in one_line(err)


def test_point9_a_billion_attempts_per_start_are_refused(tmp_path, capsys, oakland):
    text = (ROOT / "osm_expand" / "histories" / "example.toml").read_text()
    path = tmp_path / "h.toml"
    era = 'pattern = "example"'
    assert era in text
    path.write_text(text.replace(era, 'pattern = "organic"\npattern_options = { attempts_per_start = 1000000000 }', 1))
    code, _, err = run([oakland, *GROW, "--history", path, "-o", tmp_path / "o.xml"], capsys)
    assert code == 2 and "attempts_per_start" in one_line(err)


def test_point9_history_from_dev_zero_is_refused_quickly(capsys, oakland, tmp_path):
    code, _, err = run([oakland, *GROW, "--history", "/dev/zero", "-o", tmp_path / "o.xml"], capsys)
    assert code == 2 and "too large for a history file" in one_line(err)


# --- 10: the antimeridian -------------------------------------------------------------------------------


def test_point10_a_town_across_the_antimeridian_is_named(tmp_path, capsys, oakland):
    def shift(m):
        lon = float(m.group(1)) + 122.3004 + 180.0  # the town's middle onto lon 180
        return f'lon="{lon - 360 if lon > 180 else lon:.7f}"'

    path = tmp_path / "dateline.osm"
    path.write_text(re.sub(r'lon="([^"]+)"', shift, re.sub(r"<bounds[^>]*/>", "", oakland.read_text())))
    code, _, err = run([path, *GROW, "-o", tmp_path / "o.xml"], capsys)
    assert code == 2 and "antimeridian" in one_line(err) and "not supported" in err


# --- 11: Ctrl-C while the outputs are renamed into place -----------------------------------------------


def test_point11_ctrl_c_between_the_renames_leaves_all_or_nothing(tmp_path, oakland):
    script = f"""
        import os, signal, sys
        from osm_expand import cli
        real, calls = os.replace, []
        def replace(a, b):
            calls.append(b)
            if len(calls) == 1:
                os.kill(os.getpid(), signal.SIGINT)  # between the output's rename and the preview's
            real(a, b)
        os.replace = replace
        sys.exit(cli.main({[str(oakland), *GROW, '-o', 'out.osm', '--preview', 'out.png']!r}))
    """
    proc = subprocess_main(script, tmp_path)
    assert proc.returncode == 130, proc.stderr
    assert proc.stderr.strip() == "osm-expand: interrupted"
    assert leftovers(tmp_path) == []  # no temporary file: both outputs landed whole, or neither
    assert (tmp_path / "out.osm").exists() == (tmp_path / "out.png").exists()


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_point11_an_interrupt_a_library_swallows_still_stops_the_run(tmp_path, oakland, signum):
    """As a C extension's callback may swallow the exception: the run ends interrupted, nothing lands."""
    script = f"""
        import os, sys
        from osm_expand import cli, pipeline
        real = pipeline.expand
        def expand(*args, **kwargs):
            try:
                os.kill(os.getpid(), {int(signum)})
            except BaseException:
                pass  # swallowed
            return real(*args, **kwargs)
        pipeline.expand = expand
        sys.exit(cli.main({[str(oakland), *GROW, '-o', 'out.xml']!r}))
    """
    proc = subprocess_main(script, tmp_path)
    assert proc.returncode == 128 + signum, proc.stderr
    assert proc.stderr.strip().startswith("osm-expand: interrupted")
    assert not (tmp_path / "out.xml").exists() and leftovers(tmp_path) == []


# --- 12: nothing else on stderr --------------------------------------------------------------------------


def test_point12_a_file_name_with_a_newline_is_one_line(tmp_path, capsys):
    code, _, err = run([tmp_path / "no\nsuch.osm", "-q"], capsys)
    assert code == 2 and "no\\nsuch.osm: no such file" in one_line(err)


# --- 13: messages ---------------------------------------------------------------------------------------


def test_point13_messages(tmp_path, capsys, oakland):
    def refused(argv) -> str:
        code, _, err = run(argv, capsys)
        assert code == 2, err
        return one_line(err)

    out = ["-o", tmp_path / "o.xml"]
    assert "give a bundled history" in refused([oakland, *GROW, "--history", "", *out])
    bom = tmp_path / "bom.toml"
    bom.write_text("\ufeff" + (ROOT / "osm_expand" / "histories" / "example.toml").read_text())
    assert run([oakland, *GROW, "--history", bom, *out], capsys)[0] == 0  # a BOM is fine
    folder = tmp_path / "dir"
    folder.mkdir()
    assert "is a directory" in refused([oakland, *GROW, "-o", folder])
    assert "--at expects two numbers" in refused([oakland, *GROW, "--at", "", *out])
    assert "--cluster-radius" in refused(["simplify", oakland, "--cluster-radius", "inf", "-o", tmp_path / "s.osm"])
    message = refused([oakland, *GROW[:2], "--area", "1e308", *out])
    assert "--area" in message and len(message) < 120
    assert "--area" in refused(["batch", oakland, "--out", tmp_path / "b", "--area", "nan", "-q"])
    assert "nope.toml" in refused(["batch", oakland, "--out", tmp_path / "b", "--history", tmp_path / "nope.toml"])
    assert not (tmp_path / "b").exists()  # refused before any folder or job
    blocked = tmp_path / "blocked"
    blocked.write_text("")
    message = refused([oakland, "--years", "1", "-q", "--snapshots", blocked / "a" / "b", *out])
    assert "probe.png" not in message and "--snapshots" in message


def test_point12_a_non_utf8_file_name_with_a_preview(tmp_path, capsys, oakland):
    city = Path(os.fsdecode(bytes(tmp_path) + b"/\xff\xfe.osm"))  # not UTF-8: a lone surrogate in Python
    shutil.copy(oakland, city)
    code, _, err = run([city, *GROW, "-o", tmp_path / "o.xml", "--preview", tmp_path / "o.png"], capsys)
    assert code == 0 and notes_only(err) and (tmp_path / "o.png").stat().st_size > 0


def test_point12_library_warnings_never_reach_stderr(monkeypatch, capsys):
    import warnings

    import numpy as np

    def noisy(args, log):
        np.divide(np.zeros(1), np.zeros(1))  # numpy's RuntimeWarning, as sites.py raised on degenerate rings
        return {}

    monkeypatch.setitem(cli.COMMANDS, "stats", noisy)
    monkeypatch.delenv("OSM_EXPAND_DEBUG", raising=False)
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = lambda m, c, f, n, file=None, line=None: sys.stderr.write(
            warnings.formatwarning(m, c, f, n, line))  # as a plain interpreter prints them
        code, _, err = run(["stats", "any.osm", "-q"], capsys)
    assert code == 0 and notes_only(err)


def test_an_urbanenvironment_coordinate_beyond_the_earth_is_refused_in_one_line(tmp_path, capsys):
    """A segment at ``x1="1e39"`` (hypothesis found it in test_fuzz) is finite but not on the Earth: it reached
    GEOS and failed there (exit 1); it is the file's fault (exit 2, one line naming the street)."""
    from osm_expand import cli

    bad = tmp_path / "far.xml"
    bad.write_text('<?xml version="1.0" encoding="UTF-8"?>\n<urbanenvironment lon0="-122.3" lat0="37.8"><streets>'
                   '<street id="0" highway="residential" origin="source">'
                   '<segment x1="1e39" y1="-29.6" x2="-141.8" y2="5.1"/>'
                   '<segment x1="-141.8" y1="5.1" x2="-151.6" y2="7.8"/></street></streets><buildings/>'
                   '</urbanenvironment>')
    assert cli.main([str(bad), "-o", str(tmp_path / "out.xml"), "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "street 0" in err[0] and "on the Earth" in err[0]
    assert not (tmp_path / "out.xml").exists()
