"""Known-answer tests of the report tables and figures, and of the atomic output writers."""

from __future__ import annotations

import csv
import io
import math
import os
from dataclasses import dataclass
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

from rangefx.tools.errors import UserError
from rangefx.tools.report import (
    ROW_KEYS,
    format_side_by_side,
    object_table,
    overall_metrics,
    range_points_3d,
    range_to_gray,
    save_pair_png,
    save_points_3d_png,
    save_range_map_png,
    table_csv,
    table_markdown,
)
from rangefx.tools.report.outdir import (
    MARKER_NAME,
    atomic_output_dir,
    atomic_write_bytes,
    atomic_write_text,
)

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
INF = math.inf
RMAX = 64.0


@dataclass(frozen=True)
class Obj:
    name: str
    label: int
    nominal_range: float


OBJECTS = (
    Obj("Left Pencil", 1, 19.0),
    Obj("Soda can", 2, 40.0),
    Obj("Absent", 7, 50.0),
)


def _scene() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """4x6 scene whose table entries are known exactly (dyadic values throughout).

    Label 1: valid ranges 10, 12, 14, 16 (truth 16) and 18 (truth unknown); invalid
    pixels with truth 24, 24, 24, 24 and inf. Label 2: three invalid pixels, truth 40.
    Label 0 (background): valid ranges 32, 34, 36, 40, 44, 48, 24 (truth 32), one valid
    range 50 with unknown truth, three invalid pixels.
    """
    labels = np.array(
        [
            [1, 1, 1, 1, 1, 1],
            [1, 1, 1, 1, 2, 2],
            [2, 0, 0, 0, 0, 0],
            [0, 0, 0, 0, 0, 0],
        ]
    )
    rng = np.array(
        [
            [10, 12, 14, 16, RMAX, RMAX],
            [RMAX, RMAX, 18, RMAX, RMAX, RMAX],
            [RMAX, 32, 34, 36, 40, 44],
            [48, 24, 50, RMAX, RMAX, RMAX],
        ]
    )
    valid = np.array(
        [
            [1, 1, 1, 1, 0, 0],
            [0, 0, 1, 0, 0, 0],
            [0, 1, 1, 1, 1, 1],
            [1, 1, 1, 0, 0, 0],
        ],
        dtype=bool,
    )
    truth = np.array(
        [
            [16, 16, 16, 16, 24, 24],
            [24, 24, INF, INF, 40, 40],
            [40, 32, 32, 32, 32, 32],
            [32, 32, INF, 32, 32, 32],
        ]
    )
    return rng, valid, labels, truth


def _same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b


# --------------------------------------------------------------------------- object_table


def test_object_table_known_answer() -> None:
    rng, valid, labels, truth = _scene()
    rows = object_table(rng, valid, labels, OBJECTS, truth)
    nan = math.nan
    expected = [
        {
            "object": "Left Pencil",
            "actual": 20.0,  # median of the finite truth over all 10 label-1 pixels
            "nominal": 19.0,
            "estimated_median": 14.0,
            "std": math.sqrt(8.0),
            "n_points": 5,
            "median_rel_error_vs_truth": 0.1875,  # of 6/16, 4/16, 2/16, 0 (unknown truth out)
            "rel_error_of_median": -0.3,
        },
        {
            "object": "Soda can",
            "actual": 40.0,
            "nominal": 40.0,
            "estimated_median": nan,
            "std": nan,
            "n_points": 0,
            "median_rel_error_vs_truth": nan,
            "rel_error_of_median": nan,
        },
        {
            "object": "Absent",
            "actual": nan,
            "nominal": 50.0,
            "estimated_median": nan,
            "std": nan,
            "n_points": 0,
            "median_rel_error_vs_truth": nan,
            "rel_error_of_median": nan,
        },
    ]
    assert len(rows) == len(expected)
    for row, exp in zip(rows, expected, strict=True):
        assert tuple(row) == ROW_KEYS
        assert row["object"] == exp["object"]
        assert type(row["n_points"]) is int
        assert row["n_points"] == exp["n_points"]
        for key in ROW_KEYS[1:]:
            if key != "n_points":
                assert type(row[key]) is float, key
                assert _same(row[key], exp[key]), (exp["object"], key, row[key], exp[key])


def test_object_table_ignores_range_at_invalid_pixels() -> None:
    rng, valid, labels, truth = _scene()
    rng2 = np.where(valid, rng, np.nan)
    assert object_table(rng2, valid, labels, OBJECTS[:1], truth)[0]["estimated_median"] == 14.0


def test_object_table_shape_mismatch_names_arrays() -> None:
    rng, valid, labels, truth = _scene()
    with pytest.raises(ValueError, match=r"range_map \(4, 6\).*labels \(4, 5\)"):
        object_table(rng, valid, labels[:, :5], OBJECTS, truth)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ("valid_int", r"valid must be a boolean array, not dtype int"),
        ("nan_range", r"range_map must be finite at valid pixels.*row 0, column 0: nan"),
        ("labels_float", r"labels must be an integer array"),
        ("truth_negative", r"depth_truth must be positive where finite.*row 3, column 5"),
        ("range_3d", r"range_map must be a 2-D array, not 3-D"),
    ],
)
def test_object_table_rejects_bad_input(change: str, message: str) -> None:
    rng, valid, labels, truth = _scene()
    if change == "valid_int":
        valid = valid.astype(int)
    elif change == "nan_range":
        rng[0, 0] = np.nan
    elif change == "labels_float":
        labels = labels.astype(float)
    elif change == "truth_negative":
        truth[3, 5] = -1.0
    elif change == "range_3d":
        rng = rng[None]
    with pytest.raises(ValueError, match=message):
        object_table(rng, valid, labels, OBJECTS, truth)


# --------------------------------------------------------------------------- overall_metrics


def test_overall_metrics_known_answer() -> None:
    rng, valid, _, truth = _scene()
    # Scored errors, sorted: 0, 0, 1/16, 1/8, 1/8, 1/4, 1/4, 1/4, 3/8, 3/8, 1/2 (11 values).
    assert overall_metrics(rng, valid, truth) == {
        "valid_fraction": 13 / 24,
        "n_valid": 13,
        "n_scored": 11,
        "median_rel_error": 0.25,
        "p90_rel_error": 0.375,
        "within_5pct": 2 / 11,
        "within_10pct": 3 / 11,
    }


def test_overall_metrics_thresholds_are_inclusive() -> None:
    rng = np.array([[21.0, 22.0, 23.0]])  # relative errors 0.05, 0.10, 0.15 against 20
    m = overall_metrics(rng, np.ones((1, 3), dtype=bool), np.full((1, 3), 20.0))
    assert (m["within_5pct"], m["within_10pct"]) == (1 / 3, 2 / 3)


def test_overall_metrics_without_scored_pixels_is_nan() -> None:
    rng, valid, _, truth = _scene()
    m = overall_metrics(rng, np.zeros_like(valid), truth)
    assert m["n_valid"] == 0
    assert m["valid_fraction"] == 0.0
    for key in ("median_rel_error", "p90_rel_error", "within_5pct", "within_10pct"):
        assert math.isnan(m[key]), key


def test_overall_metrics_shape_mismatch() -> None:
    rng, valid, _, truth = _scene()
    with pytest.raises(ValueError, match=r"valid \(4, 5\)"):
        overall_metrics(rng, valid[:, :5], truth)


# --------------------------------------------------------------------------- tables

TABLE_ROWS = [
    {
        "object": "Left Pencil",
        "actual": 30.0,
        "nominal": 30.0,
        "estimated_median": 26.987,
        "std": 7.4812,
        "n_points": 975,
        "median_rel_error_vs_truth": 0.125,
        "rel_error_of_median": (26.987 - 30.0) / 30.0,
    },
    {
        "object": "Tape | wall",
        "actual": 60.0,
        "nominal": 60.0,
        "estimated_median": 61.5,
        "std": 2.0,
        "n_points": 12,
        "median_rel_error_vs_truth": 0.03125,
        "rel_error_of_median": 0.025,
    },
    {
        "object": "Soda can",
        "actual": 45.0,
        "nominal": 45.0,
        "estimated_median": math.nan,
        "std": math.nan,
        "n_points": 0,
        "median_rel_error_vs_truth": math.nan,
        "rel_error_of_median": math.nan,
    },
]


def test_table_markdown_matches_report_format() -> None:
    assert table_markdown(TABLE_ROWS, "in", "Lab scene, g3_paper") == (
        "### Lab scene, g3_paper\n"
        "\n"
        "| Object | Actual range (in) | Estimated range (std) | No. of points | Error |\n"
        "|:---|---:|---:|---:|---:|\n"
        "| Left Pencil | 30.00 | 26.99 (7.48) | 975 | -10.0% |\n"
        "| Tape \\| wall | 60.00 | 61.50 (2.00) | 12 | +2.5% |\n"
        "| Soda can | 45.00 | n/a | 0 | n/a |\n"
    )


def test_table_markdown_without_title_starts_with_header() -> None:
    assert table_markdown(TABLE_ROWS[:1], "ft").splitlines()[0].startswith("| Object |")


def test_table_markdown_missing_key() -> None:
    with pytest.raises(ValueError, match=r"row 0 \('x'\) lacks key\(s\) \['std'"):
        table_markdown([{"object": "x", "actual": 1.0, "estimated_median": 1.0}], "in")


def test_table_csv_round_trips_raw_values() -> None:
    text = table_csv(TABLE_ROWS)
    assert text.splitlines()[0] == ",".join(ROW_KEYS)
    assert text.splitlines()[2] == "Tape | wall,60.0,60.0,61.5,2.0,12,0.03125,0.025"
    back = list(csv.DictReader(io.StringIO(text)))
    assert len(back) == len(TABLE_ROWS)
    for got, row in zip(back, TABLE_ROWS, strict=True):
        assert got["object"] == row["object"]
        assert int(got["n_points"]) == row["n_points"]
        for key in ROW_KEYS[1:]:
            assert _same(float(got[key]), float(row[key])), key


def test_format_side_by_side_layout() -> None:
    text = format_side_by_side(
        {"g3_paper": TABLE_ROWS[:2], "g3_consistent": [TABLE_ROWS[0], TABLE_ROWS[2]]}, "in"
    )
    assert text == (
        "Object      Actual (in) | g3_paper          | g3_consistent\n"
        "                        | est. (std)      n | est. (std)      n\n"
        "Left Pencil       30.00 | 26.99 (7.48)  975 | 26.99 (7.48)  975\n"
        "Tape | wall       60.00 | 61.50 (2.00)   12 | -               -\n"
        "Soda can          45.00 | -               - | n/a             0\n"
    )


# --------------------------------------------------------------------------- figures


def test_range_to_gray_known_answer() -> None:
    rng = np.array([[0.0, 16.0, 32.0], [8.0, 40.0, np.nan]])
    valid = np.array([[True, True, True], [False, True, False]])
    gray = range_to_gray(rng, valid, 32.0)
    np.testing.assert_array_equal(gray, [[1.0, 0.5, 0.0], [0.0, 0.0, 0.0]])


def test_range_to_gray_rejects_bad_range_max() -> None:
    with pytest.raises(ValueError, match=r"range_max must be a positive finite number, not 0"):
        range_to_gray(np.ones((2, 2)), np.ones((2, 2), dtype=bool), 0)


def test_range_points_3d_known_answer_and_subsampling() -> None:
    rng = np.array([[10.0, 20.0], [40.0, 80.0]])
    valid = np.array([[True, False], [True, True]])
    xp = np.array([-1.0, 1.0])
    yp = np.array([[-2.0], [2.0]])
    pts = range_points_3d(rng, valid, xp, yp, 4.0)
    np.testing.assert_array_equal(
        pts, [[-2.5, 10.0, 5.0], [-10.0, 40.0, -20.0], [20.0, 80.0, -40.0]]
    )
    big = np.arange(1.0, 101.0).reshape(10, 10)
    sub = range_points_3d(big, np.ones_like(big, dtype=bool), 0.0, 0.0, 1.0, max_points=4)
    np.testing.assert_array_equal(sub[:, 1], [1.0, 34.0, 67.0, 100.0])


def test_range_points_3d_bad_coordinates() -> None:
    with pytest.raises(ValueError, match=r"xp of shape \(3,\) does not broadcast"):
        range_points_3d(np.ones((2, 2)), np.ones((2, 2), dtype=bool), np.ones(3), 0.0, 1.0)


def _assert_single_png(directory: Path, name: str) -> None:
    assert sorted(os.listdir(directory)) == [name]
    data = (directory / name).read_bytes()
    assert data[:8] == PNG_SIGNATURE
    image = matplotlib.image.imread(directory / name)
    assert image.ndim == 3
    assert image.shape[0] > 100
    assert image.shape[1] > 100


def test_png_writers_produce_valid_png_and_no_leftovers(tmp_path: Path) -> None:
    import matplotlib.pyplot as plt

    figs_before = plt.get_fignums()
    rng = np.linspace(5.0, 70.0, 24 * 32).reshape(24, 32)
    valid = rng < 60.0
    cases = {
        "range.png": lambda p: save_range_map_png(p, rng, valid, 64.0, "range", unit="in"),
        "pair.png": lambda p: save_pair_png(p, rng, rng[:, ::-1], ("frame 1", "frame 2")),
        "points.png": lambda p: save_points_3d_png(
            p, rng, valid, np.arange(32) - 15.5, (np.arange(24) - 11.5)[:, None], 30.0, "pts", 50
        ),
        "empty_points.png": lambda p: save_points_3d_png(
            p, rng, np.zeros_like(valid), 0.0, 0.0, 30.0, "none"
        ),
    }
    for name, write in cases.items():
        directory = tmp_path / name.removesuffix(".png")
        directory.mkdir()
        write(directory / name)
        _assert_single_png(directory, name)
        write(directory / name)  # overwriting is atomic too and leaves nothing behind
        _assert_single_png(directory, name)
    assert plt.get_fignums() == figs_before


def test_png_writer_failure_keeps_old_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from matplotlib.figure import Figure

    target = tmp_path / "range.png"
    target.write_bytes(b"old")

    def broken(*args: object, **kwargs: object) -> None:
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(Figure, "savefig", broken)
    with pytest.raises(RuntimeError, match="disk on fire"):
        save_range_map_png(target, np.ones((4, 4)), np.ones((4, 4), dtype=bool), 2.0, "t")
    assert target.read_bytes() == b"old"
    assert os.listdir(tmp_path) == ["range.png"]


def test_pair_png_rejects_mismatched_sizes(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"image1 \(4, 4\), image2 \(4, 5\)"):
        save_pair_png(tmp_path / "p.png", np.zeros((4, 4)), np.zeros((4, 5)), ("a", "b"))
    assert os.listdir(tmp_path) == []


# --------------------------------------------------------------------------- atomic writes


def test_atomic_write_text_and_bytes(tmp_path: Path) -> None:
    target = tmp_path / "summary.json"
    atomic_write_text(target, "{}\n")
    assert target.read_text() == "{}\n"
    atomic_write_bytes(target, b"new")
    assert target.read_bytes() == b"new"
    assert os.listdir(tmp_path) == ["summary.json"]


def test_atomic_write_failure_leaves_old_file_and_no_temp(tmp_path: Path) -> None:
    target = tmp_path / "a.txt"
    target.write_text("old")
    with pytest.raises(TypeError):
        atomic_write_bytes(target, "not bytes")  # type: ignore[arg-type]
    assert target.read_text() == "old"
    assert os.listdir(tmp_path) == ["a.txt"]


def test_atomic_output_dir_creates_marked_directory(tmp_path: Path) -> None:
    out = tmp_path / "sub" / "rangefx-out"
    with atomic_output_dir(out) as tmp:
        assert tmp.parent == out.parent
        assert tmp.name.startswith(f".rangefx-out.tmp-{os.getpid()}-")
        assert list(tmp.iterdir()) == []
        assert not out.exists()
        (tmp / "table.md").write_text("t")
    assert sorted(p.name for p in out.iterdir()) == [MARKER_NAME, "table.md"]
    assert os.listdir(out.parent) == ["rangefx-out"]


def test_atomic_output_dir_replaces_previous_output(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with atomic_output_dir(out) as tmp:
        (tmp / "old.txt").write_text("old")
    with atomic_output_dir(out) as tmp:
        (tmp / "new.txt").write_text("new")
    assert sorted(p.name for p in out.iterdir()) == [MARKER_NAME, "new.txt"]
    assert os.listdir(tmp_path) == ["out"]


def test_atomic_output_dir_exception_keeps_previous_output(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with atomic_output_dir(out) as tmp:
        (tmp / "old.txt").write_text("old")
    with pytest.raises(KeyError, match="boom"), atomic_output_dir(out) as tmp:
        (tmp / "half.txt").write_text("half")
        raise KeyError("boom")
    assert sorted(p.name for p in out.iterdir()) == [MARKER_NAME, "old.txt"]
    assert (out / "old.txt").read_text() == "old"
    assert os.listdir(tmp_path) == ["out"]


def test_atomic_output_dir_exception_on_fresh_path_leaves_nothing(tmp_path: Path) -> None:
    with pytest.raises(RuntimeError), atomic_output_dir(tmp_path / "out"):
        raise RuntimeError
    assert os.listdir(tmp_path) == []


def test_atomic_output_dir_refuses_foreign_directory(tmp_path: Path) -> None:
    out = tmp_path / "thesis"
    out.mkdir()
    (out / "chapter1.tex").write_text("precious")
    ran = False
    message = r"'.*thesis' is not empty and was not written by rangefx"
    with pytest.raises(UserError, match=message), atomic_output_dir(out):
        ran = True
    assert not ran
    assert (out / "chapter1.tex").read_text() == "precious"
    assert os.listdir(tmp_path) == ["thesis"]


def test_atomic_output_dir_refuses_foreign_content_appearing_meanwhile(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with pytest.raises(UserError, match="not written by rangefx"), atomic_output_dir(out) as tmp:
        (tmp / "result.txt").write_text("r")
        out.mkdir()
        (out / "user.txt").write_text("mine")
    assert os.listdir(out) == ["user.txt"]
    assert os.listdir(tmp_path) == ["out"]


def test_atomic_output_dir_accepts_empty_directory(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    with atomic_output_dir(out) as tmp:
        (tmp / "a.txt").write_text("a")
    assert sorted(p.name for p in out.iterdir()) == [MARKER_NAME, "a.txt"]


def test_atomic_output_dir_refuses_file(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.write_text("data")
    with pytest.raises(UserError, match="exists and is not a directory"), atomic_output_dir(out):
        pass
    assert out.read_text() == "data"
