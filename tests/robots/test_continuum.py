"""Continuum-body helpers against bodies of known shape and motion (exact answers, finite differences)."""

import numpy as np
import pytest

from geogait.robots import (
    CurvatureModes,
    body_pose,
    body_velocity,
    curvature_profile,
    curvature_rate,
    rod_from_curvature,
    tangent_angles,
)


def rotation(angle):
    return np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])


def arc(radius, length, n_nodes, start_angle=0.0):
    """Nodes on a circle of ``radius`` (centre (0, radius)), equal arcs, counter-clockwise from the origin."""
    angle = start_angle + np.linspace(0, length / radius, n_nodes)
    return np.stack([radius * np.sin(angle), radius * (1 - np.cos(angle))], axis=-1)


def straight(n_nodes=11, length=1.0):
    return np.stack([np.linspace(0, length, n_nodes), np.zeros(n_nodes)], axis=-1)


def test_circular_arc_has_its_curvature():
    radius, length, n = 0.4, 1.0, 26
    ds = length / (n - 1)
    s, kappa = curvature_profile(arc(radius, length, n))
    exact = (ds / radius) / (2 * radius * np.sin(ds / (2 * radius)))  # turning angle over chord length
    np.testing.assert_allclose(kappa, exact, rtol=1e-12)
    np.testing.assert_allclose(kappa, 1 / radius, rtol=2e-3)
    np.testing.assert_allclose(s, np.arange(1, n - 1) * 2 * radius * np.sin(ds / (2 * radius)), rtol=1e-12)
    _, clockwise = curvature_profile(arc(radius, length, n) * [1, -1])
    np.testing.assert_allclose(clockwise, -kappa)


def test_straight_rod_translated_and_rotated():
    rod = straight()
    for angle, offset in ((0.0, (0, 0)), (0.7, (2.0, -1.0)), (-2.9, (0.3, 5.0)), (3.1, (0, 0))):
        moved = rod @ rotation(angle).T + offset
        pose = body_pose(moved)
        centre = rotation(angle) @ [0.5, 0.0] + offset
        np.testing.assert_allclose(pose, [*centre, angle], atol=1e-12)
        np.testing.assert_allclose(curvature_profile(moved)[1], 0, atol=1e-12)


def test_centre_of_mass_uses_the_masses():
    rod = straight(3, 2.0)
    np.testing.assert_allclose(body_pose(rod, masses=[1, 0, 3])[:2], [1.5, 0.0])


def test_heading_of_an_arc_is_its_mean_tangent_angle():
    radius, length, n = 0.5, 1.0, 41
    nodes = arc(radius, length, n)
    mean_angle = np.mean(tangent_angles(nodes))
    assert body_pose(nodes)[2] == pytest.approx(mean_angle)
    assert body_pose(nodes)[2] == pytest.approx(length / (2 * radius), rel=1e-3)  # the chord's mid angle


def test_rigidly_moving_rod_has_its_body_velocity():
    """v + ω × (x − c) at every node: ξ = (R(−h) v, ω) exactly, for straight and curved rods."""
    for nodes in (straight(), arc(0.3, 1.0, 21), arc(0.3, 1.0, 21) @ rotation(2.0).T + [1, 2]):
        pose = body_pose(nodes)
        v, omega = np.array([0.3, -0.2]), 1.7
        relative = nodes - pose[:2]
        velocities = v + omega * np.stack([-relative[:, 1], relative[:, 0]], axis=-1)
        expected = np.r_[rotation(-pose[2]) @ v, omega]
        np.testing.assert_allclose(body_velocity(nodes, velocities), expected, atol=1e-12)
        np.testing.assert_allclose(curvature_rate(nodes, velocities), 0, atol=1e-10)


def test_body_velocity_and_curvature_rate_are_the_derivatives():
    rng = np.random.default_rng(3)
    nodes = rod_from_curvature(rng.normal(0, 2, 18), rng.uniform(0.04, 0.06, 19), heading=0.4)
    masses = rng.uniform(0.5, 1.5, 20)
    velocities = rng.normal(size=nodes.shape)
    eps = 1e-6
    plus, minus = nodes + eps * velocities, nodes - eps * velocities
    rate = (body_pose(plus, masses=masses) - body_pose(minus, masses=masses)) / (2 * eps)
    xi = body_velocity(nodes, velocities, masses=masses)
    heading = body_pose(nodes)[2]
    np.testing.assert_allclose(rate, np.r_[rotation(heading) @ xi[:2], xi[2]], rtol=1e-6, atol=1e-6)
    numeric = (curvature_profile(plus)[1] - curvature_profile(minus)[1]) / (2 * eps)
    np.testing.assert_allclose(curvature_rate(nodes, velocities), numeric, rtol=1e-5, atol=1e-4)


def test_rod_from_curvature_inverts_curvature_profile():
    rng = np.random.default_rng(0)
    lengths = rng.uniform(0.5, 1.5, 12)
    kappa = rng.normal(0, 0.8, 11)
    nodes = rod_from_curvature(kappa, lengths, origin=(1.0, -2.0), heading=0.3)
    np.testing.assert_allclose(curvature_profile(nodes)[1], kappa, atol=1e-12)
    np.testing.assert_allclose(np.hypot(*np.diff(nodes, axis=0).T), lengths)
    np.testing.assert_allclose(nodes[0], [1.0, -2.0])
    assert tangent_angles(nodes)[0] == pytest.approx(0.3)


@pytest.mark.parametrize("kind", ["fourier", "legendre"])
def test_modes_to_curvature_to_modes(kind):
    modes = CurvatureModes(5, kind, length=0.35)
    s = np.linspace(0, 0.35, 21)[1:-1]
    q = np.random.default_rng(1).normal(size=(7, 5))
    np.testing.assert_allclose(modes.project(modes.curvature(q, s), s), q, atol=1e-10)
    # ... and through a rod built from that rest curvature and measured back
    nodes = rod_from_curvature(modes.curvature(q[0], s), np.full(20, 0.35 / 20))
    arc_length, kappa = curvature_profile(nodes)
    np.testing.assert_allclose(modes.project(kappa, arc_length), q[0], atol=1e-10)


def test_fourier_mode_is_a_tangent_angle_wave_of_its_amplitude():
    length, n = 0.35, 401
    modes = CurvatureModes(4, length=length)
    s = np.linspace(0, length, n)[1:-1]
    for j in range(4):
        q = np.zeros(4)
        q[j] = 0.8
        nodes = rod_from_curvature(modes.curvature(q, s), np.full(n - 1, length / (n - 1)))
        angle = tangent_angles(nodes)
        assert (angle.max() - angle.min()) / 2 == pytest.approx(0.8, rel=1e-2)


def test_projection_is_least_squares():
    modes = CurvatureModes(2, length=1.0)
    s = np.linspace(0, 1, 30)[1:-1]
    kappa = np.random.default_rng(2).normal(size=s.size)
    q = modes.project(kappa, s)
    reference, *_ = np.linalg.lstsq(modes.basis(s), kappa, rcond=None)
    np.testing.assert_allclose(q, reference)


def test_heading_is_continuous_over_time_and_across_calls():
    rod = straight()
    turns = np.linspace(0, 4 * np.pi, 60)
    sequence = np.stack([rod @ rotation(a).T for a in turns])
    np.testing.assert_allclose(body_pose(sequence)[:, 2], turns, atol=1e-9)
    later = body_pose(rod @ rotation(7.0).T, reference_heading=6.5)
    assert later[2] == pytest.approx(7.0)
    assert body_pose(sequence[10:], reference_heading=turns[9])[0, 2] == pytest.approx(turns[10])


def test_bad_input_is_named():
    with pytest.raises(ValueError, match=r"'positions' parameter of curvature_profile must be an array of shape"):
        curvature_profile(np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"body_pose must be an array of shape \(\.\.\., n, 2\)"):
        body_pose(np.zeros((5, 3)))
    with pytest.raises(ValueError, match="no element of zero length"):
        body_pose([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0]])
    with pytest.raises(ValueError, match="'velocities' parameter of body_velocity"):
        body_velocity(straight(), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="'masses' parameter of body_pose"):
        body_pose(straight(), masses=[1.0, 2.0])
    with pytest.raises(ValueError, match="'kind' parameter of CurvatureModes"):
        CurvatureModes(3, "chebyshev")
    with pytest.raises(ValueError, match="resolve all 4 modes"):
        CurvatureModes(4).projector([0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match=r"'curvature' parameter of rod_from_curvature must be .* shape \(3,\)"):
        rod_from_curvature([0.0], [1.0, 1.0, 1.0, 1.0])
