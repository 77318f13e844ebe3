"""Tests of the ground-truth scene renderer (`rangefx.golden.scenes`)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from scipy import ndimage

from rangefx.golden import scenes
from rangefx.golden.geometry import (
    camera_from_inertial,
    camera_points_from_range,
    inertial_from_camera,
)
from rangefx.golden.scenes import (
    SCENE_NAMES,
    Scene,
    frame2_positions,
    render_plane,
    render_scene,
)

SMALL = (96, 96)


@pytest.fixture(scope="module")
def full() -> dict[str, Scene]:
    """Both presets at the report's 512 x 512 resolution, rendered once."""
    return {name: render_scene(name) for name in SCENE_NAMES}


def _points(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """Inertial points of the finite-depth pixels of camera 1 (eqs 32-33) and their mask."""
    xp, yp = scene.camera.pixel_grid()
    finite = np.isfinite(scene.depth1)
    xc = camera_points_from_range(scene.depth1[finite], xp[finite], yp[finite], scene.camera.f_px)
    return inertial_from_camera(scene.motion, xc), finite


def _preset_world(name: str) -> scenes._World:
    return {"lab": scenes._lab_preset, "runway": scenes._runway_preset}[name]().world


# --------------------------------------------------------------------------- determinism


@pytest.mark.parametrize("name", SCENE_NAMES)
def test_same_arguments_give_identical_bytes(name: str) -> None:
    a = render_scene(name, size=SMALL, seed=3)
    b = render_scene(name, size=SMALL, seed=3)
    for field in ("image1", "image2", "depth1", "labels1"):
        x, y = getattr(a, field), getattr(b, field)
        assert x.dtype == y.dtype
        assert x.tobytes() == y.tobytes(), field
    assert a.description == b.description


def test_seed_changes_the_noise_only() -> None:
    a = render_scene("lab", size=SMALL, seed=1)
    b = render_scene("lab", size=SMALL, seed=2)
    assert np.array_equal(a.depth1, b.depth1)
    assert np.array_equal(a.labels1, b.labels1)
    assert not np.array_equal(a.image1, b.image1)
    diff = np.abs(a.image1.astype(int) - b.image1.astype(int))
    assert diff.max() <= 5
    assert abs(diff.mean() - 2 * 0.5 / math.sqrt(math.pi)) < 0.1
    quiet = [render_scene("lab", size=SMALL, seed=s, noise_sigma=0.0) for s in (1, 2)]
    assert np.array_equal(quiet[0].image1, quiet[1].image1)
    assert np.array_equal(quiet[0].image2, quiet[1].image2)


def test_types_shapes_and_read_only() -> None:
    s = render_scene("runway", size=(40, 56), supersample=2)
    assert s.image1.shape == s.image2.shape == s.depth1.shape == s.labels1.shape == (40, 56)
    assert s.image1.dtype == np.uint8 and s.image2.dtype == np.uint8
    assert s.depth1.dtype == np.float64 and s.labels1.dtype == np.int16
    assert (s.kind, s.unit, s.seed) == ("motion", "ft", 0)
    assert [o.label for o in s.objects] == [1, 2, 3, 4, 5]
    with pytest.raises(ValueError):
        s.image1[0, 0] = 1


def test_size_keeps_the_field_of_view() -> None:
    s = render_scene("lab", size=(48, 128), supersample=1)
    assert (s.camera.height, s.camera.width) == (48, 128)
    assert s.camera.f_px == pytest.approx(64 / math.tan(math.radians(22.5)), rel=1e-12)


# --------------------------------------------------------------------------- exact depth


def test_plane_depth_is_exact_and_pair_is_a_pure_shift() -> None:
    depth, f_px = 20.0, 100.0
    baseline = 2.0 * depth / f_px
    s = render_plane(depth=depth, size=(48, 64), f_px=f_px, baseline=baseline, noise_sigma=0.0)
    assert np.all(s.depth1 == depth)
    assert np.all(s.labels1 == 1)
    assert s.objects[0].nominal_range == depth
    diff = np.abs(s.image1[:, 2:].astype(int) - s.image2[:, :-2].astype(int))
    assert diff.max() <= 1
    assert np.mean(diff == 0) > 0.99
    assert s.image1.std() > 10


@pytest.mark.parametrize("name", SCENE_NAMES)
def test_points_lie_on_the_surfaces_that_label_them(name: str) -> None:
    s = render_scene(name, size=SMALL)
    points, finite = _points(s)
    labels = s.labels1[finite]
    depth = s.depth1[finite]
    prims = _preset_world(name).primitives
    dist = np.stack([p.distance(points) for p in prims])
    tol = 1e-9 * depth + 1e-12
    assert np.all(dist.min(axis=0) <= tol)
    for label in np.unique(labels):
        can = np.array([any(label in m.labels() for m in p.materials) for p in prims])
        sel = labels == label
        assert np.all(dist[can][:, sel].min(axis=0) <= tol[sel]), label
    assert np.allclose(camera_from_inertial(s.motion, points)[:, 0], depth, rtol=1e-12)


def test_lab_wall_tape_and_table_depths() -> None:
    s = render_scene("lab", size=SMALL)
    assert np.all(np.isfinite(s.depth1))
    points, _ = _points(s)
    unnamed = (s.labels1 == 0).ravel()
    on_wall = np.abs(points[:, 0] - 60.0) <= 60.0 * 1e-9
    on_table = np.abs(points[:, 2] - 5.0) <= 1e-9 * s.depth1.ravel()
    tape = s.labels1 == 3
    assert tape.sum() > 10
    assert np.allclose(s.depth1[tape], 60.0, rtol=1e-12, atol=0)
    assert on_wall.sum() > 1000 and on_table.sum() > 1000
    # Everything unnamed is wall, table, or the 0.024 in wire between the pencils.
    rest = unnamed & ~on_wall & ~on_table
    assert rest.sum() <= 3 * SMALL[1]
    assert np.all(np.abs(points[rest, 2] + 1.5) < 0.05)


def test_runway_ground_and_sky() -> None:
    s = render_scene("runway", size=SMALL)
    points, finite = _points(s)
    ground = s.labels1[finite] == 0
    assert ground.sum() > 0.4 * s.depth1.size
    depth = s.depth1[finite][ground]
    assert np.all(np.abs(points[ground, 2]) <= 1e-9 * depth)
    sky = ~finite
    assert sky.sum() > 0.1 * s.depth1.size
    rows = np.nonzero(sky.any(axis=1))[0]
    assert rows.max() < SMALL[0] / 2
    assert np.all(s.labels1[sky] == 0)


# --------------------------------------------------------------------------- correspondence


def _correspondence(s: Scene) -> tuple[float, float]:
    """Median |E2(reprojected) - E1| and median |E2 - E1| (no motion) over valid pixels."""
    i2, j2 = frame2_positions(s)
    m, n = s.depth1.shape
    e1 = s.image1.astype(np.float64)
    e2 = s.image2.astype(np.float64)
    inside = (i2 >= 2) & (i2 <= n - 3) & (j2 >= 2) & (j2 <= m - 3)
    d = np.where(np.isfinite(s.depth1), s.depth1, 1e12)
    smooth = ndimage.maximum_filter(d, 5) <= 1.02 * ndimage.minimum_filter(d, 5)
    same = ndimage.maximum_filter(s.labels1, 5) == ndimage.minimum_filter(s.labels1, 5)
    textured = ndimage.generic_gradient_magnitude(e1, ndimage.sobel) > 8
    valid = inside & smooth & same & textured & np.isfinite(s.depth1)
    assert valid.sum() > 1000
    warped = ndimage.map_coordinates(
        e2, [np.nan_to_num(j2), np.nan_to_num(i2)], order=1, mode="nearest"
    )
    return float(np.median(np.abs(warped - e1)[valid])), float(np.median(np.abs(e2 - e1)[valid]))


@pytest.mark.parametrize("name", SCENE_NAMES)
def test_pair_is_geometrically_consistent(full: dict[str, Scene], name: str) -> None:
    reprojected, unmoved = _correspondence(full[name])
    assert reprojected <= 3.0
    assert reprojected < 0.5 * unmoved


def test_frame2_positions_of_stereo_pair_is_horizontal_disparity() -> None:
    s = render_plane(depth=10.0, size=(16, 16), f_px=50.0, baseline=0.2)
    i2, j2 = frame2_positions(s)
    xp, yp = s.camera.pixel_grid()
    cx, cy = s.camera.principal_point
    assert np.allclose(i2, xp + cx - 1.0, atol=1e-12)
    assert np.allclose(j2, yp + cy, atol=1e-12)


# --------------------------------------------------------------------------- the objects


@pytest.mark.parametrize("name", SCENE_NAMES)
def test_nominal_ranges_and_pixel_counts(full: dict[str, Scene], name: str) -> None:
    s = full[name]
    assert len({o.label for o in s.objects}) == len(s.objects)
    assert set(np.unique(s.labels1)) <= {0, *(o.label for o in s.objects)}
    for obj in s.objects:
        sel = s.labels1 == obj.label
        assert sel.sum() >= 100, obj.name
        assert np.median(s.depth1[sel]) == pytest.approx(obj.nominal_range, rel=0.03), obj.name


def test_lab_objects_follow_table_1(full: dict[str, Scene]) -> None:
    s = full["lab"]
    assert [(o.name, o.nominal_range, o.label) for o in s.objects] == [
        ("Left pencil", 30.0, 1),
        ("Right pencil", 26.0, 2),
        ("Tape-on-wall", 60.0, 3),
        ("Soda can", 28.5, 4),
        ("Bracket", 19.0, 5),
    ]
    assert s.kind == "stereo" and s.unit == "in"
    assert np.allclose(s.motion.camera_displacement, [0.0, 0.1, 0.0])


def test_runway_vehicles_have_small_parallax(full: dict[str, Scene]) -> None:
    s = full["runway"]
    names = {o.name: o.nominal_range for o in s.objects}
    assert names["Vehicle 1"] == 356.4 and names["Vehicle 2"] == 607.0
    assert names["Vehicle 3"] == 232.8
    i2, j2 = frame2_positions(s)
    xp, yp = s.camera.pixel_grid()
    cx, cy = s.camera.principal_point
    shift = np.hypot(i2 - xp - cx, j2 - yp - cy)
    for obj in s.objects:
        sel = s.labels1 == obj.label
        assert 0.5 < np.median(shift[sel]) < 3.5, obj.name


# --------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    ("kwargs", "bad"),
    [
        ({"size": (0, 64)}, (0, 64)),
        ({"size": (64,)}, (64,)),
        ({"size": (64.0, 64)}, (64.0, 64)),
        ({"noise_sigma": -0.5}, -0.5),
        ({"noise_sigma": math.nan}, math.nan),
        ({"supersample": 0}, 0),
        ({"supersample": 2.5}, 2.5),
        ({"seed": -1}, -1),
    ],
)
def test_bad_arguments_name_the_value(kwargs: dict, bad: object) -> None:
    with pytest.raises(ValueError, match=re.escape(repr(bad))):
        render_scene("lab", **kwargs)


def test_unknown_scene_lists_valid_names() -> None:
    with pytest.raises(ValueError, match=r"'moon'.*lab, runway") as info:
        render_scene("moon")
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("kwargs", "bad"),
    [
        ({"depth": -1.0}, -1.0),
        ({"depth": 5.0, "baseline": 0.0}, 0.0),
        ({"depth": 5.0, "texture": "lily"}, "lily"),
        ({"depth": 5.0, "noise_sigma": -1.0}, -1.0),
    ],
)
def test_render_plane_validates(kwargs: dict, bad: object) -> None:
    with pytest.raises(ValueError, match=re.escape(repr(bad))):
        render_plane(**kwargs)
