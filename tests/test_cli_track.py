"""End-to-end tests of ``rangefx track`` (G1) and ``rangefx degrees`` (G3 degree 1..4)."""

from __future__ import annotations

import csv
import json

import pytest

from rangefx.tools.cli import main


@pytest.fixture(scope="module")
def track_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("track") / "out"
    return out, ["track", "--out", str(out), "--duration", "3", "--json"]


def test_track_writes_figures_csv_and_summary(track_run, capsys) -> None:
    out, argv = track_run
    assert main(argv) == 0
    printed = json.loads(capsys.readouterr().out)
    names = {p.name for p in out.iterdir()}
    assert {
        "fig3_4_scene.png",
        "fig5_raw.png",
        "fig6_lowpass_tau0.1.png",
        "fig7_lowpass_tau0.4.png",
        "tracking.csv",
        "summary.json",
        ".rangefx-output",
    } <= names
    for png in out.glob("*.png"):
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = json.loads((out / "summary.json").read_text())
    assert summary == printed
    rows = list(csv.DictReader((out / "tracking.csv").open()))
    assert len(rows) == summary["steps"]
    assert set(rows[0]) >= {"t", "truth", "range_raw", "range_lowpass_tau0.1"}
    bound = summary["sampling_bound"]
    assert summary["h"] == pytest.approx(0.1 * bound["absolute"])
    assert bound["absolute"] <= bound["printed"]
    fast = summary["filtered"]["0.1"]
    assert abs(fast["final_rel_error"]) < 0.1
    assert summary["final_truth"] > 0 and summary["final_raw"] > 0


def test_track_text_output(tmp_path, capsys) -> None:
    assert main(["track", "--out", str(tmp_path / "o"), "--duration", "1", "--tau", "0.05"]) == 0
    text = capsys.readouterr().out
    assert "low-pass tau 0.05 s" in text and "eq-9 bound" in text
    assert (tmp_path / "o" / "fig6_lowpass_tau0.05.png").is_file()


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--tau", "0"], "tau"),
        (["--duration", "-1"], "--duration"),
        (["--fraction", "0"], "fraction"),
        (["--threshold", "-1"], "threshold"),
        (["--xp", "0", "--zp", "5000"], "does not see the scene"),
    ],
)
def test_track_bad_input_is_one_error_line(tmp_path, capsys, extra, message) -> None:
    out = tmp_path / "o"
    assert main(["track", "--out", str(out), *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rangefx: error:") and message in err[0]
    assert not out.exists()


@pytest.fixture(scope="module")
def degrees_json(tmp_path_factory):
    out = tmp_path_factory.mktemp("deg") / "out"
    argv = ["degrees", "--size", "128", "128", "--json", "--out", str(out)]
    return argv, out


def test_degrees_json_table(degrees_json, capsys) -> None:
    argv, out = degrees_json
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["scene"]["name"] == "lab" and summary["variant"] == "consistent"
    assert set(summary["settings"]) == {"order_equals_degree", "order4"}
    for setting in summary["settings"].values():
        assert list(setting) == ["degree1", "degree2", "degree3", "degree4"]
        for v in setting.values():
            assert v["table"][0]["object"] == "Left pencil"
            assert 0 <= v["valid_fraction"] < 1
            assert {"median_rel_error", "common_median_rel_error", "common_pixels"} <= set(v)
    order4 = summary["settings"]["order4"]
    assert {v["estimator_order"] for v in order4.values()} == {4}
    assert (out / "table.md").read_text().count("| Object |") == 8
    assert json.loads((out / "summary.json").read_text()) == summary


def test_degrees_text_with_fixed_order(capsys) -> None:
    assert main(["degrees", "--size", "96", "96", "--order", "2", "--variant", "paper"]) == 0
    text = capsys.readouterr().out
    assert "degree 1 (order 2)" in text and "degree 2 (order 2)" in text
    assert "degree 3" not in text
    assert "median relative error" in text


def test_degrees_rejects_bad_arguments(capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["degrees", "--scene", "moon"])
    assert exc.value.code == 2
    with pytest.raises(SystemExit):
        main(["degrees", "--size", "4", "4"])
    assert "image size" in capsys.readouterr().err
