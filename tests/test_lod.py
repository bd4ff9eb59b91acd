"""Hair level of detail (follicle.render.lod): a nested, stable subset of the hairs,
widened so that the summed width is kept, at a fraction chosen from screen size."""

from __future__ import annotations

import numpy as np
import pytest

from follicle.curves import HairCurves
from follicle.errors import InputError
from follicle.render.camera import Camera
from follicle.render.lod import keep_mask, lod_fraction, thin_out

N = 10_000
FRACTIONS = (0.01, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9, 0.99)


def _curves(n=N, vertices=4, ids=None, width=1e-4, profile=None):
    """``n`` straight hairs in the z = 0 plane, ``vertices`` each, all of one width profile:
    ``width`` (None: no width) times ``profile`` (per vertex; default all 1)."""
    rng = np.random.default_rng(7)
    roots = np.concatenate([rng.uniform(-0.1, 0.1, (n, 2)), np.zeros((n, 1))], axis=1)
    steps = np.linspace(0.0, 0.05, vertices)[None, :, None] * np.array([0.0, -1.0, 0.0])
    pts = (roots[:, None, :] + steps).reshape(-1, 3)
    point_data = {}
    if width is not None:
        profile = np.ones(vertices) if profile is None else np.asarray(profile)
        point_data["width"] = np.tile(width * profile, n).astype(np.float32)
    curve_data = {} if ids is None else {"hair_id": np.asarray(ids)}
    return HairCurves(pts, np.arange(n + 1) * vertices, point_data, curve_data)


def test_masks_are_nested_over_a_sweep_of_fractions():
    curves = _curves(ids=np.arange(N) * 7 + 3)
    masks = [keep_mask(curves, f) for f in FRACTIONS]
    for small, large in zip(masks, masks[1:], strict=False):
        assert not np.any(small & ~large)  # kept at f, kept at every f' > f
    assert keep_mask(curves, 1.0).all()


def test_kept_share_follows_the_fraction():
    curves = _curves()
    for f in FRACTIONS:
        share = keep_mask(curves, f).mean()
        assert abs(share - f) < 0.015, (f, share)


def test_mask_follows_hair_ids_not_order_or_chunks():
    ids = np.random.default_rng(1).permutation(10 * N)[:N]
    curves = _curves(ids=ids)
    mask = keep_mask(curves, 0.3)
    order = np.random.default_rng(2).permutation(N)
    assert np.array_equal(keep_mask(curves[order], 0.3), mask[order])
    halves = [curves[: N // 2], curves[N // 2 :]]
    joined = HairCurves.concatenate(halves)
    parts = np.concatenate([keep_mask(h, 0.3) for h in halves])
    assert np.array_equal(keep_mask(joined, 0.3), parts)
    assert np.array_equal(parts, mask)


def test_strands_of_one_fibre_go_together():
    ids = np.repeat(np.arange(N // 4), 4)  # four strands per hair
    mask = keep_mask(_curves(ids=ids), 0.4).reshape(-1, 4)
    assert np.all(mask == mask[:, :1])
    assert 0.37 < mask[:, 0].mean() < 0.43


def test_without_hair_id_the_curve_index_is_the_key():
    assert np.array_equal(keep_mask(_curves(), 0.5), keep_mask(_curves(ids=np.arange(N)), 0.5))


def test_at_least_one_hair_is_kept():
    curves = _curves(3, ids=[10, 11, 12])
    mask = keep_mask(curves, 1e-9)
    assert mask.sum() == 1
    assert np.all(keep_mask(curves, 0.5) >= mask)  # still nested
    assert keep_mask(_curves(0), 0.5).shape == (0,)


def test_thin_out_preserves_the_summed_width():
    curves = _curves(ids=np.arange(N) + 1000, profile=[1.0, 0.9, 0.7, 0.4])
    total = curves.point_data["width"].astype(np.float64).sum()
    for f in (0.05, 0.25, 0.6):
        thin = thin_out(curves, f)
        keep = keep_mask(curves, f)
        assert thin.curve_count == keep.sum() < N
        assert np.array_equal(thin.curve_data["hair_id"], curves.curve_data["hair_id"][keep])
        assert thin.point_data["width"].dtype == curves.point_data["width"].dtype
        got = thin.point_data["width"].astype(np.float64).sum()
        assert abs(got / total - 1.0) < 1e-5, (f, got / total)


def test_thin_out_without_width_uses_the_default():
    curves = _curves(width=None)
    thin = thin_out(curves, 0.25, default_width=8e-5)
    expected = 8e-5 * N / thin.curve_count
    np.testing.assert_allclose(thin.point_data["width"], expected, rtol=1e-6)
    assert "width" not in curves.point_data


def test_fraction_one_is_the_identity():
    curves = _curves()
    assert thin_out(curves, 1.0) is curves
    assert thin_out(curves, 1) is curves


def _seen(distance: float, width: float = 1e-4) -> float:
    cam = Camera((0.0, 0.0, distance), (0.0, 0.0, 0.0), fov_y=30.0)
    return lod_fraction(_curves(width=width), cam, (640, 480), min_fraction=0.01)


def test_lod_fraction_halves_when_the_camera_is_twice_as_far():
    near, far = _seen(2.0), _seen(4.0)
    assert 0.02 < far < near < 1.0
    assert far == pytest.approx(near / 2, rel=1e-6)
    cam = Camera((0.0, 0.0, 2.0), (0.0, 0.0, 0.0), fov_y=30.0)
    px = np.median(_curves().point_data["width"]) / (cam.pixel_scale(480) * 2.0)
    assert near == pytest.approx(px, rel=1e-6)
    assert _seen(1000.0) == 0.01  # clamped at min_fraction


def test_lod_fraction_is_one_for_wide_hair_and_ignores_hair_behind():
    assert _seen(0.5, width=1e-3) == 1.0  # several pixels wide
    cam = Camera((0.0, 0.0, 2.0), (0.0, 0.0, 0.0), fov_y=30.0)
    front, behind = _curves(), _curves(width=1.0).with_points(_curves().points + [0, 0, 5.0])
    both = HairCurves.concatenate([front, behind])
    assert lod_fraction(both, cam, (640, 480)) == lod_fraction(front, cam, (640, 480)) < 0.5
    assert lod_fraction(behind, cam, (640, 480)) == 1.0


def test_lod_fraction_samples_a_large_groom_evenly():
    cam = Camera((0.0, 0.0, 2.0), (0.0, 0.0, 0.0))
    # a wide root and three thin vertices: a stride in step with the 4 vertices a hair
    # would see only roots (or only tips); the median vertex is a thin one
    curves = _curves(200_000, profile=[1.0, 0.1, 0.1, 0.1])  # 800 k vertices
    thin_px = 1e-5 / (cam.pixel_scale(480) * 2.0)
    assert lod_fraction(curves, cam, (640, 480), min_fraction=0.001) == pytest.approx(thin_px)
    # varied widths: the sample's median is the groom's to within a few per cent
    curves = _curves(200_000)
    w = np.random.default_rng(3).uniform(0.5e-4, 1.5e-4, curves.point_count)
    curves.point_data["width"] = w.astype(np.float32)
    px = np.median(w) / (cam.pixel_scale(480) * 2.0)
    assert lod_fraction(curves, cam, (640, 480), min_fraction=0.001) == pytest.approx(px, rel=0.03)


@pytest.mark.parametrize("fraction", [0, -0.1, 1.5, float("nan"), True, "0.5", None])
def test_bad_fraction_is_refused(fraction):
    with pytest.raises(InputError, match="fraction"):
        keep_mask(_curves(10), fraction)
    with pytest.raises(InputError, match="fraction"):
        thin_out(_curves(10), fraction)


def test_bad_arguments_are_refused():
    curves, cam = _curves(10), Camera((0.0, 0.0, 2.0), (0.0, 0.0, 0.0))
    with pytest.raises(InputError, match="curves"):
        keep_mask(np.zeros((4, 3)), 0.5)
    with pytest.raises(InputError, match="hair_id"):
        keep_mask(_curves(10, ids=np.linspace(0, 1, 10)), 0.5)
    with pytest.raises(InputError, match="default_width"):
        thin_out(curves, 0.5, default_width=0.0)
    with pytest.raises(InputError, match="max_width_px"):
        lod_fraction(curves, cam, (64, 64), max_width_px=0.0)
    for bad in (0.0, 1.5):
        with pytest.raises(InputError, match="min_fraction"):
            lod_fraction(curves, cam, (64, 64), min_fraction=bad)
    with pytest.raises(InputError, match="camera"):
        lod_fraction(curves, "camera", (64, 64))
    for size in ((64,), (64, 0), 64, (64.5, 64)):
        with pytest.raises(InputError, match="size"):
            lod_fraction(curves, cam, size)
