"""``rangefx config export``: the word-length config as an HLS header and a VHDL package.

The header is compiled with g++ against the real Vitis HLS ``ap_fixed.h`` (shipped in
the hls4ml wheel, ``hls4ml/templates/vivado/ap_types/``) when both are here: every
signal's type quantises a set of doubles exactly as the model's format does."""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pytest
from ap_types import ap_types_dir, skip_or_fail

from rangefx.rtl_model.fixedpoint import FixedFormat, Overflow, Quant
from rangefx.rtl_model.registry import PIPELINES
from rangefx.tools.cli import main
from rangefx.vectors.export import hls_header, vhdl_inexact, vhdl_package

NAMES = list(PIPELINES)


@pytest.mark.parametrize("name", NAMES)
def test_header_has_one_typedef_per_signal(name):
    cfg = PIPELINES[name].default_config()
    text = hls_header(cfg)
    typedefs = [line for line in text.splitlines() if line.startswith("typedef ")]
    assert len(typedefs) == len(cfg.signals())
    for line, sig in zip(typedefs, cfg.signals(), strict=True):
        f = cfg.fmt(sig)
        assert line.startswith(f"typedef {f.describe()} {sig}_t;")
        assert ("ap_fixed<" if f.signed else "ap_ufixed<") in line


@pytest.mark.parametrize("name", NAMES)
def test_vhdl_package_ranges_and_styles(name):
    cfg = PIPELINES[name].default_config()
    text = vhdl_package(cfg)
    for sig in cfg.signals():
        f = cfg.fmt(sig)
        kind = "sfixed" if f.signed else "ufixed"
        assert f"subtype {sig}_t is {kind}({f.int_bits - 1} downto {-f.frac});" in text
    assert text.count("NOT EXACT") == len(vhdl_inexact(cfg))


def test_vhdl_marks_every_mode_fixed_pkg_lacks():
    cfg = PIPELINES["p1"].default_config()
    exact = cfg.with_formats(bias_in=FixedFormat(False, 10, 1, Quant.RND_CONV, Overflow.WRAP))
    odd = cfg.with_formats(bias_in=FixedFormat(False, 10, 1, Quant.TRN_ZERO, Overflow.SAT_SYM))
    assert "bias_in" not in vhdl_inexact(exact)
    assert vhdl_inexact(odd)["bias_in"] == "TRN_ZERO, SAT_SYM"
    assert "constant bias_in_round : fixed_round_style_type := fixed_round;" in vhdl_package(exact)


def test_cli_export(tmp_path, capsys):
    h, v = tmp_path / "t.h", tmp_path / "t.vhd"
    argv = ["config", "export", "--pipeline", "p2", "--hls", str(h), "--vhdl", str(v), "--json"]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["written"] == [str(h), str(v)] and out["pipeline"] == "p2"
    assert h.read_text() == hls_header(PIPELINES["p2"].default_config())
    assert main(["config", "export", "--pipeline", "p2"]) == 2
    assert "needs --hls" in capsys.readouterr().err


@pytest.mark.parametrize("name", NAMES)
def test_header_compiles_against_ap_fixed_and_quantises_like_the_model(name, tmp_path):
    if shutil.which("g++") is None:
        skip_or_fail("g++ is not installed")
    inc = ap_types_dir()
    if inc is None:
        skip_or_fail("the ap_types headers are not found ($RANGEFX_AP_TYPES or hls4ml)")
    cfg = PIPELINES[name].default_config()
    (tmp_path / "types.h").write_text(hls_header(cfg))
    rng = np.random.default_rng(5)
    xs = [0.3, -1.7, 2.5, -2.5, 1e9, -1e9, *rng.normal(0, 300, 40).tolist()]
    body = "\n".join(
        f'  for (double x : xs) printf("%.17g\\n", {sig}_t(x).to_double());'
        for sig in cfg.signals()
    )
    src = (
        '#include "types.h"\n#include <cstdio>\nint main() {\n'
        f"  const double xs[] = {{{', '.join(repr(x) for x in xs)}}};\n{body}\n}}\n"
    )
    (tmp_path / "t.cpp").write_text(src)
    exe = tmp_path / "t"
    subprocess.run(["g++", "-std=c++14", f"-I{inc}", "-o", str(exe), str(tmp_path / "t.cpp")],
                   check=True, capture_output=True)  # fmt: skip
    got = [float(v) for v in subprocess.run([str(exe)], check=True, capture_output=True,
                                            text=True).stdout.split()]  # fmt: skip
    want = [float(cfg.fmt(s).to_float(cfg.fmt(s).from_float(x))) for s in cfg.signals() for x in xs]
    assert got == want
