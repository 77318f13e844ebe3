"""Safe manoeuvres of the avoiding law and the stress programme (issue 39, SPEC §13).

Short problems and coarse settings keep these fast; the figures of the full runs are
in docs/guidance.md.
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import replace

import numpy as np
import pytest

from rangefx.guidance.avoid import (
    MANOEUVRES,
    OUTCOMES,
    STOP_DISTANCE_FACTORS,
    AvoidConfig,
    InfeasibleClearanceWarning,
    escape_walls,
    manoeuvre_candidates,
    plan_braking_stop,
    plan_safe_manoeuvre,
    simulate_avoid,
    stopping_distance,
)
from rangefx.guidance.cases import synthetic_case
from rangefx.guidance.extraction import ObstacleBox
from rangefx.guidance.law import BoundaryConditions, GuidanceWeights, ObstacleField
from rangefx.guidance.simulate import SimulationConfig
from rangefx.guidance.stress import braking_segment, stress_layouts, stress_programme

# A short straight-in problem: 300 ft down range, the report's weights.
BC = BoundaryConditions(
    r0=[0.0, 0.0, 10.0], v0=[30.0, 0.0, 0.0], rf=[300.0, 0.0, 5.0], vf=[5.0, 0.0, 0.0]
)
WEIGHTS = GuidanceWeights(zeta=0.96, alpha=0.5, mu=0.0, beta=1e-6)
FAST = AvoidConfig(n_samples=24, n_basis=5, replan_interval=2.0, terminal_time=2.0)
SIM = SimulationConfig(guidance_interval=0.25, sample_interval=0.02)


def _box(x, y, half_u=4.0, half_v=4.0, top=8.0):
    return ObstacleBox("box", (x, y), 0.0, half_u, half_v, top)


def _field(boxes):
    return ObstacleField(np.array([[b.centre[0], b.centre[1], 4.0] for b in boxes]), WEIGHTS)


def _dist(pos, boxes):
    return np.min([b.signed_distance(pos) for b in boxes], axis=0)


def _fly(boxes, **kw):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = simulate_avoid(BC, _field(boxes), boxes, config=SIM, avoid=FAST, **kw)
    return res, [str(w.message) for w in caught if w.category is InfeasibleClearanceWarning]


def test_blocked_touchdown_takes_a_safe_manoeuvre_not_the_landing():
    # A box on the touch-down point: no landing keeps 20 ft. The law decelerates to a
    # hover short of it and holds, says so, and keeps the clearance on the integrated
    # trajectory (before issue 39 it flew the best-effort plan into the box's clearance).
    boxes = (_box(300.0, 0.0),)
    res, notes = _fly(boxes)
    ex = res.extras
    assert ex["outcome"] == "hover" and ex["manoeuvre"]["kind"] == "hover"
    assert ex["feasible"] is False and "touch-down point is" in ex["landing_blocked"]
    assert any("safe manoeuvre: hover" in n for n in notes)
    assert _dist(res.positions, boxes).min() >= FAST.clearance_ft
    hold = np.array(ex["manoeuvre"]["hold_point_ft"])
    assert np.linalg.norm(res.positions[-1] - hold) < 2.0  # it got there
    assert np.allclose(ex["touchdown"], BC.rf)


def test_wall_ahead_gives_a_climb_over():
    # A long low wall across the track from 100 to 290 ft down range: the touch-down
    # point is 10 ft from it and every hover point ahead inside its clearance; the law
    # climbs over it and holds.
    boxes = (_box(195.0, 0.0, half_u=95.0, half_v=120.0, top=6.0),)
    res, notes = _fly(boxes)
    ex = res.extras
    assert ex["outcome"] == "go-around" and ex["manoeuvre"]["kind"] == "climb"
    assert _dist(res.positions, boxes).min() >= FAST.clearance_ft
    assert any("safe manoeuvre: climb" in n for n in notes)


def test_best_effort_option_lands_anyway():
    boxes = (_box(300.0, 0.0),)
    av = AvoidConfig(**{**FAST.__dict__, "when_blocked": "best-effort"})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate_avoid(BC, _field(boxes), boxes, config=SIM, avoid=av)
    assert res.extras["outcome"] == "landing" and res.extras["manoeuvre"] is None
    assert np.linalg.norm(res.positions[-1] - BC.rf) < 1.0


def test_manoeuvre_hold_points_keep_the_clearance():
    boxes = (_box(120.0, 0.0), _box(60.0, 90.0), _box(0.0, -140.0))
    cands = manoeuvre_candidates(np.array(BC.r0), np.array(BC.v0), boxes, FAST)
    assert cands and {k for k, _ in cands} <= set(MANOEUVRES)
    need = FAST.clearance_ft + FAST.margin_ft + 2.0
    for _, p in cands:
        assert _dist(p[None], boxes)[0] >= need
    # hover points lie on the track ahead, at the present altitude
    for k, p in cands:
        if k == "hover":
            assert p[1] == 0.0 and p[0] > 0 and p[2] == BC.r0[2]


def test_the_simulation_reports_a_crash_instead_of_raising():
    boxes = (_box(150.0, 60.0),)
    short = SimulationConfig(guidance_interval=0.25, sample_interval=0.02, max_time=2.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate_avoid(BC, _field(boxes), boxes, config=short, avoid=FAST)
    assert res.extras["outcome"] == "crash"
    assert "max_time" in res.extras["crash_reason"]
    assert res.t[-1] <= 2.0 + SIM.guidance_interval + 1e-9


# --------------------------------------------------------------------------- stress


@pytest.fixture(scope="module")
def synthetic():
    return synthetic_case()


def _nominal():
    t = np.linspace(0.0, 18.0, 91)
    pos = np.column_stack([532 + 208 * t / 18, 590 - 590 * t / 18, np.full_like(t, 7.0)])
    return t, pos


def test_stress_layouts_put_a_vehicle_on_the_nominal_path(synthetic):
    t, pos = _nominal()
    a = stress_layouts(synthetic, t, pos, 6, seed=3, max_offset_ft=12.0)
    assert a == stress_layouts(synthetic, t, pos, 6, seed=3, max_offset_ft=12.0)
    assert a != stress_layouts(synthetic, t, pos, 6, seed=4, max_offset_ft=12.0)
    for lay in a:
        moved = synthetic.shifted(lay.shift_ft)
        box = next(b for b in moved.truth if b.name == lay.vehicle)
        # the chosen vehicle's centre stands |offset| <= 12 ft from the nominal path's
        # position at the drawn time
        p = [np.interp(lay.path_time_s, t, pos[:, i]) for i in range(2)]
        off = np.asarray(box.centre) - p
        assert math.hypot(*off) == pytest.approx(abs(lay.offset_ft))
        assert abs(lay.offset_ft) <= 12.0
        tangent = pos[1, :2] - pos[0, :2]  # the nominal path is straight
        assert abs(off @ tangent) / np.linalg.norm(tangent) < 1e-6  # beside it, not along
        assert 0.15 * 18 <= lay.path_time_s <= 0.85 * 18
        # no true vehicle on the start or the touch-down
        assert _dist(pos[[0, -1]], moved.truth).min() >= 5.0


def test_stress_layouts_keep_the_braking_segment_clear(synthetic):
    # A layout whose true vehicle lies within the stopping distance (or the clearance)
    # of the start has no safe answer: such draws are redrawn, so the law's braking
    # stop keeps 20 ft from every true vehicle. Seed 2 draws three (stress2-10, -12, -13).
    t, pos = _nominal()
    v0 = (pos[1] - pos[0]) / (t[1] - t[0])
    seg = braking_segment(pos[0], v0)
    speed = math.hypot(*v0[:2])
    decel = 32.174 * math.tan(math.radians(0.9 * 20.0))  # the default limits less back-off
    assert stopping_distance(speed) == pytest.approx(speed**2 / (2 * decel))
    # to where the braking stop holds: its first hold point
    length = STOP_DISTANCE_FACTORS[0] * stopping_distance(speed)
    assert seg[-1] - seg[0] == pytest.approx(length * v0 / speed)
    lays = stress_layouts(synthetic, t, pos, 14, seed=2, clearance_ft=20.0)
    assert lays == stress_layouts(synthetic, t, pos, 14, seed=2, clearance_ft=20.0)
    for lay in lays:
        assert _dist(seg, synthetic.shifted(lay.shift_ft).truth).min() >= 20.0, lay.name


def test_stress_programme_scores_against_the_true_vehicles(synthetic):
    coarse = AvoidConfig(n_samples=24, n_basis=5, replan_interval=50.0)
    res = stress_programme(
        synthetic, 1, seed=1, source="synthetic", config=SimulationConfig(guidance_interval=0.5),
        avoid=coarse,
    )  # fmt: skip
    (row,) = res.rows
    assert row["outcome"] in OUTCOMES
    moved, run, rep = res.runs[row["name"]]
    d_true = _dist(run.result.positions, moved.truth).min()
    assert row["min_true_distance_ft"] == pytest.approx(d_true)
    assert row["collision"] is bool(d_true < 0)
    assert row["report_law_min_true_distance_ft"] == pytest.approx(
        _dist(rep.result.positions, moved.truth).min()
    )
    s = res.summary
    assert s["layouts"] == 1 and sum(s["outcomes"].values()) == 1
    assert s["collisions"] == 0 and s["crashes"] == 0
    json.dumps(res.to_dict())  # plain data


def _start_inside_layout():
    # stress0-10 in miniature: a long along-ray extent (as P1 gives a far vehicle) holds
    # the start and a true vehicle on the straight path; the touch-down keeps 20 ft.
    extent = _box(90.0, 0.0, half_u=110.0, half_v=6.0, top=14.0)
    truck = _box(160.0, 0.0, half_u=10.0, half_v=4.0, top=8.0)
    return extent, truck


def test_start_inside_a_clearance_moves_away_first_and_lands_only_keeping_it():
    extent, truck = _start_inside_layout()
    res, notes = _fly((extent,))
    ex = res.extras
    man = ex["manoeuvre"]
    assert man is not None and "the start is" in ex["landing_blocked"]
    assert man["keeps_clearance_floor"]
    start_d = float(extent.signed_distance(np.asarray(BC.r0)[None])[0])
    assert start_d < 0  # the start lies inside the extent itself
    d = _dist(res.positions, (extent,))
    # never closer than what the start leaves (less 10 %, >= 0.5 ft) ...
    assert d.min() >= start_d - max(0.1 * abs(start_d), 0.5) - 0.5
    # ... and it moves away: the true vehicle inside the extent keeps the clearance
    assert _dist(res.positions, (truck,)).min() >= FAST.clearance_ft
    after = man["landing_after"]
    assert after is not None and after["landed"] is True
    assert ex["outcome"] == "landing"
    assert np.linalg.norm(res.positions[-1] - BC.rf) < 2.0
    # the landing, flown from the hold point, keeps the full clearance
    landing = res.t >= after["decided_at_s"]
    assert d[landing].min() >= FAST.clearance_ft
    assert any("then landed from the hold point" in n for n in notes)


def test_start_inside_a_clearance_with_no_landing_holds():
    # The same, but a second box within 20 ft of the touch-down: no landing keeps the
    # clearance, from the start or the hold point; the law moves away and holds.
    extent, truck = _start_inside_layout()
    boxes = (extent, _box(300.0, 0.0))
    res, _ = _fly(boxes)
    ex = res.extras
    assert ex["outcome"] in ("hover", "go-around") and ex["manoeuvre"]["keeps_clearance_floor"]
    assert _dist(res.positions, (truck,)).min() >= FAST.clearance_ft
    assert np.linalg.norm(res.positions[-1] - BC.rf) > 20.0


def test_stress_journal_resumes_the_layouts_it_holds(synthetic, tmp_path):
    # Each finished layout goes to the journal at once; a re-run takes those rows from it
    # (flies nothing again) and flies only the rest. A torn last line (a kill mid-write)
    # is cut off; records of other settings are ignored; a bad line is one error.
    from rangefx.tools.errors import UserError
    from rangefx.tools.studies.flights import read_stress_journal

    coarse = AvoidConfig(n_samples=24, n_basis=5, replan_interval=50.0)
    sim = SimulationConfig(guidance_interval=0.5)
    kw = {"seed": 1, "source": "synthetic", "config": sim, "avoid": coarse}
    flown: list[dict] = []
    first = stress_programme(synthetic, 1, on_row=flown.append, **kw)
    assert [r["name"] for r in flown] == ["stress1-0"] and set(first.runs) == {"stress1-0"}
    settings = {"source": "synthetic", "seed": 1}
    path = tmp_path / "stress_layouts.jsonl"
    lines = [json.dumps({"settings": settings, "row": r}) for r in flown]
    other = json.dumps({"settings": {**settings, "seed": 2}, "row": {**flown[0], "outcome": "x"}})
    path.write_text("\n".join([*lines, other]) + "\n" + lines[0][:30])  # torn last line
    done = read_stress_journal(path, settings)
    assert list(done) == ["stress1-0"] and done["stress1-0"]["outcome"] == flown[0]["outcome"]
    assert path.read_text().endswith("\n")  # the torn line is cut off
    again: list[dict] = []
    second = stress_programme(synthetic, 2, done=done, on_row=again.append, **kw)
    assert [r["name"] for r in second.rows] == ["stress1-0", "stress1-1"]
    assert second.rows[0] == json.loads(lines[0])["row"]  # taken, not flown again
    assert set(second.runs) == {"stress1-1"} and [r["name"] for r in again] == ["stress1-1"]
    path.write_text(lines[0] + "\nnot json\n")
    with pytest.raises(UserError, match="line 2 is not a stress layout record"):
        read_stress_journal(path, settings)


def test_an_escape_from_inside_an_extent_leaves_it_sideways_not_over_its_top():
    # runway/P1 stress0-10 in miniature: the start lies inside a long along-ray extent's
    # footprint, 4 ft below its top, flying along it at 38 ft/s; a true vehicle inside
    # the extent stands 80 ft ahead, 8 ft to the side. The nearest way out of the extent
    # was up through its top (4 ft): the escape climbed there, slowly (0.09 g at the
    # load-factor limit), and passed the vehicle at 18.2 ft, 2 ft above its roof. Made
    # a wall for the escape, the extent is left sideways: >= 20 ft from the vehicle.
    bc = BoundaryConditions(
        r0=[0.0, 0.0, 7.0], v0=[38.0, 0.0, 0.0], rf=[300.0, 140.0, 5.0], vf=[5.0, 0.0, 0.0]
    )
    extent = ObstacleBox("extent", (100.0, -3.0), 0.0, 160.0, 12.0, 11.0)
    truck = ObstacleBox("truck", (80.0, -8.0), 0.0, 10.0, 4.0, 8.0)
    field = ObstacleField(np.array([[100.0, -3.0, 4.0]]), WEIGHTS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate_avoid(bc, field, (extent,), config=SIM, avoid=FAST)
    ex = res.extras
    assert "the start is" in ex["landing_blocked"] and ex["manoeuvre"]["keeps_clearance_floor"]
    assert _dist(res.positions, (truck,)).min() >= FAST.clearance_ft
    assert ex["outcome"] == "landing"  # and it lands from the hold point


def test_when_no_manoeuvre_keeps_its_floor_the_law_brakes_to_a_stop():
    # runway/P1 stress0-13 in kind: no manoeuvre keeps its floor (the start flies down a
    # corridor between two extents 15 ft to either side, a third across it 64 ft ahead);
    # the braking stop holds 10 ft short of the one ahead and never comes closer to any,
    # every candidate comes closer (through a side or over the one ahead): the law
    # brakes straight ahead to a hover and says so (stress0-13: 21.4 ft from Vehicle 3;
    # the candidate least short of its floor climbed over its extent 18.58 ft from it).
    left = _box(100.0, 65.0, half_u=200.0, half_v=50.0, top=12.0)
    right = _box(100.0, -65.0, half_u=200.0, half_v=50.0, top=12.0)
    front = _box(94.0, 0.0, half_u=30.0, half_v=15.0, top=12.0)
    res, notes = _fly((left, right, front))
    ex = res.extras
    assert ex["outcome"] == "hover" and ex["manoeuvre"]["kind"] == "stop"
    assert ex["manoeuvre"]["keeps_clearance_floor"] is False
    assert "braking to a stop" in notes[0]
    hold = np.asarray(ex["manoeuvre"]["hold_point_ft"])
    speed = float(np.linalg.norm(BC.v0))
    assert hold == pytest.approx([1.25 * stopping_distance(speed, FAST), 0.0, 10.0])
    assert np.abs(res.positions[:, 1]).max() < 1.0  # straight ahead
    assert _dist(res.positions, (front,)).min() >= 9.0  # short of the extent ahead
    assert _dist(res.positions, (left, right)).min() >= 14.0  # no nearer the sides


def test_a_stop_that_would_hold_inside_an_extent_gives_way_to_a_turn_away():
    # runway-p1 shifted by (-79.935, 376.446) ft in kind: braking straight ahead ends
    # inside an extent (a wide one 40 ft ahead; the vehicle it holds may stand anywhere
    # in it: there the stop held 16.5 ft from one). The stop's path and hold point are
    # checked against the extents; a turn-away to a hold point clear of every extent
    # comes less short of the clearance and is taken instead.
    strip = _box(60.0, 0.0, half_u=80.0, half_v=1.5, top=2.0)
    wide = _box(100.0, 0.0, half_u=60.0, half_v=100.0, top=12.0)
    boxes = (strip, wide)
    stop = plan_braking_stop(BC.r0, BC.v0, _field(boxes), boxes, config=FAST)
    assert stop is not None and not stop.keeps_floor
    assert float(wide.signed_distance(stop.goal.rf[None])[0]) < 0  # it would hold inside
    fast = replace(FAST, maxiter=10)  # the candidates' solves: a few iterations will do
    man = plan_safe_manoeuvre(BC.r0, BC.v0, _field(boxes), boxes, config=fast, closest_if_none=True)
    assert man.kind in ("turn-away", "climb") and not man.keeps_floor
    assert _dist(man.goal.rf[None], boxes)[0] >= FAST.clearance_ft
    tau = np.linspace(0.0, 1.0, 65)
    path = man.plan.evaluate(tau * man.plan.t_go)[0]
    braking = stop.plan.evaluate(tau * stop.plan.t_go)[0]
    # it comes no deeper into the extent than its face; the stop goes 2 ft in and stays
    assert _dist(path, (wide,)).min() > -0.5 and _dist(braking[-1:], (wide,))[0] < -1.5


def test_an_escape_wall_is_left_by_a_side_never_through_the_ground():
    # Made a wall for an escape, an extent's inside distance is the depth to its nearest
    # side: a start 7 ft up and 10 ft from the nearest side is 10 ft deep, not 7 ft from
    # the bottom face (with that floor no escape of the shifted runway-p1 layout could
    # reach the side in time, and the law braked along the extent).
    extent = _box(0.0, 0.0, half_u=100.0, half_v=20.0, top=11.0)
    start = np.array([0.0, 10.0, 7.0])
    assert float(extent.signed_distance(start[None])[0]) == pytest.approx(-4.0)  # its top
    (wall,) = escape_walls((extent,), start, 20.0)
    assert float(wall.signed_distance(start[None])[0]) == pytest.approx(-10.0)
    assert float(wall.signed_distance(np.array([[0.0, 10.0, 0.5]]))[0]) == pytest.approx(-10.0)
    assert float(wall.signed_distance(np.array([[0.0, 25.0, 0.5]]))[0]) == pytest.approx(5.0)


def test_a_landing_from_the_hold_point_that_reaches_zero_airspeed_holds_not_crashes(monkeypatch):
    # The landing from a hold point starts at the hold speed; if the model's integration
    # fails there (V -> 0, eqs 2-3 singular: runway/P1 stress0-14 crashed so), the
    # vehicle holds where it is: outcome the manoeuvre's, the landing reported as not
    # flown, never "crash". Injected: the integrator fails 1 s into the landing.
    import rangefx.guidance.avoid as avoid

    extent, _ = _start_inside_layout()
    res, _ = _fly((extent,))
    decided = res.extras["manoeuvre"]["landing_after"]["decided_at_s"]
    real = avoid.integrate_held_controls

    def failing(state, ctrl, params, t, *args):
        if t >= decided + 1.0:
            raise RuntimeError(f"integration failed at t = {t:g} s: injected")
        return real(state, ctrl, params, t, *args)

    monkeypatch.setattr(avoid, "integrate_held_controls", failing)
    res, notes = _fly((extent,))
    ex = res.extras
    after = ex["manoeuvre"]["landing_after"]
    assert ex["outcome"] == ex["manoeuvre"]["outcome"] and ex["crash_reason"] == ""
    assert after["landed"] is False and after["aborted_at_s"] >= decided + 1.0
    assert ex["feasible"] is False
    assert any("reached zero airspeed" in n for n in notes)
