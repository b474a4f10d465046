"""Fuzz: hostile but fair inputs through the real command line (issue 21).

Every case runs ``osm_expand.cli.main`` in this process on a small input —
a tiny synthetic town and West-Oakland, in every format the tool reads,
and the bundled history and a towns table — after one mutation:
truncation at a random offset, flipped bytes, shuffled or duplicated
elements (lines of OSM XML and TOML, elements of the tool's XML, features
of its GeoJSON), a number replaced by an out-of-range or non-finite one,
odd characters in tag values and in the file's name. Every case must end
in exit 0 with a valid output, or exit 2 with exactly one line on stderr;
never an internal error, a traceback, a warning, a temporary file left.

Cases per test: ``FUZZ_CASES`` (default 30, quick; in CI, where ``CI`` is
set, 350), half as many again for the cheap ``stats`` and ``options``,
half as many for the main command: 2,275 cases in CI. The exit codes are
counted and printed at the end of the session (``conftest.py``).
"""
from __future__ import annotations

import bz2
import collections
import contextlib
import gzip
import io
import json
import os
import re
import shutil
import tempfile
import warnings
from functools import lru_cache
from pathlib import Path

import osmium
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from lxml import etree

from osm_expand import cli
from tests.conftest import FIXTURES, notes_only

CASES = int(os.environ.get("FUZZ_CASES") or (350 if os.environ.get("CI") else 30))
FUZZ = settings(max_examples=CASES, deadline=None, derandomize=bool(os.environ.get("CI")), database=None,
                suppress_health_check=list(HealthCheck))
#: The cheap tests (a second or less a case) run half as many cases again; the main command, which
#: grows West-Oakland and may draw a preview, half as many.
MORE, FEWER = settings(FUZZ, max_examples=CASES * 3 // 2), settings(FUZZ, max_examples=max(CASES // 2, 5))
#: (test, exit code) → cases; printed by conftest's terminal summary.
EXIT_CODES: collections.Counter = collections.Counter()
ROOT = Path(__file__).resolve().parent.parent

ODD_NUMBERS = ["nan", "NaN", "inf", "-inf", "1e400", "-1e400", "1e39", "1e308", "-0", "", "abc", "999", "-999",
               "0x10", "1_000", "9" * 40, "4.5e1", " 1", "\u0661"]


def synthetic_town(lon0: float = 15.0, lat0: float = 48.0, n: int = 5) -> str:
    """An OSM XML grid of n×n junctions 100 m apart with named residential streets and one building."""
    dlat, dlon = 100 / 111_320, 100 / (111_320 * 0.669)
    lines = ["<?xml version='1.0' encoding='UTF-8'?>", '<osm version="0.6" generator="fuzz">']
    node = lambda i, j: 1 + i * n + j  # noqa: E731
    for i in range(n):
        for j in range(n):
            lines.append(f' <node id="{node(i, j)}" version="1" timestamp="2020-01-01T00:00:00Z" '
                         f'lat="{lat0 + i * dlat:.7f}" lon="{lon0 + j * dlon:.7f}"/>')
    way = 1
    for i in range(n):
        for horizontal in (True, False):
            refs = [node(i, j) if horizontal else node(j, i) for j in range(n)]
            lines.append(f' <way id="{way}" version="1" timestamp="2020-01-01T00:00:00Z">'
                         + "".join(f'<nd ref="{r}"/>' for r in refs)
                         + f'<tag k="highway" v="residential"/><tag k="name" v="Street {way}"/></way>')
            way += 1
    b = [(0.2, 0.2), (0.2, 0.6), (0.6, 0.6), (0.6, 0.2)]
    for k, (u, v) in enumerate(b):
        lines.append(f' <node id="{1000 + k}" version="1" lat="{lat0 + u * dlat:.7f}" lon="{lon0 + v * dlon:.7f}"/>')
    lines.append(' <way id="500" version="1">' + "".join(f'<nd ref="{1000 + k}"/>' for k in (0, 1, 2, 3, 0))
                 + '<tag k="building" v="yes"/><tag k="height" v="9"/></way>')
    lines.append("</osm>")
    return "\n".join(lines) + "\n"


@lru_cache(maxsize=None)
def sources() -> dict[str, bytes]:
    """The inputs to mutate, by name: OSM XML, PBF, and the tool's own GeoJSON and XML outputs."""
    tmp = Path(tempfile.mkdtemp(prefix="fuzz-sources-"))
    out = {"tiny.osm": synthetic_town().encode(),
           "oakland.osm": bz2.decompress((FIXTURES / "West-Oakland.osm.bz2").read_bytes())}
    (tmp / "tiny.osm").write_bytes(out["tiny.osm"])
    writer = osmium.SimpleWriter(str(tmp / "tiny.osm.pbf"))
    for obj in osmium.FileProcessor(str(tmp / "tiny.osm")):
        writer.add(obj)
    writer.close()
    out["tiny.osm.pbf"] = (tmp / "tiny.osm.pbf").read_bytes()
    (tmp / "oakland.osm").write_bytes(out["oakland.osm"])
    with contextlib.redirect_stderr(io.StringIO()):
        assert cli.main(["simplify", str(tmp / "oakland.osm"), "-q", "-o", str(tmp / "s.geojson")]) == 0
        assert cli.main([str(tmp / "oakland.osm"), "-q", "--years", "0", "--area", "200000", "--beyond-bounds",
                         "-o", str(tmp / "grown.xml")]) == 0
    out["oakland.geojson"] = (tmp / "s.geojson").read_bytes()
    out["oakland.xml"] = (tmp / "grown.xml").read_bytes()
    shutil.rmtree(tmp)
    return out


# --- mutations ------------------------------------------------------------------------------------------


@st.composite
def mutated(draw, data: bytes) -> bytes:
    """One mutation of ``data`` (or none: the valid input must pass too)."""
    how = draw(st.sampled_from(["none", "truncate", "flip", "shuffle", "duplicate", "number", "tag"]))
    if how == "truncate":
        return data[:draw(st.integers(0, len(data)))]
    if how == "flip":
        b = bytearray(data)
        for _ in range(draw(st.integers(1, 8))):
            b[draw(st.integers(0, len(b) - 1))] ^= draw(st.integers(1, 255))
        return bytes(b)
    # elements: a line each in OSM XML and TOML; the tool's own XML and GeoJSON are one line
    sep = b"\n" if data.count(b"\n") > 50 else b'},{"type":"Feature"' if data.startswith(b"{") else b"><"
    lines = data.split(sep)
    if how in ("shuffle", "duplicate") and len(lines) > 2:
        i = draw(st.integers(0, len(lines) - 2))
        j = draw(st.integers(i + 1, min(len(lines), i + 40)))
        part = lines[i:j]
        if how == "shuffle":
            part = draw(st.permutations(part))
        else:
            part = part + part
        return sep.join(lines[:i] + list(part) + lines[j:])
    text = data.decode("utf-8", "replace")
    if how == "number":
        spots = list(re.finditer(r'(?<=")-?\d+\.?\d*(?:e-?\d+)?(?=")|(?<=[\[,])-?\d+\.\d+(?=[\],])', text))
        if spots:
            m = draw(st.sampled_from(spots[:2000]))
            text = text[:m.start()] + draw(st.sampled_from(ODD_NUMBERS)) + text[m.end():]
    elif how == "tag":
        spots = list(re.finditer(r'(?<=v=")[^"]*(?=")|(?<="name":")[^"]*(?=")', text))
        if spots:
            m = draw(st.sampled_from(spots[:2000]))
            value = draw(st.text(st.characters(codec="utf-8", exclude_characters='"<&\\'), max_size=20))
            text = text[:m.start()] + value + text[m.end():]
    return text.encode("utf-8", "surrogatepass")


odd_names = st.one_of(
    st.text(st.characters(codec="utf-8", exclude_characters="/\x00"), min_size=1, max_size=40),
    st.binary(min_size=1, max_size=40).map(lambda b: os.fsdecode(b.replace(b"/", b"_").replace(b"\x00", b"_"))),
).filter(lambda s: s not in (".", ".."))  # text, or bytes that are not UTF-8 (lone surrogates in Python)


# --- the check ------------------------------------------------------------------------------------------


def check(test: str, argv: list, workdir: Path, output: Path | None = None) -> int:
    """Run the command; exit 0 with a valid output or exit 2 with one stderr line, nothing left behind."""
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out), warnings.catch_warnings():
        warnings.simplefilter("always")  # a warning is a stray stderr line too (issue 21 point 12)
        code = cli.main([str(a) for a in argv])
    lines = err.getvalue().splitlines()
    EXIT_CODES[(test, code)] += 1
    assert code in (0, 2), f"exit {code}: {err.getvalue()}"
    if code == 2 and test == "towns" and len(lines) > 1:  # a batch names each failed job, then sums up
        assert all(ln.startswith("osm-expand: batch: ") for ln in lines[:-1]) and "failed" in lines[-1], lines
    elif code == 2:
        assert len(lines) == 1 and lines[0].startswith("osm-expand: "), err.getvalue()
        assert "internal error" not in lines[0]
        if output is not None:
            assert not output.exists()
    else:
        assert notes_only(err.getvalue()), err.getvalue()
        if output is not None:
            valid(output)
    stray = [p.name for p in workdir.rglob(".*") if p.name.endswith(".tmp") or p.name.startswith(".osm-expand")]
    assert stray == []
    return code


def valid(path: Path) -> None:
    name = path.name.lower()
    if name.endswith((".geojson", ".json")):
        doc = json.loads(path.read_text(encoding="utf-8"))
        assert doc["type"] == "FeatureCollection" and doc["features"]
    else:
        root = etree.fromstring(path.read_bytes())  # (lxml refuses a file name that is not UTF-8)
        assert root.tag in ("osm", "urbanenvironment") and len(root)


def _input(tmp: Path, source: str, data: bytes, name: str, container: str) -> Path:
    suffix = {"oakland.geojson": ".geojson", "oakland.xml": ".xml", "tiny.osm.pbf": ".osm.pbf"}.get(source, ".osm")
    if suffix == ".osm" and container != "plain":
        suffix, data = (".osm.gz", gzip.compress(data, mtime=0)) if container == "gz" else (".osm.bz2",
                                                                                          bz2.compress(data))
    path = tmp / (name + suffix)
    try:
        path.write_bytes(data)
    except OSError:  # the name is too long for the file system: the command must say so
        pass
    return path


@contextlib.contextmanager
def workdir():
    folder = Path(tempfile.mkdtemp(prefix="fuzz-"))
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


sources_names = st.sampled_from(["tiny.osm", "oakland.osm", "tiny.osm.pbf", "oakland.geojson", "oakland.xml"])


# --- the tests ------------------------------------------------------------------------------------------


@MORE
@given(st.data())
def test_fuzz_stats(data):
    source = data.draw(sources_names)
    blob = data.draw(mutated(sources()[source]))
    with workdir() as tmp:
        path = _input(tmp, source, blob, "in", data.draw(st.sampled_from(["plain", "gz", "bz2"])))
        check("stats", ["stats", path, "-q"], tmp)


@FUZZ
@given(st.data())
def test_fuzz_simplify(data):
    source = data.draw(sources_names)
    blob = data.draw(mutated(sources()[source]))
    with workdir() as tmp:
        path = _input(tmp, source, blob, data.draw(odd_names), data.draw(st.sampled_from(["plain", "gz", "bz2"])))
        out = tmp / ("out" + data.draw(st.sampled_from([".osm", ".geojson"])))
        check("simplify", ["simplify", path, "-q", "-o", out], tmp, out)


@FEWER
@given(st.data())
def test_fuzz_expand(data):
    """The main command without the engine (--years 0): reading, the site, growing, writing."""
    source = data.draw(sources_names)
    blob = data.draw(mutated(sources()[source]))
    with workdir() as tmp:
        path = _input(tmp, source, blob, "in", data.draw(st.sampled_from(["plain", "gz", "bz2"])))
        out = tmp / (data.draw(odd_names) + data.draw(st.sampled_from([".xml", ".osm", ".geojson"])))
        area = data.draw(st.sampled_from([[], ["--area", "200000", "--beyond-bounds"]]))
        preview = data.draw(st.sampled_from([[], [], [], ["--preview", tmp / (data.draw(odd_names) + ".png")]]))
        check("expand", [path, "-q", "--years", "0", *area, *preview, "-o", out], tmp, out)


@MORE
@given(st.data())
def test_fuzz_options(data):
    """Odd option values on a valid small town: refused in one line or used."""
    option = data.draw(st.sampled_from(["--area", "--at", "--at-lonlat", "--bbox", "--around", "--seed",
                                        "--cluster-radius", "--years", "--unbuildable", "--direction"]))
    value = data.draw(st.one_of(st.sampled_from(ODD_NUMBERS + ["1,2", "-1,-1", "0,0", "-180,-90,180,90",
                                                               "15,48,15.01,48.01", "15.003,48.003"]),
                                st.text(st.characters(codec="utf-8", exclude_characters="\x00"), max_size=12)))
    with workdir() as tmp:
        town = tmp / "tiny.osm"
        town.write_bytes(sources()["tiny.osm"])
        if option == "--cluster-radius":
            out = tmp / "out.osm"
            argv = ["simplify", town, "-q", "-o", out, f"{option}={value}"]
        else:
            out = tmp / "out.xml"
            extra = ["--radius", "300"] if option == "--around" else []
            argv = [town, "-q", "--years", "0", "-o", out, f"{option}={value}", *extra]
        check("options", argv, tmp, out)


@FUZZ
@given(st.data())
def test_fuzz_history(data):
    """The bundled history, mutated: refused in one line naming it, or read (the tiny town then is too small)."""
    text = (ROOT / "osm_expand" / "histories" / data.draw(st.sampled_from(["example.toml", "european.toml"])))
    blob = data.draw(mutated(text.read_bytes()))
    if data.draw(st.booleans()):
        blob = data.draw(st.sampled_from([b"\xef\xbb\xbf", b""])) + blob
    with workdir() as tmp:
        town = tmp / "tiny.osm"
        town.write_bytes(sources()["tiny.osm"])
        history = tmp / (data.draw(odd_names) + ".toml")
        try:
            history.write_bytes(blob)
        except OSError:
            pass
        check("history", [town, "-q", "--years", "0", "--history", history, "-o", tmp / "out.xml"], tmp,
              tmp / "out.xml")


@FUZZ
@given(st.data())
def test_fuzz_towns_table(data):
    """A towns table, mutated: refused in one line, or its towns (far from the tiny town) fail alone."""
    table = "name,lon,lat,radius\nfar,100.0,10.0,500\nfurther,-60.5,-30.25,1000\n".encode()
    blob = data.draw(mutated(table))
    encoding = data.draw(st.sampled_from(["utf-8", "latin-1", "utf-16"]))
    blob = blob.decode("utf-8", "replace").encode(encoding, "replace")
    with workdir() as tmp:
        town = tmp / "tiny.osm"
        town.write_bytes(sources()["tiny.osm"])
        path = tmp / "towns.csv"
        path.write_bytes(blob)
        check("towns", ["batch", town, "--out", tmp / "out", "--towns", path, "-q", "--workers", "1"], tmp)
