import numpy as np
import pytest

from follicle import HairCurves, InputError


def _two_curves():
    a = np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0]], dtype=np.float32)
    b = np.array([[1, 0, 0], [1, 0, 1]], dtype=np.float32)
    return HairCurves.from_polylines(
        [a, b],
        point_data={"width": np.array([3, 2, 1, 5, 4], np.float32)},
        curve_data={"hair_id": np.array([10, 11])},
    )


def test_from_polylines_builds_offsets_and_counts():
    c = _two_curves()
    assert c.offsets.tolist() == [0, 3, 5]
    assert c.counts.tolist() == [3, 2]
    assert c.points.dtype == np.float32 and c.offsets.dtype == np.int64
    assert len(c) == 2 and c.point_count == 5
    np.testing.assert_array_equal(c.curve(1), [[1, 0, 0], [1, 0, 1]])
    assert c.curve_index().tolist() == [0, 0, 0, 1, 1]


def test_from_array_and_as_array_roundtrip():
    arr = np.arange(2 * 4 * 3, dtype=np.float32).reshape(2, 4, 3)
    c = HairCurves.from_array(arr)
    assert c.offsets.tolist() == [0, 4, 8]
    assert c.uniform_count() == 4
    np.testing.assert_array_equal(c.as_array(), arr)
    assert _two_curves().uniform_count() is None
    with pytest.raises(InputError, match="resample"):
        _two_curves().as_array()


def test_bounds_of_vertices():
    lo, hi = _two_curves().bounds()
    assert lo.tolist() == [0, 0, 0] and hi.tolist() == [1, 2, 1]


def test_indexing_by_int_slice_array_and_mask_carries_attributes():
    c = _two_curves()
    one = c[1]
    assert one.counts.tolist() == [2]
    assert one.point_data["width"].tolist() == [5, 4]
    assert one.curve_data["hair_id"].tolist() == [11]
    assert c[-1] == one
    rev = c[[1, 0]]
    assert rev.point_data["width"].tolist() == [5, 4, 3, 2, 1]
    assert rev.offsets.tolist() == [0, 2, 5]
    assert c[np.array([False, True])] == one
    assert c[0:1].counts.tolist() == [3]
    assert c[[]].curve_count == 0
    with pytest.raises(IndexError):
        c[2]


def test_concatenate_shifts_offsets_and_joins_attributes():
    c = _two_curves()
    both = HairCurves.concatenate([c, c[1]])
    assert both.offsets.tolist() == [0, 3, 5, 7]
    assert both.curve_data["hair_id"].tolist() == [10, 11, 11]
    assert both[2] == c[1]
    with pytest.raises(InputError, match="attributes"):
        HairCurves.concatenate([c, HairCurves.from_array(np.zeros((1, 2, 3)))])


@pytest.mark.parametrize(
    ("points", "offsets", "message"),
    [
        (np.zeros((4, 2)), [0, 4], r"shape \(P, 3\)"),
        (np.zeros((4, 3)), [0, 1, 4], "curve 0 has 1 vertices"),
        (np.zeros((4, 3)), [0, 3], "end at the point count 4"),
        (np.zeros((4, 3)), [1, 4], "start at 0"),
        (np.array([[0, 0, 0], [np.nan, 0, 0]]), [0, 2], "vertex 1 is not finite"),
        (np.zeros((4, 3)), [0, 3, 2, 4], "vertices"),
    ],
)
def test_validation_rejects_bad_arrays(points, offsets, message):
    with pytest.raises(InputError, match=message):
        HairCurves(points, offsets)


def test_validation_rejects_bad_attribute_lengths_and_nan():
    pts = np.zeros((4, 3))
    with pytest.raises(InputError, match=r"point_data\['width'\]: expected 4 rows"):
        HairCurves(pts, [0, 4], point_data={"width": np.ones(3)})
    with pytest.raises(InputError, match=r"curve_data\['hair_id'\]: expected 1 rows"):
        HairCurves(pts, [0, 4], curve_data={"hair_id": np.ones(2)})
    with pytest.raises(InputError, match="NaN"):
        HairCurves(pts, [0, 4], point_data={"width": np.array([1, np.nan, 1, 1])})


def test_repr_is_informative():
    text = repr(_two_curves())
    assert "2 curves" in text and "5 points" in text and "2–3 vertices" in text
    assert "width" in text and "hair_id" in text


def test_with_points_and_copy_are_independent():
    c = _two_curves()
    d = c.copy()
    d.points[0, 0] = 9
    assert c.points[0, 0] == 0
    moved = c.with_points(c.points + 1)
    assert moved.points[0].tolist() == [1, 1, 1]
    assert moved.point_data["width"] is c.point_data["width"]


def test_replaced_swaps_curves_in_place_or_rebuilt():
    def curves(counts, base):
        pts = [base + np.arange(n * 3, dtype=np.float32).reshape(n, 3) for n in counts]
        c = HairCurves.from_polylines(pts)
        c.point_data["width"] = np.full(c.point_count, base, np.float32)
        c.curve_data["hair_id"] = np.arange(len(counts)) + int(base)
        return c

    a = curves([2, 3, 4, 2], 0.0)
    same = a.replaced([1, 3], curves([3, 2], 100.0))  # the same vertex counts
    assert np.array_equal(same.offsets, a.offsets)
    assert np.array_equal(same.curve(1), curves([3], 100.0).curve(0))
    assert np.array_equal(same.curve(0), a.curve(0)) and np.array_equal(same.curve(2), a.curve(2))
    assert same.point_data["width"][a.offsets[3] :].tolist() == [100.0, 100.0]
    assert same.curve_data["hair_id"].tolist() == [0, 100, 2, 101]
    assert np.array_equal(a.curve(1), curves([2, 3], 0.0).curve(1))  # a is untouched
    with pytest.raises(InputError, match="vertex counts"):
        a.replaced([0, 2], curves([5, 2], 50.0))
    with pytest.raises(InputError, match="ascending"):
        a.replaced([3, 1], curves([2, 3], 0.0))
    with pytest.raises(InputError, match="expected 2"):
        a.replaced([1], curves([2, 3], 0.0))
