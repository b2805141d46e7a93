"""The resistance model: drag sensitivities against finite differences, recovery of known drags from noisy
data, predictions against the true system's oracle, the hybrid's residual, uncertainty, and the optimiser
on it."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from geogait import GeogaitError
from geogait.gaits import FourierGait, seed_gait
from geogait.models import ResistanceModel
from geogait.optimize import InSituOptimizer, ModelStep, cached_ceiling
from geogait.simulate import SwimmerStream, cycle_displacement, simulate
from geogait.systems import FunctionSystem, PurcellSwimmer

RNG_SEED = 7


def unequal_swimmer(n_links, rng, drag_ratio=2.5, spread=0.3):
    lengths = rng.uniform(0.5, 1.5, n_links)
    return PurcellSwimmer(n_links, link_lengths=lengths / lengths.sum(), drag_ratio=drag_ratio,
                          link_drag_scale=np.exp(rng.normal(0, spread, (n_links, 2))))


def fit_by_cycles(model, run, n_cycles):
    per = len(run.phase) // n_cycles
    for c in range(n_cycles):
        part = slice(c * per, (c + 1) * per)
        model.partial_fit(run.phase[part], run.shape[part], run.shape_velocity[part], run.body_velocity[part])
    return model


def connection_error(model, system, rng, n=400, reach=2.0):
    shapes = rng.uniform(-reach, reach, (n, system.n_joints))
    truth = system.connection(shapes)
    return np.linalg.norm(model.connection(shapes) - truth, axis=(-1, -2)) / np.linalg.norm(truth, axis=(-1, -2))


def assert_jacobian_is_the_derivative(model, gait, atol, h=1e-6):
    """predict_displacement's Jacobian against central differences in each gait parameter."""
    _, jacobian = model.predict_displacement(gait, jacobian=True)
    for k in range(gait.params.size):
        step = np.zeros(gait.params.size)
        step[k] = h
        difference = (model.predict_displacement(gait.with_params(gait.params + step))
                      - model.predict_displacement(gait.with_params(gait.params - step))) / (2 * h)
        np.testing.assert_allclose(jacobian[:, k], difference, atol=atol)


def test_drag_sensitivity_is_the_derivative_of_the_body_velocity():
    rng = np.random.default_rng(RNG_SEED)
    swimmer = unequal_swimmer(5, rng)
    shapes, rates = rng.uniform(-1.5, 1.5, (6, 4)), rng.normal(size=(6, 4))
    velocity, sensitivity = swimmer.drag_sensitivity(shapes, rates)
    np.testing.assert_allclose(velocity, -np.einsum("nkj,nj->nk", swimmer.connection(shapes), rates), atol=1e-15)
    scale, h = np.asarray(swimmer.link_drag_scale), 1e-6
    for link in range(5):
        for kind in range(2):
            up, down = scale.copy(), scale.copy()
            up[link, kind] *= np.exp(h)
            down[link, kind] *= np.exp(-h)
            moved = [PurcellSwimmer(5, link_lengths=swimmer.link_lengths, drag_ratio=2.5, link_drag_scale=s)
                     .drag_sensitivity(shapes, rates)[0] for s in (up, down)]
            np.testing.assert_allclose((moved[0] - moved[1]) / (2 * h), sensitivity[..., link, kind], atol=1e-8)


@settings(max_examples=25, deadline=None)
@given(n_links=st.integers(2, 7), factor=st.floats(1e-3, 1e3), seed=st.integers(0, 2**16))
def test_only_ratios_of_drags_move_the_body(n_links, factor, seed):
    """Scaling every drag alike leaves A unchanged, so the sensitivities sum to zero (a gauge the prior fixes)."""
    rng = np.random.default_rng(seed)
    swimmer = unequal_swimmer(n_links, rng)
    scaled = PurcellSwimmer(n_links, link_lengths=swimmer.link_lengths, drag_ratio=2.5,
                            drag_coefficient=factor, link_drag_scale=swimmer.link_drag_scale)
    shapes, rates = rng.uniform(-2, 2, (3, n_links - 1)), rng.normal(size=(3, n_links - 1))
    np.testing.assert_allclose(scaled.connection(shapes), swimmer.connection(shapes), rtol=1e-9, atol=1e-12)
    _, sensitivity = swimmer.drag_sensitivity(shapes, rates)
    assert np.abs(sensitivity.sum(axis=(-1, -2))).max() < 1e-12


@pytest.mark.parametrize(("n_links", "link_variation", "limit"), [(5, 0.3, 0.04), (9, 0.3, 0.04)])
def test_per_link_drags_are_recovered_from_noisy_data(n_links, link_variation, limit):
    """10 % sensor noise, four cycles of the seed gait with the stream's perturbations: the connection is
    right everywhere in [-2, 2]^d, far beyond the ±1 rad the data visit."""
    rng = np.random.default_rng(RNG_SEED + n_links)
    swimmer = unequal_swimmer(n_links, rng)
    run = simulate(swimmer, seed_gait(n_links - 1), n_cycles=4, sensor_noise=0.1, seed=1)
    model = fit_by_cycles(ResistanceModel(link_lengths=swimmer.link_lengths, link_variation=link_variation), run, 4)
    error = connection_error(model, swimmer, rng)
    assert np.median(error) < limit
    assert 0.5 < model.gamma_ < 1  # noise bounds Γ below 1; the model beats the phase average


def test_a_shared_drag_ratio_is_one_parameter_recovered_to_a_percent():
    swimmer = PurcellSwimmer(5, drag_ratio=3.0)
    run = simulate(swimmer, seed_gait(4), n_cycles=2, sensor_noise=0.1, seed=2)
    model = ResistanceModel.from_swimmer(swimmer, link_variation=0.0).fit(run.phase, run.shape,
                                                                          run.shape_velocity, run.body_velocity)
    assert model.parameters_.shape == (1,)
    ratio = np.exp(model.log_drag_[:, 1] - model.log_drag_[:, 0])
    np.testing.assert_allclose(ratio, 3.0, rtol=0.01)
    spread = np.sqrt(model.parameter_covariance_[0, 0])  # of log k: its error is within its uncertainty
    assert spread < 0.02 and abs(np.log(ratio[0] / 3.0)) < 3 * spread


def test_predicted_motion_and_gradient_agree_with_the_true_system():
    rng = np.random.default_rng(RNG_SEED)
    swimmer = unequal_swimmer(4, rng)
    run = simulate(swimmer, seed_gait(3), n_cycles=3, seed=3)  # noise-free: the fit is exact
    model = ResistanceModel.from_swimmer(swimmer, link_variation=1.0, iterations=30).fit(
        run.phase, run.shape, run.shape_velocity, run.body_velocity)
    other = seed_gait(3, amplitude=1.4)  # a gait the data never visited
    np.testing.assert_allclose(model.predict_displacement(other), cycle_displacement(swimmer, other, resolution=128),
                               atol=1e-6)
    assert_jacobian_is_the_derivative(model, other, atol=1e-7)


def test_a_shape_map_learns_a_chain_driven_through_fewer_coordinates(tmp_path):
    """A 6-link chain whose 5 joints follow 2 modal coordinates (r_chain = M q, as a continuum's curvature modes
    on its discretisation): the model on the chain's geometry with M recovers the drag ratio from noisy data, and
    predicts the motion and its gradient of a gait the data never visited as the chain itself moves under it."""
    swimmer = PurcellSwimmer(6, drag_ratio=3.0, body_frame="center_of_mass")
    nodes = np.arange(1, 6) / 6
    shape_map = np.stack([np.cos(2 * np.pi * nodes), np.sin(2 * np.pi * nodes)], axis=1) / 2  # (5, 2)
    robot = FunctionSystem(lambda q: swimmer.connection(q @ shape_map.T) @ shape_map, 2)
    run = simulate(robot, seed_gait(2, amplitude=1.5), n_cycles=2, sensor_noise=0.1, seed=4)
    model = ResistanceModel(link_lengths=swimmer.link_lengths, body_frame="center_of_mass", shape_map=shape_map,
                            link_variation=0.0).fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)
    np.testing.assert_allclose(np.exp(np.diff(model.log_drag_, axis=1)), 3.0, rtol=0.02)
    other = seed_gait(2, amplitude=2.0)
    on_chain = FourierGait(shape_map @ other.coefficients)  # the same motion, as the chain's own gait
    truth = cycle_displacement(swimmer, on_chain, resolution=128)
    np.testing.assert_allclose(model.predict_displacement(other), truth, atol=0.02 * np.abs(truth).max())
    assert_jacobian_is_the_derivative(model, other, atol=1e-6)
    assert model.connection(np.zeros((3, 2))).shape == (3, 3, 2)
    loaded = ResistanceModel.load(model.save(tmp_path / "mapped.npz"))
    np.testing.assert_array_equal(loaded.predict_displacement(other), model.predict_displacement(other))
    with pytest.raises(GeogaitError, match="'shape_map' parameter of ResistanceModel.* 5 rows"):
        ResistanceModel(link_lengths=swimmer.link_lengths, shape_map=shape_map[1:]).fit(
            run.phase, run.shape, run.shape_velocity, run.body_velocity)
    with pytest.raises(GeogaitError, match="'shape' parameter .* 2 joints \\(shape_map has 2 columns"):
        ResistanceModel(link_lengths=swimmer.link_lengths, shape_map=shape_map).fit(
            run.phase, np.zeros((len(run.phase), 3)), np.zeros((len(run.phase), 3)), run.body_velocity)
    with pytest.raises(GeogaitError, match="'shape_map' parameter"):
        ResistanceModel(link_lengths=swimmer.link_lengths, shape_map=[[np.nan, 1.0]] * 5).validate()


def test_rotation_std_is_the_linear_spread_of_the_predicted_heading():
    """σ_θ = √(gᵀ C g) with g the derivative of the predicted net rotation in the parameters, here taken
    by finite differences of predict_displacement (independent of the model's closed form)."""
    rng = np.random.default_rng(RNG_SEED)
    swimmer = unequal_swimmer(5, rng)
    run = simulate(swimmer, seed_gait(4), n_cycles=2, sensor_noise=0.1, seed=4)
    model = ResistanceModel.from_swimmer(swimmer).fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)
    gait = seed_gait(4).with_params(seed_gait(4).params + rng.normal(0, 0.2, seed_gait(4).params.size))
    base, h = model.parameters_.copy(), 1e-6
    g = np.empty(base.size)
    for k in range(base.size):
        headings = []
        for sign in (1, -1):
            model.parameters_ = base + sign * h * np.eye(base.size)[k]
            model._system = None
            headings.append(model.predict_displacement(gait)[2])
        g[k] = (headings[0] - headings[1]) / (2 * h)
    model.parameters_, model._system = base, None
    np.testing.assert_allclose(model.rotation_std(gait, 0.0), np.sqrt(g @ model.parameter_covariance_ @ g),
                               rtol=1e-5)


def test_the_hybrid_learns_what_the_resistive_structure_misses():
    """A medium that is not resistive (an extra smooth, shape-dependent drift): the hybrid's residual model
    predicts it, the structure alone cannot; on a resistive medium both are as good."""
    swimmer = PurcellSwimmer(3)

    def skewed(shapes):
        extra = np.zeros(np.shape(shapes)[:-1] + (3, 2))
        extra[..., 0, :] = 0.05 * np.cos(shapes)  # a forward drift no chain of drag coefficients makes
        return swimmer.connection(shapes) + extra

    medium = FunctionSystem(skewed, 2)
    gait = seed_gait(2)
    train = simulate(medium, gait, n_cycles=20, sensor_noise=0.05, seed=5)
    test = simulate(medium, gait, n_cycles=2, sensor_noise=0.0, seed=6)
    errors = {}
    for name, degree in (("structure", None), ("hybrid", 2)):
        model = fit_by_cycles(ResistanceModel.from_swimmer(swimmer, residual_degree=degree), train, 20)
        predicted = model.predict(test.phase, test.shape, test.shape_velocity)
        errors[name] = np.sqrt(np.mean((predicted - test.body_velocity) ** 2))
    assert errors["hybrid"] < 0.5 * errors["structure"]
    resistive = simulate(swimmer, gait, n_cycles=4, sensor_noise=0.05, seed=5)
    rng = np.random.default_rng(RNG_SEED)
    alone, hybrid = (fit_by_cycles(ResistanceModel.from_swimmer(swimmer, residual_degree=d), resistive, 4)
                     for d in (None, 2))
    assert np.median(connection_error(hybrid, swimmer, rng, reach=1.0)) < 0.05
    assert np.median(connection_error(alone, swimmer, rng, reach=1.0)) < 0.02


@pytest.mark.parametrize("noise", [0.0, 0.1])
def test_the_residual_share_tells_a_resistive_medium_from_one_that_is_not(noise):
    """The hybrid's residual share: zero on the swimmer's own noise-free samples (the structure is exact),
    noise-sized with 10 % sensor noise, and of the drift's size where a forward drift no drag coefficients
    make is added; NaN for the structure alone."""
    swimmer = PurcellSwimmer(3)

    def drifting(shapes):
        extra = np.zeros(np.shape(shapes)[:-1] + (3, 2))
        extra[..., 0, :] = 0.05 * np.cos(shapes)
        return swimmer.connection(shapes) + extra

    shares = {}
    for name, system in (("resistive", swimmer), ("drifting", FunctionSystem(drifting, 2))):
        run = simulate(system, seed_gait(2), n_cycles=4, sensor_noise=noise, seed=5)
        shares[name] = fit_by_cycles(ResistanceModel.from_swimmer(swimmer, residual_degree=2), run, 4).residual_share_
        assert np.isnan(fit_by_cycles(ResistanceModel.from_swimmer(swimmer), run, 4).residual_share_)
    assert shares["resistive"] < (1e-6 if noise == 0 else 0.1)
    assert shares["drifting"] > 0.5


def test_forgetting_relearns_a_changed_medium():
    gait = seed_gait(4)
    before = simulate(PurcellSwimmer(5, drag_ratio=2.0), gait, n_cycles=8, sensor_noise=0.05, seed=8)
    after = simulate(PurcellSwimmer(5, drag_ratio=4.0), gait, n_cycles=1, sensor_noise=0.05, seed=9)
    model = ResistanceModel.from_swimmer(PurcellSwimmer(5), link_variation=0.0)
    fit_by_cycles(model, before, 8)
    model.forget(8.0)  # keep an eighth of the memory: one cycle of the old medium against one of the new
    model.partial_fit(after.phase, after.shape, after.shape_velocity, after.body_velocity)
    ratio = float(np.exp(np.mean(model.log_drag_[:, 1] - model.log_drag_[:, 0])))
    assert 2.6 < ratio < 4.0  # without forgetting: eight old cycles against one new keep it near 2.2
    model_kept = fit_by_cycles(ResistanceModel.from_swimmer(PurcellSwimmer(5), link_variation=0.0), before, 8)
    model_kept.partial_fit(after.phase, after.shape, after.shape_velocity, after.body_velocity)
    kept = float(np.exp(np.mean(model_kept.log_drag_[:, 1] - model_kept.log_drag_[:, 0])))
    assert kept < ratio


def test_bad_input_is_named():
    run = simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=1, seed=0)
    args = (run.phase, run.shape, run.shape_velocity, run.body_velocity)
    with pytest.raises(GeogaitError, match="'link_lengths' parameter of ResistanceModel"):
        ResistanceModel().fit(*args)
    with pytest.raises(GeogaitError, match="'shape' parameter .* 4 joints"):
        ResistanceModel(link_lengths=[0.2] * 5).fit(*args)
    with pytest.raises(GeogaitError, match="'phase' parameter .* no trial axes"):
        ResistanceModel(link_lengths=[0.3] * 3).fit(*(np.stack([a, a]) for a in args))
    with pytest.raises(GeogaitError, match="'swimmer' parameter"):
        ResistanceModel.from_swimmer("purcell")


@pytest.mark.parametrize(("chain", "match"), [
    (dict(link_lengths=[True, True, True]), "'link_lengths'.* real numbers. Got 'booleans"),
    (dict(link_lengths=np.array([1, 1, 1]) + 1j), "'link_lengths'.* real numbers. Got 'complex numbers'"),
    (dict(link_lengths=[1e300, 1, 1]), r"'link_lengths'.*within ±1e\+12"),
    (dict(frame_offset=[True, False, 0]), "'frame_offset'.* real numbers. Got 'text, booleans or complex"),
    (dict(frame_offset=np.array([1j, 0, 0])), "'frame_offset'.* real numbers. Got 'complex numbers'"),
    (dict(frame_offset=[1e300, 0, 0]), r"'frame_offset'.*within ±1e\+12"),
    (dict(shape_map=[[True, False], [False, True]]), "'shape_map'.* real numbers. Got 'booleans"),
    (dict(shape_map=np.eye(2) * 1j), "'shape_map'.* real numbers. Got 'complex numbers'"),
    (dict(shape_map=np.eye(2) * 1e300), r"'shape_map'.*within ±1e\+12"),
])
def test_a_chain_of_booleans_complex_numbers_or_huge_values_is_refused_not_cast(chain, match):
    """Issue 58 (confusing): each was cast silently (True as 1, 1j as 0) and 1e300 accepted."""
    with pytest.raises(GeogaitError, match=match):
        ResistanceModel(**{"link_lengths": [1.0, 1.0, 1.0], **chain}).validate()


def test_the_optimiser_reaches_the_ceiling_with_the_resistance_model():
    """Five links, 10 % sensor noise: with the chain's geometry known and its drags learned, SQP steps over
    a large trust region reach the rotation-free ceiling (the window and shape-space models stop near
    95 %)."""
    swimmer = PurcellSwimmer(5)
    stream = SwimmerStream(swimmer, seed_gait(4), sensor_noise=0.1, seed=0)
    optimizer = InSituOptimizer(model=ResistanceModel.from_swimmer(swimmer),
                                step=ModelStep(rule="sqp", max_trust_radius=0.5), climb=False)
    log = optimizer.run(stream, 24, ceiling=cached_ceiling(swimmer).value).log
    assert log["ceiling_fraction"].iloc[-1] > 0.98
    assert np.abs(log["true_heading"]).max() < 1e-9  # the symmetric family (the swimmer declares it)


def test_the_path_tracker_follows_a_path_and_relearns_a_drag_change_with_it():
    """The tracker takes the resistance model unchanged: after a drag change 2 → 4 the alarm's forgetting and
    a cycle of new data put the predicted step within 10 % of the measured one (the drag ratio is one of the
    model's few parameters)."""
    from geogait.control import PathTracker, ReferencePath
    from geogait.experiments.tracking import feasible_turn_limit, straight_gait
    from geogait.gaits import Perturbation
    from geogait.simulate import DragRatioSchedule

    system, gait, step = straight_gait(5)
    change = 12
    robot = SwimmerStream(system, gait, perturbation=Perturbation.from_std(0.05), sensor_noise=0.1,
                          environment=DragRatioSchedule(system, (2.0, 4.0), 10 + change), seed=0)
    tracker = PathTracker(warmup_cycles=10, turn_limit=feasible_turn_limit(5),
                          model=ResistanceModel.from_swimmer(system), change_forgetting=100.0)
    log = tracker.run(robot, ReferencePath.circle(10 * step), change + 4).log
    predicted = np.hypot(log["predicted_x"], log["predicted_y"])
    ratio = (predicted / np.hypot(log["measured_x"], log["measured_y"])).to_numpy()
    assert np.all(np.abs(ratio[:change] - 1) < 0.1)  # before the change the model's steps are the measured ones
    assert abs(ratio[change] - 1) > 0.2  # the change is real
    assert np.all(np.abs(ratio[change + 2:] - 1) < 0.1)


def test_a_stream_gives_its_swimmers_geometry_and_refuses_other_systems():
    swimmer = PurcellSwimmer(4, link_lengths=(0.4, 0.2, 0.3, 0.1), body_frame="tail", frame_offset=(0.05, 0.0, 0.0))
    geometry = SwimmerStream(swimmer, seed_gait(3), seed=0).chain_geometry()
    model = ResistanceModel(**geometry, link_variation=0.0, drag_ratio=swimmer.drag_ratio)
    run = simulate(swimmer, seed_gait(3), n_cycles=1, seed=0)
    model.fit(run.phase, run.shape, run.shape_velocity, run.body_velocity)
    shapes = np.random.default_rng(0).uniform(-1, 1, (5, 3))
    np.testing.assert_allclose(model.connection(shapes), swimmer.connection(shapes), rtol=1e-6, atol=1e-9)
    other = SwimmerStream(FunctionSystem(PurcellSwimmer(3).connection, 2), seed_gait(2), seed=0)
    with pytest.raises(GeogaitError, match="not a chain of links"):
        other.chain_geometry()
