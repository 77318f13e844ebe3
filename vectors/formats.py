"""Writers and readers of the vector file formats (SPEC §5, ``docs/vectors.md``).

Every writer takes raw integer codes of one fixed-point format and returns the file's
bytes (the caller writes them), so that the same bytes can be hashed, compared and
written atomically. Values are two's complement codes of ``word`` bits, printed as
lower-case hexadecimal with ``ceil(word / 4)`` digits, one word per line, in scan order.

* ``.mem``: ``$readmemh``; one ``//`` comment line, then one word per line.
* ``.coe``: Xilinx memory init (``memory_initialization_radix=16``).
* ``.mif``: Intel memory init (``WIDTH``, ``DEPTH``, ``CONTENT BEGIN ... END;``).
* ``.csv``: ``cycle,row,col,sof,eol,value`` with the raw code in signed decimal.
* stream words ``{sof, eol, valid, data}``: packed with bitstring, one byte-aligned
  big-endian word per clock cycle (``.stream.bin``) and the same words as ``.mem`` text
  (``.stream.mem``).

This module imports numpy and bitstring only (no numba), so a simulator process can
use it cheaply.
"""

from __future__ import annotations

import io
import re

import bitstring
import numpy as np

__all__ = [
    "hex_digits",
    "pack_stream",
    "read_coe",
    "read_csv",
    "read_mem",
    "read_mem_words",
    "read_mif",
    "read_stream_bin",
    "read_stream_bin_valid",
    "stream_word_bytes",
    "to_signed",
    "to_unsigned",
    "write_coe",
    "write_csv",
    "write_mem",
    "write_mif",
    "write_stream_mem",
]

_HEX = np.frombuffer(b"0123456789abcdef", dtype=np.uint8)


def hex_digits(word: int) -> int:
    """Hex digits of a ``word``-bit code."""
    return (int(word) + 3) // 4


def to_unsigned(raw: np.ndarray, word: int) -> np.ndarray:
    """Two's complement codes: the low ``word`` bits of ``raw`` as uint64.

    Raises
    ------
    ValueError
        A value does not fit ``word`` bits signed or unsigned.
    """
    a = np.asarray(raw, dtype=np.int64).ravel()
    if a.size and (int(a.min()) < -(1 << (word - 1)) or int(a.max()) > (1 << word) - 1):
        raise ValueError(f"values [{int(a.min())}, {int(a.max())}] do not fit a {word}-bit word")
    return a.astype(np.uint64) & np.uint64((1 << word) - 1)


def to_signed(codes: np.ndarray, word: int, signed: bool) -> np.ndarray:
    """Raw int64 values of ``word``-bit codes: sign-extended when ``signed``."""
    u = np.asarray(codes, dtype=np.uint64) & np.uint64((1 << word) - 1)
    v = u.astype(np.int64)
    if signed:
        v = np.where(v >= (1 << (word - 1)), v - (1 << word), v)
    return v


def _hex_matrix(codes: np.ndarray, digits: int) -> np.ndarray:
    """(N, digits) uint8 ASCII hex of uint64 codes, most significant digit first."""
    shifts = np.arange(digits - 1, -1, -1, dtype=np.uint64) * np.uint64(4)
    nib = (codes[:, None] >> shifts[None, :]) & np.uint64(15)
    return _HEX[nib.astype(np.intp)]


def _lines(codes: np.ndarray, digits: int, suffix: bytes = b"") -> bytes:
    """One hex word per line, each followed by ``suffix`` and ``\\n``."""
    n = codes.size
    body = np.empty((n, digits + len(suffix) + 1), dtype=np.uint8)
    body[:, :digits] = _hex_matrix(codes, digits)
    if suffix:
        body[:, digits:-1] = np.frombuffer(suffix, dtype=np.uint8)
    body[:, -1] = ord("\n")
    return body.tobytes()


def write_mem(raw: np.ndarray, word: int, comment: str = "") -> bytes:
    """``$readmemh`` text: an optional ``// comment`` line, then one word per line."""
    head = f"// {comment}\n".encode() if comment else b""
    return head + _lines(to_unsigned(raw, word), hex_digits(word))


def write_coe(raw: np.ndarray, word: int, comment: str = "") -> bytes:
    """Xilinx ``.coe``: radix 16, words separated by ``,``, the last ended by ``;``."""
    codes = to_unsigned(raw, word)
    head = (f"; {comment}\n" if comment else "") + (
        "memory_initialization_radix=16;\nmemory_initialization_vector=\n"
    )
    text = bytearray(_lines(codes, hex_digits(word), b","))
    if codes.size:
        text[-2:-1] = b";"
    else:
        text += b";\n"
    return head.encode() + bytes(text)


def write_mif(raw: np.ndarray, word: int, comment: str = "") -> bytes:
    """Intel ``.mif``: ``WIDTH``, ``DEPTH``, hex address and data radix, ``addr : data;``."""
    codes = to_unsigned(raw, word)
    n = codes.size
    head = (f"-- {comment}\n" if comment else "") + (
        f"WIDTH={word};\nDEPTH={n};\nADDRESS_RADIX=HEX;\nDATA_RADIX=HEX;\nCONTENT BEGIN\n"
    )
    ad = hex_digits(max(n - 1, 1).bit_length())
    dd = hex_digits(word)
    body = np.empty((n, 2 + ad + 3 + dd + 2), dtype=np.uint8)
    body[:, 0:2] = ord(" ")
    body[:, 2 : 2 + ad] = _hex_matrix(np.arange(n, dtype=np.uint64), ad)
    body[:, 2 + ad : 5 + ad] = np.frombuffer(b" : ", dtype=np.uint8)
    body[:, 5 + ad : 5 + ad + dd] = _hex_matrix(codes, dd)
    body[:, -2] = ord(";")
    body[:, -1] = ord("\n")
    return head.encode() + body.tobytes() + b"END;\n"


def write_csv(
    raw: np.ndarray,
    cycle: np.ndarray,
    row: np.ndarray,
    col: np.ndarray,
    sof: np.ndarray,
    eol: np.ndarray,
) -> bytes:
    """``cycle,row,col,sof,eol,value`` (header line first), value the signed raw code."""
    cols = np.column_stack(
        [np.asarray(a, dtype=np.int64).ravel() for a in (cycle, row, col, sof, eol, raw)]
    )
    buf = io.StringIO()
    buf.write("cycle,row,col,sof,eol,value\n")
    np.savetxt(buf, cols, fmt="%d", delimiter=",")
    return buf.getvalue().encode()


# -- stream words ------------------------------------------------------------------------
def stream_word_bytes(word: int) -> int:
    """Bytes of one packed ``{sof, eol, valid, data}`` word of a ``word``-bit stream."""
    return (word + 3 + 7) // 8


def _stream_spec(nbits: int, word: int) -> str:
    """bitstring layout of one stream word: zero padding (if any), sof, eol, valid, data."""
    pad = f"uint{nbits - word - 3}, " if nbits > word + 3 else ""
    return f"{pad}bool, bool, bool, uint{word}"


def pack_stream(
    valid: np.ndarray, data: np.ndarray, sof: np.ndarray, eol: np.ndarray, word: int
) -> tuple[bytes, np.ndarray]:
    """Pack beats into ``{sof, eol, valid, data}`` words with bitstring.

    Each word is ``stream_word_bytes(word)`` bytes, big-endian, zero-padded at the top:
    bit ``word + 2`` is ``sof`` (TUSER), ``word + 1`` ``eol`` (TLAST), ``word`` ``valid``
    (TVALID), bits ``word - 1 .. 0`` the data (TDATA, two's complement). bitstring packs
    every distinct word once; the stream is then gathered from those.

    Returns
    -------
    (bytes, numpy.ndarray)
        The packed binary stream, and the words as uint64 (for ``.stream.mem``).
    """
    nbits = 8 * stream_word_bytes(word)
    fields = (
        (np.asarray(sof, dtype=np.uint64) << np.uint64(word + 2))
        | (np.asarray(eol, dtype=np.uint64) << np.uint64(word + 1))
        | (np.asarray(valid, dtype=np.uint64) << np.uint64(word))
        | to_unsigned(data, word)
    )
    uniq, inverse = np.unique(fields, return_inverse=True)
    spec = _stream_spec(nbits, word)
    table = np.empty((uniq.size, nbits // 8), dtype=np.uint8)
    words = np.empty(uniq.size, dtype=np.uint64)
    for k, w in enumerate(uniq.tolist()):
        pad = [0] if nbits > word + 3 else []
        flags = [bool(w >> (word + b) & 1) for b in (2, 1, 0)]  # sof, eol, valid
        bits = bitstring.pack(spec, *pad, *flags, w & ((1 << word) - 1))
        table[k] = np.frombuffer(bits.tobytes(), dtype=np.uint8)
        words[k] = bits.uint
    return table[inverse.ravel()].tobytes(), words[inverse.ravel()]


def write_stream_mem(words: np.ndarray, word: int, comment: str = "") -> bytes:
    """Stream words as ``$readmemh`` text, ``word + 3`` bits each."""
    return write_mem(np.asarray(words, dtype=np.uint64).astype(np.int64), word + 3, comment)


def read_stream_bin(data: bytes, word: int) -> dict[str, np.ndarray]:
    """Unpack a ``.stream.bin`` into ``valid``, ``data`` (unsigned codes), ``sof``, ``eol``.

    Raises
    ------
    ValueError
        The length is not a whole number of words.
    """
    nb = stream_word_bytes(word)
    if len(data) % nb:
        raise ValueError(f"stream of {len(data)} bytes is not a whole number of {nb}-byte words")
    bs = bitstring.Bits(bytes(data))  # the bytes initialiser of bitstring 4.1 and 5
    spec = _stream_spec(8 * nb, word)
    pad = 8 * nb > word + 3
    n, step = len(data) // nb, 8 * nb
    out = {k: np.zeros(n, dtype=np.int64) for k in ("valid", "data", "sof", "eol")}
    for k in range(n):
        sof, eol, valid, value = bs[k * step : (k + 1) * step].unpack(spec)[pad:]
        out["sof"][k], out["eol"][k], out["valid"][k], out["data"][k] = sof, eol, valid, value
    return out


def read_stream_bin_valid(data: bytes, word: int) -> np.ndarray:
    """The ``valid`` bit of every word of a ``.stream.bin`` (fast, numpy only)."""
    nb = stream_word_bytes(word)
    if len(data) % nb:
        raise ValueError(f"stream of {len(data)} bytes is not a whole number of {nb}-byte words")
    b = np.frombuffer(data, dtype=np.uint8).reshape(-1, nb)
    return ((b[:, nb - 1 - word // 8] >> (word % 8)) & 1).astype(bool)


# -- readers ------------------------------------------------------------------------------
_TOKEN = re.compile(rb"[^\s,;]+")
_HEX_WORD = re.compile(rb"[0-9a-fA-F]+")
_XZ_WORD = re.compile(rb"[0-9a-fA-FxXzZ?]+")
_PLAIN_HEX = re.compile(rb"[0-9a-fA-F\s,;]*")


def _strip_comments(data: bytes | str) -> bytes:
    """``$readmemh`` text without its ``//`` and ``/* */`` comments."""
    raw = data.encode() if isinstance(data, str) else data
    raw = re.sub(rb"/\*.*?\*/", b" ", raw, flags=re.S)
    return re.sub(rb"//[^\n]*", b"", raw)


def read_mem_words(data: bytes | str) -> dict[int, tuple[int | None, int]]:
    """Words of a ``$readmemh`` file by word address: ``address -> (value, bits)``.

    ``value`` is the unsigned integer the hex digits spell (``None`` for a word with
    ``x``/``z`` digits), ``bits`` the width the word was written with (4 bits per hex
    digit, ``_`` separators not counted), which :func:`rangefx.vectors.generate.dump_code`
    needs to tell a sign extension from garbage. ``//`` and ``/* */`` comments and blank
    lines are skipped. As IEEE 1364 §17.2.8 defines ``$readmemh``: the words load at
    consecutive addresses from 0, an ``@hhh`` directive (hexadecimal word address) moves
    the next word to ``hhh``, a later word at an address already loaded replaces it, and
    addresses no word names are not loaded (they keep what the memory held: a gap).

    Raises
    ------
    ValueError
        A token that is neither a hexadecimal word nor an ``@`` followed by one.
    """
    raw = _strip_comments(data)
    tokens = _TOKEN.findall(raw)
    if _PLAIN_HEX.fullmatch(raw):  # the common case: hex words only, no x/z, no @, no _
        return {k: (int(t, 16), 4 * len(t)) for k, t in enumerate(tokens)}
    out: dict[int, tuple[int | None, int]] = {}
    address = 0
    for tok in tokens:
        t = tok.replace(b"_", b"")
        if t.startswith(b"@"):
            if not _HEX_WORD.fullmatch(t[1:]):
                raise ValueError(f"not a hexadecimal @address: {t.decode(errors='replace')!r:.40}")
            address = int(t[1:], 16)
            continue
        if _HEX_WORD.fullmatch(t):
            value: int | None = int(t, 16)
        elif _XZ_WORD.fullmatch(t):
            value = None
        else:
            raise ValueError(f"not a hexadecimal word: {t.decode(errors='replace')!r:.40}")
        out[address] = (value, 4 * len(t))
        address += 1
    return out


def read_mem(data: bytes | str) -> list[int | None]:
    """Words of a ``$readmemh`` file as unsigned integers in address order, ``None`` for
    ``x``/``z`` words (:func:`read_mem_words`; the words must fill addresses 0 to N-1).

    Raises
    ------
    ValueError
        A token that is not hexadecimal, or ``@address`` directives leaving a gap.
    """
    raw = _strip_comments(data)
    if _PLAIN_HEX.fullmatch(raw):  # the vector files' own case: a plain list, fast
        return [int(t, 16) for t in _TOKEN.findall(raw)]
    words = read_mem_words(raw)
    if words and max(words) != len(words) - 1:
        gap = next(k for k in range(len(words) + 1) if k not in words)
        raise ValueError(f"$readmemh words leave address {gap:x} (hex) unloaded")
    return [words[k][0] for k in range(len(words))]


def read_coe(data: bytes | str) -> list[int]:
    """Words of a Xilinx ``.coe`` written by :func:`write_coe` (radix 16).

    Raises
    ------
    ValueError
        No ``memory_initialization_vector`` or a radix other than 16.
    """
    text = data.decode() if isinstance(data, bytes) else data
    text = "\n".join(ln.split(";", 1)[0] if ln.lstrip().startswith(";") else ln
                     for ln in text.splitlines())  # fmt: skip
    radix = re.search(r"memory_initialization_radix\s*=\s*(\d+)", text)
    if radix is None or radix.group(1) != "16":
        raise ValueError("only memory_initialization_radix=16 .coe files are supported")
    _, sep, vector = text.partition("memory_initialization_vector")
    if not sep:
        raise ValueError("no memory_initialization_vector in the .coe")
    vector = vector.split("=", 1)[1].split(";", 1)[0]
    return [int(t, 16) for t in re.split(r"[\s,]+", vector) if t]


def read_mif(data: bytes | str) -> list[int]:
    """Words of an Intel ``.mif`` written by :func:`write_mif` (hex radix, one per address).

    Raises
    ------
    ValueError
        A radix other than HEX, or a missing ``CONTENT BEGIN``.
    """
    text = data.decode() if isinstance(data, bytes) else data
    text = re.sub(r"--[^\n]*", "", text)
    for key in ("ADDRESS_RADIX", "DATA_RADIX"):
        m = re.search(rf"{key}\s*=\s*(\w+)", text)
        if m is None or m.group(1).upper() != "HEX":
            raise ValueError(f"only {key}=HEX .mif files are supported")
    _, sep, body = text.partition("CONTENT BEGIN")
    if not sep:
        raise ValueError("no CONTENT BEGIN in the .mif")
    words: dict[int, int] = {}
    for addr, value in re.findall(r"([0-9A-Fa-f]+)\s*:\s*([0-9A-Fa-f]+)\s*;", body):
        words[int(addr, 16)] = int(value, 16)
    return [words[k] for k in sorted(words)]


def read_csv(data: bytes | str) -> dict[str, list]:
    """Columns of a vector ``.csv``: ``cycle``, ``row``, ``col``, ``sof``, ``eol``, ``value``.

    ``value`` entries that are not integers (e.g. ``x`` from a simulator) become ``None``.

    Raises
    ------
    ValueError
        The header lacks ``value`` or a row has the wrong number of fields.
    """
    text = data.decode() if isinstance(data, bytes) else data
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if not lines:
        return {"value": []}
    header = [h.strip() for h in lines[0].split(",")]
    if "value" not in header:
        raise ValueError(f"csv header {lines[0]!r} has no 'value' column")
    cols: dict[str, list] = {h: [] for h in header}
    for no, ln in enumerate(lines[1:], start=2):
        parts = [p.strip() for p in ln.split(",")]
        if len(parts) != len(header):
            raise ValueError(f"csv line {no}: {len(parts)} fields, header has {len(header)}")
        for h, p in zip(header, parts, strict=True):
            try:
                cols[h].append(int(p, 0))
            except ValueError:
                cols[h].append(None)
    return cols
