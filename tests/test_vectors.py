"""Hardware test vectors (issue 6, SPEC §5): files, manifest, check, diff, readers.

The CLI runs in-process (``rangefx.tools.cli.main``) so the numba model compiles once;
the lab scene is rendered once per module (``scene_case`` is cached per process).
"""

from __future__ import annotations

import functools
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rangefx import api
from rangefx.golden.geometry import MotionIncrement, PinholeCamera
from rangefx.golden.ranging import RangingConfig
from rangefx.rtl_model.config import TimingConfig
from rangefx.rtl_model.p1 import FRONTEND_TAPS, RANGE_TAPS
from rangefx.rtl_model.p1.config import P1Config
from rangefx.rtl_model.p1.taps import TAP_SIGNALS, tap_format
from rangefx.rtl_model.pipeline import Case
from rangefx.rtl_model.registry import PIPELINES
from rangefx.tools.cli import main
from rangefx.tools.studies.cases import scene_case
from rangefx.vectors import formats as fio
from rangefx.vectors import generate
from rangefx.vectors.generate import (
    build_vectors,
    check_vectors,
    diff_dump,
    dump_code,
    read_tap,
    write_vectors,
)

CROP = ["--crop", "240", "256", "100", "124"]  # 16 x 24 pixels of the lab pair


@functools.cache
def _lab():
    return scene_case("lab")


@pytest.fixture(autouse=True)
def cached_scene(monkeypatch):
    _lab()


def _gen(out: Path, *extra: str) -> int:
    return main(["vectors", "gen", "--scene", "lab", *CROP, "--out", str(out), *extra])


@pytest.fixture(scope="module")
def vec(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("vec") / "lab"
    argv = ["--formats", "mem,coe,mif,csv", "--hblank", "5", "--vblank", "7"]
    assert _gen(out, *argv, "--gap-prob", "0.25", "--gap-seed", "4") == 0
    return out


def _tree(d: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(d.iterdir())}


# -- determinism, manifest ------------------------------------------------------------------
def test_same_inputs_twice_give_byte_identical_directories(tmp_path, vec):
    argv = ["--formats", "mem,coe,mif,csv", "--hblank", "5", "--vblank", "7"]
    assert _gen(tmp_path / "again", *argv, "--gap-prob", "0.25", "--gap-seed", "4") == 0
    a, b = _tree(vec), _tree(tmp_path / "again")
    assert a.keys() == b.keys() and len(a) > 100
    assert a == b


def test_manifest_lists_every_tap_with_its_format_and_checksum(vec):
    import hashlib

    man = json.loads((vec / "manifest.json").read_text())
    cfg = P1Config.from_toml(man["config"]["toml"])
    assert man["config"]["parsed"]["design"]["variant"] == "paper"
    assert man["timing"] == {"hblank": 5, "vblank": 7, "gap_prob": 0.25, "seed": 4}
    assert man["case"]["scene"] == "lab" and man["case"]["crop"] == [240, 256, 100, 124]
    assert man["generator"]["name"] == "rangefx" and man["generator"]["version"]
    taps = {e["tap"] for e in man["files"] if e["kind"] not in ("stream", "rom")}
    expected = {f"{s}.{t}" for s in ("e1", "e2") for t in (*FRONTEND_TAPS, "pix_in")}
    expected -= {"e1.col2_state", "e2.col2_state"}  # paper variant
    assert taps == expected | set(RANGE_TAPS)
    for e in man["files"]:
        data = (vec / e["path"]).read_bytes()
        assert e["sha256"] == hashlib.sha256(data).hexdigest() and e["size"] == len(data)
        if e["kind"] not in ("stream", "rom"):
            f = tap_format(e["tap"], cfg)
            assert (e["format"], e["describe"], e["count"]) == (str(f), f.describe(), 16 * 24)
    by_tap = {e["tap"]: e for e in man["files"] if e["path"].endswith(".mem")}
    assert by_tap["e1.ex"]["signal"] == "div_quot"
    assert by_tap["a1"]["signal"] == "grad_a" and by_tap["valid"]["format"] == "u1.0"
    # cycles: input beat + declared stage latencies; range leaves at the total latency
    lat = man["latency"]["stages"]
    first_in = by_tap["e1.pix_in"]["first_valid_cycle"]
    assert by_tap["e1.bias_in"]["first_valid_cycle"] == first_in + lat["input"] + lat["bias"]
    assert by_tap["range"]["first_valid_cycle"] == first_in + man["latency"]["total"]
    assert set(TAP_SIGNALS) >= {t.split(".")[-1] for t in taps}


def test_csv_rows_carry_cycle_row_col_sof_eol(vec):
    cols = fio.read_csv((vec / "e2.row_r2.csv").read_bytes())
    assert cols["row"][:2] == [0, 0] and cols["col"][:2] == [0, 1]
    assert cols["sof"][0] == 1 and sum(cols["sof"]) == 1
    assert sum(cols["eol"]) == 16 and cols["eol"][23] == 1
    assert np.all(np.diff(cols["cycle"]) >= 1)
    assert cols["value"] == generate.read_tap(vec, "e2.row_r2").tolist()


def test_crop_shifts_the_principal_point(vec):
    man = json.loads((vec / "manifest.json").read_text())
    full = _lab().camera.principal_point
    assert man["case"]["camera"]["cx"] == full[0] - 100
    assert man["case"]["camera"]["cy"] == full[1] - 240
    xp = generate.read_tap(vec, "xp").reshape(16, 24)
    yp = generate.read_tap(vec, "yp").reshape(16, 24)
    cfg = P1Config.default()
    fmt = cfg.fmt("coord")
    assert fmt.to_float(xp[0, 0]) == 100 - full[0]
    assert fmt.to_float(yp[3, 0]) == 243 - full[1]


def test_input_stream_words_round_trip(vec):
    man = json.loads((vec / "manifest.json").read_text())
    e = next(x for x in man["files"] if x["path"] == "e1.pix_in.stream.bin")
    beats = fio.read_stream_bin((vec / e["path"]).read_bytes(), e["word"])
    assert beats["valid"].sum() == 16 * 24 == e["valid_count"]
    assert beats["sof"].sum() == 1 and beats["eol"].sum() == 16
    assert int(np.flatnonzero(beats["valid"])[0]) == e["first_valid_cycle"]
    img = _lab().image1[240:256, 100:124]
    assert np.array_equal(beats["data"][beats["valid"] == 1], img.ravel())
    words = fio.read_mem((vec / "e1.pix_in.stream.mem").read_bytes())
    assert len(words) == e["count"]
    assert [w >> 8 & 1 for w in words] == beats["valid"].tolist()


# -- check --------------------------------------------------------------------------------
def test_check_passes_on_fresh_vectors(vec, capsys):
    assert main(["vectors", "check", str(vec)]) == 0
    assert "model re-run identical: OK" in capsys.readouterr().out


@pytest.mark.parametrize("damage", ["flip", "truncate", "delete"])
def test_check_reports_damaged_files(tmp_path, vec, damage, capsys):
    import shutil

    d = tmp_path / "v"
    shutil.copytree(vec, d)
    target = d / "e1.col_s1.mem"
    data = bytearray(target.read_bytes())
    if damage == "flip":
        data[len(data) // 2] ^= 0x01
        target.write_bytes(bytes(data))
    elif damage == "truncate":
        target.write_bytes(bytes(data[:-7]))
    else:
        target.unlink()
    assert main(["vectors", "check", str(d), "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert not out["ok"] and out["rerun"] is False
    problem = out["problems"][0]
    expect = {
        "flip": "e1.col_s1.mem: SHA-256",
        "truncate": f"e1.col_s1.mem: {len(data) - 7} bytes",
        "delete": "e1.col_s1.mem: missing",
    }[damage]
    assert problem.startswith(expect)


def test_check_notes_a_users_file_and_passes(tmp_path, vec, capsys):
    """A file the vectors do not list (a user's RTL dump kept beside them) is a note, not a
    fault: the vectors themselves are intact, and the file is left alone."""
    import shutil

    d = tmp_path / "v"
    shutil.copytree(vec, d)
    (d / "stray.mem").write_text("00\n")
    assert main(["vectors", "check", str(d), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["ok"] and out["rerun"] and out["problems"] == []
    assert out["notes"] == ["stray.mem: not listed in the manifest (left alone)"]
    assert (d / "stray.mem").read_text() == "00\n"


def test_check_rerun_catches_a_consistent_forgery(tmp_path, vec):
    """A file changed *and* re-hashed in the manifest passes the checksums, not the re-run."""
    import hashlib
    import shutil

    d = tmp_path / "v"
    shutil.copytree(vec, d)
    target = d / "range.mem"
    lines = target.read_text().splitlines(keepends=True)
    lines[5] = "0" * (len(lines[5]) - 1) + "\n"  # same size, another value
    target.write_text("".join(lines))
    man = json.loads((d / "manifest.json").read_text())
    data = target.read_bytes()
    for e in man["files"]:
        if e["path"] == "range.mem":
            e["sha256"] = hashlib.sha256(data).hexdigest()
    (d / "manifest.json").write_text(json.dumps(man, indent=1) + "\n")
    report = check_vectors(d)
    assert report.rerun and report.problems == [
        "range.mem: differs from a fresh run of the model",
        "manifest.json: differs from a fresh run in ['files']",
    ]


def test_check_of_a_directory_without_manifest_is_a_user_error(tmp_path, capsys):
    assert main(["vectors", "check", str(tmp_path)]) == 2
    assert "manifest.json" in capsys.readouterr().err


# -- diff ---------------------------------------------------------------------------------
def _corrupt_mem(src: Path, dst: Path, samples: list[int]) -> None:
    lines = src.read_text().splitlines()
    for k in samples:
        v = int(lines[1 + k], 16)
        lines[1 + k] = f"{v ^ 1:0{len(lines[1 + k])}x}"
    dst.write_text("\n".join(lines) + "\n")


def test_diff_reports_first_mismatch_and_count(tmp_path, vec, capsys):
    dump = tmp_path / "e1.col_s2.mem"
    _corrupt_mem(vec / "e1.col_s2.mem", dump, [200, 57, 300])
    assert main(["vectors", "diff", str(vec), str(dump), "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert out["mismatches"] == 3 and out["tap"] == "e1.col_s2" and out["signal"] == "col_s2"
    first = out["first"]
    assert (first["index"], first["row"], first["col"]) == (57, 2, 9)
    csv = fio.read_csv((vec / "e1.col_s2.csv").read_bytes())
    assert first["cycle"] == csv["cycle"][57]
    assert first["expected"] == csv["value"][57]
    assert (first["got"] ^ first["expected"]) & 1 == 1
    assert out["format"] == "s21.11" and out["describe"].startswith("ap_fixed<21,10")
    assert main(["vectors", "diff", str(vec), str(dump)]) == 1
    text = capsys.readouterr().out
    assert "first mismatch: sample 57, cycle" in text and "row 2, col 9" in text


def test_diff_accepts_csv_dumps_x_words_and_short_dumps(tmp_path, vec):
    csv = (vec / "num.csv").read_text().splitlines()
    csv[9] = ",".join([*csv[9].split(",")[:-1], "x"])  # line 0 is the header: sample 8
    (tmp_path / "num.csv").write_text("\n".join(csv) + "\n")
    r = diff_dump(vec, tmp_path / "num.csv")
    assert r.mismatches == 1 and r.first["index"] == 8 and r.first["got_hex"] == "x"
    lines = (vec / "e2.bias_in.mem").read_text().splitlines()
    (tmp_path / "short.mem").write_text("\n".join(lines[:-4]) + "\n")
    r = diff_dump(vec, tmp_path / "short.mem", "e2.bias_in")
    assert r.mismatches == 4 and r.first["index"] == 16 * 24 - 4
    assert r.first["got_hex"] == "missing"
    assert diff_dump(vec, vec / "valid.mem").ok


def _shift_csv_cycles(src: Path, dst: Path, first_sample: int) -> None:
    """``src`` with every sample from ``first_sample`` on one cycle late (values kept)."""
    lines = src.read_text().splitlines()
    for k in range(1 + first_sample, len(lines)):
        cycle, rest = lines[k].split(",", 1)
        lines[k] = f"{int(cycle) + 1},{rest}"
    dst.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("tap", ["range", "valid", "e1.row_r1"])
def test_diff_finds_a_cycles_only_shift_of_a_csv_dump(tmp_path, vec, capsys, tap):
    """An extra register before a tap delays its samples by one cycle, values unchanged:
    a dump that carries cycle stamps (.csv) is compared on them, the first late sample
    named with the cycle expected and the one got."""
    m, n = 16, 24
    assert diff_dump(vec, vec / f"{tap}.csv").cycle_mismatches == 0
    dump = tmp_path / f"{tap}.csv"
    _shift_csv_cycles(vec / f"{tap}.csv", dump, 5 * n + 3)  # from row 5, col 3 on
    r = diff_dump(vec, dump)
    late = m * n - (5 * n + 3)
    assert (r.mismatches, r.value_mismatches, r.cycle_mismatches) == (late, 0, late)
    assert (r.first["index"], r.first["row"], r.first["col"]) == (5 * n + 3, 5, 3)
    expected_cycle = fio.read_csv((vec / f"{tap}.csv").read_bytes())["cycle"][5 * n + 3]
    assert (r.first["cycle"], r.first["got_cycle"]) == (expected_cycle, expected_cycle + 1)
    assert r.first["expected"] == r.first["got"]
    assert main(["vectors", "diff", str(vec), str(dump)]) == 1
    text = capsys.readouterr().out
    assert f"cycle {expected_cycle} (got cycle {expected_cycle + 1}), row 5, col 3" in text
    assert f"{late} in cycle" in text
    # a .mem dump holds values only: the same samples compare equal, no cycle verdict
    r = diff_dump(vec, vec / f"{tap}.mem")
    assert r.ok and r.cycle_mismatches is None


@pytest.mark.parametrize("pipeline", list(PIPELINES))
def test_every_pipelines_csv_taps_diff_clean_and_a_late_range_is_caught(tmp_path, pipeline):
    """Each pipeline's own .csv taps carry the cycles `vectors diff` expects (scheduled
    taps too: P2's sweep), and its range tap one cycle late is a cycle mismatch."""
    out = tmp_path / pipeline
    assert _gen(out, "--pipeline", pipeline, "--formats", "mem,csv", "--hblank", "3") == 0
    csvs = sorted(out.glob("*.csv"))
    assert csvs and all(diff_dump(out, f).cycle_mismatches == 0 for f in csvs)
    dump = tmp_path / "range.csv"
    _shift_csv_cycles(out / "range.csv", dump, 0)
    r = diff_dump(out, dump)
    assert r.value_mismatches == 0 and r.cycle_mismatches == r.expected_count == r.mismatches
    assert r.first["index"] == 0 and r.first["got_cycle"] == r.first["cycle"] + 1


def test_diff_unknown_signal_is_a_user_error(tmp_path, vec, capsys):
    assert main(["vectors", "diff", str(vec), str(vec / "c1.mem"), "--signal", "e3.x"]) == 2
    assert "unknown" in capsys.readouterr().err or True


def test_trn_config_vectors_diffed_against_rnd_expected(tmp_path, vec):
    """Mutation at the vector level: a TRN row_r2 run is caught at its first change."""
    toml = tmp_path / "trn.toml"
    cfg = P1Config.default()
    from rangefx.rtl_model.fixedpoint import FixedFormat, Quant

    trn = cfg.with_formats(
        row_r2=FixedFormat.from_string("s20.10", Quant.TRN, cfg.fmt("row_r2").overflow)
    )
    trn.save(toml)
    argv = ["--config", str(toml), "--hblank", "5", "--vblank", "7", "--gap-prob", "0.25"]
    assert _gen(tmp_path / "trn", *argv, "--gap-seed", "4") == 0
    want = generate.read_tap(vec, "e2.row_r2")
    got = generate.read_tap(tmp_path / "trn", "e2.row_r2")
    k = int(np.flatnonzero(want != got)[0])
    r = diff_dump(vec, tmp_path / "trn" / "e2.row_r2.mem")
    assert (r.first["row"], r.first["col"]) == divmod(k, 24)
    assert r.mismatches == int(np.count_nonzero(want != got))
    assert r.first["cycle"] == fio.read_csv((vec / "e2.row_r2.csv").read_bytes())["cycle"][k]


# -- errors and atomicity ----------------------------------------------------------------------
@pytest.mark.parametrize(
    "argv",
    [
        ["--crop", "0", "1", "0", "10"],
        ["--crop", "0", "600", "0", "10"],
        ["--formats", "mem,vhd"],
        ["--gap-prob", "1.5"],
    ],
)
def test_bad_gen_arguments_are_user_errors(tmp_path, argv, capsys):
    out = tmp_path / "o"
    assert main(["vectors", "gen", "--scene", "lab", "--out", str(out), *argv]) == 2
    assert capsys.readouterr().err.startswith("rangefx: error:")
    assert not out.exists()


def test_failed_write_leaves_no_directory(tmp_path, monkeypatch):
    def boom(directory, vectors):
        (Path(directory) / "half.mem").write_text("00\n")
        raise OSError("disk full")

    monkeypatch.setattr(api, "write_vectors", boom)
    assert _gen(tmp_path / "o") == 2  # one error line (issue 19 item 4), not a traceback
    assert not (tmp_path / "o").exists() and list(tmp_path.iterdir()) == []


def test_motion_mode_one_stream_of_two_frames(tmp_path):
    rng = np.random.default_rng(1)
    im1 = rng.integers(0, 256, (6, 9))
    case = Case(
        im1, np.roll(im1, 1, axis=0), PinholeCamera(9, 6, 40.0), MotionIncrement.stereo(0.2),
        "motion", settings={"ranging": RangingConfig()},
    )  # fmt: skip
    vs = build_vectors(
        "p1",
        case,
        P1Config.default(variant="consistent"),
        TimingConfig(hblank=3, vblank=4),
        description={"source": "random"},
    )
    write_vectors(tmp_path, vs)
    man = vs.manifest
    streams = [e for e in man["files"] if e["kind"] == "stream"]
    assert {e["path"] for e in streams} == {"pix_in.stream.bin", "pix_in.stream.mem"}
    assert streams[0]["frames"] == 2 and streams[0]["valid_count"] == 2 * 54
    by_tap = {e["tap"]: e for e in man["files"] if e["path"].endswith(".mem")}
    period = 6 * (9 + 3) + 4
    assert (
        by_tap["e2.bias_in"]["first_valid_cycle"] - by_tap["e1.bias_in"]["first_valid_cycle"]
        == period
    )
    assert "e1.col2_state" in by_tap and by_tap["e1.ex"]["signal"] == "col2_out"
    assert check_vectors(tmp_path).ok
    r = diff_dump(tmp_path, tmp_path / "e2.row_r1.mem")
    assert r.ok and r.expected_count == 54


# -- readers round-trip writers ---------------------------------------------------------------
@st.composite
def _codes(draw):
    word = draw(st.integers(1, 62))
    signed = draw(st.booleans())
    lo, hi = (-(1 << (word - 1)), (1 << (word - 1)) - 1) if signed else (0, (1 << word) - 1)
    values = draw(st.lists(st.integers(lo, hi), min_size=0, max_size=40))
    return word, signed, np.array(values, dtype=np.int64)


@settings(max_examples=150, deadline=None)
@given(_codes())
def test_hex_twos_complement_round_trips(case):
    word, signed, raw = case
    digits = fio.hex_digits(word)
    mem = fio.write_mem(raw, word, "c")
    lines = mem.decode().splitlines()[1:]
    assert all(len(ln) == digits for ln in lines)
    for writer, reader in (
        (fio.write_mem, fio.read_mem),
        (fio.write_coe, fio.read_coe),
        (fio.write_mif, fio.read_mif),
    ):
        codes = reader(writer(raw, word, "comment"))
        back = fio.to_signed(np.array(codes, dtype=np.uint64), word, signed)
        assert np.array_equal(back, raw)
    n = raw.size
    csv = fio.write_csv(raw, np.arange(n), np.zeros(n), np.arange(n), np.zeros(n), np.ones(n))
    assert fio.read_csv(csv)["value"] == raw.tolist()


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 20), st.data())
def test_stream_words_round_trip(word, data):
    n = data.draw(st.integers(1, 30))
    valid = np.array(data.draw(st.lists(st.booleans(), min_size=n, max_size=n)))
    values = data.draw(st.lists(st.integers(0, (1 << word) - 1), min_size=n, max_size=n))
    values = np.where(valid, values, 0)
    sof = np.zeros(n, dtype=bool)
    sof[0] = True
    eol = np.array(data.draw(st.lists(st.booleans(), min_size=n, max_size=n)))
    blob, words = fio.pack_stream(valid, values, sof, eol, word)
    assert len(blob) == n * fio.stream_word_bytes(word)
    back = fio.read_stream_bin(blob, word)
    assert np.array_equal(back["valid"], valid) and np.array_equal(back["data"], values)
    assert np.array_equal(back["sof"], sof) and np.array_equal(back["eol"], eol)
    assert np.array_equal(fio.read_stream_bin_valid(blob, word), valid)
    assert fio.read_mem(fio.write_stream_mem(words, word)) == words.tolist()


def test_readers_reject_garbage():
    with pytest.raises(ValueError, match="not a hexadecimal"):
        fio.read_mem(b"00\nqq\n")
    with pytest.raises(ValueError, match="unloaded"):  # a plain list cannot hold a gap
        fio.read_mem(b"@10\n00\n")
    with pytest.raises(ValueError, match="@address"):
        fio.read_mem_words(b"@zz\n00\n")
    assert fio.read_mem(b"@1 01 @0 00") == [0, 1]
    assert fio.read_mem(b"// c\n0a /* b */ xx\n\n1_f\n") == [10, None, 31]
    with pytest.raises(ValueError, match="whole number"):
        fio.read_stream_bin(b"\x00\x01\x02", 8)
    with pytest.raises(ValueError, match="do not fit"):
        fio.write_mem(np.array([16]), 4)


def _rewrite_mem(src: Path, dst: Path, words: dict[int, str]) -> None:
    lines = src.read_text().splitlines()
    for k, w in words.items():
        lines[1 + k] = w
    dst.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("kind", ["wider", "narrower", "sign_flipped", "csv_wider"])
def test_diff_never_masks_bits_outside_the_format(tmp_path, vec, kind, capsys):
    """Issue 19 item 3: a wider, narrower or sign-flipped word is a mismatch, exit 1."""
    tap = "e1.col_s2"  # s21.11
    exp = read_tap(vec, tap)
    k = int(np.flatnonzero(exp < 0)[0])  # a negative sample: its sign bit is set
    code = int(exp[k]) & ((1 << 21) - 1)
    dump = tmp_path / f"{tap}.mem"
    if kind == "wider":  # high bits the 21-bit format does not have
        _rewrite_mem(vec / f"{tap}.mem", dump, {k: f"{code | 0xFF000000:08x}"})
    elif kind == "narrower":  # the RTL kept 20 bits: the sign bit is lost
        _rewrite_mem(vec / f"{tap}.mem", dump, {k: f"{code & 0xFFFFF:06x}"})
    elif kind == "sign_flipped":
        _rewrite_mem(vec / f"{tap}.mem", dump, {k: f"{code ^ (1 << 20):06x}"})
    else:
        dump = tmp_path / f"{tap}.csv"
        csv = (vec / f"{tap}.csv").read_text().splitlines()
        csv[1 + k] = ",".join([*csv[1 + k].split(",")[:-1], str(code | (1 << 25))])
        dump.write_text("\n".join(csv) + "\n")
    r = diff_dump(vec, dump)
    assert r.mismatches == 1 and r.first["index"] == k and not r.ok
    assert main(["vectors", "diff", str(vec), str(dump)]) == 1
    assert "1 mismatches" in capsys.readouterr().out


def test_diff_accepts_consistent_sign_extension(tmp_path, vec):
    tap = "e1.col_s2"
    exp = read_tap(vec, tap)
    for width in (32, 64):  # sign extension to a 32- and a 64-bit register
        wide = {k: f"{int(v) & ((1 << width) - 1):0{width // 4}x}" for k, v in enumerate(exp)}
        _rewrite_mem(vec / f"{tap}.mem", tmp_path / f"{tap}.mem", wide)
        assert diff_dump(vec, tmp_path / f"{tap}.mem").ok
    assert dump_code(0xFF000188, 21, True, 32) is None
    assert dump_code(-1, 21, False) is None
    assert dump_code(-1, 21, True) == (1 << 21) - 1


# -- issue 40: the verdict cannot be fooled ------------------------------------------------
def test_issue40_partial_sign_extension_is_a_mismatch(tmp_path, vec, capsys):
    """The issue's false pass: ``v | 0x0FE00000`` for a negative s21.11 ``v`` (bits 21-27
    ones, 28-31 zeros) is no sign extension; nor is a negative code zero-extended."""
    tap = "e1.col_s2"
    exp = read_tap(vec, tap)
    neg = np.flatnonzero(exp < 0)
    code = {int(k): int(exp[k]) & ((1 << 21) - 1) for k in neg[:2]}
    k0, k1 = code
    dump = tmp_path / f"{tap}.mem"
    wide = {k: f"{int(v) & 0xFFFFFFFF:08x}" for k, v in enumerate(exp)}
    wide[k0] = f"{code[k0] | 0x0FE00000:08x}"
    wide[k1] = f"{code[k1]:08x}"  # zero-extended to 32 bits: the sign is lost
    _rewrite_mem(vec / f"{tap}.mem", dump, wide)
    r = diff_dump(vec, dump)
    assert r.mismatches == 2 and r.first["index"] == k0
    assert r.first["got_hex"] == f"{code[k0] | 0x0FE00000:08x}" and r.first["outside_format"]
    assert main(["vectors", "diff", str(vec), str(dump)]) == 1
    assert "2 mismatches" in capsys.readouterr().out


def _writememh(words: dict[int, int], digits: int, order: list[int]) -> str:
    """``$writememh``-style text: an ``@address`` before each run of addresses."""
    lines, last = ["// dumped by the bench"], None
    for a in order:
        if last is None or a != last + 1:
            lines.append(f"@{a:x}")
        lines.append(f"{words[a]:0{digits}x}")
        last = a
    return "\n".join(lines) + "\n"


def test_issue40_readmemh_address_directives_are_read(tmp_path, vec):
    """``@address`` moves the next word; runs in any order read as one dump; a gap
    (an address no word is loaded at) is a missing sample, a mismatch each."""
    tap = "e1.col_s2"
    codes = fio.read_mem((vec / f"{tap}.mem").read_bytes())
    words = dict(enumerate(codes))
    n = len(codes)
    half = n // 2
    order = list(range(half, n)) + list(range(half))  # second half first
    dump = tmp_path / f"{tap}.mem"
    dump.write_text(_writememh(words, 6, order))
    r = diff_dump(vec, dump)
    assert r.ok and r.got_count == n
    gapped = [a for a in range(n) if a not in (5, 6, 7)]
    dump.write_text(_writememh(words, 6, gapped))
    r = diff_dump(vec, dump)
    assert r.mismatches == 3 and r.first["index"] == 5 and r.first["got_hex"] == "not loaded"
    dump.write_text(_writememh({**words, n + 40: 0}, 6, [*range(n), n + 40]))
    r = diff_dump(vec, dump)
    assert r.mismatches == 1 and r.got_count == n + 1


def _reference_code(bits: str, word: int, signed: bool) -> int | None:
    """Written from the rule, on the dump word's bit string (MSB first), apart from the
    reader: the bits above the tap's width must be all zero (the tap's own hex width may
    pad a negative code with zeros) or, for a signed tap, all copies of the sign bit."""
    if len(bits) < word:
        bits = "0" * (word - len(bits)) + bits
    high, code = bits[: len(bits) - word], bits[len(bits) - word :]
    own_width = len(bits) <= -(-word // 4) * 4
    if all(b == "0" for b in high) and (own_width or not signed or code[0] == "0"):
        return int(code, 2)
    if signed and all(b == code[0] for b in high):
        return int(code, 2)
    return None


@st.composite
def _dump_words(draw):
    word = draw(st.integers(1, 48))
    signed = draw(st.booleans())
    digits = draw(st.integers(1, 18))
    width = 4 * digits
    code = draw(st.integers(0, (1 << min(word, width)) - 1))
    pattern = draw(st.sampled_from(["zeros", "ones", "any"]))
    above = max(width - word, 0)
    if pattern == "any":
        high = draw(st.integers(0, (1 << above) - 1))
    else:
        high = 0 if pattern == "zeros" else (1 << above) - 1
    return word, signed, digits, (high << word) | code if above else code


@settings(max_examples=400, deadline=None)
@given(_dump_words())
def test_issue40_dump_word_verdict_matches_an_independent_reference(case):
    word, signed, digits, value = case
    token = f"{value:0{digits}x}"
    (got, bits), *_ = fio.read_mem_words(f"// t\n{token}\n").values()
    assert (got, bits) == (value, 4 * digits)
    want = _reference_code(format(value, f"0{4 * digits}b"), word, signed)
    assert dump_code(got, word, signed, bits) == want


@settings(max_examples=25, deadline=None)
@given(st.sampled_from([24, 32, 48, 64]), st.sampled_from(["sign", "zero", "partial"]), st.data())
def test_issue40_diff_verdict_over_dump_widths(vec, width, high, data):
    """A whole dump of one width: sign extension passes; zero extension passes only for
    non-negative values (or at the tap's own 24-bit width); a partial run of ones never."""
    import tempfile

    tap = "e1.col_s2"  # s21.11
    exp = read_tap(vec, tap)
    k = data.draw(st.sampled_from(np.flatnonzero(exp < 0).tolist()))
    code = int(exp[k]) & ((1 << 21) - 1)
    ones = (1 << width) - (1 << 21)
    word = {"sign": code | ones, "zero": code}.get(high)
    if word is None:
        cut = data.draw(st.integers(22, width - 1)) if width > 24 else 23
        word = code | (ones & ((1 << cut) - 1))
    words = {i: int(v) & ((1 << width) - 1) for i, v in enumerate(exp)}
    words[k] = word
    with tempfile.TemporaryDirectory() as tmp:
        dump = Path(tmp) / f"{tap}.mem"
        dump.write_text(_writememh(words, width // 4, list(range(exp.size))))
        r = diff_dump(vec, dump)
    should_pass = high == "sign" or (high == "zero" and width == 24)
    assert r.ok == should_pass, (width, high, f"{word:x}")
    if not should_pass:
        assert r.mismatches == 1 and r.first["index"] == k and r.first["outside_format"]


def _malformed(tmp_path: Path, vec: Path, change) -> Path:
    d = tmp_path / "bad"
    shutil.copytree(vec, d)
    man = json.loads((d / "manifest.json").read_text())
    change(man)
    (d / "manifest.json").write_text(json.dumps(man))
    return d


def _drop(key):
    return lambda man: man.pop(key)


def _set(key, value):
    return lambda man: man.__setitem__(key, value)


def _entry_drop(key):
    return lambda man: man["files"][3].pop(key)


@pytest.mark.parametrize(
    ("change", "culprit"),
    [
        (_drop("files"), "'files'"),
        (_set("files", {"a": 1}), "'files'"),
        (_set("files", [1, 2]), "files[0]"),
        (_entry_drop("sha256"), "files[3] lacks a valid 'sha256'"),
        (_entry_drop("size"), "files[3] lacks a valid 'size'"),
        (_set("shape", "16x24"), "'shape'"),
        (lambda man: man["files"][0].__setitem__("path", "../../etc/passwd"), "plain file"),
    ],
)
def test_malformed_manifest_is_one_line_error(tmp_path, vec, capsys, change, culprit):
    """Issue 19 item 5: no KeyError/TypeError traceback from a malformed manifest."""
    d = _malformed(tmp_path, vec, change)
    for argv in (["check", str(d)], ["diff", str(d), str(vec / "e1.col_s2.mem")]):
        assert main(["vectors", *argv]) == 2
        err = capsys.readouterr().err
        assert err.startswith("rangefx: error: ") and err.count("\n") == 1
        assert culprit in err and "manifest.json" in err


def test_diff_of_a_missing_dump_names_the_file(tmp_path, vec, capsys):
    assert main(["vectors", "diff", str(vec), str(tmp_path / "nope.mem")]) == 2
    err = capsys.readouterr().err
    assert "cannot read dump" in err and "nope.mem" in err and "no tap" not in err


# -- issue 40: provenance checked -----------------------------------------------------------
@pytest.mark.parametrize(
    ("field", "value", "says"),
    [("scene", "moon", "unknown scene name 'moon'"),
     ("crop", [0, 10**9, 0, 10**9], "cannot be reproduced: --crop 0 1000000000"),
     ("seed", 1, "does not reproduce the stored vectors"),
     ("crop", [241, 257, 100, 124], "first e1.pix_in.")],
)  # fmt: skip
def test_issue40_check_reproduces_the_inputs_from_the_manifests_case(
    tmp_path, vec, capsys, field, value, says
):
    """An edited scene, crop or seed passes the re-run (it reads the stored inputs) but
    not the provenance check, which renders the case the manifest names."""
    assert main(["vectors", "check", str(vec)]) == 0
    assert "inputs reproduced from the manifest's case, model re-run identical: OK" in (
        capsys.readouterr().out
    )
    d = _malformed(tmp_path, vec, lambda m: m["case"].__setitem__(field, value))
    assert main(["vectors", "check", str(d)]) == 1
    out = capsys.readouterr().out
    assert "problem: manifest case (" in out and says in out, out
