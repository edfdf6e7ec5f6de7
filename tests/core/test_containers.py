"""Records in the wrappers logs come in (bench.containers): compressed (gzip, bzip2, xz, zstd),
zipped, cut short by a logger stopped mid-write, in UTF-16 or a Windows code page.  Each was
refused as "not UTF-8 text" until 2026-12-06.  A 20 s j3 record, fresh seed 10227."""
import bz2
import gzip
import io
import json
import lzma
import subprocess
import sys
import zipfile

import numpy as np
import pyarrow as pa
import pytest

from bench.analysis import analyze_record
from bench.errors import InputError
from bench.readers import read_record
from virtual_drives.joint import simulate_record
from virtual_drives.presets import PRESETS


@pytest.fixture(scope="module")
def rec():
    return simulate_record(PRESETS["j3"], *PRESETS["j3"].excitation, duration=20.0, seed=10227).record


def _zstd(raw: bytes) -> bytes:
    sink = pa.BufferOutputStream()
    with pa.CompressedOutputStream(sink, "zstd") as s:
        s.write(raw)
    return sink.getvalue().to_pybytes()


def _zip(members: dict) -> bytes:
    b = io.BytesIO()
    with zipfile.ZipFile(b, "w", zipfile.ZIP_DEFLATED) as z:
        for name, raw in members.items():
            z.writestr(name, raw)
    return b.getvalue()


def test_a_compressed_or_zipped_record_reads_as_the_plain_one(rec):
    plain = rec.to_csv().encode()
    want = read_record(plain, name="r.csv")
    cases = {"gzip": gzip.compress(plain), "bzip2": bz2.compress(plain), "xz": lzma.compress(plain),
             "zstd": _zstd(plain),
             # a logger's rotation appends gzip members; a Mac's zip carries its resource forks
             "gzip (two members)": gzip.compress(plain[:400000]) + gzip.compress(plain[400000:]),
             "zip": _zip({"bench/r.csv": plain, "__MACOSX/bench/._r.csv": b"\x00\x05\x16\x07"}),
             "zip+gzip": _zip({"r.csv.gz": gzip.compress(plain)})}
    for how, raw in cases.items():
        got = read_record(raw, name="r.csv.x")
        for k in ("t", "tau", "q"):
            np.testing.assert_array_equal(getattr(got, k), getattr(want, k), err_msg=how)
        assert got.meta == want.meta, how
        assert got.reading["container"] == how.split(" ")[0], (how, got.reading)
        assert "truncated_lines" not in got.reading
    assert read_record(cases["zip"], name="a.zip").reading["member"] == "bench/r.csv"


def test_a_compressed_log_cut_short_keeps_its_whole_lines_and_says_so(rec):
    """A logger killed mid-write: what was written before the cut is read, and the report's
    first warnings say the file ended early."""
    raw = gzip.compress(rec.to_csv().encode())
    for cut in (0.6, 0.9):
        got = read_record(raw[:int(cut * len(raw))], name="cut.csv.gz")
        n = len(got.t)
        assert 0.4 * len(rec.t) < n < len(rec.t), (cut, n)
        np.testing.assert_allclose(got.q, rec.q[:n], atol=1e-9)
        np.testing.assert_allclose(got.t, rec.t[:n], atol=1e-9)
        assert got.reading["truncated_lines"] > 0
    doc = analyze_record(got, diagnose_effects=False).report()
    assert doc["input"]["container"] == "gzip" and doc["input"]["truncated_lines"] == got.reading["truncated_lines"]
    assert any("ends before its compressed stream does" in w for w in doc["warnings"]), doc["warnings"]


def test_text_in_utf16_or_a_windows_code_page_reads_with_its_units(rec):
    """Excel's "Unicode Text" (UTF-16, tabs) and a German PC's CSV (Windows-1252, semicolons,
    decimal commas, a degree sign in the header) give the record in radians."""
    rows = zip(rec.t, rec.tau, np.degrees(rec.q))
    head = "# inertia: 30\n"
    german = head + "Zeit [s];Moment [N·m];Winkel [°]\n" + "\n".join(
        f"{t:.6f};{x:.9g};{q:.10g}".replace(".", ",") for t, x, q in rows)
    excel = head + "time [s]\ttorque [N·m]\tangle [°]\n" + "\n".join(
        f"{t:.6f}\t{x:.9g}\t{q:.10g}" for t, x, q in zip(rec.t, rec.tau, np.degrees(rec.q)))
    for raw, columns, encoding in (
            (german.encode("cp1252"), "t=Zeit [s],tau=Moment [N·m],q=Winkel [°]", "windows-1252"),
            (excel.encode("utf-16"), "t=time [s],tau=torque [N·m],q=angle [°]", "utf-16")):
        got = read_record(raw, name="r.txt", columns=columns)
        np.testing.assert_allclose(got.q, rec.q, atol=1e-9, err_msg=encoding)
        np.testing.assert_allclose(got.tau, rec.tau, rtol=1e-8, err_msg=encoding)
        assert got.reading["encoding"] == encoding
        assert got.reading["header_units"]["taken"]["q"] == "deg", got.reading["header_units"]
        warned = any("read as Windows-1252" in w for w in analyze_record(got, diagnose_effects=False).report()["warnings"])
        assert warned == (encoding == "windows-1252"), encoding


BAD_WRAPPERS = [
    (_zip({"a.csv": b"t,tau,q\n", "b.csv": b"t,tau,q\n"}), "two.zip", "a zip archive holding 2 files (a.csv, b.csv)"),
    (_zip({}), "empty.zip", "a zip archive holding 0 files"),
    (b"\x1f\x8b\x08" + b"garbage" * 20, "bad.gz", "not a readable gzip stream"),
    (b"\x28\xb5\x2f\xfd" + b"junk" * 20, "bad.zst", "not a readable zstd stream"),
    (gzip.compress(b"t,tau,q\n0,1,2\n", mtime=0)[:12], "early.gz", "ends before any whole line"),
    (b"PK\x03\x04" + b"\x00" * 40, "torn.zip", "not a readable zip archive"),
    (b"\xff\xfe" + "t,tau,q\n".encode("utf-16-le") + b"\x00", "odd.csv", "does not decode as"),
]


# named by file: ids from the bytes carried gzip's and zip's clock, and pytest-xdist's workers,
# collecting a second apart, refused to run the suite ("Different tests were collected")
@pytest.mark.parametrize("raw,name,expect", BAD_WRAPPERS, ids=[case[1] for case in BAD_WRAPPERS])
def test_a_bad_wrapper_is_one_line_naming_it(raw, name, expect):
    with pytest.raises(InputError) as err:
        read_record(raw, name=name)
    msg = str(err.value)
    assert expect in msg and "\n" not in msg and msg.startswith(name), msg


def test_the_command_line_reads_a_gzipped_log(tmp_path, rec):
    p = tmp_path / "log.csv.gz"
    p.write_bytes(gzip.compress(rec.to_csv().encode()))
    out = tmp_path / "r.json"
    r = subprocess.run([sys.executable, "-m", "bench.cli", "analyze", str(p), "--no-diagnosis", "--json", str(out)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    doc = json.loads(out.read_text())
    assert doc["input"]["container"] == "gzip" and doc["input"]["format"] == "csv"
    assert abs(doc["parameters"]["Fc"] / PRESETS["j3"].friction.Fc - 1) < 0.1


@pytest.mark.parametrize("how", ["gzip", "bzip2", "xz", "zstd", "zip"])
def test_a_file_that_unpacks_beyond_the_limit_is_refused_while_unpacking(monkeypatch, how):
    """A few kB that unpack to gigabytes (a decompression bomb, or a day's log) are stopped
    at ``MAX_UNPACKED`` (here lowered to 4 MiB), not held whole in memory first."""
    import bench.containers as containers
    monkeypatch.setattr(containers, "MAX_UNPACKED", 4 << 20)
    zeros = b"0" * (8 << 20)
    raw = {"gzip": gzip.compress, "bzip2": bz2.compress, "xz": lzma.compress, "zstd": _zstd,
           "zip": lambda b: _zip({"big.csv": b})}[how](zeros)
    assert len(raw) < 100_000
    with pytest.raises(InputError) as err:
        read_record(raw, name="big")
    assert "unpacks to more than 4 MiB" in str(err.value), str(err.value)


def test_a_message_about_a_compressed_file_names_the_file_itself(tmp_path):
    """The user's file is log.csv.gz, not log.csv; a MATLAB v4 file (no magic bytes) is still
    told by the name under the compression."""
    p = tmp_path / "log.csv.gz"
    p.write_bytes(gzip.compress(b"t,tau\n0,1\n0.001,2\n"))
    with pytest.raises(InputError) as err:
        read_record(p)
    assert str(err.value).startswith(f"{p}: missing column 'q'"), str(err.value)
    from bench.readers import _format
    assert _format(b"\x00\x00\x00\x00", "old.mat.gz") == "mat" and _format(b"t,q\n", "x.csv.gz") == "csv"
