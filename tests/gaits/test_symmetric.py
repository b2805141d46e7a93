"""Rotation-free gait families (front–back and half-wave symmetric): the relation, rotation-free against the
oracle, membership."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from geogait.gaits import FourierGait, FreeGaitFamily, MirrorGaitFamily, SymmetricGaitFamily, seed_gait, shift_phase
from geogait.optimize import cached_ceiling, optimize_ceiling
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


@settings(max_examples=30, deadline=None)
@given(n_joints=st.integers(2, 5), order=st.integers(1, 3), center=st.floats(0, 3.14), seed=st.integers(0, 2**32 - 1))
def test_a_member_about_any_phase_is_found_a_member_to_rounding(n_joints, order, center, seed):
    """from_gait's φ₀ was good to about 1e-8 (its search's tolerance grows with |φ₀|): 56 of 60 random members
    then failed params_of's 1e-9, and a shifted seed was refused by family='symmetric'."""
    family = SymmetricGaitFamily(n_joints, order, center)
    gait = family.gait(np.random.default_rng(seed).normal(size=family.n_params))
    found = SymmetricGaitFamily.from_gait(gait)
    assert found.residual(gait) < 1e-12 * max(1.0, np.abs(gait.coefficients).max())
    np.testing.assert_allclose(found.gait(found.params_of(gait)).coefficients, gait.coefficients, atol=1e-12)


def test_a_shifted_seed_is_run_in_its_symmetric_family():
    from geogait.optimize import InSituOptimizer
    from geogait.simulate import SwimmerStream

    seed = shift_phase(seed_gait(2), 0.3)
    result = InSituOptimizer(family="symmetric").run(SwimmerStream(PurcellSwimmer(3), seed, seed=0), 2)
    assert result.family == "symmetric" and result.initial_gait == seed


def test_shift_phase_is_a_reparametrisation(rng):
    gait = FourierGait(rng.normal(size=(3, 5)))
    phase = rng.uniform(0, 2 * np.pi, 9)
    np.testing.assert_allclose(shift_phase(gait, 0.7).shape(phase), gait.shape(phase + 0.7), atol=1e-12)


def test_free_family_is_the_identity():
    family = FreeGaitFamily(3, 2)
    gait = seed_gait(3, order=2)
    np.testing.assert_array_equal(family.params_of(gait), gait.params)
    assert family.gait(gait.params) == gait and family.n_params == 15


# -- the half-wave symmetric (mirror) family ---------------------------------------------------
@settings(max_examples=25, deadline=None)
@given(n_joints=st.integers(1, 6), order=st.integers(1, 4), seed=st.integers(0, 2**32 - 1))
def test_mirror_members_are_half_wave_symmetric_and_round_trip(n_joints, order, seed):
    rng = np.random.default_rng(seed)
    family = MirrorGaitFamily(n_joints, order)
    assert family.n_params == n_joints * 2 * ((order + 1) // 2)
    params = rng.normal(size=family.n_params)
    gait = family.gait(params)
    phase = rng.uniform(0, 2 * np.pi, 9)
    # θ(φ + π) = −θ(φ), on the shapes themselves (not on the coefficient map)
    np.testing.assert_allclose(gait.shape(phase + np.pi), -gait.shape(phase), atol=1e-12)
    np.testing.assert_allclose(family.params_of(gait), params, atol=1e-12)
    assert family.residual(gait) < 1e-12
    offset = gait.coefficients.copy()
    offset[:, 0] += 0.3  # a constant bend: no longer its own mirror image half a cycle later
    assert family.residual(FourierGait(offset)) == pytest.approx(0.3 * np.sqrt(n_joints))


@pytest.mark.parametrize("lengths", [(0.2, 0.3, 0.5), (0.3, 0.15, 0.2, 0.25, 0.1), (0.1, 0.2, 0.3, 0.4)])
def test_mirror_members_do_not_rotate_any_chain(rng, lengths):
    """Zero net rotation per cycle on chains without front–back symmetry (independent integrator: the
    swimmer's connection through cycle_displacement), where a constant bend makes the same loop turn."""
    swimmer = PurcellSwimmer(len(lengths), link_lengths=lengths)
    family = MirrorGaitFamily(swimmer.n_joints, 2)
    for _ in range(3):
        gait = family.gait(rng.normal(scale=0.5, size=family.n_params))
        pose = cycle_displacement(swimmer, gait, resolution=128)
        assert abs(pose[2]) < 1e-12 and np.hypot(pose[0], pose[1]) > 1e-4
        bent = gait.coefficients.copy()
        bent[:, 0] += rng.normal(scale=0.3, size=swimmer.n_joints)
        assert abs(cycle_displacement(swimmer, FourierGait(bent), resolution=128)[2]) > 1e-4


def test_the_free_ceiling_of_an_unequal_chain_is_half_wave_symmetric():
    """The free family's ceiling (15 parameters, zero rotation imposed as a constraint) lands in the
    mirror family, as the symmetry predicts for a unique optimum, and the mirror family's own ceiling
    (10 parameters, no constraint) reaches the same value."""
    swimmer = PurcellSwimmer(5, link_lengths=(0.3, 0.15, 0.2, 0.25, 0.1))
    free = cached_ceiling(swimmer, family="free")
    mirror = cached_ceiling(swimmer, family="mirror")
    assert MirrorGaitFamily(4).residual(free.gait) < 1e-5
    assert mirror.value == pytest.approx(free.value, rel=1e-6)
    assert abs(cycle_displacement(swimmer, mirror.gait)[2]) < 1e-12
    with pytest.raises(ValueError, match="'start' parameter of optimize_ceiling"):
        optimize_ceiling(swimmer, family="mirror", start=FourierGait(seed_gait(4).coefficients + 0.1))


def test_mirror_family_refuses_bad_input():
    with pytest.raises(ValueError, match="'n_joints' parameter of MirrorGaitFamily"):
        MirrorGaitFamily(0)
    with pytest.raises(ValueError, match="'params' parameter of MirrorGaitFamily.fourier_params"):
        MirrorGaitFamily(2).gait([1.0, 2.0])
    with pytest.raises(ValueError, match="'gait' parameter of MirrorGaitFamily.params_of"):
        MirrorGaitFamily(2).params_of(FourierGait(seed_gait(2).coefficients + 0.1))
    with pytest.raises(ValueError, match="'gait' parameter of MirrorGaitFamily.residual"):
        MirrorGaitFamily(3).residual(seed_gait(2))
