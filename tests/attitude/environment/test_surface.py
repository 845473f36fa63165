"""Surface model: plate geometry, the box and panel constructors, and the argument checks.

What each group checks against (derivations in docs/environment_torques.md):

* Geometry by hand: normals stored as unit vectors, a cuboid's six faces (area of each face = product
  of the two other edges, centre at half the edge along the normal, shifted by the centre-of-pressure
  offset), two-sided panels as two opposite plates.
* Immutability: the dataclass is frozen and its arrays read-only (a model shared between runs
  cannot be changed by one of them).
* Bad input (DESIGN.md, issue #11): each error names the argument with the plate index, the rule and
  the value.
"""

import numpy as np
import pytest

from attitude.environment.surface import DEFAULT_DRAG_COEFFICIENT, SurfaceModel


def one_plate(**kwargs):
    values = {"area_m2": [1.0], "normal_B": [[0.0, 0.0, 1.0]], "centre_of_pressure_B_m": [[0.0, 0.0, 0.0]]}
    values.update(kwargs)
    return SurfaceModel(**values)


def test_normals_are_normalised_and_scalars_broadcast():
    # A normal of length 5 = 3-4-5 triangle: the unit normal is [0.6, 0.8, 0] exactly in binary to 1 ulp.
    s = SurfaceModel(
        area_m2=[1.0, 2.0],
        normal_B=[[3.0, 4.0, 0.0], [0.0, 0.0, -2.0]],
        centre_of_pressure_B_m=[[0.1, 0.0, 0.0], [0.0, 0.0, -0.3]],
        specular=0.25,
        diffuse=[0.5, 0.1],
    )
    np.testing.assert_allclose(s.normal_B, [[0.6, 0.8, 0.0], [0.0, 0.0, -1.0]], rtol=0, atol=1e-16)
    assert s.n_plates == 2
    np.testing.assert_array_equal(s.specular, [0.25, 0.25])
    np.testing.assert_array_equal(s.drag_coefficient, [DEFAULT_DRAG_COEFFICIENT] * 2)
    np.testing.assert_array_equal(s.residual_dipole_Am2, [0.0, 0.0, 0.0])
    # absorbed = 1 - specular - diffuse by hand: 0.25 and 0.65 (0.65 to rounding of the subtraction).
    np.testing.assert_allclose(s.absorbed, [0.25, 0.65], rtol=0, atol=1e-15)


def test_box_faces_by_hand():
    # Edges 1 x 2 x 3 m: the x faces are 2 x 3 = 6 m^2, the y faces 1 x 3 = 3 m^2, the z faces 1 x 2 = 2 m^2;
    # face centres at +-0.5, +-1, +-1.5 m along their normals, shifted by the offset.
    offset = np.array([0.01, -0.02, 0.03])
    s = SurfaceModel.box([1.0, 2.0, 3.0], specular=0.1, diffuse=0.2, centre_of_pressure_offset_B_m=offset)
    np.testing.assert_array_equal(s.area_m2, [6.0, 6.0, 3.0, 3.0, 2.0, 2.0])
    expected_normals = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)
    np.testing.assert_array_equal(s.normal_B, expected_normals)
    expected_cop = np.array([[0.5, 0, 0], [-0.5, 0, 0], [0, 1.0, 0], [0, -1.0, 0], [0, 0, 1.5], [0, 0, -1.5]]) + offset
    np.testing.assert_array_equal(s.centre_of_pressure_B_m, expected_cop)
    np.testing.assert_array_equal(s.specular, [0.1] * 6)
    text = s.describe()
    assert "6 plates" in text and "22 m^2" in text


def test_with_panels_adds_front_and_back():
    body = SurfaceModel.box([1.0, 1.0, 1.0], residual_dipole_Am2=[0.0, 0.0, 0.05])
    s = body.with_panels(2.0, [0.0, 1.0, 0.0], [0.0, 1.5, 0.0], specular=0.05, diffuse=0.1, back_diffuse=0.6)
    assert s.n_plates == 8
    np.testing.assert_array_equal(s.normal_B[6:], [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]])
    np.testing.assert_array_equal(s.centre_of_pressure_B_m[6:], [[0.0, 1.5, 0.0], [0.0, 1.5, 0.0]])
    np.testing.assert_array_equal(s.diffuse[6:], [0.1, 0.6])
    np.testing.assert_array_equal(s.specular[6:], [0.05, 0.05])
    np.testing.assert_array_equal(s.residual_dipole_Am2, [0.0, 0.0, 0.05])


def test_frozen_and_read_only():
    s = one_plate()
    with pytest.raises(AttributeError):
        s.area_m2 = np.array([2.0])  # type: ignore[misc]
    with pytest.raises(ValueError):
        s.normal_B[0, 0] = 1.0
    assert s == one_plate() and s != one_plate(area_m2=[2.0])


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"normal_B": [[0.0, 0.0, 0.0]]}, ["normal_B[0]", "non-zero", "[0. 0. 0.]"]),
        ({"area_m2": [-1.5]}, ["area_m2[0]", "non-negative", "-1.5"]),
        ({"specular": [1.2]}, ["specular[0]", "[0, 1]", "1.2"]),
        ({"diffuse": -0.1}, ["diffuse[0]", "[0, 1]", "-0.1"]),
        ({"specular": 0.7, "diffuse": 0.4}, ["specular[0] + diffuse[0]", "<= 1", "0.7", "0.4"]),
        ({"drag_coefficient": -2.2}, ["drag_coefficient[0]", "non-negative", "-2.2"]),
        ({"area_m2": [1.0, 1.0]}, ["normal_B", "(2, 3)"]),
        ({"specular": [0.1, 0.2]}, ["specular", "(1,)"]),
        ({"residual_dipole_Am2": [1.0, 2.0]}, ["residual_dipole_Am2", "(..., 3)"]),
        ({"area_m2": [np.nan]}, ["area_m2", "finite"]),
    ],
)
def test_bad_plates_name_argument_index_rule_and_value(kwargs, words):
    with pytest.raises(ValueError) as info:
        one_plate(**kwargs)
    for word in words:
        assert word in str(info.value), (word, str(info.value))


def test_bad_plate_index_is_the_offending_one():
    # The second of three plates is the bad one: the message must say [1], not [0].
    with pytest.raises(ValueError, match=r"normal_B\[1\]"):
        SurfaceModel([1.0, 1.0, 1.0], [[1, 0, 0], [0, 0, 0], [0, 0, 1]], np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"specular\[2\] \+ diffuse\[2\]"):
        SurfaceModel([1.0] * 3, np.eye(3), np.zeros((3, 3)), specular=[0, 0, 0.9], diffuse=[1, 0, 0.2])


@pytest.mark.parametrize(
    ("size", "words"),
    [([1.0, 0.0, 1.0], ["size_m[1]", "strictly positive", "0.0"]), ([1.0, 1.0], ["size_m", "(..., 3)"])],
)
def test_bad_box(size, words):
    with pytest.raises(ValueError) as info:
        SurfaceModel.box(size)
    for word in words:
        assert word in str(info.value)


def test_bad_panel_is_checked_in_the_combined_model():
    body = SurfaceModel.box([1.0, 1.0, 1.0])
    # Panel front faces are plates 6.. of the combined model: the index names the combined plate.
    with pytest.raises(ValueError, match=r"normal_B\[6\]"):
        body.with_panels(1.0, [0.0, 0.0, 0.0], [0.0, 1.0, 0.0])
