"""What a record's bytes come wrapped in, taken off before its format is read.

Long robot logs are kept compressed (``log.csv.gz`` from a logger's rotation, ``.xz`` and
``.zst`` archives, a ``.zip`` mailed from a Windows bench PC), and text is not always UTF-8:
Excel's "Unicode Text" export and a PowerShell redirect write UTF-16, and a German or French
Windows PC writes its header's degree sign in Windows-1252.  Each was refused as "not UTF-8
text"; the user had to guess why.  The standard library decompresses gzip, bzip2, xz and zip,
Arrow zstd (already a dependency: ``pyarrow.CompressedInputStream``).

A logger killed mid-run leaves a compressed stream without its end: what was written is
kept, up to its last whole line, and the report says the file was cut short.
"""
from __future__ import annotations

import bz2
import io
import lzma
import zipfile
import zlib

from bench.errors import InputError

_COMPRESSED = {b"\x1f\x8b": "gzip", b"BZh": "bzip2", b"\xfd7zXZ\x00": "xz", b"\x28\xb5\x2f\xfd": "zstd"}
_DECOMPRESSORS = {"gzip": lambda: zlib.decompressobj(wbits=47), "bzip2": bz2.BZ2Decompressor,
                  "xz": lzma.LZMADecompressor}
# bytes unpacked at most: ``bench.validate.MAX_SAMPLES`` (1e7) rows of ~60 characters of text
# is 0.6 GB; beyond is no record the analysis would take, or a decompression bomb
MAX_UNPACKED = 1 << 30
CHUNK = 1 << 20
_SUFFIXES = (".gz", ".gzip", ".bz2", ".xz", ".zst", ".zstd", ".zip")
TRUNCATED_WARNING = ("the {how} file ends before its compressed stream does (a logger stopped "
                     "mid-write?): the {n} whole lines before the cut were read")


def unwrap(raw: bytes, name: str) -> tuple[bytes, str, dict]:
    """(the record's own bytes, its name -- a zip's member after the archive's --, what was
    taken off: {"container": "gzip", "member": ..., "truncated_lines": n})."""
    told: dict = {}
    for _ in range(3):    # a .tar.gz is not a record; a .csv.gz inside a .zip is
        how = _kind(raw)
        if how is None:
            return raw, name, told
        told["container"] = how if "container" not in told else f"{told['container']}+{how}"
        if how == "zip":
            raw, member = _zip_member(raw, name)
            told["member"] = member
            name = f"{name}:{member}"
        else:
            raw, whole = _decompress(raw, how, name)
            if not whole:
                raw = raw[:raw.rfind(b"\n") + 1]
                if not raw.strip():
                    raise InputError(f"{name}: the {how} file ends before any whole line of the record")
                told["truncated_lines"] = raw.count(b"\n")
    raise InputError(f"{name}: compressed more than three times over; unpack it first")


def _kind(raw: bytes) -> str | None:
    if raw[:4] == b"PK\x03\x04" or raw[:4] == b"PK\x05\x06":
        return "zip"
    return next((how for magic, how in _COMPRESSED.items() if raw.startswith(magic)), None)


def strip_suffix(name: str) -> str:
    """``log.mat.gz`` -> ``log.mat``: the name a format is told by (messages keep the file's)."""
    while name.lower().endswith(_SUFFIXES):
        name = name[:name.rindex(".")]
    return name


def _decompress(raw: bytes, how: str, name: str) -> tuple[bytes, bool]:
    """(the bytes, whether the stream ended as it should)."""
    out = _Unpacked(name)
    if how == "zstd":
        import pyarrow as pa
        try:
            with pa.CompressedInputStream(pa.BufferReader(raw), "zstd") as stream:
                return out.drain(stream), True
        except (OSError, pa.ArrowInvalid) as e:
            raise InputError(f"{name}: not a readable zstd stream ({str(e).splitlines()[0][:100]})") from None
    # streaming, so that a stream without its end still gives what it holds
    magic = next(m for m, h in _COMPRESSED.items() if h == how)
    data = raw
    try:
        while True:
            d = _DECOMPRESSORS[how]()
            for chunk in _inflate(d, data, how):
                out.add(chunk)
            if not d.eof:
                return out.bytes(), False
            data = d.unused_data        # gzip and bzip2 allow members one after another
            if not data.startswith(magic):    # (padding after the last is not a member)
                return out.bytes(), True
    except (zlib.error, OSError, lzma.LZMAError, EOFError) as e:
        if not out.size:
            raise InputError(f"{name}: not a readable {how} stream ({e})") from None
        return out.bytes(), False


def _inflate(d, data: bytes, how: str):
    """A decompressor's output in pieces of at most CHUNK bytes (a small file may unpack to
    gigabytes: each piece is counted before the next is made)."""
    if how == "gzip":
        while True:
            yield d.decompress(data, CHUNK)
            data = d.unconsumed_tail
            if d.eof or not data:
                return
    yield d.decompress(data, max_length=CHUNK)
    while not d.eof and not d.needs_input:
        yield d.decompress(b"", max_length=CHUNK)


class _Unpacked:
    """Pieces of an unpacked stream, refused beyond ``MAX_UNPACKED``."""

    def __init__(self, name: str):
        self.name, self.pieces, self.size = name, [], 0

    def add(self, piece: bytes) -> bool:
        self.size += len(piece)
        if self.size > MAX_UNPACKED:
            raise InputError(f"{self.name}: unpacks to more than {MAX_UNPACKED >> 20} MiB, more than a "
                             f"record the analysis takes (1e7 samples); cut the log first")
        self.pieces.append(piece)
        return bool(piece)

    def drain(self, stream) -> bytes:
        """All of a file-like ``stream``, read in pieces."""
        while self.add(stream.read(CHUNK)):
            pass
        return self.bytes()

    def bytes(self) -> bytes:
        return b"".join(self.pieces)


def _zip_member(raw: bytes, name: str) -> tuple[bytes, str]:
    try:
        with zipfile.ZipFile(io.BytesIO(raw)) as z:
            members = [i for i in z.infolist() if not i.is_dir()
                       and not i.filename.startswith("__MACOSX/") and not i.filename.split("/")[-1].startswith(".")]
            if len(members) != 1:
                listed = ", ".join(i.filename for i in members[:5]) + (", ..." if len(members) > 5 else "")
                raise InputError(f"{name}: a zip archive holding {len(members)} files ({listed or 'none'}); "
                                 f"unpack the record to analyse, or zip it alone")
            with z.open(members[0]) as f:
                return _Unpacked(name).drain(f), members[0].filename
    except (zipfile.BadZipFile, zlib.error, EOFError, NotImplementedError) as e:
        raise InputError(f"{name}: not a readable zip archive ({e})") from None
    except RuntimeError as e:     # an encrypted member
        raise InputError(f"{name}: {e}") from None


def decode_text(raw: bytes, name: str) -> tuple[str, str]:
    """(the text, its encoding): UTF-8 (with or without a byte-order mark), UTF-16 with its
    mark, or else Windows-1252, which any single-byte Western text reads as; binary content
    is caught by the caller's check for control characters."""
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        try:
            return raw.decode("utf-16"), "utf-16"
        except UnicodeDecodeError:
            raise InputError(f"{name}: starts as UTF-16 text and does not decode as it") from None
    try:
        return raw.decode("utf-8-sig"), "utf-8"
    except UnicodeDecodeError:
        pass
    try:
        return raw.decode("cp1252"), "windows-1252"
    except UnicodeDecodeError:
        raise InputError(f"{name}: not text (neither UTF-8, UTF-16 nor Windows-1252) and not "
                         f"Parquet or MATLAB .mat") from None
