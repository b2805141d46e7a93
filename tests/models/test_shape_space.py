"""The shape-space connection model and the perfect-information model (the optimiser's model interface)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from geogait.gaits import FourierGait, Perturbation, seed_gait
from geogait.models import (
    AdaptiveGaitModel,
    PerfectInformationModel,
    ShapeSpaceModel,
    monomial_exponents,
    monomials,
    predicted_displacement,
    symmetry_blocks,
)
from geogait.simulate import cycle_displacement, simulate
from geogait.systems import FunctionSystem, PurcellSwimmer


def polynomial_connection(shape):
    """A(r) with entries of degree ≤ 2 in (r₀, r₁)."""
    x, y = shape[..., 0], shape[..., 1]
    rows = [[0.1 * x + 0.2 * y * y, 0.3 - 0.1 * x * y], [0.05 + x * x, 0.2 * y], [-0.3 + 0.1 * y, 0.3 + 0.2 * x]]
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def samples(run):
    return run.phase, run.shape, run.shape_velocity, run.body_velocity


def test_monomials_and_their_derivatives(rng):
    exponents = monomial_exponents(3, 3)
    assert exponents.shape == (20, 3) and exponents.sum(axis=1).max() == 3  # C(3 + 3, 3) monomials
    shape = rng.normal(size=(4, 3))
    values, derivative = monomials(shape, exponents, derivative=True)
    np.testing.assert_allclose(values, np.prod(shape[:, None, :] ** exponents, axis=-1))
    step = 1e-6 * np.eye(3)
    numeric = np.stack([(monomials(shape + s, exponents) - monomials(shape - s, exponents)) / 2e-6 for s in step], -1)
    np.testing.assert_allclose(derivative, numeric, atol=1e-8)
    with pytest.raises(ValueError, match="'exponents' parameter of monomials must be exponents closed under"):
        monomials(shape, np.array([[0, 0, 0], [2, 0, 0]]))  # r₀² without r₀


def test_recovers_a_polynomial_connection_exactly():
    system = FunctionSystem(polynomial_connection, n_joints=2)
    run = simulate(system, seed_gait(2), n_cycles=5, perturbation=Perturbation.from_std(0.3), seed=1)
    model = ShapeSpaceModel(degree=2, forgetting_factor=1.0, initial_covariance=1e8).fit(*samples(run))
    shapes = np.random.default_rng(3).normal(size=(7, 2))
    np.testing.assert_allclose(model.connection(shapes), polynomial_connection(shapes), atol=1e-8)
    np.testing.assert_allclose(model.predict_displacement(seed_gait(2)), cycle_displacement(system, seed_gait(2)),
                               atol=1e-8)
    assert model.gamma_ > 0.99 and model.score(*samples(run)) > 0.99


def test_displacement_jacobian_matches_finite_differences(rng):
    run = simulate(PurcellSwimmer(4), seed_gait(3), n_cycles=3, perturbation=Perturbation.from_std(0.2), seed=0)
    model = ShapeSpaceModel(degree=2, shape_scale=2.0).fit(*samples(run))
    gait = FourierGait(seed_gait(3, order=2).coefficients + rng.normal(scale=0.2, size=(3, 5)))
    _, jacobian = model.predict_displacement(gait, jacobian=True)
    numeric = np.stack([(model.predict_displacement(gait.with_params(gait.params + e))
                         - model.predict_displacement(gait.with_params(gait.params - e))) / 2e-6
                        for e in 1e-6 * np.eye(gait.params.size)], axis=-1)
    np.testing.assert_allclose(jacobian, numeric, atol=1e-7)


def test_batched_trials_equal_separate_models():
    run = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=2, seed=[0, 1], sensor_noise=0.1)
    batched = ShapeSpaceModel(degree=2).fit(*samples(run))
    for trial in range(2):
        single = ShapeSpaceModel(degree=2).fit(*(array[trial] for array in samples(run)))
        np.testing.assert_allclose(batched.weights_[trial], single.weights_, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(batched.gamma_[trial], single.gamma_, rtol=1e-10)
        np.testing.assert_allclose(batched.predict_displacement(seed_gait(2))[trial],
                                   single.predict_displacement(seed_gait(2)), atol=1e-12)


@pytest.mark.parametrize("symmetry", [None, "mirror+reversal"])
@pytest.mark.parametrize(("forgetting_factor", "tolerance"), [(0.99, 1e-10), (0.9, 1e-4)])
def test_streaming_equals_one_batch_and_covariance_stays_bounded(symmetry, forgetting_factor, tolerance):
    """Equal to rounding, which the conditioning amplifies: with λ = 0.9 and poor excitation the trace clamp
    acts and cond P ≈ 1e6, so sequential RLS itself is reproducible only to ≈ 1e-6 there."""
    run = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=3, seed=2, sensor_noise=0.1)
    whole = ShapeSpaceModel(degree=3, symmetry=symmetry, forgetting_factor=forgetting_factor).fit(*samples(run))
    parts = ShapeSpaceModel(degree=3, symmetry=symmetry, forgetting_factor=forgetting_factor)
    for start in range(0, 300, 70):
        parts.partial_fit(*(array[start:start + 70] for array in samples(run)))
    scale = np.abs(whole.weights_).max()
    np.testing.assert_allclose(parts.weights_, whole.weights_, rtol=0, atol=tolerance * scale)
    np.testing.assert_allclose(parts.gamma_, whole.gamma_, rtol=tolerance)
    for covariance in whole.covariances_:
        np.testing.assert_array_equal(covariance, covariance.T)
        assert np.linalg.eigvalsh(covariance).min() > 0  # λ = 0.9 with poor excitation: SPD, trace clamped
        assert np.trace(covariance) <= covariance.shape[0] * whole.initial_covariance * (1 + 1e-12)


def test_far_gaits_are_predicted_better_than_by_the_local_model():
    """Trained on two gaits, the shape-space model predicts gaits far from both 2-4× better than the window
    model (rebased onto the second gait, whose local expansion is all it keeps)."""
    swimmer = PurcellSwimmer(3)
    trained = [seed_gait(2), FourierGait(np.array([[0.3, 1.2, 0.0], [-0.2, 0.0, 0.8]]))]
    far = [FourierGait(np.array([[0.0, 1.2, 0.0], [0.0, 0.6, 1.0]])), FourierGait(np.array([[0.4, 1, 0], [0.4, 0, 1]]))]
    for trial in range(2):
        shape_space = ShapeSpaceModel(degree=3, forgetting_factor=1.0)
        local = AdaptiveGaitModel(gait=trained[0], forgetting_factor=0.95)
        for i, gait in enumerate(trained):
            run = simulate(swimmer, gait, n_cycles=10, perturbation=Perturbation.from_std(0.15), sensor_noise=0.1,
                           seed=[trial, i])
            if i:
                local.rebase(gait, terms="all")
            local.partial_fit(*samples(run))
            shape_space.partial_fit(*samples(run))
        for gait in far:
            truth = cycle_displacement(swimmer, gait)
            error = np.linalg.norm(shape_space.predict_displacement(gait) - truth)
            assert error < 0.6 * np.linalg.norm(predicted_displacement(local, gait) - truth)


def test_model_interface_of_the_optimiser():
    run = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=2, seed=0, sensor_noise=0.1)
    model = ShapeSpaceModel(degree=1)
    assert model.partial_fit(*samples(run)) is model
    assert model.get_params()["degree"] == 1 and model.set_params(degree=2) is model and model.degree == 2
    with pytest.raises(ValueError, match="'smoothness' parameter of ShapeSpaceModel"):
        model.set_params(smoothness=1)
    before = model.weights_.copy()
    assert model.rebase(FourierGait(seed_gait(2).coefficients * 1.2), terms="all", covariance_inflation=2.0) is model
    np.testing.assert_array_equal(model.weights_, before)  # nothing to re-centre
    assert model.reset_gamma().gamma_ == 0.0
    with pytest.raises(ValueError, match="'degree' parameter of ShapeSpaceModel must be an int >= 0"):
        ShapeSpaceModel(degree=-1).fit(*samples(run))
    with pytest.raises(ValueError, match="'shape' parameter of ShapeSpaceModel.partial_fit"):
        model.partial_fit(run.phase, run.shape[:, :1], run.shape_velocity, run.body_velocity)


def test_perfect_information_model_is_the_oracle():
    swimmer = PurcellSwimmer(4)
    model = PerfectInformationModel(system=swimmer)
    run = simulate(swimmer, seed_gait(3), n_cycles=1, seed=0)
    assert model.partial_fit(*samples(run)) is model and model.gamma_ == 1.0 and model.reset_gamma() is model
    gait = seed_gait(3)
    pose, jacobian = model.predict_displacement(gait, jacobian=True)
    expected = cycle_displacement(swimmer, gait, resolution=128, jacobian=True)
    np.testing.assert_array_equal(pose, expected[0])
    np.testing.assert_array_equal(jacobian, expected[1])
    np.testing.assert_allclose(model.predict(run.phase, run.shape, run.shape_velocity), run.body_velocity,
                               atol=1e-12)
    assert model.rebase(gait, terms="all") is model
    with pytest.raises(ValueError, match="'system' parameter of PerfectInformationModel"):
        PerfectInformationModel().predict_displacement(gait)


def test_state_round_trip_gives_identical_predictions():
    from geogait.models import model_from_state

    run = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=2, seed=0, sensor_noise=0.1)
    model = ShapeSpaceModel(degree=2).fit(*samples(run))
    copy = model_from_state(*model.get_state())
    assert isinstance(copy, ShapeSpaceModel) and copy.get_params() == model.get_params()
    np.testing.assert_array_equal(copy.predict_displacement(seed_gait(2)), model.predict_displacement(seed_gait(2)))
    assert copy.gamma_ == model.gamma_
    more = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=1, seed=5, sensor_noise=0.1)
    np.testing.assert_array_equal(copy.partial_fit(*samples(more)).weights_, model.partial_fit(*samples(more)).weights_)


MIRROR = np.array([1.0, -1.0, -1.0])  # ξ(−r, −ṙ) = diag(1, −1, −1) ξ(r, ṙ)
REVERSAL = np.array([-1.0, 1.0, -1.0])  # ξ(Pr, Pṙ) = diag(−1, 1, −1) ξ(r, ṙ), P reverses the joints


def symmetrised(connection, n_joints):
    """The average of ``connection`` over the swimmer's symmetry group {1, mirror, reversal, both}."""
    reverse = np.eye(n_joints)[::-1]

    def mirrored(shape):
        return -MIRROR[:, None] * connection(-shape)

    def reversed_(function):
        return lambda shape: REVERSAL[:, None] * function(shape @ reverse) @ reverse

    return lambda shape: (connection(shape) + mirrored(shape) + reversed_(connection)(shape)
                          + reversed_(mirrored)(shape)) / 4


def test_the_purcell_connection_has_the_symmetries_the_basis_assumes(rng):
    """Independent of the model: A(−r) = −M A(r) and A(Pr) P = diag(−1, 1, −1) A(r) for the swimmer."""
    for links in (4, 9):
        swimmer, d = PurcellSwimmer(links), links - 1
        shapes, reverse = rng.uniform(-2, 2, size=(30, d)), np.eye(d)[::-1]
        connection = swimmer.connection(shapes)
        np.testing.assert_allclose(swimmer.connection(-shapes), -MIRROR[:, None] * connection, atol=1e-14)
        np.testing.assert_allclose(swimmer.connection(shapes @ reverse) @ reverse, REVERSAL[:, None] * connection,
                                   atol=1e-14)
        np.testing.assert_allclose(symmetrised(swimmer.connection, d)(shapes), connection, atol=1e-14)


def test_symmetry_blocks_sizes_and_orthonormal_bases():
    exponents = monomial_exponents(8, 3)  # 9 links: 165 monomials, 8 + 120 of odd degree, 1 + 36 even
    for symmetry, sizes in ((None, [1320]), ("mirror", [128 * 8, 37 * 8]), ("mirror+reversal", [512, 148, 148])):
        blocks = symmetry_blocks(exponents, symmetry)
        assert [basis.shape[1] for _, basis in blocks] == sizes
        assert sorted(np.concatenate([outputs for outputs, _ in blocks]).tolist()) == [0, 1, 2]
        for _, basis in symmetry_blocks(monomial_exponents(4, 3), symmetry):
            np.testing.assert_allclose(basis.T @ basis, np.eye(basis.shape[1]), atol=1e-15)


@pytest.mark.parametrize("symmetry", ["mirror", "mirror+reversal"])
def test_symmetric_model_has_the_parity_whatever_the_data(symmetry, rng):
    """Fitted to noisy, asymmetric data the constrained model still predicts ξ(−r, −ṙ) = M ξ(r, ṙ) (and the
    reversal's relation); the unconstrained model fitted to the same data does not."""
    run = simulate(PurcellSwimmer(4), seed_gait(3), n_cycles=2, perturbation=Perturbation.from_std(0.3),
                   sensor_noise=0.3, seed=4)
    shapes, rates, phase, reverse = rng.normal(size=(20, 3)), rng.normal(size=(20, 3)), np.zeros(20), np.eye(3)[::-1]
    free = ShapeSpaceModel(degree=3).fit(*samples(run))
    model = ShapeSpaceModel(degree=3, symmetry=symmetry).fit(*samples(run))
    for fitted, constrained in ((model, True), (free, False)):
        xi = fitted.predict(phase, shapes, rates)
        mirrored = fitted.predict(phase, -shapes, -rates)
        reversed_ = fitted.predict(phase, shapes @ reverse, rates @ reverse)
        assert np.allclose(mirrored, MIRROR * xi, atol=1e-12) == constrained
        assert np.allclose(reversed_, REVERSAL * xi, atol=1e-12) == (constrained and symmetry == "mirror+reversal")


def test_symmetric_model_recovers_a_symmetric_polynomial_connection_exactly():
    connection = symmetrised(polynomial_connection, 2)
    system = FunctionSystem(connection, n_joints=2)
    run = simulate(system, seed_gait(2), n_cycles=5, perturbation=Perturbation.from_std(0.3), seed=1)
    model = ShapeSpaceModel(degree=2, symmetry="mirror+reversal", forgetting_factor=1.0,
                            initial_covariance=1e8).fit(*samples(run))
    # of 12 features: x row r_i ṙ_j, antisymmetric pairs (r₀ṙ₀, r₁ṙ₁), (r₀ṙ₁, r₁ṙ₀); y and θ rows the 8 even
    # features in 4 reversal pairs, symmetric for y, antisymmetric for θ
    assert [basis.shape[1] for _, basis in model.blocks_] == [2, 4, 4]
    shapes = np.random.default_rng(3).normal(size=(7, 2))
    np.testing.assert_allclose(model.connection(shapes), connection(shapes), atol=1e-8)


def test_symmetry_fits_the_purcell_connection_better_from_noise_free_data(rng):
    """5 links, degree 3, 10 noise-free cycles: the connection on the visited shapes within 5 % of its
    largest entry for both bases; the seed gait's displacement per cycle ≈ 3× closer with the symmetry."""
    swimmer = PurcellSwimmer(5)
    run = simulate(swimmer, seed_gait(4), n_cycles=10, perturbation=Perturbation.from_std(0.3), seed=1)
    shapes = run.shape[rng.choice(len(run.shape), 50)]
    truth, displacement = swimmer.connection(shapes), cycle_displacement(swimmer, seed_gait(4))
    errors = {}
    for symmetry in (None, "mirror+reversal"):
        model = ShapeSpaceModel(degree=3, symmetry=symmetry, forgetting_factor=1.0,
                                initial_covariance=1e4).fit(*samples(run))
        assert np.abs(model.connection(shapes) - truth).max() < 0.05 * np.abs(truth).max()
        errors[symmetry] = np.abs(model.predict_displacement(seed_gait(4)) - displacement).max()
    assert errors["mirror+reversal"] < 2e-3 < errors[None]


def test_symmetric_model_file_round_trip(tmp_path):
    run = simulate(PurcellSwimmer(4), seed_gait(3), n_cycles=2, seed=0, sensor_noise=0.1)
    model = ShapeSpaceModel(degree=2, symmetry="mirror+reversal").fit(*samples(run))
    copy = ShapeSpaceModel.load(model.save(tmp_path / "model.npz"))
    assert isinstance(copy, ShapeSpaceModel) and copy.get_params() == model.get_params()
    gait = FourierGait(seed_gait(3).coefficients * 1.3)
    np.testing.assert_array_equal(copy.predict_displacement(gait), model.predict_displacement(gait))
    np.testing.assert_array_equal(copy.rotation_std(gait, 0.01), model.rotation_std(gait, 0.01))
    more = simulate(PurcellSwimmer(4), seed_gait(3), n_cycles=1, seed=5, sensor_noise=0.1)
    np.testing.assert_array_equal(copy.partial_fit(*samples(more)).weights_, model.partial_fit(*samples(more)).weights_)
    with pytest.raises(ValueError, match="'symmetry' parameter of ShapeSpaceModel must be one of None, 'mirror'"):
        ShapeSpaceModel(symmetry="reversal").fit(*samples(run))


@pytest.mark.parametrize("symmetry", [None, "mirror+reversal"])
def test_degree_shrinkage_is_the_graded_ridge_solution(symmetry):
    """With λ = 1 the weights are the closed-form ridge solution of each block, penalty b^q / δ₀ on the
    weights of degree-q monomials (every block column has one degree), and b > 1 shrinks the high degrees."""
    run = simulate(PurcellSwimmer(4), seed_gait(3), n_cycles=2, perturbation=Perturbation.from_std(0.3),
                   sensor_noise=0.2, seed=2)
    delta, shrinkage = 3.0, 10.0
    model = ShapeSpaceModel(degree=3, symmetry=symmetry, forgetting_factor=1.0, initial_covariance=delta,
                            degree_shrinkage=shrinkage).fit(*samples(run))
    exponents = monomial_exponents(3, 3)
    degree = np.repeat(exponents.sum(axis=1), 3)
    features = monomials(run.shape, exponents)[:, :, None] * run.shape_velocity[:, None, :]
    features = features.reshape(len(run.shape), -1)
    expected = np.zeros((features.shape[1], 3))
    for outputs, basis in symmetry_blocks(exponents, symmetry):
        used = basis != 0
        column_degree = np.array([np.unique(degree[used[:, c]]).item() for c in range(basis.shape[1])])
        z = features @ basis
        penalty = np.diag(shrinkage ** column_degree / delta)
        expected[:, outputs] = basis @ np.linalg.solve(z.T @ z + penalty, z.T @ run.body_velocity[:, outputs])
    np.testing.assert_allclose(model.weights_.reshape(-1, 3), expected, rtol=1e-6, atol=1e-9)
    flat = ShapeSpaceModel(degree=3, symmetry=symmetry, forgetting_factor=1.0,
                           initial_covariance=delta).fit(*samples(run)).weights_
    cubic = exponents.sum(axis=1) == 3
    assert np.linalg.norm(model.weights_[cubic]) < 0.5 * np.linalg.norm(flat[cubic])


def test_forget_is_weighted_least_squares_with_the_old_evidence_discounted():
    """With λ = 1, learning run A, forgetting by F, then learning run B gives the closed-form ridge
    solution in which A's samples and the prior weigh 1/F each and B's samples 1 (covariance resetting
    rescales the information matrix; the weights are untouched by the forgetting itself)."""
    system, gait = PurcellSwimmer(3), seed_gait(2)
    first = simulate(system, gait, n_cycles=3, perturbation=Perturbation.from_std(0.2), sensor_noise=0.1, seed=3)
    second = simulate(system.with_drag_ratio(4.0), gait, n_cycles=1, perturbation=Perturbation.from_std(0.2),
                      sensor_noise=0.1, seed=4)
    delta, factor = 10.0, 30.0
    model = ShapeSpaceModel(degree=2, forgetting_factor=1.0, initial_covariance=delta).fit(*samples(first))
    before = model.weights_.copy()
    model.forget(factor)
    np.testing.assert_array_equal(model.weights_, before)
    model.partial_fit(*samples(second))
    exponents = monomial_exponents(2, 2)

    def features(run):
        f = monomials(run.shape, exponents)[:, :, None] * run.shape_velocity[:, None, :]
        return f.reshape(len(run.shape), -1)

    za, zb = features(first), features(second)
    information = (za.T @ za + np.eye(za.shape[1]) / delta) / factor + zb.T @ zb
    expected = np.linalg.solve(information, za.T @ first.body_velocity / factor + zb.T @ second.body_velocity)
    np.testing.assert_allclose(model.weights_.reshape(-1, 3), expected, rtol=1e-6, atol=1e-9)
    # without forgetting, the old drag ratio keeps three times the weight of the new one
    stale = ShapeSpaceModel(degree=2, forgetting_factor=1.0, initial_covariance=delta).fit(*samples(first))
    stale.partial_fit(*samples(second))
    truth = cycle_displacement(system.with_drag_ratio(4.0), gait)
    assert np.abs(model.predict_displacement(gait) - truth).max() < 0.5 * np.abs(
        stale.predict_displacement(gait) - truth).max()


def test_forget_scales_the_informed_directions_on_both_models_and_checks_its_factor():
    """Where the samples shrank every direction far below the prior (the shape-space model, 2 cycles)
    the whole covariance is multiplied by the factor; in the window model's sparsely covered windows
    no direction grows beyond the prior, and none shrinks."""
    run = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=2, perturbation=Perturbation.from_std(0.2), seed=0)
    for model in (ShapeSpaceModel(degree=2), AdaptiveGaitModel(gait=seed_gait(2))):
        with pytest.raises(Exception, match="fit"):
            model.forget(10.0)
        model.fit(*samples(run))
        covariance = [c.copy() for c in model.covariances_] if hasattr(model, "covariances_") else [
            model.covariance_.copy()]
        model.forget(4.0)
        after = model.covariances_ if hasattr(model, "covariances_") else [model.covariance_]
        prior = model.initial_covariance
        for old, new in zip(covariance, after, strict=True):
            grown = np.linalg.eigvalsh(new - old)
            assert grown.min() > -1e-9 * np.abs(old).max()  # nothing became more certain
            assert np.linalg.eigvalsh(4.0 * old - new).min() > -1e-9 * np.abs(old).max()  # nor more than 4×
            assert np.linalg.eigvalsh(new).max() <= max(prior, np.linalg.eigvalsh(old).max()) * (1 + 1e-9)
            if isinstance(model, ShapeSpaceModel):
                np.testing.assert_allclose(new, 4.0 * old, rtol=1e-9, atol=1e-12 * np.abs(old).max())
        for bad in (0.5, np.nan, "2"):
            with pytest.raises(ValueError, match="'factor'"):
                model.forget(bad)


@settings(max_examples=30, deadline=None)
@given(n=st.integers(3, 12), informed=st.integers(1, 3), factor=st.floats(1.0, 1e4), seed=st.integers(0, 2**16))
def test_forget_is_not_undone_by_the_trace_clamp(n, informed, factor, seed):
    """A covariance whose never-excited directions hold the rest of the clamp's budget (steady forgetting
    with many regressors): the informed directions get ``factor`` times their variance, up to the
    prior's, then only the clamp's rescaling by the trace they add (multiplying P and clamping, as
    before, left it unchanged)."""
    from geogait.models._rls import RLSBank

    informed = min(informed, n - 2)
    rng = np.random.default_rng(seed)
    delta = 10.0
    bank = RLSBank((), 1, n, 3, 0.999, delta)
    basis, _ = np.linalg.qr(rng.standard_normal((n, n)))
    variances = np.empty(n)
    variances[:informed] = delta * 10.0 ** rng.uniform(-6, -1, informed)  # what the samples taught
    variances[informed:] = (bank.max_trace - variances[:informed].sum()) / (n - informed)  # at the clamp
    bank.covariance[0] = (basis * variances) @ basis.T
    bank.forget(factor)
    raised = np.minimum(factor * variances[:informed], delta)
    clamp = min(1.0, bank.max_trace / (variances[informed:].sum() + raised.sum()))
    for k in range(informed):
        direction = basis[:, k]
        assert direction @ bank.covariance[0] @ direction == pytest.approx(raised[k] * clamp, rel=1e-6)
    assert np.trace(bank.covariance[0]) <= bank.max_trace * (1 + 1e-12)


@pytest.mark.parametrize("symmetry", ["mirror", "mirror+reversal"])
def test_a_degree_that_leaves_an_output_without_weights_is_refused_before_anything_changes(symmetry):
    """Degree 0 (a constant connection) under the mirror symmetry has no feature for the x output (odd
    in r): a clear error naming 'degree', not a reshape failure, and the model stays unfitted."""
    run = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=1, seed=0)
    model = ShapeSpaceModel(degree=0, symmetry=symmetry)
    with pytest.raises(ValueError, match=r"'degree' parameter of ShapeSpaceModel.*output x without any weight"):
        model.fit(*samples(run))
    with pytest.raises(ValueError, match="not fitted"):
        model.predict_displacement(seed_gait(2))
    assert ShapeSpaceModel(degree=0).fit(*samples(run)).weights_.shape[0] == 1  # without symmetry: fine
