"""A feasible region of the user's on any system (RegionSystem): the ceiling keeps it, and agrees with
an optimiser that writes the same region in closed form; bad regions and seeds are refused."""

import numpy as np
import pytest
from scipy.optimize import minimize

from geogait import GeogaitError
from geogait.gaits import seed_gait
from geogait.optimize import optimize_ceiling
from geogait.simulate import cycle_displacement
from geogait.systems import FeasibleSystem, PurcellSwimmer, RegionSystem

SWIMMER = PurcellSwimmer(3)
LIMIT = 0.8  # joint 0 may bend at most 0.8 rad one way (the other way: the joint limit 2π/3)


@pytest.fixture(scope="module")
def bent():
    return RegionSystem(SWIMMER, lambda r: LIMIT - r[..., 0], seed=seed_gait(2, amplitude=0.7))


def test_it_is_a_feasible_system_with_the_users_margin_and_gradient(bent):
    assert isinstance(bent, FeasibleSystem) and bent.n_joints == 2
    shapes = np.random.default_rng(0).uniform(-2, 2, (20, 2))
    value, gradient = bent.feasibility(shapes, jacobian=True)
    np.testing.assert_allclose(value, LIMIT - shapes[:, 0])
    np.testing.assert_allclose(gradient, np.tile([-1.0, 0.0], (20, 1)), atol=1e-8)
    np.testing.assert_array_equal(bent.connection(shapes), SWIMMER.connection(shapes))
    assert bent.seed_gait().order == 1 and bent.seed_gait(order=2).order == 2


def test_the_ceiling_keeps_the_region_and_matches_a_closed_form_constraint(bent):
    ceiling = optimize_ceiling(bent, starts=4)
    phases = np.linspace(0, 2 * np.pi, 8192, endpoint=False)
    assert ceiling.gait.shape(phases)[:, 0].max() <= LIMIT
    assert ceiling.value < 0.9 * optimize_ceiling(SWIMMER, starts=2).value  # the region binds

    # independently: max r₀ over a cycle of an order-1 gait is a₀ + √(a₁² + b₁²), in closed form
    slack, r_max = 2e-3, 2 * np.pi / 3

    def progress(p):
        return -np.hypot(*cycle_displacement(SWIMMER, seed_gait(2).with_params(p))[:2])

    constraints = [{"type": "eq", "fun": lambda p: cycle_displacement(SWIMMER, seed_gait(2).with_params(p))[2]},
                   {"type": "ineq", "fun": lambda p: LIMIT - slack - p[0] - np.hypot(p[1], p[2])}]
    constraints += [{"type": "ineq", "fun": lambda p, j=j: r_max - abs(p[3 * j]) - np.hypot(p[3 * j + 1], p[3 * j + 2])}
                    for j in range(2)]
    best = min((minimize(progress, start, method="SLSQP", constraints=constraints, options={"maxiter": 300})
                for start in (ceiling.gait.params * 0.9, bent.seed_gait().params)), key=lambda r: r.fun)
    assert -best.fun == pytest.approx(ceiling.value, rel=1e-3)


def test_bad_regions_and_seeds_are_refused():
    with pytest.raises(GeogaitError, match="'seed'.*inside the region.*falls to"):
        RegionSystem(SWIMMER, lambda r: 0.5 - r[..., 0], seed=seed_gait(2, amplitude=0.7))
    with pytest.raises(GeogaitError, match="'feasibility' callable .* shape"):
        RegionSystem(SWIMMER, lambda r: np.zeros(3), seed=seed_gait(2))
    with pytest.raises(GeogaitError, match="'feasibility' callable .* finite"):
        RegionSystem(SWIMMER, lambda r: np.full(r.shape[:-1], np.nan), seed=seed_gait(2))
    with pytest.raises(GeogaitError, match="'feasibility' parameter of RegionSystem"):
        RegionSystem(SWIMMER, "r0 < 1", seed=seed_gait(2))
    with pytest.raises(GeogaitError, match="'system' parameter of RegionSystem"):
        RegionSystem(object(), lambda r: r[..., 0], seed=seed_gait(2))
    region = RegionSystem(SWIMMER, lambda r: LIMIT - r[..., 0], seed=seed_gait(2, amplitude=0.7))
    with pytest.raises(GeogaitError, match="'amplitude'.*inside the region"):
        region.seed_gait(amplitude=1.5)


def test_different_regions_have_different_cache_keys():
    one = RegionSystem(SWIMMER, lambda r: 0.8 - r[..., 0], seed=seed_gait(2, amplitude=0.7))
    other = RegionSystem(SWIMMER, lambda r: 0.9 - r[..., 0], seed=seed_gait(2, amplitude=0.7))
    assert repr(one) != repr(other)
    assert repr(one) == repr(RegionSystem(SWIMMER, lambda r: 0.8 - r[..., 0], seed=seed_gait(2, amplitude=0.7)))


def test_the_in_situ_optimiser_keeps_the_region_on_a_simulator(bent):
    from geogait.gaits import Perturbation
    from geogait.optimize import InSituOptimizer
    from geogait.simulate import SwimmerStream

    stream = SwimmerStream(bent, bent.seed_gait(), perturbation=Perturbation.from_std(0.05), sensor_noise=0.05, seed=0)
    result = InSituOptimizer(family="free", exploration=None).run(stream, 30)
    phases = np.linspace(0, 2 * np.pi, 2048, endpoint=False)
    assert result.n_steps >= 2
    assert max(gait.shape(phases)[:, 0].max() for gait in result.gaits) <= LIMIT
    # the gait the run hands over (the last cycle may be a climb's candidate, not kept)
    final = result.log.loc[np.all(result.log.filter(regex=r"^param_\d+$").to_numpy() == result.final_gait.params,
                                  axis=1), "true_objective"]
    assert final.iloc[-1] > result.log["true_objective"].iloc[0]


def test_the_tracker_keeps_a_simulators_region_in_every_steering_gait(bent):
    """Steering gaits (family members and each cycle's solve) keep the region, as they keep the joint
    limits: the straight gait is the region's ceiling gait, so the region binds from the first turn."""
    from geogait.control import PathTracker, ReferencePath
    from geogait.simulate import SwimmerStream, cycle_displacement

    straight = optimize_ceiling(bent, starts=2).gait
    step = float(np.hypot(*cycle_displacement(bent, straight)[:2]))
    stream = SwimmerStream(bent, straight, sensor_noise=0.05, seed=0)
    result = PathTracker(controller="true", turn_limit=0.3).run(stream, ReferencePath.circle(6 * step), 12)
    phases = np.linspace(0, 2 * np.pi, 2048, endpoint=False)
    commanded = result.log.filter(like="param_").to_numpy()
    assert result.log["solved"].any()
    for params in commanded:
        assert straight.with_params(params).shape(phases)[:, 0].max() <= LIMIT
    for gait, feasible in zip(result.family.gaits, result.family.feasible, strict=True):
        if feasible:
            assert gait.shape(phases)[:, 0].max() <= LIMIT
    free = PathTracker(controller="true", turn_limit=0.3).run(
        SwimmerStream(SWIMMER, straight, sensor_noise=0.05, seed=0), ReferencePath.circle(6 * step), 12)
    assert max(straight.with_params(p).shape(phases)[:, 0].max() for p in free.log.filter(like="param_").to_numpy()) \
        > LIMIT  # without the region the same steering leaves it
    with pytest.raises(GeogaitError, match="'gait'.*feasible region"):
        PathTracker(controller="true").run(SwimmerStream(bent, seed_gait(2), seed=0), ReferencePath.circle(1.0), 2)


def test_the_symmetric_family_keeps_the_region_too(bent):
    """The front-back symmetric family about the seed: a ceiling inside the region (0.0522 per cycle), above the
    seed's and not above the free family's (0.0652): a family is a subset of the free gaits."""
    ceiling = optimize_ceiling(bent, family="symmetric", starts=3)
    phases = np.linspace(0, 2 * np.pi, 8192, endpoint=False)
    assert ceiling.gait.shape(phases)[:, 0].max() <= LIMIT
    seed = float(np.hypot(*cycle_displacement(bent, bent.seed_gait())[:2]))
    assert seed < ceiling.value <= optimize_ceiling(bent, starts=4).value + 1e-9


def test_the_seed_keeps_its_harmonics_or_says_why_not():
    """An order below the seed's dropped its harmonics (a zero gait, a ceiling of 0); order 0 was accepted."""
    from geogait.gaits import FourierGait

    region = RegionSystem(PurcellSwimmer(3), lambda r: 0.8 - r[..., 0],
                          seed=FourierGait(np.array([[0, 0, 0.5, 0, 0], [0, 0, 0, 0, 0.5]])))
    for order, match in ((1, "at least the seed's order 2"), (0, "an int >= 1")):
        with pytest.raises(GeogaitError, match=rf"'order' parameter .* {match}"):
            region.seed_gait(order=order)
    lifted = region.seed_gait(order=3)
    phase = np.linspace(0, 2 * np.pi, 9)
    np.testing.assert_allclose(lifted.shape(phase), region.seed_gait(order=2).shape(phase), atol=1e-15)
    with pytest.raises(GeogaitError, match="'amplitude' parameter"):
        region.seed_gait(amplitude=np.inf, order=2)


@pytest.mark.parametrize(("feasibility", "gradient", "match"), [
    (lambda r: LIMIT - r[..., 0] + 0j, None, "'feasibility' callable .* must return real numbers. Got complex"),
    (lambda r: r[..., 0] < LIMIT, None, "'feasibility' callable .* must return real numbers. Got booleans"),
    (lambda r: 1e300 - r[..., 0], None, r"'feasibility' callable .* must return values within ±1e\+12. Got 1e\+300"),
    (lambda r: LIMIT - r[..., 0], lambda r: np.ones(r.shape) * 1j, "'gradient' callable .* must return real numbers"),
])
def test_a_region_callable_returning_other_than_real_bounded_numbers_is_named(feasibility, gradient, match):
    """Issue 58 (confusing): a complex margin lost its imaginary part, a boolean one read as 0 and 1."""
    with pytest.raises(GeogaitError, match=match):
        region = RegionSystem(SWIMMER, feasibility, gradient=gradient, seed=seed_gait(2, amplitude=0.7))
        region.feasibility([0.1, 0.2], jacobian=True)
