"""The avoiding law (guidance/avoid.py) and the obstacle extraction (guidance/extraction.py).

Flights use a short problem and coarse settings (few samples, sparse re-plans) to keep
the suite fast; the figures of the full runs are in docs/guidance.md.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest

from rangefx.guidance.avoid import (
    MANOEUVRES,
    AvoidConfig,
    InfeasibleClearanceWarning,
    limit_margins,
    limited_command,
    plan_trajectory,
    simulate_avoid,
    within_limits,
)
from rangefx.guidance.cases import (
    fly,
    layout_sweep,
    random_layouts,
    shift_grid_layouts,
    synthetic_case,
)
from rangefx.guidance.extraction import (
    ExtractionConfig,
    ObstacleBox,
    box_from_corners,
    boxes_from_vehicles,
    extract_from_points,
    extract_obstacles,
    scene_truth_boxes,
    score_extraction,
)
from rangefx.guidance.law import BoundaryConditions, GuidanceWeights, ObstacleField
from rangefx.guidance.model import VehicleParams, inverse_controls
from rangefx.guidance.obstacles import REPORT_VEHICLES, synthetic_runway_obstacles
from rangefx.guidance.simulate import SimulationConfig, simulate

# A short straight-in problem: 300 ft down range, the report's weights.
BC = BoundaryConditions(
    r0=[0.0, 0.0, 10.0], v0=[30.0, 0.0, 0.0], rf=[300.0, 0.0, 5.0], vf=[5.0, 0.0, 0.0]
)
WEIGHTS = GuidanceWeights(zeta=0.96, alpha=0.5, mu=0.0, beta=1e-6)
FAST = AvoidConfig(n_samples=24, n_basis=5, replan_interval=2.0, terminal_time=2.0)
SIM = SimulationConfig(guidance_interval=0.25, sample_interval=0.02)


def _box(x, y, name="truck", half_u=10.0, half_v=4.0, top=8.0, heading=0.0):
    return ObstacleBox(name, (x, y), heading, half_u, half_v, top)


def _field(boxes):
    pts = np.array([[b.centre[0], b.centre[1], 4.0] for b in boxes])
    return ObstacleField(pts, WEIGHTS)


def _dist(pos, boxes):
    return np.min([b.signed_distance(pos) for b in boxes], axis=0)


# --------------------------------------------------------------------------- boxes


def test_signed_distance_matches_brute_force():
    box = _box(5.0, -3.0, heading=0.7, half_u=6.0, half_v=2.0, top=4.0)
    rng = np.random.default_rng(3)
    p = rng.uniform(-15, 15, size=(200, 3)) + np.array([5.0, -3.0, 2.0])
    # Brute force: dense samples of the box surface.
    u, v, z = np.meshgrid(np.linspace(-6, 6, 61), np.linspace(-2, 2, 21), np.linspace(0, 4, 21))
    on_surface = (
        (np.abs(np.abs(u) - 6) < 1e-9)
        | (np.abs(np.abs(v) - 2) < 1e-9)
        | (z < 1e-9)
        | (z > 4 - 1e-9)
    )
    local = np.stack([u[on_surface], v[on_surface], z[on_surface]], axis=1)
    xy = local[:, :2] @ box.axes + box.centre
    surf = np.column_stack([xy, local[:, 2]])
    brute = np.min(np.linalg.norm(p[:, None] - surf[None], axis=-1), axis=1)
    d = box.signed_distance(p)
    assert np.allclose(np.abs(d), brute, atol=0.15)
    inside = np.all(np.abs(box.local(p)[:, :2]) < [6, 2], axis=1) & (p[:, 2] > 0) & (p[:, 2] < 4)
    assert np.array_equal(d < 0, inside)


def test_signed_distance_gradient_matches_finite_differences():
    box = _box(0.0, 0.0, heading=-0.4, half_u=5.0, half_v=3.0, top=6.0)
    rng = np.random.default_rng(7)
    p = rng.uniform(-12, 12, size=(50, 3)) + np.array([0.0, 0.0, 3.0])
    g = box.signed_distance_gradient(p)
    h = 1e-6
    fd = np.stack(
        [
            (box.signed_distance(p + h * e) - box.signed_distance(p - h * e)) / (2 * h)
            for e in np.eye(3)
        ],
        axis=1,
    )
    assert np.allclose(g, fd, atol=1e-5)


def test_box_from_corners_recovers_rotated_box():
    box = _box(100.0, -40.0, heading=0.3, half_u=10.0, half_v=4.0, top=8.0)
    fit = box_from_corners("fit", box.corners())
    assert math.dist(fit.centre, box.centre) < 1e-9
    assert sorted([fit.half_u, fit.half_v]) == pytest.approx([4.0, 10.0])
    assert fit.top == pytest.approx(8.0)
    assert np.all(fit.signed_distance(box.corners()) < 1e-9)


def test_score_extraction_counts_detections_and_false_obstacles():
    truth = boxes_from_vehicles(REPORT_VEHICLES)
    far = _box(0.0, -500.0, name="ghost")
    sc = score_extraction((*truth, far), truth)
    assert sc["detected"] == 4 and sc["false_obstacles"] == 1
    assert sc["false_obstacle_names"] == ["ghost"]
    assert sc["max_centre_error_ft"] == pytest.approx(0.0, abs=1e-9)
    assert all(r["contained"] for r in sc["per_object"])
    sc2 = score_extraction(truth[:2], truth)
    assert sc2["detected"] == 2 and not sc2["per_object"][3]["detected"]


# --------------------------------------------------------------------------- extraction


def test_extraction_of_synthetic_set_finds_each_vehicle_once():
    pts = synthetic_runway_obstacles()
    ex = extract_from_points(pts, camera_position=(532.0, 590.0, 7.0))
    sc = score_extraction(ex.obstacles, boxes_from_vehicles(REPORT_VEHICLES))
    assert sc["detected"] == 4 and sc["false_obstacles"] == 0 and len(ex.obstacles) == 4
    assert sc["max_centre_error_ft"] < 5.0
    assert ex.counts["ground"] > 0  # the bottom-edge points at z = 0 are ground returns


@pytest.fixture(scope="module")
def small_runway():
    from rangefx.golden.scenes import render_scene
    from rangefx.guidance.obstacles import runway_frame_map

    scene = render_scene("runway", size=(256, 256), supersample=1)
    return scene, runway_frame_map(scene)


def test_extraction_on_true_ranges_detects_every_vehicle(small_runway):
    scene, fmap = small_runway
    depth = np.where(np.isfinite(scene.depth1), scene.depth1, 0.0)
    valid = np.isfinite(scene.depth1) & (depth < 2000)
    ex = extract_obstacles(depth, valid, scene.camera, scene.motion, frame_map=fmap)
    sc = score_extraction(ex.obstacles, scene_truth_boxes("runway", fmap))
    assert sc["detected"] == sc["n_true"] == 5
    assert sc["false_obstacles"] == 0
    assert sc["max_centre_error_ft"] < 6.0


def test_misranged_ground_is_not_an_obstacle(small_runway):
    # The ground ranged 40 % short lies on a plane ~5 ft up: flat, and scaling like the
    # ground along its rays -- removed, while the vehicles stay.
    scene, fmap = small_runway
    depth = np.where(np.isfinite(scene.depth1), scene.depth1, 0.0)
    ground = (scene.labels1 == 0) & np.isfinite(scene.depth1) & (depth < 400)
    depth = np.where(ground, 0.6 * depth, depth)
    valid = np.isfinite(scene.depth1) & (depth < 2000)
    ex = extract_obstacles(depth, valid, scene.camera, scene.motion, frame_map=fmap)
    sc = score_extraction(ex.obstacles, scene_truth_boxes("runway", fmap))
    assert sc["false_obstacles"] == 0, sc["false_obstacle_names"]
    assert ex.counts["ground_like"] + ex.counts["ground"] > ground.sum() // 2
    loose = extract_obstacles(
        depth, valid, scene.camera, scene.motion, frame_map=fmap,
        config=ExtractionConfig(ground_slope=50.0, min_rows=1),
    )  # fmt: skip
    assert (
        score_extraction(loose.obstacles, scene_truth_boxes("runway", fmap))["false_obstacles"] > 0
    )


def test_extraction_is_not_biased_short_by_its_ground_test(small_runway):
    # Every vehicle pixel ranged 0.7x or 1/0.7x its true range (a checkerboard): the
    # ground test alone keeps the short half (they rise along their rays, the long half
    # sinks into the ground), which put the obstacles 30 % short -- in front of the
    # vehicles (before this fix: 2 of 5 detected, 5 false). The cluster's range from
    # its whole image region puts them back.
    scene, fmap = small_runway
    depth = np.where(np.isfinite(scene.depth1), scene.depth1, 0.0)
    yy, xx = np.indices(depth.shape)
    factor = np.where((yy + xx) % 2 == 0, 0.7, 1 / 0.7)
    depth = np.where(scene.labels1 > 0, depth * factor, depth)
    valid = np.isfinite(scene.depth1) & (depth < 2000)
    images = (scene.image1, scene.image2)
    ex = extract_obstacles(depth, valid, scene.camera, scene.motion, images=images, frame_map=fmap)
    sc = score_extraction(ex.obstacles, scene_truth_boxes("runway", fmap))
    assert sc["false_obstacles"] == 0, sc["false_obstacle_names"]
    assert sc["detected"] >= 4  # vehicle 5 (470 ft) has too few pixels at 256 x 256
    assert sc["max_centre_error_ft"] < 40.0
    assert ex.counts["region_added"] > 0


def test_bad_extraction_config():
    with pytest.raises(ValueError, match="min_height"):
        ExtractionConfig(min_height=5.0, max_height=2.0)
    with pytest.raises(ValueError, match="link_px"):
        ExtractionConfig(link_px=-1)


# --------------------------------------------------------------------------- avoiding law


@pytest.fixture(scope="module")
def blocked():
    """A truck parked across the straight path, 150 ft down range."""
    boxes = (_box(150.0, 2.0, half_u=4.0, half_v=10.0),)
    field = _field(boxes)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        avoid = simulate_avoid(BC, field, boxes, config=SIM, avoid=FAST)
        report = simulate(BC, field, config=SIM)
    return boxes, avoid, report


def test_plan_meets_boundary_conditions_and_limits(blocked):
    boxes, _, _ = blocked
    plan = plan_trajectory(BC.r0, BC.v0, BC, _field(boxes), boxes, config=FAST)
    r, v, a = plan.evaluate(np.array([0.0, plan.t_go]))
    assert np.allclose(r[0], BC.r0) and np.allclose(v[0], BC.v0)
    assert np.allclose(r[1], BC.rf) and np.allclose(v[1], BC.vf)
    assert plan.feasible
    tau = np.linspace(0, plan.t_go, 400)
    r, v, a = plan.evaluate(tau)
    assert limit_margins(v, a, VehicleParams(), AvoidConfig(limit_backoff=0.0)).min() > -1e-3


def test_closed_loop_reaches_final_state_within_limits(blocked):
    _, res, _ = blocked
    assert res.extras["feasible"]
    assert np.linalg.norm(res.positions[-1] - BC.rf) < 1.0
    v_end = res.velocities()[-1]
    assert np.linalg.norm(v_end - BC.vf) < 0.5
    assert res.thrust.max() / res.params.weight_lbf <= FAST.max_load_factor + 1e-6
    assert np.degrees(np.abs(res.theta)).max() < FAST.max_theta_deg
    assert np.degrees(np.abs(res.phi)).max() < FAST.max_phi_deg


def test_command_limiter_keeps_held_controls_within_limits():
    rng = np.random.default_rng(11)
    params, cfg = VehicleParams(), AvoidConfig()
    n_limited = 0
    for _ in range(300):
        v = np.array([30.0, 0.0, 0.0]) + rng.normal(0, [10, 10, 4])
        a_plan, a_track = rng.normal(0, 4, 3), rng.normal(0, 6, 3)
        a, ctrl, limited = limited_command(v, a_plan, a_track, params, cfg)
        assert within_limits(ctrl, params, cfg)
        full = inverse_controls(v, a_plan + a_track, params)
        if within_limits(full, params, cfg):
            assert not limited and np.array_equal(a, a_plan + a_track)
        else:
            n_limited += 1
            assert limited
            if inverse_controls(v, a, params) != ctrl:  # clipped: only when even a = 0
                assert not within_limits(inverse_controls(v, np.zeros(3), params), params, cfg)
    assert 30 < n_limited < 270  # both branches exercised


def test_limits_hold_on_the_integrated_trajectory_with_a_coarse_programme(blocked):
    # No back-off in the plan, few constraint samples, a long hold: the tracking term
    # and the held commands would exceed the limits; the limiter keeps every held
    # control (constant between updates, so along the whole integrated trajectory)
    # within them.
    boxes, _, _ = blocked
    tight = AvoidConfig(
        n_samples=12, n_basis=5, replan_interval=2.0, limit_backoff=0.0,
        max_load_factor=1.05, max_theta_deg=12.0, max_phi_deg=15.0,
    )  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate_avoid(
            BC, _field(boxes), boxes, config=SimulationConfig(guidance_interval=0.5), avoid=tight
        )
    assert res.extras["limited_updates"] > 0
    assert res.thrust.max() / res.params.weight_lbf <= tight.max_load_factor + 1e-12
    assert np.degrees(np.abs(res.theta)).max() <= tight.max_theta_deg + 1e-9
    assert np.degrees(np.abs(res.phi)).max() <= tight.max_phi_deg + 1e-9
    assert np.linalg.norm(res.positions[-1] - BC.rf) < 1.0


def test_vehicle_on_the_straight_path_is_avoided(blocked):
    boxes, avoid, report = blocked
    # The report's law flies straight through (its obstacle term sees the centroid only).
    assert _dist(report.positions, boxes).min() < 5.0
    # The clearance holds on the integrated nonlinear trajectory (0.02 s samples), not
    # only at the guidance updates.
    assert len(avoid.t) > 4 * len(avoid.t_cmd)
    assert _dist(avoid.positions, boxes).min() >= FAST.clearance_ft


BEST_EFFORT = replace(FAST, when_blocked="best-effort")


def test_impossible_layout_is_flagged_not_flown_silently():
    boxes = (_box(300.0, 0.0, half_u=4.0, half_v=4.0),)  # on the touch-down point
    with pytest.warns(InfeasibleClearanceWarning, match="no trajectory keeps 20 ft"):
        res = simulate_avoid(BC, _field(boxes), boxes, config=SIM, avoid=BEST_EFFORT)
    assert res.extras["feasible"] is False
    assert res.extras["planned_min_clearance_ft"] < FAST.clearance_ft


def test_best_effort_keeps_the_full_clearance_from_the_other_extents():
    # The touch-down point is 10 ft from one box (infeasible: flagged), a truck stands
    # across the straight path: best effort keeps 20 ft from the truck and as much as
    # the end point leaves from the other, on the integrated trajectory.
    near = _box(300.0, 16.0, half_u=4.0, half_v=2.0)  # 10 ft from (300, 0, 5)
    truck = _box(150.0, 2.0, half_u=4.0, half_v=10.0)
    boxes = (near, truck)
    with pytest.warns(InfeasibleClearanceWarning):
        res = simulate_avoid(BC, _field(boxes), boxes, config=SIM, avoid=BEST_EFFORT)
    assert res.extras["feasible"] is False
    assert _dist(res.positions, (truck,)).min() >= FAST.clearance_ft
    assert _dist(res.positions, (near,)).min() >= 8.0


def test_fly_reports_infeasible_layout_in_metrics():
    vehicles = tuple(
        v.__class__(v.name, (v.centre[0] + 12.0, v.centre[1]), v.size, v.n_points)
        for v in REPORT_VEHICLES
    )  # vehicle 1 moved to 10 ft from the touch-down point
    case = synthetic_case(vehicles)
    run = fly(
        case, "avoid", config=SimulationConfig(guidance_interval=0.5),
        avoid=AvoidConfig(n_samples=24, n_basis=4, replan_interval=50.0),
    )  # fmt: skip
    assert run.metrics["feasible"] is False
    assert any("no trajectory to the touch-down keeps" in w for w in run.warnings)
    # it does not land 10 ft from vehicle 1: it holds short, clear of every vehicle
    assert run.metrics["outcome"] in ("hover", "go-around")
    assert run.metrics["manoeuvre"]["kind"] in MANOEUVRES
    assert run.metrics["min_true_obstacle_distance_ft"] >= 20.0


def test_layout_sweep_names_the_infeasible_layout():
    grid = dict(shift_grid_layouts())
    layouts = [(n, grid[n]) for n in ("shift(+0,+0)", "shift(+10,+0)")]
    out = layout_sweep(
        layouts, config=SimulationConfig(guidance_interval=0.5),
        avoid=AvoidConfig(n_samples=24, n_basis=4, replan_interval=50.0),
    )  # fmt: skip
    s = out["summary"]
    assert s["layouts"] == 2 and s["feasible"] == 1 and not s["failed"]
    assert s["fraction_feasible_keeping_clearance"] == 1.0
    assert [r["layout"] for r in s["infeasible"]] == ["shift(+10,+0)"]
    assert s["infeasible"][0]["touchdown_extent_clearance_ft"] < 20.0
    assert s["worst_true_clearance_feasible_ft"] >= 20.0


def test_layout_generators_are_seeded_and_beside_the_runway():
    grid = shift_grid_layouts()
    assert len(grid) == 9 and grid[4][0] == "shift(+0,+0)"
    a, b = random_layouts(20, seed=5), random_layouts(20, seed=5)
    assert len(a) == 20 and a == b and a != random_layouts(20, seed=6)
    for _, vs in a:
        for v in vs:
            assert abs(v.centre[0] - 714) <= 3 or abs(v.centre[0] - 766) <= 3


@pytest.mark.parametrize(
    "kw",
    [{"clearance_ft": 0.0}, {"max_load_factor": 1.0}, {"max_phi_deg": 95.0}, {"n_samples": 2}],
)
def test_bad_avoid_config(kw):
    with pytest.raises(ValueError):
        AvoidConfig(**kw)
