"""Delimited text as loggers write it: any delimiter (tab, semicolon with decimal commas,
comma, whitespace), ``#`` metadata lines, a header or none (columns numbered), a units or
description row under the header, parsed by Arrow's CSV reader (``bench.readers`` maps and
converts what this returns)."""
from __future__ import annotations

import csv
import io
import re

from bench import header_units
from bench.containers import decode_text
from bench.errors import InputError
from bench.records import split_metadata


def read_text(raw: bytes, name: str):
    """Delimited text, parsed by Arrow's CSV reader (a 10-minute log in well under a second);
    ``#`` metadata lines and blank lines are taken out first, an export's lines before its
    header and after its rows too (``skipped``: {"preamble_lines": [...], "footer_lines": [...]})."""
    import pyarrow as pa
    import pyarrow.csv as pacsv
    text, encoding = decode_text(raw, name)
    if _CONTROL.search(text):   # valid UTF-8 need not be text: a binary dump, a truncated copy
        raise InputError(f"{name}: holds control characters (binary content), not a text record")
    meta, body = {}, text
    if "#" in text:
        meta = split_metadata("\n".join(_META.findall(text)))[0]
        body = _META.sub("", text)
    body = body.lstrip()     # Arrow skips empty lines, not leading blank ones before the header
    body, preamble = _after_preamble(body)
    first = _line(body, 0).strip()
    if not first:
        raise InputError(f"{name}: no header row and no data")
    delim = _delimiter(first)
    if delim is None:   # whitespace-separated: one tab between fields
        body = _SPACES.sub("\t", _LEADING.sub("", body))
    sep = delim or "\t"
    header = _fields(first, sep) if delim else first.split()
    headerless = all(_is_number(h) for h in header)   # no header: columns are numbered
    if headerless:
        header = [str(i + 1) for i in range(len(header))]
    elif len(set(header)) != len(header):
        raise InputError(f"{name}: duplicate column names in header")
    second = first if headerless else _line(body, 1)
    units_row = None if headerless else header_units.split_units_row(
        header, _fields(second, sep) if delim else second.split())
    if units_row is not None:  # a data-acquisition export's units (or descriptions) under the names
        at = body.find("\n") + 1
        nxt = body.find("\n", at)
        body = body[:at] + (body[nxt + 1:] if nxt >= 0 else "")
        second = _line(body, 1)
    body, footer = _before_footer(body, len(header), sep if delim else None)
    decimal = "," if sep != "," and "," in second else "."
    try:
        table = pacsv.read_csv(
            io.BytesIO(body.encode()),
            # one thread: Arrow's CSV thread pool can still be running when a one-line error
            # exits the process, and its shutdown then aborts ("terminate called ...", exit -6)
            read_options=pacsv.ReadOptions(column_names=header, skip_rows=0 if headerless else 1,
                                           use_threads=False),
            parse_options=pacsv.ParseOptions(delimiter=sep),
            convert_options=pacsv.ConvertOptions(decimal_point=decimal, strings_can_be_null=False))
    except pa.ArrowInvalid as e:
        msg = str(e).splitlines()[0]
        if "skip initial" in msg:   # Arrow's words for a header with nothing under it
            raise InputError(f"{name}: a header row and no data rows") from None
        msg = msg.replace("CSV parse error: ", "").replace("Expected", "expected")[:160]
        raise InputError(f"{name}: {msg} (header has {len(header)} fields)") from None
    fmt = {None: "text (whitespace)", ",": "csv", ";": "csv (semicolon)", "\t": "csv (tab)"}[delim]
    skipped = {k: v for k, v in (("preamble_lines", preamble), ("footer_lines", footer)) if v}
    return table, meta, fmt, units_row, encoding, skipped


# Lines a data-acquisition or scope export writes before its header ("Logger export",
# "Sample rate: 1000", a blank line) were refused as rows of the wrong length.  The header is
# the line above the first run of data rows (or above a units row there); what precedes it
# is skipped and said.  Only the first lines are looked at: a preamble is a few lines long.
PREAMBLE_LINES = 200
DATA_RUN = 3        # rows of one length, at least half of each a number: the table has begun


def _after_preamble(body: str) -> tuple[str, list[str]]:
    """``body`` from its header on, and the preamble's lines before it (empty: none)."""
    lines = body[:200_000].split("\n", PREAMBLE_LINES + DATA_RUN)[:PREAMBLE_LINES + DATA_RUN]
    fields = [_split(ln) for ln in lines]
    start = next((i for i in range(min(len(lines), PREAMBLE_LINES))
                  if all(_data_like(f) and len(f) == len(fields[i]) for f in fields[i:i + DATA_RUN])), None)
    if start is None or start < 2:
        return body, []
    head = start - 1
    if not lines[head].strip():     # a blank line, then rows: no header (columns numbered)
        head = start
    elif len(fields[start - 2]) == len(fields[start - 1]) and \
            header_units.split_units_row(fields[start - 2], fields[start - 1]) is not None:
        head = start - 2     # a units or description row under the names
    names = fields[head]
    # only a header of names as long as the rows, above lines that are not rows of the table:
    # otherwise the file is read as it was (a row of empty cells is not a preamble)
    if (not any(ln.strip() for ln in lines[:head]) or len(names) != len(fields[start])
            or (head < start and any(_is_number(f) for f in names))
            or any(len(f) == len(names) and _data_like(f) for f in fields[:head])):
        return body, []
    at = sum(len(ln) + 1 for ln in lines[:head])      # the lines were split on "\n" alone
    return body[at:], [ln.strip() for ln in lines[:head] if ln.strip()]


# Lines an export writes after its rows ("End of data", "Samples;20000", a summary) and a last
# row cut short by a logger that died mid-write were refused as rows of the wrong length, and
# the whole record with them.  They are skipped and said when the rows before them are whole
# rows of the table; more than a few such lines is no footer, and Arrow's refusal stands.
FOOTER_LINES = 20


def _before_footer(body: str, width: int, sep: str | None) -> tuple[str, list[str]]:
    """``body`` without the lines after its last whole rows, and those lines (empty: none)."""
    end = len(body)
    while end and body[end - 1].isspace():      # not body.rstrip(): a copy of a long log
        end -= 1
    lines = body[max(0, end - 100_000):end].rsplit("\n", FOOTER_LINES + DATA_RUN)[1:]

    def row(line):
        f = _fields(line.strip(), sep) if sep else line.split()
        return f if any(f) else None

    fields = [row(ln) for ln in lines]
    k = 0       # footer lines, from the end: a line of text, or a last row cut short
    while k < len(lines) and fields[-1 - k] is not None and not (
            len(fields[-1 - k]) == width and _data_like(fields[-1 - k])):
        k += 1
    whole = fields[len(fields) - k - DATA_RUN:len(fields) - k]
    if k == 0 or k > FOOTER_LINES or len(whole) < DATA_RUN or \
            not all(f is not None and len(f) == width and _data_like(f) for f in whole):
        return body, []
    cut = end - sum(len(ln) + 1 for ln in lines[-k:])
    return body[:cut + 1], [ln.strip() if sep else " ".join(ln.split()) for ln in lines[-k:]]


def _split(line: str) -> list[str]:
    line = line.strip()
    delim = _delimiter(line)
    return _fields(line, delim) if delim else line.split()


def _data_like(fields: list[str]) -> bool:
    """A data row: two fields or more, at least half of those not empty numbers (a decimal
    comma too; an empty cell is a stream's lost or other reading)."""
    filled = [f for f in fields if f]
    numbers = sum(_is_number(f) or _is_number(f.replace(",", ".")) for f in filled)
    return len(fields) >= 2 and numbers > 0 and 2 * numbers >= len(filled)


_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")   # not tab, newline or carriage return
_META = re.compile(r"^[ \t]*(#.*)$\n?", re.M)
_LEADING = re.compile(r"^[ \t]+|[ \t]+(?=\r?$)", re.M)    # leading and trailing blanks
_SPACES = re.compile(r"[ \t]+")


def _line(text: str, k: int) -> str:
    """Line k of a long text without splitting all of it."""
    at = 0
    for _ in range(k):
        at = text.find("\n", at) + 1
        if at == 0:
            return ""
    end = text.find("\n", at)
    return text[at:end if end >= 0 else None]


def _fields(line: str, sep: str) -> list[str]:
    """A header's (or units row's) fields, a quoted one holding the delimiter kept whole
    ("time, s" split in two gave a header longer than its rows)."""
    return [f.strip().strip('"') for f in next(csv.reader([line], delimiter=sep, skipinitialspace=True), [""])]


def _delimiter(header: str):
    for d in ("\t", ";", ","):
        if d in header:
            return d
    return None


def _is_number(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False
