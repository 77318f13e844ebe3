"""Vector directories of any registered pipeline: build, write, check and diff (SPEC §5, §10).

:func:`build_vectors` runs a pipeline (from :data:`rangefx.rtl_model.registry.PIPELINES`)
with every tap on and returns the bytes of every file plus the manifest; the taps, their
formats and the cycle of every sample come from the pipeline's tap table;
:func:`write_vectors` puts them into a directory (the caller makes that directory
atomic, e.g. with ``rangefx.tools.report.atomic_output_dir``);
:func:`check_vectors` re-verifies sizes and SHA-256 and re-runs the model from the
manifest; :func:`diff_dump` compares an RTL dump with an expected tap and reports the
first mismatch. ``docs/vectors.md`` describes the files and the manifest.
"""

from __future__ import annotations

import hashlib
import json
import os
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, field
from importlib import metadata
from pathlib import Path

import numpy as np

from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.rtl_model.config import TimingConfig, WordLengthConfig, loads_json
from rangefx.rtl_model.fixedpoint import FixedFormat
from rangefx.rtl_model.pipeline import Case, Pipeline, PipelineResult
from rangefx.rtl_model.registry import PIPELINES, get_pipeline
from rangefx.rtl_model.stream import make_stream

from . import formats as fmt_io
from .regular import read_regular

__all__ = [
    "FORMATS",
    "MANIFEST_NAME",
    "SCHEMA",
    "CheckReport",
    "DiffReport",
    "VectorSet",
    "build_vectors",
    "case_from_manifest",
    "check_vectors",
    "diff_dump",
    "dump_code",
    "load_manifest",
    "read_tap",
    "stream_memory_bytes",
    "tap_cycles",
    "write_report",
    "write_vectors",
]

SCHEMA = "rangefx-vectors/1"
MANIFEST_NAME = "manifest.json"
#: Per-tap file formats; ``mem`` is always written.
FORMATS = ("mem", "coe", "mif", "csv")
#: Input pixels of a stream (``e1.pix_in``, ``e2.pix_in``): the beats' data.
INPUT_TAP = "pix_in"


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _version() -> str:
    try:
        return metadata.version("rangefx")
    except metadata.PackageNotFoundError:  # pragma: no cover - running from a bare checkout
        return "unknown"


@dataclass(frozen=True)
class VectorSet:
    """The files of one vector directory, in memory.

    ``files`` maps a file name to its bytes, in manifest order; ``manifest`` is the parsed
    manifest (its ``files`` entries carry each file's SHA-256 and size); ``result`` the
    model run they came from.
    """

    files: dict[str, bytes]
    manifest: dict
    result: PipelineResult = field(repr=False)

    def manifest_bytes(self) -> bytes:
        return (json.dumps(self.manifest, indent=1) + "\n").encode()


def _camera_dict(camera: PinholeCamera) -> dict:
    return {k: (None if v is None else float(v)) for k, v in asdict(camera).items()} | {
        "width": int(camera.width),
        "height": int(camera.height),
    }


def _motion_dict(motion: MotionIncrement) -> dict:
    return {k: np.asarray(v, dtype=np.float64).tolist() for k, v in asdict(motion).items()}


def _format_entry(f: FixedFormat) -> dict:
    return {
        "format": str(f),
        "describe": f.describe(),
        "word": f.word,
        "frac": f.frac,
        "signed": f.signed,
        "quant": f.quant.name,
        "overflow": f.overflow.name,
    }


#: Peak bytes per stream cycle while the input streams are built and encoded (measured:
#: ~35 for a 16x24 crop with 200000 cycles of blanking; the arrays, packed words, text).
STREAM_BYTES_PER_CYCLE = 48


def stream_memory_bytes(shape: tuple[int, int], timing: TimingConfig, mode: str) -> int:
    """Peak memory of the input streams of a case: every stream cycle (pixels, expected
    input gaps, blanking) costs :data:`STREAM_BYTES_PER_CYCLE`. Stereo has two streams of
    one frame, motion one stream of two frames."""
    m, n = shape
    gaps = 1.0 / (1.0 - timing.gap_prob) if timing.gap_prob < 1 else float("inf")
    frame = m * n * gaps + m * timing.hblank + timing.vblank
    return int(2 * frame * STREAM_BYTES_PER_CYCLE) if frame < 2**62 else 2**62


def _input_cycles(case: Case, timing: TimingConfig) -> tuple[dict[str, tuple], dict]:
    """The input stream(s) of a case and each stream's per-pixel input cycles: stereo =
    two synchronised streams, motion = one stream of two frames."""
    im1, im2 = (np.asarray(im, dtype=np.int64) for im in (case.image1, case.image2))
    streams: dict[str, tuple] = {}
    if case.mode == "stereo":
        for s, im in (("e1", im1), ("e2", im2)):
            streams[f"{s}.{INPUT_TAP}.stream"] = (make_stream(im, timing), s)
        cyc = {"e1": streams[f"e1.{INPUT_TAP}.stream"][0].pixel_cycles()[0]}
        cyc["e2"] = cyc["e1"]
    else:
        st = make_stream(np.stack([im1, im2]), timing)
        streams[f"{INPUT_TAP}.stream"] = (st, "e1+e2")
        pc = st.pixel_cycles()
        cyc = {"e1": pc[0], "e2": pc[1]}
    return streams, cyc


def build_vectors(
    pipeline: Pipeline | str,
    case: Case,
    config: WordLengthConfig | None = None,
    timing: TimingConfig | None = None,
    *,
    description: Mapping | None = None,
    formats: Iterable[str] = ("mem",),
    result: PipelineResult | None = None,
) -> VectorSet:
    """Run ``pipeline`` with all taps on ``case`` and build every vector file.

    Parameters
    ----------
    pipeline
        A registered pipeline or its name (``"p1"``, ``"p2"``).
    case
        Images (integer grey levels), camera, motion, mode and the pipelines' settings.
    config, timing
        Word-length config (default: the pipeline's shipped default) and input timing.
    description
        Recorded in the manifest's ``case`` (scene name, seed, crop, ...); JSON-able.
    formats
        Per-tap formats among :data:`FORMATS`; ``mem`` is always included.
    result
        An existing run of ``pipeline`` on ``case`` with every tap (``taps=True``): its
        config and timing are used and the model is not run again.

    Raises
    ------
    ValueError
        Bad images, config, timing or format names (from the model or here); a ``result``
        of another pipeline or mode, without taps, or with another config or timing.
    """
    pipe = get_pipeline(pipeline) if isinstance(pipeline, str) else pipeline
    wanted = {"mem", *formats}
    unknown = sorted(wanted - set(FORMATS))
    if unknown:
        raise ValueError(f"unknown vector formats {unknown}; choose from {', '.join(FORMATS)}")
    if result is None:
        timing = timing or TimingConfig()
        config = config or pipe.default_config()
        result = pipe.run(case, config, timing, taps=True)
    else:
        _check_result(pipe, case, config, timing, result)
        config, timing = result.config, result.timing
    im1 = np.asarray(case.image1, dtype=np.int64)
    im2 = np.asarray(case.image2, dtype=np.int64)
    m, n = im1.shape
    table = pipe.tap_table(config, case.mode)
    pix_spec = next(t for t in table if t.name == f"e1.{INPUT_TAP}")
    pix = pix_spec.fmt
    for name, im in (("image1", im1), ("image2", im2)):
        if im.min() < pix.raw_min or im.max() > pix.raw_max:
            raise ValueError(
                f"{name} grey levels [{im.min()}, {im.max()}] do not fit {pix_spec.signal} "
                f"({pix}); the input vectors carry the pixels as the stream's data"
            )
    files: dict[str, bytes] = {}
    entries: list[dict] = []
    streams, cyc = _input_cycles(case, timing)
    rows = np.repeat(np.arange(m, dtype=np.int64), n)
    cols = np.tile(np.arange(n, dtype=np.int64), m)
    sof = (rows == 0) & (cols == 0)
    eol = cols == n - 1
    values = {f"e1.{INPUT_TAP}": im1, f"e2.{INPUT_TAP}": im2, **result.taps}

    def add(name: str, data: bytes, entry: dict) -> None:
        files[name] = data
        entries.append({"path": name, **entry, "sha256": _sha256(data), "size": len(data)})

    for sname, (st, which) in streams.items():
        words_bin, words = fmt_io.pack_stream(st.valid, st.data, st.sof, st.eol, pix.word)
        first = int(np.flatnonzero(st.valid)[0])
        common = {
            "kind": "stream",
            "tap": f"{which}.{INPUT_TAP}" if which in ("e1", "e2") else which,
            "signal": pix_spec.signal,
            **_format_entry(pix),
            "stream_word_bits": pix.word + 3,
            "stream_word_bytes": fmt_io.stream_word_bytes(pix.word),
            "layout": "{sof, eol, valid, data}",
            "count": int(st.cycles),
            "valid_count": int(np.count_nonzero(st.valid)),
            "frames": int(st.frames),
            "first_valid_cycle": first,
        }
        comment = f"{sname} {{sof,eol,valid,data[{pix.word - 1}:0]}} one word per cycle"
        add(f"{sname}.bin", words_bin, {**common, "encoding": "bin"})
        add(f"{sname}.mem", fmt_io.write_stream_mem(words, pix.word, comment), common)
    for rom, rom_words in pipe.roms(config).items():
        word = max(1, int(rom_words.max()).bit_length())
        comment = f"{rom}: {rom_words.size} unsigned {word}-bit words, address = table index"
        rom_fmt = FixedFormat(False, word, 0)
        entry = {"kind": "rom", "tap": rom, "signal": rom, **_format_entry(rom_fmt),
                 "count": int(rom_words.size), "first_valid_cycle": 0,
                 "design": config.design()}  # fmt: skip
        add(f"{rom}.mem", fmt_io.write_mem(rom_words, word, comment), entry)
    for spec in table:
        if spec.name not in values:
            continue
        f = spec.fmt
        raw = np.asarray(values[spec.name], dtype=np.int64).ravel()
        base = cyc[spec.stream or "e2"]
        cycles = pipe.tap_cycles(spec, config, timing, cyc["e2"], base).ravel()
        if spec.name == "range" and not np.array_equal(cycles, result.out_cycles.ravel()):
            raise RuntimeError(f"{pipe.name}: the range tap's cycles are not the output cycles")
        kind = "input" if spec.stage is None else ("range" if spec.stream is None else "stream_tap")
        entry = {
            "kind": kind,
            "tap": spec.name,
            "signal": spec.signal,
            "stage": spec.stage,
            "latency": spec.latency,
            **_format_entry(f),
            "count": int(raw.size),
            "first_valid_cycle": int(cycles[0]),
            "last_valid_cycle": int(cycles.max()),
        }
        comment = f"{spec.name} {f} {f.describe()} {raw.size} words, scan order"
        add(f"{spec.name}.mem", fmt_io.write_mem(raw, f.word, comment), entry)
        if "coe" in wanted:
            add(f"{spec.name}.coe", fmt_io.write_coe(raw, f.word, comment), entry)
        if "mif" in wanted:
            add(f"{spec.name}.mif", fmt_io.write_mif(raw, f.word, comment), entry)
        if "csv" in wanted:
            add(f"{spec.name}.csv", fmt_io.write_csv(raw, cycles, rows, cols, sof, eol), entry)
    toml = config.to_toml()
    manifest = {
        "schema": SCHEMA,
        "generator": {"name": "rangefx", "version": _version()},
        "pipeline": pipe.name,
        "mode": case.mode,
        "shape": [m, n],
        "formats": [f for f in FORMATS if f in wanted],
        "config": {"name": config.name, "toml": toml, "parsed": tomllib.loads(toml)},
        "timing": asdict(timing),
        "case": {
            **dict(description or {}),
            "camera": _camera_dict(case.camera),
            "motion": _motion_dict(case.motion),
            # every settings the case holds, and the pipeline's own (defaults if absent)
            **{key: asdict(value) for key, value in case.settings.items()},
            pipe.settings_key: asdict(pipe.settings(case)),
        },
        "latency": {"total": result.latency, "stages": dict(result.stage_latency)},
        "total_cycles": result.total_cycles,
        "registers": {
            name: {
                "signal": signal,
                "format": str(config.fmt(signal)),
                "describe": config.fmt(signal).describe(),
                "raw": raw,
                "requested": result.registers[name][0],
                "value": result.registers[name][1],
            }
            for name, (signal, raw) in result.register_codes.items()
        },
        "saturated_registers": list(result.saturated_registers),
        "overflows": {k: v for k, v in result.overflows.items() if v},
        "total_bytes": sum(len(b) for b in files.values()),
        "files": entries,
    }
    return VectorSet(files, manifest, result)


def _check_result(
    pipe: Pipeline,
    case: Case,
    config: WordLengthConfig | None,
    timing: TimingConfig | None,
    result: PipelineResult,
) -> None:
    """A ``result`` given to :func:`build_vectors` must be ``pipe``'s run on ``case``
    with every tap (and the config and timing given, if any)."""
    if result.pipeline != pipe.name or result.mode != case.mode:
        raise ValueError(
            f"the result is a {result.pipeline} run in {result.mode} mode, not {pipe.name} "
            f"in the case's {case.mode} mode"
        )
    if np.shape(result.range) != case.shape:
        raise ValueError(
            f"the result's shape {np.shape(result.range)} is not the case's {case.shape}"
        )
    missing = [t.name for t in pipe.tap_table(result.config, case.mode)
               if t.stage is not None and t.name not in result.taps]  # fmt: skip
    if missing:
        raise ValueError(f"the result holds no tap {missing[0]} (run it with taps=True)")
    if config is not None and config != result.config:
        raise ValueError("the result was run with another config than the one given")
    if timing is not None and timing != result.timing:
        raise ValueError("the result was run with another timing than the one given")


def write_vectors(directory: str | Path, vectors: VectorSet) -> None:
    """Write the files and ``manifest.json`` (last) into an existing, empty ``directory``.

    Not atomic by itself: give it the temporary directory of an atomic output directory
    (``rangefx vectors gen`` uses ``rangefx.tools.report.outdir.atomic_output_dir``).
    """
    d = Path(directory)
    for name, data in vectors.files.items():
        (d / name).write_bytes(data)
    (d / MANIFEST_NAME).write_bytes(vectors.manifest_bytes())


# -- reading back ---------------------------------------------------------------------------
def load_manifest(directory: str | Path) -> dict:
    """The parsed ``manifest.json`` of a vector directory.

    Raises
    ------
    ValueError
        Missing, unreadable or not a rangefx vector manifest.
    """
    p = Path(directory) / MANIFEST_NAME
    try:
        data = read_regular(p, directory)  # a ValueError of its own names a special file
    except OSError as exc:
        raise ValueError(f"cannot read {p}: {exc.strerror}") from None
    try:
        manifest = loads_json(data)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{p} is not valid JSON: {exc}") from None
    except (ValueError, UnicodeDecodeError) as exc:  # nesting; bytes json cannot decode
        raise ValueError(f"{p} is not a {SCHEMA} manifest: {exc}") from None
    if not isinstance(manifest, dict) or manifest.get("schema") != SCHEMA:
        raise ValueError(f"{p} is not a {SCHEMA} manifest")
    _check_manifest(manifest, p)
    return manifest


_ENTRY_TYPES: dict[str, tuple[type, ...]] = {
    "path": (str,),
    "kind": (str,),
    "tap": (str,),
    "sha256": (str,),
    "size": (int,),
    "word": (int,),
    "frac": (int,),
    "signed": (bool,),
    "first_valid_cycle": (int,),
    "signal": (str,),
    "format": (str,),
    "describe": (str,),
}
_KINDS = ("stream", "input", "stream_tap", "range", "rom")


def _check_manifest(manifest: Mapping, where: Path) -> None:
    """Raise ValueError naming ``where`` and the field unless the parts that ``check``,
    ``diff`` and ``read_tap`` rely on are present and of the right type."""
    shape = manifest.get("shape")
    if (
        not isinstance(shape, list)
        or len(shape) != 2
        or not all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in shape)
    ):
        raise ValueError(f"{where}: 'shape' must be [rows, columns], not {shape!r}")
    files = manifest.get("files")
    if not isinstance(files, list):
        raise ValueError(f"{where}: 'files' must be a list of file entries, not {files!r:.60}")
    for k, e in enumerate(files):
        if not isinstance(e, dict):
            raise ValueError(f"{where}: files[{k}] is not an object")
        for key, types in _ENTRY_TYPES.items():
            v = e.get(key)
            if not isinstance(v, types) or (bool not in types and isinstance(v, bool)):
                raise ValueError(f"{where}: files[{k}] lacks a valid {key!r} (got {v!r:.60})")
        name = e["path"]
        if Path(name).name != name or name.startswith(".") or not name:
            raise ValueError(f"{where}: files[{k}] path {name!r} is not a plain file name")
        if e["kind"] not in _KINDS:
            raise ValueError(f"{where}: files[{k}] kind {e['kind']!r} is not one of {_KINDS}")
        if not 1 <= e["word"] <= 62 or e["size"] < 0:
            raise ValueError(f"{where}: files[{k}] has word {e['word']}, size {e['size']}")


def read_tap(directory: str | Path, tap: str, manifest: Mapping | None = None) -> np.ndarray:
    """Raw int64 codes of ``tap`` from its ``.mem`` file (scan order).

    Raises
    ------
    ValueError
        Unknown tap, or a word that is not hexadecimal.
    """
    manifest = manifest or load_manifest(directory)
    entry = _find_entry(manifest, tap)
    path = Path(directory) / entry["path"]
    try:
        words = fmt_io.read_mem(read_regular(path, directory))
    except OSError as exc:
        raise ValueError(f"cannot read {path}: {exc.strerror}") from None
    if any(w is None for w in words):
        raise ValueError(f"{entry['path']} holds x/z words")
    return fmt_io.to_signed(np.array(words, dtype=np.uint64), entry["word"], entry["signed"])


def _find_entry(manifest: Mapping, tap: str) -> dict:
    for e in manifest["files"]:
        if e.get("tap") == tap and e["path"].endswith(".mem") and e["kind"] != "stream":
            return e
    taps = sorted({e["tap"] for e in manifest["files"] if e["kind"] != "stream"})
    raise ValueError(f"no tap {tap!r} in the vectors; taps: {', '.join(taps)}")


def case_from_manifest(directory: str | Path, manifest: Mapping) -> dict:
    """Arguments of :func:`build_vectors` that reproduce a vector directory.

    The images come from the input ``.mem`` files (whose checksums the caller verified);
    pipeline, camera, motion, settings, config and timing from the manifest.
    """
    m, n = manifest["shape"]
    images = []
    for s in ("e1", "e2"):
        raw = read_tap(directory, f"{s}.{INPUT_TAP}", manifest)
        if raw.size != m * n:
            raise ValueError(
                f"{s}.{INPUT_TAP} holds {raw.size} words, the shape {m}x{n} in the manifest "
                f"needs {m * n}"
            )
        images.append(raw.reshape(m, n))
    try:
        c = manifest["case"]
        pipe = get_pipeline(manifest.get("pipeline", "p1"))
        config = pipe.config_from_toml(manifest["config"]["toml"], manifest["config"]["name"])
        # the settings of every registered pipeline's key the manifest holds
        types = {p.settings_key: p.settings_type for p in reversed(PIPELINES.values())}
        types[pipe.settings_key] = pipe.settings_type
        settings = {key: types[key](**c[key]) for key in types if key in c}
        case = Case(
            images[0],
            images[1],
            PinholeCamera(**c["camera"]),
            MotionIncrement(**{k: np.array(v) for k, v in c["motion"].items()}),
            manifest["mode"],
            settings=settings,
        )
        timing = TimingConfig(**manifest["timing"])
        rest = {k: v for k, v in c.items() if k not in ("camera", "motion", *types)}
    except (TypeError, KeyError, AttributeError, ValueError, IndexError) as exc:
        raise ValueError(f"manifest case is incomplete: {exc!r:.200}") from None
    if manifest.get("mode") not in ("stereo", "motion") or not isinstance(
        manifest.get("formats"), list
    ):
        raise ValueError("manifest case is incomplete: 'mode' or 'formats'")
    return {
        "pipeline": pipe,
        "case": case,
        "config": config,
        "timing": timing,
        "description": rest,
        "formats": manifest["formats"],
    }


@dataclass
class CheckReport:
    """Outcome of :func:`check_vectors`: ``problems`` empty means the directory is good;
    ``notes`` name files that are not part of the vectors (a user's RTL dump kept beside
    them, say): reported, left alone, not a fault."""

    files: int = 0
    bytes: int = 0
    problems: list[str] = field(default_factory=list)
    rerun: bool = False
    notes: list[str] = field(default_factory=list)
    #: The manifest's case (scene, seed, crop) was rendered and reproduced the vectors
    #: (set by ``rangefx vectors check``, which can render scenes).
    provenance: bool = False

    @property
    def ok(self) -> bool:
        return not self.problems

    def to_dict(self) -> dict:
        """The report as JSON-able values (``rangefx vectors check --json``)."""
        return {**asdict(self), "ok": self.ok}

    def write(self, directory: str | Path) -> Path:
        """Write ``check.json`` (:meth:`to_dict`) into ``directory`` (created if needed)."""
        return write_report(directory, "check.json", self.to_dict())


def write_report(directory: str | Path, name: str, data: Mapping) -> Path:
    """Write ``data`` as ``directory/name`` (JSON): to a temporary file beside it, then
    renamed, so a reader never sees half a report. Returns the path."""
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    path = d / name
    tmp = d / f".{name}.tmp-{os.getpid()}"
    tmp.write_text(json.dumps(data, indent=1) + "\n")
    os.replace(tmp, path)
    return path


_MARKER = ".rangefx-output"  # rangefx.tools.report.outdir.MARKER_NAME (vectors sits below tools)
_IGNORED = {MANIFEST_NAME, _MARKER}


def _incomplete_marker(d: Path) -> str | None:
    """A problem line if ``d``'s output marker says ``state: incomplete``: a run was
    stopped while it moved its files in, so old and new files may be mixed."""
    try:
        text = read_regular(d / _MARKER, d).decode("utf-8", "replace")
    except (OSError, ValueError):
        return None
    if "state: incomplete" not in text.splitlines():
        return None
    return (
        f"{_MARKER}: state: incomplete (a run was stopped while it put its files in place; "
        "files of two runs may be mixed: generate the vectors again)"
    )


def check_vectors(directory: str | Path, *, rerun: bool = True) -> CheckReport:
    """Verify every listed file's size and SHA-256, then re-run the model and compare bytes.

    Parameters
    ----------
    directory
        A vector directory.
    rerun
        Re-run P1 from the manifest (inputs from the directory's input files, configs and
        case from the manifest) and require byte-identical files and manifest; skipped
        when the checksums already failed.

    Raises
    ------
    ValueError
        The directory has no readable manifest.
    """
    d = Path(directory)
    manifest = load_manifest(d)
    report = CheckReport()
    if (incomplete := _incomplete_marker(d)) is not None:
        report.problems.append(incomplete)
    listed = set()
    for e in manifest["files"]:
        p = d / e["path"]
        listed.add(e["path"])
        try:
            data = read_regular(p, d)  # a FIFO or /dev/zero: one error line, not a hang
        except OSError:
            report.problems.append(f"{e['path']}: missing")
            continue
        report.files += 1
        report.bytes += len(data)
        if len(data) != e["size"]:
            report.problems.append(f"{e['path']}: {len(data)} bytes, manifest says {e['size']}")
        elif _sha256(data) != e["sha256"]:
            report.problems.append(f"{e['path']}: SHA-256 differs from the manifest")
    for p in sorted(d.iterdir()):
        if p.name not in listed and p.name not in _IGNORED:
            report.notes.append(f"{p.name}: not listed in the manifest (left alone)")
    if report.problems or not rerun:
        return report
    again = build_vectors(**case_from_manifest(d, manifest))
    report.rerun = True
    for name, data in again.files.items():
        if name not in listed:
            report.problems.append(f"{name}: the model writes it, the directory lacks it")
        elif read_regular(d / name, d) != data:
            report.problems.append(f"{name}: differs from a fresh run of the model")
    mine = json.loads(again.manifest_bytes())
    theirs = dict(manifest)
    mine["generator"] = theirs.get("generator")  # another version may check the same vectors
    if mine != theirs:
        keys = sorted(k for k in set(mine) | set(theirs) if mine.get(k) != theirs.get(k))
        report.problems.append(f"{MANIFEST_NAME}: differs from a fresh run in {keys}")
    return report


@dataclass
class DiffReport:
    """First mismatch between an RTL dump and an expected tap (SPEC §5)."""

    tap: str
    signal: str
    format: str
    describe: str
    expected_count: int
    got_count: int
    mismatches: int
    first: dict | None
    #: samples whose value differs (missing and extra ones too)
    value_mismatches: int = 0
    #: samples at another cycle than the model's; ``None``: the dump carries no cycles
    #: (a ``.mem``), so only values were compared
    cycle_mismatches: int | None = None

    @property
    def ok(self) -> bool:
        return self.mismatches == 0

    def as_dict(self) -> dict:
        return {**asdict(self), "ok": self.ok}

    def to_dict(self) -> dict:
        """The report as JSON-able values (``rangefx vectors diff --json``)."""
        return self.as_dict()

    def write(self, directory: str | Path) -> Path:
        """Write ``diff.json`` (:meth:`to_dict`) into ``directory`` (created if needed)."""
        return write_report(directory, "diff.json", self.to_dict())

    def text(self) -> str:
        head = f"{self.tap} ({self.signal}, {self.format}, {self.describe})"
        if self.ok:
            return f"{head}: {self.expected_count} samples, 0 mismatches"
        cycles = (
            "" if self.cycle_mismatches is None
            else f"; {self.value_mismatches} in value, {self.cycle_mismatches} in cycle"
        )  # fmt: skip
        lines = [f"{head}: {self.mismatches} mismatches ({self.expected_count} samples expected, "
                 f"{self.got_count} in the dump{cycles})"]  # fmt: skip
        if self.first is not None:
            f = self.first
            got_cycle = f.get("got_cycle")
            late = f" (got cycle {got_cycle})" if got_cycle not in (None, f["cycle"]) else ""
            lines.append(
                f"first mismatch: sample {f['index']}, cycle {f['cycle']}{late}, row {f['row']}, "
                f"col {f['col']}, signal {self.tap}, expected {f['expected']} "
                f"({f['expected_hex']}), got {f['got']} ({f['got_hex']}), format {self.format}"
                + (f" (bits outside the {self.format} word)" if f.get("outside_format") else "")
            )
        return "\n".join(lines)


#: Memory that reading one byte of a ``.mem``/``.csv`` dump may take (the bytes, their
#: tokens and the words as Python objects; tracemalloc peak of read_mem_words: 29 for
#: 6-digit lines, 69 for 1-digit lines, the worst case): :func:`dump_memory_bytes`.
DUMP_BYTES_PER_FILE_BYTE = 80


def dump_memory_bytes(dump: str | Path) -> int:
    """Memory :func:`diff_dump` needs to read ``dump`` (0 if it cannot be sized)."""
    try:
        return Path(dump).stat().st_size * DUMP_BYTES_PER_FILE_BYTE
    except OSError:
        return 0


def diff_dump(directory: str | Path, dump: str | Path, tap: str | None = None) -> DiffReport:
    """Compare an RTL dump (``.mem`` or ``.csv``, samples in scan order) with a tap.

    ``tap`` defaults to the dump's file name without its extension (``e1.row_r1.mem`` ->
    ``e1.row_r1``). Codes are compared as ``W``-bit two's complement words; ``x``/``z``
    words and words with bits outside the format (:func:`dump_code`) always mismatch. A
    ``.mem`` dump is read as ``$readmemh`` reads it (:func:`~rangefx.vectors.formats.
    read_mem_words`): sample ``k`` is the word at address ``k``; an address no word was
    loaded at (a gap left by ``@address`` directives) is a missing sample, a word at an
    address past the last sample an extra one; each counts as a mismatch. The first
    mismatch is the first differing sample in scan order (cycle = the model's cycle for
    that sample). A ``.csv`` dump with a ``cycle`` column carries each sample's cycle:
    a sample at another cycle than the model's is a mismatch too, whatever its value (an
    extra register before a tap shifts every cycle and no value), and the first one names
    the cycle expected and the cycle got (``got_cycle``). A ``.mem`` dump holds values
    only (``cycle_mismatches`` is ``None``).

    Raises
    ------
    ValueError
        Unreadable dump, unknown tap, or a dump format other than ``.mem``/``.csv``.
    """
    d = Path(directory)
    dump = Path(dump)
    manifest = load_manifest(d)
    try:  # before the tap: a missing dump is not an unknown tap
        data = read_regular(dump)  # not /dev/zero, a FIFO
    except OSError as exc:
        raise ValueError(f"cannot read dump {dump}: {exc.strerror}") from None
    if tap is None:
        tap = dump.name.split(".mem")[0].split(".csv")[0]
    entry = _find_entry(manifest, tap)
    word, signed = int(entry["word"]), bool(entry["signed"])
    read: dict[int, tuple[int | None, int | None]]
    got_cycles: list[int | None] | None = None  # the dump's cycle stamps, if it has them
    if dump.suffix == ".csv":  # decimal numbers: no width (dump_code)
        columns = fmt_io.read_csv(data)
        read = dict(enumerate((v, None) for v in columns["value"]))
        got_cycles = columns.get("cycle")
    elif dump.suffix == ".mem":
        read = fmt_io.read_mem_words(data)
    else:
        raise ValueError(f"dump {dump.name}: expected a .mem or .csv file")
    expected = fmt_io.to_unsigned(read_tap(d, tap, manifest), word).astype(np.int64)
    n_exp, n_got = expected.size, len(read)
    # a word that is not this format's (bits outside it) is a mismatch, never masked;
    # -1 marks an x/z or outside word, -2 an address no word was loaded at
    g = np.full(n_exp, -2, dtype=np.int64)
    extra = 0
    for address, (value, bits) in read.items():
        if address >= n_exp:
            extra += 1
            continue
        code = dump_code(value, word, signed, bits)
        g[address] = -1 if code is None else code
    bad_value = g != expected
    bad = bad_value.copy()
    base = int(entry["first_valid_cycle"])
    cycles: np.ndarray | None = None
    cycle_mismatches = None
    if got_cycles is not None:  # every sample at the model's cycle (an unreadable stamp: not)
        # cycle of each sample: the tap's cycles are the input cycles plus a fixed latency
        cycles = tap_cycles(d, manifest, tap, base)
        k = min(n_exp, len(got_cycles))
        stamps = np.array([-1 if c is None else c for c in got_cycles[:k]], dtype=np.int64)
        bad_cycle = np.zeros(n_exp, dtype=bool)
        bad_cycle[:k] = stamps != cycles[:k]
        cycle_mismatches = int(np.count_nonzero(bad_cycle))
        bad |= bad_cycle
    value_mismatches = int(np.count_nonzero(bad_value)) + extra
    mismatches = int(np.count_nonzero(bad)) + extra
    first = None
    if mismatches:
        idx = int(np.flatnonzero(bad)[0]) if bad.any() else min(a for a in read if a >= n_exp)
        m, n = manifest["shape"]
        digits = fmt_io.hex_digits(word)
        if cycles is None:
            cycles = tap_cycles(d, manifest, tap, base)
        exp_raw = (
            int(fmt_io.to_signed(expected[idx : idx + 1], word, signed)[0]) if idx < n_exp else None
        )
        got_word = read.get(idx, (None, None))[0]
        got_code = int(g[idx]) if idx < n_exp else dump_code(got_word, word, signed)
        got_raw = (
            got_word
            if got_code is None or got_code < 0
            else int(fmt_io.to_signed(np.array([got_code], dtype=np.uint64), word, signed)[0])
        )
        first = {
            "index": idx,
            "cycle": int(cycles[idx]) if idx < cycles.size else None,
            "row": (idx // n) % m,
            "col": idx % n,
            "expected": exp_raw,
            "expected_hex": "-" if exp_raw is None else f"{int(expected[idx]):0{digits}x}",
            "got": got_raw,
            "got_hex": "x",
        }
        if got_cycles is not None:
            first["got_cycle"] = got_cycles[idx] if idx < len(got_cycles) else None
        if idx not in read:
            first["got_hex"] = "missing" if dump.suffix == ".csv" or idx >= n_got else "not loaded"
            first["got"] = None
        elif got_word is not None and (got_code is None or got_code < 0):
            width = read[idx][1] or 0  # the word as the dump wrote it, leading zeros too
            first["got_hex"] = f"{got_word:0{width // 4}x}" if got_word >= 0 else str(got_word)
            first["outside_format"] = True
        elif got_code is not None and got_code >= 0:
            first["got_hex"] = f"{got_code:0{digits}x}"
    return DiffReport(
        tap, entry["signal"], entry["format"], entry["describe"], n_exp, n_got, mismatches, first,
        value_mismatches, cycle_mismatches,
    )  # fmt: skip


def dump_code(value: int | None, word: int, signed: bool, bits: int | None = None) -> int | None:
    """The ``word``-bit code of one RTL dump word, or ``None`` if it is not one.

    ``bits`` is the width the dump wrote the word with (4 bits per hex digit of a
    ``.mem`` word); ``None`` for a decimal number (a ``.csv`` value), which has no width.
    Accepted:

    * the code itself, ``0 <= value < 2**word``, when the word is no wider than the
      tap's own hex width (``4 * ceil(word / 4)`` bits, what ``$writememh`` writes for a
      ``word``-bit register: its top bits are padding) or is a decimal number;
    * in a wider word, bits ``word`` and up all zero for an unsigned tap or a
      non-negative value of a signed one (zero extension), all equal to the sign bit
      ``word - 1`` for a signed tap (sign extension: ``ffffffff`` is -1 of a 21-bit tap);
    * for a signed tap, a negative decimal number ``-2**(word-1) <= value < 0`` (the
      ``.csv`` vectors write the signed raw value).

    Anything else has bits outside the format and is ``None``, a mismatch like an ``x``
    word: ``0fe00188`` for a 21-bit signed tap (bits 21-27 ones, 28-31 zeros),
    ``001fffff`` (a negative 21-bit code zero-extended to 32 bits), a negative value
    for an unsigned tap.
    """
    if value is None:
        return None
    if value < 0:
        return value + (1 << word) if signed and value >= -(1 << (word - 1)) else None
    own = 4 * fmt_io.hex_digits(word)
    if value < (1 << word):
        wider = bits is not None and bits > own
        if wider and signed and value >> (word - 1):
            return None  # a negative code with zeros above it: not its sign extension
        return value
    if signed and bits is not None and value >> (word - 1) == (1 << (bits - word + 1)) - 1:
        return value & ((1 << word) - 1)
    return None


def tap_cycles(d: Path, manifest: Mapping, tap: str, first: int) -> np.ndarray:
    """Cycle of every sample of ``tap``, from the input streams' valid beats: a tap with
    a fixed latency is its stream's beats shifted to ``first``; a scheduled tap (P2's
    sweep) takes the pipeline's schedule on those beats."""
    entry = _find_entry(manifest, tap)
    stream = tap.rpartition(".")[0] or None
    names = [e for e in manifest["files"] if e["kind"] == "stream" and e["path"].endswith(".bin")]
    if not names:
        raise ValueError(f"{d / MANIFEST_NAME} lists no input stream (.bin) file")
    beats = {}
    for e in names:
        try:
            raw = read_regular(d / e["path"], d)
        except OSError as exc:
            raise ValueError(f"cannot read {d / e['path']}: {exc.strerror}") from None
        data = fmt_io.read_stream_bin_valid(raw, int(e["word"]))
        beats[e["tap"]] = np.flatnonzero(data).astype(np.int64)
    m, n = manifest["shape"]
    if f"e1.{INPUT_TAP}" in beats:
        cyc = {"e1": beats[f"e1.{INPUT_TAP}"], "e2": beats[f"e2.{INPUT_TAP}"]}
    else:  # motion: one stream of two frames
        both = next(iter(beats.values()))
        cyc = {"e1": both[: m * n], "e2": both[m * n :]}
    base = cyc[stream or "e2"]
    if entry.get("latency", 0) is not None:
        return base - base[0] + first
    pipe = get_pipeline(manifest["pipeline"])
    config = pipe.config_from_toml(manifest["config"]["toml"], manifest["config"]["name"])
    spec = next(t for t in pipe.tap_table(config, manifest["mode"]) if t.name == tap)
    timing = TimingConfig(**manifest["timing"])
    in_cycles = cyc["e2"].reshape(m, n)
    return pipe.tap_cycles(spec, config, timing, in_cycles, base.reshape(m, n)).ravel()
