"""Command-line tests of ``rangefx guide``."""

from __future__ import annotations

import json

import pytest

from rangefx.tools.cli import main

KEYS = {
    "flight_time_s",
    "min_obstacle_distance",
    "max_load_factor",
    "max_abs_theta_deg",
    "max_abs_phi_deg",
    "initial_t_go_s",
    "final_position_error_ft",
    "n_obstacles",
}


@pytest.fixture(scope="module")
def guide_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("guide") / "out"
    argv = ["guide", "--out", str(out), "--json", "--law", "report", "--guidance-interval", "0.25"]
    return out, main(argv)


def test_guide_json_and_outputs(guide_run, capsys):
    out, code = guide_run
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert KEYS <= set(summary)
    assert summary["n_obstacles"] == 293
    assert 10 < summary["flight_time_s"] < 30
    assert summary["final_position_error_ft"] < 0.1
    assert 1.0 < summary["max_load_factor"] < 1.2
    names = {p.name for p in out.iterdir()}
    assert set(summary["figures"]) <= names
    assert {"trajectory.csv", "obstacles.csv", ".rangefx-output"} <= names
    for png in out.glob("*.png"):
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    rows = (out / "obstacles.csv").read_text().splitlines()
    assert rows[0] == "x_ft,y_ft,z_ft" and len(rows) == 294


def test_guide_prints_one_json_object(tmp_path, capsys):
    code = main(
        [
            "guide",
            "--out",
            str(tmp_path / "o"),
            "--json",
            "--law",
            "report",
            "--guidance-interval",
            "0.5",
            "--shift",
            "0",
            "-10",
            "0",
        ]
    )
    assert code == 0
    printed = capsys.readouterr().out.strip().splitlines()
    assert len(printed) == 1
    data = json.loads(printed[0])
    assert KEYS <= set(data) and data["shift_ft"] == [0.0, -10.0, 0.0]


@pytest.mark.parametrize(
    "argv, culprit",
    [
        (["--guidance-interval", "-1"], "--guidance-interval"),
        (["--guidance-interval", "nan"], "--guidance-interval"),
        (["--shift", "nan", "0", "0"], "--shift"),
        (["--clearance", "-5"], "--clearance"),
        (["--clearance", "inf"], "--clearance"),
        (["--replan-interval", "0"], "--replan-interval"),
        (["--stress", "-1"], "--stress"),
        (["--stress", "1", "--layout-sweep", "1"], "--stress"),
        (["--stress", "1", "--jobs", "0"], "--jobs"),
    ],
)
def test_guide_bad_input_is_one_line_error(tmp_path, capsys, argv, culprit):
    out = tmp_path / "o"
    assert main(["guide", "--out", str(out), *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rangefx: error:") and culprit in err[0]
    assert not out.exists()


def test_guide_refuses_foreign_output_dir(tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "keep.txt").write_text("user data")
    argv = ["guide", "--out", str(out), "--law", "report", "--guidance-interval", "0.5"]
    assert main(argv) == 2
    assert (out / "keep.txt").read_text() == "user data"
    assert "rangefx: error:" in capsys.readouterr().err


def test_guide_unknown_obstacle_source_exits_2(tmp_path):
    with pytest.raises(SystemExit) as exc:
        main(["guide", "--out", str(tmp_path / "o"), "--obstacles", "moon"])
    assert exc.value.code == 2


AVOID_KEYS = KEYS | {
    "law",
    "clearance_ft",
    "min_true_obstacle_distance_ft",
    "min_extent_distance_ft",
    "max_abs_phi_deg_excluding_final_0_5s",
    "feasible",
    "compute",
    "extraction",
    "report_law",
}
COARSE = ["--guidance-interval", "0.5", "--replan-interval", "100"]


def test_guide_avoid_json_keys_and_report_law_beside(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["guide", "--out", str(out), "--json", "--clearance", "10", *COARSE]) == 0
    data = json.loads(capsys.readouterr().out.strip())
    assert AVOID_KEYS <= set(data)
    assert data["law"] == "avoid" and data["clearance_ft"] == 10.0 and data["feasible"] is True
    assert data["min_true_obstacle_distance_ft"] >= 10.0
    assert data["min_obstacle_distance"] == data["min_extent_distance_ft"]
    assert data["extraction"]["scores"]["detected"] == 4
    assert data["report_law"]["law"] == "report"
    assert data["max_abs_phi_deg_excluding_final_0_5s"] <= data["max_abs_phi_deg"]
    rows = (out / "extents.csv").read_text().splitlines()
    assert len(rows) == 1 + data["extraction"]["n_obstacles"]


def test_guide_avoid_infeasible_clearance_is_flagged(tmp_path, capsys):
    # The touch-down point lies 22 ft from vehicles 1 and 2: 40 ft cannot be kept.
    out = tmp_path / "o"
    assert main(["guide", "--out", str(out), "--json", "--clearance", "40", *COARSE]) == 0
    cap = capsys.readouterr()
    data = json.loads(cap.out.strip())
    assert data["feasible"] is False and data["outcome"] in ("hover", "go-around")
    assert "no trajectory to the touch-down keeps 40 ft" in cap.err
    assert "safe manoeuvre" in cap.err
    assert all(line.startswith("rangefx: warning:") for line in cap.err.strip().splitlines())


def test_guide_stress_json_and_worst_case_plot(tmp_path, capsys):
    out = tmp_path / "o"
    # seed 4: its one layout puts an extent over the touch-down point, a hover decided at
    # the start (seed 2's start lies inside an extent: 47 s of CPU in the law's escape)
    argv = ["guide", "--out", str(out), "--json", "--stress", "1", "--seed", "4", "--pipeline"]
    argv += ["p1", *COARSE]
    assert main(argv) == 0
    data = json.loads(capsys.readouterr().out.strip())
    assert data["source"] == "runway-p1" and data["seed"] == 4
    (row,) = data["layouts"]
    assert row["outcome"] in ("landing", "hover", "go-around", "crash")
    s = data["summary"]
    assert s["layouts"] == 1 and sum(s["outcomes"].values()) == 1
    assert data["extent_along_ray_ft"]["n"] >= 1
    assert (out / "stress.json").is_file() and (out / "stress_worst.png").is_file()
    # the layout went to the journal as it finished; the same command again takes it
    # from there (flies nothing) and keeps the journal
    (rec,) = [json.loads(x) for x in (out / "stress_layouts.jsonl").read_text().splitlines()]
    assert rec["row"]["name"] == row["name"] and rec["settings"]["seed"] == 4
    assert data["resumed_layouts"] == []
    assert main(argv) == 0
    again = json.loads(capsys.readouterr().out.strip())
    assert again["resumed_layouts"] == [row["name"]]
    assert again["layouts"] == data["layouts"]
    assert len((out / "stress_layouts.jsonl").read_text().splitlines()) == 1


def test_an_interrupted_stress_programme_says_what_its_journal_kept(tmp_path, capsys, monkeypatch):
    # Stopped after one layout finished: the journal keeps it, and the line says so
    # (not "no output was written"); the same command resumes from it.
    import signal

    import rangefx.guidance.stress as stress
    import rangefx.tools.studies.flights as flights
    from rangefx.guidance.cases import synthetic_case
    from rangefx.tools.interrupts import Interrupted

    def programme(case, count, *, on_row, done, **kw):
        assert done == {}
        on_row({"name": "stress0-0", "outcome": "hover"})
        raise Interrupted(signal.SIGTERM)  # the second layout is flying

    ranged_by = []

    def runway_case(pipeline):
        ranged_by.append(pipeline)
        return synthetic_case()

    monkeypatch.setattr(flights, "_runway_case", runway_case)
    monkeypatch.setattr(stress, "stress_programme", programme)
    out = tmp_path / "o"
    assert main(["guide", "--out", str(out), "--stress", "2", *COARSE]) == 128 + signal.SIGTERM
    assert ranged_by == ["p3"]  # the default pipeline: P3 flew the stress programme better
    err = capsys.readouterr().err.strip()
    journal = out / "stress_layouts.jsonl"
    assert err == (
        f"rangefx: interrupted; 1 finished stress layout kept in {journal} (no other output "
        "was written): the same command flies only the others"
    )
    (rec,) = [json.loads(x) for x in journal.read_text().splitlines()]
    assert rec["row"]["name"] == "stress0-0"
    assert "stress.json" not in {p.name for p in out.iterdir()}
