import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.linalg import expm, logm

from geogait import GeogaitError, se2

finite = st.floats(-3.0, 3.0, allow_nan=False)
twists = arrays(float, (3,), elements=finite)


def matrix(pose):
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return np.array([[c, -s, pose[0]], [s, c, pose[1]], [0, 0, 1]])


@given(twists)
@settings(max_examples=200, deadline=None)
def test_log_inverts_exp(twist):
    np.testing.assert_allclose(se2.log(se2.exp(twist)), twist, atol=1e-9)


@given(twists)
@settings(max_examples=100, deadline=None)
def test_exp_matches_matrix_exponential(twist):
    np.testing.assert_allclose(matrix(se2.exp(twist)), expm(se2.hat(twist)), atol=1e-12)


@given(arrays(float, (3,), elements=st.floats(-1e-6, 1e-6)))
def test_exp_series_branch_near_zero_rotation(twist):
    np.testing.assert_allclose(matrix(se2.exp(twist)), expm(se2.hat(twist)), atol=1e-15)


def test_log_matches_matrix_logarithm(rng):
    for twist in rng.uniform(-2, 2, size=(20, 3)):
        np.testing.assert_allclose(se2.log(se2.exp(twist)), se2.vee(np.real(logm(matrix(se2.exp(twist))))),
                                   atol=1e-9)


def test_compose_inverse_and_between_are_matrix_products(rng):
    a, b = rng.normal(size=(2, 50, 3))
    for i in range(50):
        np.testing.assert_allclose(matrix(se2.compose(a[i], b[i])), matrix(a[i]) @ matrix(b[i]), atol=1e-12)
        np.testing.assert_allclose(matrix(se2.inverse(a[i])), np.linalg.inv(matrix(a[i])), atol=1e-12)
    np.testing.assert_allclose(se2.compose(a, se2.between(a, b)), b, atol=1e-12)


def test_adjoint_and_bracket_match_matrix_definitions(rng):
    pose, x, y = rng.normal(size=(3, 3))
    g = matrix(pose)
    np.testing.assert_allclose(se2.adjoint(pose) @ x, se2.vee(g @ se2.hat(x) @ np.linalg.inv(g)), atol=1e-12)
    commutator = se2.hat(x) @ se2.hat(y) - se2.hat(y) @ se2.hat(x)
    np.testing.assert_allclose(se2.bracket(x, y), se2.vee(commutator), atol=1e-12)
    assert np.allclose(se2.hat(se2.vee(commutator)), commutator)


def test_integration_equals_product_of_exponentials(rng):
    xi = rng.normal(size=(2, 40, 3))
    dt = 0.05
    poses = se2.integrate_body_velocity(xi, dt, initial_pose=[0.3, -0.2, 1.0])
    for trial in range(2):
        g = matrix([0.3, -0.2, 1.0])
        for n in range(40):
            g = g @ expm(se2.hat(xi[trial, n] * dt))
        np.testing.assert_allclose(matrix(poses[trial, -1]), g, atol=1e-12)
    assert poses.shape == (2, 41, 3)


def test_constant_twist_traces_an_exact_circle():
    # Unit forward speed with unit turn rate: a circle of radius 1 back to the start after 2π.
    n = 7  # coarse steps are still exact for a constant twist
    poses = se2.integrate_body_velocity(np.tile([1.0, 0.0, 1.0], (n, 1)), 2 * np.pi / n)
    np.testing.assert_allclose(poses[-1], [0, 0, 2 * np.pi], atol=1e-12)
    np.testing.assert_allclose(np.hypot(poses[:, 0], poses[:, 1] - 1), 1.0, atol=1e-12)


@pytest.mark.parametrize(("call", "match"), [
    (lambda: se2.exp([1.0, 2.0, 3.0, 4.0]), "'twist' parameter of exp must be an array of shape \\(..., 3\\)"),
    (lambda: se2.log([1.0, 2.0, 3.0, 4.0]), "'pose' parameter of log"),
    (lambda: se2.compose([1.0, 2.0], [0.0, 0.0, 0.0]), "'first' parameter of compose"),
    (lambda: se2.hat([1.0, 2.0]), "'twist' parameter of hat"),
    (lambda: se2.vee(np.eye(2)), "'matrix' parameter of vee must be an array of shape \\(..., 3, 3\\)"),
    (lambda: se2.integrate_body_velocity(np.ones((5, 3)), np.nan), "'dt' parameter .* finite"),
    (lambda: se2.integrate_body_velocity(np.ones((5, 3)), -0.1), "'dt' parameter .* durations >= 0"),
    (lambda: se2.integrate_body_velocity(np.ones((5, 3)), np.ones(3)), "'dt' parameter .* broadcasts"),
    (lambda: se2.integrate_body_velocity(np.ones((5, 3)), 0.1, initial_pose=[np.nan, 0, 0]), "'initial_pose'"),
    (lambda: se2.displacement(np.ones((5, 2)), 0.1), "'body_velocity' parameter of displacement"),
])
def test_group_operations_refuse_what_is_not_a_twist_or_pose(call, match):
    """A 4th entry was silently ignored, a 2-vector an IndexError, a NaN or negative dt NaN or reversed poses."""
    with pytest.raises(GeogaitError, match=match):
        call()
