import numpy as np
import pytest

from geogait.gaits import FourierGait, Perturbation, seed_gait


def random_gait(rng, n_joints=3, order=3):
    return FourierGait(rng.normal(size=(n_joints, 2 * order + 1)) / np.arange(1, 2 * order + 2))


def test_params_round_trip_and_layout(rng):
    gait = random_gait(rng)
    again = FourierGait.from_params(gait.params, gait.n_joints)
    assert again == gait and again.order == 3 and gait.params.size == 3 * 7
    phase = 0.7
    a0, a, b = gait.coefficients[:, 0], gait.coefficients[:, 1:4], gait.coefficients[:, 4:]
    k = np.arange(1, 4)
    expected = a0 + (a * np.cos(k * phase)).sum(1) + (b * np.sin(k * phase)).sum(1)
    np.testing.assert_allclose(gait.shape(phase), expected)


def test_derivatives_match_finite_differences(rng):
    gait = random_gait(rng)
    phase = rng.uniform(0, 2 * np.pi, 25)
    h = 1e-5
    np.testing.assert_allclose(gait.velocity(phase), (gait.shape(phase + h) - gait.shape(phase - h)) / (2 * h),
                               atol=1e-8)
    np.testing.assert_allclose(gait.acceleration(phase),
                               (gait.velocity(phase + h) - gait.velocity(phase - h)) / (2 * h), atol=1e-8)
    assert gait.shape(np.zeros((4, 5))).shape == (4, 5, 3)


def test_joint_limit_matches_closed_form_and_dense_grid(rng):
    first = FourierGait(np.array([[0.2, 0.6, -0.8], [-0.1, 0.3, 0.4]]))
    np.testing.assert_allclose(first.joint_limit(), [0.2 + 1.0, 0.1 + 0.5], rtol=1e-12)
    gait = random_gait(rng)
    dense = np.abs(gait.shape(np.linspace(0, 2 * np.pi, 200001))).max(axis=0)
    np.testing.assert_allclose(gait.joint_limit(), dense, rtol=1e-9)
    assert np.all(gait.joint_limit() >= dense - 1e-12)


@pytest.mark.parametrize(("n_joints", "lag"), [(2, np.pi / 2), (4, np.pi / 2), (8, np.pi / 4)])
def test_seed_gait_has_equal_phase_lags(n_joints, lag):
    gait = seed_gait(n_joints, amplitude=0.9)
    phase = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    for j in range(n_joints):
        np.testing.assert_allclose(gait.shape(phase)[:, j], 0.9 * np.cos(phase - j * lag), atol=1e-12)


def test_from_shapes_recovers_coefficients(rng):
    gait = random_gait(rng, order=2)
    phase = rng.uniform(0, 2 * np.pi, 300)
    np.testing.assert_allclose(FourierGait.from_shapes(phase, gait.shape(phase), 2).coefficients,
                               gait.coefficients, atol=1e-12)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: FourierGait(np.zeros((2, 2))), "'coefficients'"),
        (lambda: FourierGait(np.full((2, 3), np.nan)), "'coefficients'.*finite"),
        (lambda: FourierGait.from_params(np.zeros(5), 2), "'params'"),
        (lambda: seed_gait(0), "'n_joints'"),
        (lambda: seed_gait(2, amplitude=-1), "'amplitude'"),
        (lambda: Perturbation(alpha=0), "'alpha'"),
        (lambda: Perturbation(beta=-1), "'beta'"),
        (lambda: Perturbation(eta=np.nan), "'eta'"),
    ],
)
def test_bad_input_names_the_field(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_sde_stationary_variance_matches_closed_form():
    sde = Perturbation(alpha=3.0, beta=40.0, eta=2.0)
    delta, rate = sde.sample(40000, 0.02, 1, np.random.default_rng(1), size=(8,))
    # Closed form of the Lyapunov equation: Var δ = η²/(2αβ), Var δ̇ = η²/(2α), Cov(δ, δ̇) = 0.
    np.testing.assert_allclose(delta.var(), 2.0**2 / (2 * 3 * 40), rtol=0.03)
    np.testing.assert_allclose(rate.var(), 2.0**2 / (2 * 3), rtol=0.03)
    assert abs(np.mean(delta * rate)) < 0.03 * np.sqrt(delta.var() * rate.var())


def test_sde_exact_discretisation_is_step_size_consistent():
    # Two steps of dt equal one step of 2 dt in law: same transition and covariance.
    sde = Perturbation(alpha=5.0, beta=30.0, eta=1.5)
    (f1, l1), (f2, l2) = sde.discretize(0.05), sde.discretize(0.1)
    np.testing.assert_allclose(f1 @ f1, f2, atol=1e-12)
    np.testing.assert_allclose(f1 @ (l1 @ l1.T) @ f1.T + l1 @ l1.T, l2 @ l2.T, atol=1e-12)
    # Small steps agree with the Euler–Maruyama covariance η² dt on δ̇.
    _, small = sde.discretize(1e-6)
    np.testing.assert_allclose((small @ small.T)[1, 1], 1.5**2 * 1e-6, rtol=1e-4)


def test_sde_is_seeded_and_streamable():
    sde = Perturbation.from_std(0.1)
    a = sde.sample(300, 0.01, 2, np.random.default_rng(7))
    b = sde.sample(300, 0.01, 2, np.random.default_rng(7))
    np.testing.assert_array_equal(a[0], b[0])
    still = Perturbation(eta=0).sample(50, 0.01, 2, np.random.default_rng(0), initial_state=np.zeros((2, 2)))
    assert np.abs(still[0]).max() == 0
    std = Perturbation.from_std(0.3).stationary_std[0]
    assert std == pytest.approx(0.3)


def test_sde_sample_by_sample_equals_whole_array():
    sde = Perturbation.from_std(0.2)
    delta, rate = sde.sample(120, 0.01, 3, np.random.default_rng(11))
    rng = np.random.default_rng(11)
    stream = sde.stream(0.01, 3, rng)
    white = rng.standard_normal((120, 3, 2))
    one_by_one = np.concatenate([stream.run(white[n:n + 1]) for n in range(120)])
    np.testing.assert_allclose(one_by_one[..., 0], delta, atol=1e-15)
    np.testing.assert_allclose(one_by_one[..., 1], rate, atol=1e-15)
