"""Physics of the Purcell swimmer against independent facts."""

import numpy as np
import pytest

from geogait import GeogaitError
from geogait.gaits import FourierGait, seed_gait
from geogait.simulate import cycle_displacement
from geogait.systems import FunctionSystem, PurcellSwimmer, System


def random_gait(rng, n_joints, order=2, scale=0.7):
    return FourierGait(rng.normal(scale=scale, size=(n_joints, 2 * order + 1)))


def test_three_link_connection_at_straight_shape_matches_closed_form():
    a = PurcellSwimmer(3).connection(np.zeros(2))
    np.testing.assert_allclose(a[0], [0, 0], atol=1e-15)
    np.testing.assert_allclose(a[1], [1 / 18, 1 / 18], rtol=1e-12)
    np.testing.assert_allclose(a[2], [-7 / 27, 7 / 27], rtol=1e-12)


@pytest.mark.parametrize("n_links", [3, 4, 5, 9])
def test_drag_ratio_one_cannot_displace_the_centre_of_mass(rng, n_links):
    # Isotropic drag: zero net force means the centroid never moves, for every gait. Net rotation
    # about it is still possible (a "falling cat" effect), so a frame off the centroid can drift
    # only through that rotation; gaits without net rotation go nowhere in every frame.
    swimmer = PurcellSwimmer(n_links, drag_ratio=1.0, body_frame="center_of_mass")
    for _ in range(3):
        np.testing.assert_allclose(cycle_displacement(swimmer, random_gait(rng, n_links - 1))[:2], 0, atol=1e-12)
    for frame in ("middle", "tail"):
        net = cycle_displacement(PurcellSwimmer(n_links, drag_ratio=1.0, body_frame=frame), seed_gait(n_links - 1))
        assert abs(net[2]) < 1e-12
        np.testing.assert_allclose(net, 0, atol=1e-9)  # Magnus integration error ~1e-10
    assert np.linalg.norm(cycle_displacement(swimmer.with_drag_ratio(2.0), seed_gait(n_links - 1))[:2]) > 1e-2


@pytest.mark.parametrize("n_links", [3, 5])
def test_reversed_gait_gives_inverse_motion(rng, n_links):
    from geogait import se2

    swimmer = PurcellSwimmer(n_links)
    gait = random_gait(rng, n_links - 1)
    coefficients = gait.coefficients.copy()
    coefficients[:, 1 + gait.order:] *= -1  # θ(-φ): same loop, traversed backwards
    forward = cycle_displacement(swimmer, gait)
    backward = cycle_displacement(swimmer, FourierGait(coefficients))
    assert np.linalg.norm(forward[:2]) > 1e-3
    np.testing.assert_allclose(backward, se2.inverse(forward), atol=1e-10)


@pytest.mark.parametrize("frame", ["middle", "center_of_mass", "tail"])
def test_scaling_lengths_scales_translation_only(rng, frame):
    gait = random_gait(rng, 3)
    lengths = np.array([0.3, 0.2, 0.25, 0.25])
    base = cycle_displacement(PurcellSwimmer(4, link_lengths=lengths, body_frame=frame), gait)
    scaled = cycle_displacement(PurcellSwimmer(4, link_lengths=2.5 * lengths, body_frame=frame), gait)
    np.testing.assert_allclose(scaled[:2], 2.5 * base[:2], rtol=1e-9)
    np.testing.assert_allclose(scaled[2], base[2], atol=1e-12)


def test_body_frame_change_rotates_translation_of_a_non_rotating_gait():
    # The seed gait of the 3-link swimmer has zero net rotation; the net motion seen from another
    # body frame is h⁻¹ g h with h the frame offset at the start shape: a pure rotation of the
    # translation by h's angle. Tail frame vs middle frame: angle -r_1(0) (closed form).
    gait = seed_gait(2)
    middle = cycle_displacement(PurcellSwimmer(3), gait)
    tail = cycle_displacement(PurcellSwimmer(3, body_frame="tail"), gait)
    assert abs(middle[2]) < 1e-12 and abs(tail[2]) < 1e-12
    angle = -gait.shape(0.0)[0]
    rotation = np.array([[np.cos(angle), np.sin(angle)], [-np.sin(angle), np.cos(angle)]])
    np.testing.assert_allclose(tail[:2], rotation @ middle[:2], atol=1e-10)
    com = cycle_displacement(PurcellSwimmer(3, body_frame="center_of_mass"), gait)
    np.testing.assert_allclose(np.linalg.norm(com[:2]), np.linalg.norm(middle[:2]), rtol=1e-8)


def _rft_wrench_and_power(swimmer, shape, shape_velocity, body_velocity, points=8):
    """Independent RFT: Gauss–Legendre points along each link, point velocities by central finite
    differences of world positions; returns net force/torque about the body origin and power."""
    lengths = np.asarray(swimmer.link_lengths)
    nodes, weights = np.polynomial.legendre.leggauss(points)

    def link_points(shape, g):
        angles = np.concatenate([[0.0], np.cumsum(shape)])
        joints = np.concatenate([[[0, 0]], np.cumsum(lengths[:, None] * np.c_[np.cos(angles), np.sin(angles)], 0)])
        mid = len(lengths) // 2
        centre, ref = (joints[mid] + joints[mid + 1]) / 2, angles[mid]  # middle link frame (odd N)
        pts = []
        for i, l in enumerate(lengths):
            along = (joints[i] + joints[i + 1]) / 2 + np.outer(nodes * l / 2, [np.cos(angles[i]), np.sin(angles[i])])
            local = (along - centre) @ np.array([[np.cos(ref), -np.sin(ref)], [np.sin(ref), np.cos(ref)]])
            c, s = np.cos(g[2]), np.sin(g[2])
            pts.append(g[:2] + local @ np.array([[c, s], [-s, c]]))
        return np.array(pts), angles - ref + g[2]

    from geogait import se2

    h = 1e-6
    plus, _ = link_points(shape + h * shape_velocity, se2.exp(h * body_velocity))
    minus, _ = link_points(shape - h * shape_velocity, se2.exp(-h * body_velocity))
    here, angles = link_points(shape, np.zeros(3))
    velocity = (plus - minus) / (2 * h)
    force, torque, power = np.zeros(2), 0.0, 0.0
    for i, l in enumerate(lengths):
        t = np.array([np.cos(angles[i]), np.sin(angles[i])])
        n = np.array([-t[1], t[0]])
        f = -(np.outer(velocity[i] @ t, t) + swimmer.drag_ratio * np.outer(velocity[i] @ n, n))
        f = f * swimmer.drag_coefficient * (weights * l / 2)[:, None]
        force += f.sum(0)
        torque += np.sum(here[i][:, 0] * f[:, 1] - here[i][:, 1] * f[:, 0])
        power -= np.sum(f * velocity[i])
    return force, torque, power


def test_connection_balances_forces_in_an_independent_rft_computation(rng):
    swimmer = PurcellSwimmer(5, drag_ratio=2.7, drag_coefficient=1.3)
    for _ in range(3):
        shape, rate = rng.normal(scale=0.8, size=(2, 4))
        xi = -swimmer.connection(shape) @ rate
        force, torque, power = _rft_wrench_and_power(swimmer, shape, rate, xi)
        scale = np.abs(_rft_wrench_and_power(swimmer, shape, rate, np.zeros(3))[0]).max()
        assert np.abs(force).max() < 1e-8 * scale and abs(torque) < 1e-8 * scale
        np.testing.assert_allclose(power, rate @ swimmer.metric(shape) @ rate, rtol=1e-8)
        # Any other body velocity leaves a net force: the balance pins ξ down.
        assert np.abs(_rft_wrench_and_power(swimmer, shape, rate, xi + [0.01, 0, 0])[0]).max() > 1e-4


def test_metric_is_symmetric_positive_definite(rng):
    metric = PurcellSwimmer(9).metric(rng.normal(size=(50, 8)))
    np.testing.assert_allclose(metric, np.swapaxes(metric, -1, -2), atol=1e-14)
    assert np.all(np.linalg.eigvalsh(metric) > 0)


@pytest.mark.parametrize("n_links", [2, 4, 6])
def test_even_chains_and_batches(rng, n_links):
    swimmer = PurcellSwimmer(n_links)
    shapes = rng.normal(size=(4, 7, n_links - 1))
    batch = swimmer.connection(shapes)
    assert batch.shape == (4, 7, 3, n_links - 1)
    np.testing.assert_allclose(batch[2, 3], swimmer.connection(shapes[2, 3]), atol=1e-14)


@pytest.mark.parametrize("batch", ["derivative", "cycle"])
def test_a_large_batch_is_evaluated_in_bounded_parts_with_the_same_bits(rng, monkeypatch, batch):
    """The ceiling's derivative at 38 links asked one (128, 2, 37, 37) batch of connections: 6.3 s in one compiled
    call on a loaded 2-core machine, SIGTERM unheard (and `simulate`'s 100 000-sample cycles 5 s). In parts of at most
    _CHUNK_FLOATS floats per array, the signal is handled between them; the result is the one of a single call."""
    from geogait.systems import _purcell

    swimmer = PurcellSwimmer(38, body_frame="center_of_mass", frame_offset=(0.1, 0.0, 0.2))
    if batch == "derivative":
        shapes = rng.uniform(-0.5, 0.5, (8, 2, 37))[..., None, :] + 1e-6 * np.eye(37)
    else:  # (a simulated cycle's samples, one perturbation stream)
        shapes = rng.uniform(-0.5, 0.5, (1, 600, 37))
    whole = swimmer._connection(shapes, swimmer._angles(shapes))  # one call, as before
    parts, evaluate = [], PurcellSwimmer._connection

    def counted(self, part, angles):
        parts.append(part.shape)
        return evaluate(self, part, angles)

    monkeypatch.setattr(PurcellSwimmer, "_connection", counted)
    assert np.array_equal(swimmer.connection(shapes), whole)
    assert len(parts) > 1 and sum(part[0] for part in parts) == np.prod(shapes.shape[:-1])
    assert all(np.prod(part[:-1]) * 38 * 3 * 37 <= _purcell._CHUNK_FLOATS for part in parts)  # (J_i: N × 3 × d each)


def test_mirror_symmetry_of_the_connection(rng):
    # Reflecting the swimmer (r -> -r) flips v_y and ω but not v_x.
    swimmer = PurcellSwimmer(5)
    shape = rng.normal(size=4)
    np.testing.assert_allclose(swimmer.connection(-shape), np.diag([-1, 1, 1]) @ swimmer.connection(shape),
                               atol=1e-14)


def test_user_connection_plugs_in():
    swimmer = PurcellSwimmer(3)
    custom = FunctionSystem(swimmer.connection, n_joints=2, name="wrapped")
    assert isinstance(custom, System) and isinstance(swimmer, System)
    np.testing.assert_allclose(cycle_displacement(custom, seed_gait(2)), cycle_displacement(swimmer, seed_gait(2)))
    broken = FunctionSystem(lambda r: np.zeros((3, 2)), n_joints=2)
    with pytest.raises(ValueError, match="connection_function"):
        broken.connection(np.zeros((5, 2)))


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: PurcellSwimmer(1), "'n_links'"),
        (lambda: PurcellSwimmer(3, drag_ratio=0), "'drag_ratio'"),
        (lambda: PurcellSwimmer(3, drag_ratio=-2), "'drag_ratio'"),
        (lambda: PurcellSwimmer(3, drag_coefficient=0), "'drag_coefficient'"),
        (lambda: PurcellSwimmer(3, link_lengths=[0.5, 0.0, 0.5]), "'link_lengths'"),
        (lambda: PurcellSwimmer(3, link_lengths=[0.5, 0.5]), "'link_lengths'"),
        (lambda: PurcellSwimmer(3, body_frame="head"), "'body_frame'.*'middle'"),
        (lambda: PurcellSwimmer(3).connection(np.zeros(3)), r"'shapes'.*\(\.\.\., 2\)"),
        (lambda: PurcellSwimmer(3).connection([np.nan, 0.0]), "'shapes'.*finite"),
        (lambda: PurcellSwimmer(3).connection([np.inf, 0.0]), "'shapes'.*finite"),
        (lambda: PurcellSwimmer(3).connection("ab"), "'shapes'"),
    ],
)
def test_bad_input_names_the_field(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_the_height_functions_curl_part_is_the_line_integral_by_stokes():
    """Stokes: around a small circle of radius ε about r₀ the body-frame line integral ∮ ξ dφ of
    ξ = −A(r)ṙ equals π ε² × the curl part of the height function (first order: the frame's rotation,
    the Lie-bracket part, is what the height function adds; the small-loop test checks the sum)."""
    from geogait import se2
    from geogait.systems import height_function

    swimmer = PurcellSwimmer(3)
    direction = np.array([0.6, 0.8])
    axis, values = height_function(swimmer, direction, limit=1.0, resolution=21)  # grid step 0.1
    phase = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    for i, j in [(10, 10), (13, 8), (6, 15)]:
        centre, epsilon = np.array([axis[j], axis[i]]), 0.01  # values are indexed [r2, r1]
        shape = centre + epsilon * np.stack([np.cos(phase), np.sin(phase)], axis=-1)  # counter-clockwise
        rate = epsilon * np.stack([-np.sin(phase), np.cos(phase)], axis=-1)
        xi = -np.einsum("nkj,nj->nk", swimmer.connection(shape), rate)
        line_integral = xi[:, :2].mean(axis=0) * 2 * np.pi @ direction
        connection = swimmer.connection(centre)
        bracket = se2.bracket(connection[:, 0], connection[:, 1])[:2] @ direction
        np.testing.assert_allclose(line_integral, np.pi * epsilon**2 * (values[i, j] - bracket), rtol=1e-3)


def test_a_frame_offset_conjugates_the_net_motion_and_link_frames_match_the_named_ones():
    """The net motion per cycle seen from a frame o rigidly attached to the body frame is o⁻¹ g o (a
    group identity, independent of the connection's arithmetic); link-index frames are the named ones."""
    from geogait import se2
    from geogait.gaits import seed_gait
    from geogait.simulate import cycle_displacement

    lengths = (0.3, 0.15, 0.2, 0.25, 0.1)
    gait = seed_gait(4)
    named = PurcellSwimmer(5, link_lengths=lengths)
    np.testing.assert_array_equal(PurcellSwimmer(5, link_lengths=lengths, body_frame=2).connection([[0.3] * 4]),
                                  named.connection([[0.3] * 4]))
    np.testing.assert_array_equal(PurcellSwimmer(5, link_lengths=lengths, body_frame=0).connection([[0.3] * 4]),
                                  PurcellSwimmer(5, link_lengths=lengths, body_frame="tail").connection([[0.3] * 4]))
    offset = np.array([0.12, -0.05, 2.5])
    moved = PurcellSwimmer(5, link_lengths=lengths, frame_offset=offset)
    g = cycle_displacement(named, gait)
    expected = se2.compose(se2.compose(se2.inverse(offset), g), offset)
    np.testing.assert_allclose(cycle_displacement(moved, gait), expected, atol=1e-9)
    with pytest.raises(GeogaitError, match="'body_frame' parameter"):
        PurcellSwimmer(5, body_frame=5)
    with pytest.raises(GeogaitError, match="'frame_offset' parameter"):
        PurcellSwimmer(5, frame_offset=(1.0, 2.0))


@pytest.mark.parametrize("links", [3, (0.3, 0.5, 0.2)])
@pytest.mark.parametrize("centre", [(0.0, 0.0), (-1.0, 0.7), (0.5, 0.3)])
def test_the_height_function_is_what_a_small_loop_moves(links, centre):
    """Independent check, by simulation: a loop of radius ε about the shape r moves the body by the height
    function × its area (π ε²), to O(ε). The curl alone (the bracket left out) was 2.4× off at r = 0, and of
    the wrong sign at (−1, 0.7)."""
    from geogait.systems import height_function

    swimmer = PurcellSwimmer(3) if links == 3 else PurcellSwimmer(3, link_lengths=links)
    limit, resolution = 1.2, 241
    axis, values = height_function(swimmer, [1.0, 0.0], limit, resolution)
    column, row = (int(np.argmin(np.abs(axis - c))) for c in centre)
    radius = 0.004
    loop = FourierGait(np.array([[axis[column], radius, 0.0], [axis[row], 0.0, radius]]))
    moved = cycle_displacement(swimmer, loop, 512)[0] / (np.pi * radius**2)
    assert moved == pytest.approx(values[row, column], abs=5e-4 + 0.02 * abs(moved))
