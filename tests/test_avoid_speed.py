"""The avoiding law's faster programme decides as before (issue 39, SPEC §13).

The extents are evaluated at once (:class:`~rangefx.guidance.extraction.BoxSet`), the
time-to-go column of every Jacobian is analytic instead of a forward difference, the
limit Jacobian is one vectorised call, the basis and the path are cached, and the
stress programme can fly its layouts in worker processes. None of it may change a
decision: the figures below were measured with the code before these changes (commit
8700491, ``guidance/avoid.py``) on the same layouts and settings, and the flights must
reproduce them — outcome, manoeuvre and feasibility exactly, distances and times within
a tolerance (the analytic derivative moves SLSQP's iterates by its round-off).
"""

from __future__ import annotations

import os
import time
import warnings

import numpy as np
import pytest

from rangefx.guidance.avoid import AvoidConfig, simulate_avoid
from rangefx.guidance.cases import synthetic_case
from rangefx.guidance.extraction import BoxSet, ObstacleBox
from rangefx.guidance.law import BoundaryConditions, GuidanceWeights, ObstacleField
from rangefx.guidance.simulate import SimulationConfig
from rangefx.guidance.stress import stress_programme

BC = BoundaryConditions(
    r0=[0.0, 0.0, 10.0], v0=[30.0, 0.0, 0.0], rf=[300.0, 0.0, 5.0], vf=[5.0, 0.0, 0.0]
)
WEIGHTS = GuidanceWeights(zeta=0.96, alpha=0.5, mu=0.0, beta=1e-6)
FAST = AvoidConfig(n_samples=24, n_basis=5, replan_interval=2.0, terminal_time=2.0)
SIM = SimulationConfig(guidance_interval=0.25, sample_interval=0.02)

#: Measured at commit 8700491 (before the speed work) with the layouts of :func:`_layout`,
#: ``simulate_avoid(BC, field, boxes, config=SIM, avoid=FAST)``: outcome, manoeuvre,
#: feasible, smallest distance to the boxes on the 0.02 s trajectory (ft), flight time (s).
BEFORE = {
    0: ("landing", "", True, 21.051, 11.587),
    1: ("hover", "hover", False, 32.286, 6.492),
    2: ("landing", "", True, 21.179, 11.596),
    3: ("hover", "hover", False, 23.981, 6.492),
}


def _layout(seed: int) -> tuple[ObstacleBox, ...]:
    """A truck on or near the straight path, a long one beside it, and for odd seeds a
    truck on the touch-down point (no landing keeps the clearance: a safe manoeuvre)."""
    rng = np.random.default_rng([39, seed])
    x = rng.uniform(110.0, 190.0)
    y = rng.uniform(-6.0, 6.0)
    side = rng.choice([-1.0, 1.0])
    boxes = (
        ObstacleBox("on path", (x, y), rng.uniform(-0.3, 0.3), 4.0, 10.0, 8.0),
        ObstacleBox("beside", (x + rng.uniform(-30, 30), side * 45.0), 0.0, 30.0, 4.0, 8.0),
    )
    if seed % 2:
        boxes += (ObstacleBox("on touch-down", (305.0, rng.uniform(-5, 5)), 0.0, 4.0, 10.0, 8.0),)
    return boxes


def _dist(pos, boxes):
    return np.min([b.signed_distance(pos) for b in boxes], axis=0)


@pytest.mark.parametrize("seed", sorted(BEFORE))
def test_decisions_are_those_before_the_speed_work(seed):
    boxes = _layout(seed)
    field = ObstacleField(np.array([[b.centre[0], b.centre[1], 4.0] for b in boxes]), WEIGHTS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate_avoid(BC, field, boxes, config=SIM, avoid=FAST)
    outcome, kind, feasible, distance, flight_time = BEFORE[seed]
    ex = res.extras
    assert ex["outcome"] == outcome
    assert (ex["manoeuvre"] or {}).get("kind", "") == kind
    assert ex["feasible"] is feasible
    assert _dist(res.positions, boxes).min() == pytest.approx(distance, abs=0.25)
    assert res.flight_time == pytest.approx(flight_time, abs=0.1)


def test_box_set_matches_each_box():
    rng = np.random.default_rng(5)
    boxes = tuple(
        ObstacleBox(
            f"b{k}",
            tuple(rng.uniform(-20, 20, 2)),
            rng.uniform(-3, 3),
            *rng.uniform(1, 10, 2),
            rng.uniform(2, 9),
        )
        for k in range(4)
    )
    p = rng.uniform([-40, -40, -2], [40, 40, 12], (300, 3))
    bs = BoxSet(boxes)
    d, g = bs.signed_distance(p), bs.signed_distance_gradient(p)
    assert d.shape == (300, 4) and g.shape == (300, 4, 3)
    for k, b in enumerate(boxes):
        # each box's distance from first principles, in its own frame
        c, s = np.cos(b.heading), np.sin(b.heading)
        rel = p[:, :2] - b.centre
        q = np.column_stack([rel @ [c, s], rel @ [-s, c], p[:, 2] - b.top / 2])
        e = np.abs(q) - [b.half_u, b.half_v, b.top / 2]
        want = np.linalg.norm(np.maximum(e, 0), axis=1) + np.minimum(e.max(axis=1), 0)
        assert np.allclose(d[:, k], want, atol=1e-12)
        h = 1e-6
        fd = np.stack(
            [(bs.signed_distance(p + h * ax)[:, k] - bs.signed_distance(p - h * ax)[:, k])
             / (2 * h) for ax in np.eye(3)],
            axis=1,
        )  # fmt: skip
        smooth = np.sort(np.abs(e), axis=1)[:, 0] > 1e-3  # away from faces' kinks
        assert np.allclose(g[smooth, k], fd[smooth], atol=1e-5)


def test_stress_jobs_fly_the_same_rows():
    # Worker processes fly the same layouts with the same code: identical rows, in
    # layout order.
    case = synthetic_case()
    kw = dict(
        seed=2, source="synthetic", config=SimulationConfig(guidance_interval=0.5),
        avoid=AvoidConfig(n_samples=24, n_basis=5, replan_interval=50.0),
    )  # fmt: skip
    one = stress_programme(case, 2, **kw)
    two = stress_programme(case, 2, jobs=2, **kw)
    drop = ("planner_wall_s", "cpu_s", "wall_s")  # timings differ run to run
    strip = [
        [{k: v for k, v in r.items() if k not in drop} for r in res.rows] for res in (one, two)
    ]
    assert strip[0] == strip[1]
    assert [r["name"] for r in two.rows] == ["stress2-0", "stress2-1"]
    with pytest.raises(ValueError, match="jobs"):
        stress_programme(case, 1, jobs=0, **kw)


def _one_fails_one_runs_on(case, lay, *args):
    """A stand-in flight, module level so that any pool can send it to a worker: layout 0
    runs for 20 s, layout 1 fails once layout 0 has started."""
    from pathlib import Path

    work = Path(os.environ["RANGEFX_TEST_STRESS_DIR"])
    if lay.name.endswith("-0"):
        (work / "started").write_text("")
        time.sleep(20.0)
        (work / "finished").write_text("")
        return {}, ()
    while not (work / "started").exists():
        time.sleep(0.01)
    raise RuntimeError("layout failed")


def test_a_stopped_stress_programme_ends_its_workers(monkeypatch, tmp_path):
    # One layout fails while the other is still being flown in its worker: the programme
    # raises at once and the other worker is ended, not waited for (a stop signal takes
    # the same path: the command's workers must not outlive it).
    from rangefx.guidance import stress

    monkeypatch.setenv("RANGEFX_TEST_STRESS_DIR", str(tmp_path))
    monkeypatch.setattr(stress, "_stress_row", _one_fails_one_runs_on)
    with pytest.raises(RuntimeError, match="layout failed"):
        stress_programme(
            synthetic_case(), 2, jobs=2, seed=2, source="synthetic",
            config=SimulationConfig(guidance_interval=0.5),
            avoid=AvoidConfig(n_samples=24, n_basis=5, replan_interval=50.0),
        )  # fmt: skip
    time.sleep(0.5)
    assert (tmp_path / "started").exists() and not (tmp_path / "finished").exists()
