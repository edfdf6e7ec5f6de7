"""Lines a data-acquisition or scope export writes before its header (bench.text_table): they
were refused as rows of the wrong length; now skipped, said, and the table read as without
them; so are the lines an export writes after its rows.  Fresh seed 10240 (j3, 10 s)."""
import numpy as np
import pytest

from bench.analysis import analyze_record
from bench.errors import InputError
from bench.readers import read_record
from bench.text_table import _after_preamble
from virtual_drives.joint import simulate_record
from virtual_drives.presets import PRESETS


@pytest.fixture(scope="module")
def table():
    rec = simulate_record(PRESETS["j3"], *PRESETS["j3"].excitation, duration=10.0, seed=10240).record
    return rec, "\n".join(f"{t:.6f},{x:.9g},{q:.10g}" for t, x, q in zip(rec.t, rec.tau, rec.q)) + "\n"


@pytest.mark.parametrize("preamble", [
    "Logger export\nSample rate: 1000\n\n",                          # a DAQ's free text
    "% exported by logger v2\n% date 2026-12-01\n",                  # MATLAB-style comments
    "Channels,3\nRate,1000\nOperator,JS\n\n",                        # key,value lines
])
def test_a_preamble_before_the_header_is_skipped_and_said(table, preamble):
    rec, rows = table
    got = read_record((preamble + "t,tau,q\ns,Nm,deg\n" + rows).encode(), name="daq.csv", inertia=30.0)
    np.testing.assert_allclose(got.q, np.radians(rec.q), rtol=1e-9, atol=1e-12)   # the units row read
    kept = [ln.strip() for ln in preamble.splitlines() if ln.strip()]
    assert got.reading["preamble_lines"] == kept
    said = [w for w in analyze_record(got, diagnose_effects=False).report()["warnings"] if "preamble" in w]
    assert len(said) == 1 and said[0].startswith(f"{len(kept)} line(s) before the table"), said


def test_tables_without_a_preamble_are_read_as_they_were(table):
    _, rows = table
    for body in ("t,tau,q\n" + rows,                                    # the plain file
                 "t,tau,q\ns,Nm,rad\n" + rows,                          # a units row
                 rows,                                                   # no header
                 "t,tau,q\n0.000,1.5,\n0.001,,\n0.002,,0.1\n" + rows,   # streams on rows of their own
                 "t,tau,q\n1,2,3\n" + "x,y,z\n" + rows):                # not a preamble: left to the reader
        assert _after_preamble(body) == (body, []), body[:60]


def test_a_preamble_then_a_blank_line_then_rows_is_a_table_without_a_header(table):
    _, rows = table
    assert _after_preamble("Scope export\nRate: 1000\n\n" + rows) == (rows, ["Scope export", "Rate: 1000"])


@pytest.mark.parametrize("footer,sep,kept", [
    ("End of data\nSamples,10001\n", "\n", ["End of data", "Samples,10001"]),   # an export's summary
    ("9.999500,0.5", "\n", ["9.999500,0.5"]),                                 # a last row cut short
    ("Stopped by user\n\n\n", "\r\n", ["Stopped by user"]),                   # CRLF, blank lines after
])
def test_lines_after_the_rows_are_skipped_and_said(table, footer, sep, kept):
    rec, rows = table
    text = ("t,tau,q\n" + rows + footer).replace("\n", sep)
    got = read_record(text.encode(), name="daq.csv", inertia=30.0)
    np.testing.assert_allclose(got.q, rec.q, rtol=1e-9, atol=1e-12)
    assert got.reading["footer_lines"] == kept
    said = [w for w in analyze_record(got, diagnose_effects=False).report()["warnings"] if "after the table" in w]
    assert len(said) == 1 and said[0].startswith(f"{len(kept)} line(s) after the table"), said


@pytest.mark.parametrize("what,text", [
    ("a bad row among the rows", lambda rows: "t,tau,q\n" + rows.replace("\n", "\nx,y\n", 1)),
    ("more lines than a footer", lambda rows: "t,tau,q\n" + rows + "note\n" * 21),
])
def test_what_is_no_footer_is_still_refused(table, what, text):
    _, rows = table
    with pytest.raises(InputError, match=r"expected 3 columns, got (1|2)"):
        read_record(text(rows).encode(), name="daq.csv", inertia=30.0)
