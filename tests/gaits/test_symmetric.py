"""Front–back symmetric gait families: the relation, rotation-free against the oracle, membership."""

import numpy as np
import pytest

from geogait.gaits import FourierGait, FreeGaitFamily, SymmetricGaitFamily, seed_gait, shift_phase
from geogait.optimize import cached_ceiling
from geogait.simulate import cycle_displacement
from geogait.systems import PurcellSwimmer


@pytest.mark.parametrize("n_joints", [2, 3, 4, 7, 8])
@pytest.mark.parametrize("order", [1, 2])
def test_members_satisfy_the_relation_and_do_not_rotate(rng, n_joints, order):
    family = SymmetricGaitFamily(n_joints, order, center=rng.uniform(0, 2 * np.pi))
    assert family.n_params == n_joints // 2 * (2 * order + 1) + n_joints % 2 * order
    swimmer = PurcellSwimmer(n_joints + 1)
    for _ in range(2):
        gait = family.gait(rng.normal(scale=0.5, size=family.n_params))
        phase = rng.uniform(0, 2 * np.pi, 7)
        # θ_{d-1-j}(φ) = -θ_j(2φ₀ - φ), checked on the shapes themselves (not the coefficient map)
        np.testing.assert_allclose(gait.shape(phase)[:, ::-1], -gait.shape(2 * family.center - phase), atol=1e-12)
        pose = cycle_displacement(swimmer, gait, resolution=64)
        assert abs(pose[2]) < 1e-12 and np.hypot(pose[0], pose[1]) > 1e-4
        # a generic perturbation of the same gait does rotate: the zero above is the symmetry's doing
        other = FourierGait(gait.coefficients + rng.normal(scale=0.1, size=gait.coefficients.shape))
        assert abs(cycle_displacement(swimmer, other, resolution=64)[2]) > 1e-4


def test_unequal_links_break_the_symmetry(rng):
    family = SymmetricGaitFamily(2, 1, center=0.3)
    gait = family.gait(rng.normal(scale=0.6, size=family.n_params))
    lopsided = PurcellSwimmer(3, link_lengths=(0.2, 0.3, 0.5))
    assert abs(cycle_displacement(lopsided, gait)[2]) > 1e-4


@pytest.mark.parametrize("n_joints", [2, 4, 8])
def test_family_contains_the_seed_and_round_trips(n_joints):
    seed = seed_gait(n_joints)
    family = SymmetricGaitFamily.from_gait(seed)
    lag = 2 * np.pi / max(n_joints, 4)
    assert np.isclose(family.center, np.mod(((n_joints - 1) * lag + np.pi) / 2, np.pi))
    np.testing.assert_allclose(family.gait(family.params_of(seed)).coefficients, seed.coefficients, atol=1e-12)
    assert not family.matrix.flags.writeable  # the constant Jacobian ∂p/∂q
    with pytest.raises(ValueError, match="'gait' parameter of SymmetricGaitFamily.params_of"):
        family.params_of(FourierGait(seed.coefficients + 0.1))


def test_ceiling_gait_is_a_member_up_to_a_phase_shift():
    ceiling = cached_ceiling(PurcellSwimmer(3)).gait
    family = SymmetricGaitFamily.from_gait(seed_gait(2))
    assert family.residual(ceiling) > 0.1  # not with the seed's φ₀ as it stands ...
    own = SymmetricGaitFamily.from_gait(ceiling)
    assert own.residual(ceiling) < 1e-6  # ... but about its own φ₀
    shifted = shift_phase(ceiling, own.center - family.center)  # moves the symmetry phase onto the seed's
    assert family.residual(shifted) < 1e-6
    assert np.isclose(np.hypot(*cycle_displacement(PurcellSwimmer(3), shifted)[:2]),
                      np.hypot(*cycle_displacement(PurcellSwimmer(3), ceiling)[:2]))


def test_shift_phase_is_a_reparametrisation(rng):
    gait = FourierGait(rng.normal(size=(3, 5)))
    phase = rng.uniform(0, 2 * np.pi, 9)
    np.testing.assert_allclose(shift_phase(gait, 0.7).shape(phase), gait.shape(phase + 0.7), atol=1e-12)


def test_free_family_is_the_identity():
    family = FreeGaitFamily(3, 2)
    gait = seed_gait(3, order=2)
    np.testing.assert_array_equal(family.params_of(gait), gait.params)
    assert family.gait(gait.params) == gait and family.n_params == 15
