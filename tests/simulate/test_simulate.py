import numpy as np
import pandas as pd
import pytest

from geogait.gaits import FourierGait, Perturbation, seed_gait
from geogait.simulate import DragRatioSchedule, SwimmerStream, Trajectory, cycle_displacement, simulate, simulate_rate
from geogait.systems import PurcellSwimmer


def test_oracle_converges_at_fourth_order_and_reaches_1e_6():
    swimmer, gait = PurcellSwimmer(5), FourierGait(np.random.default_rng(3).normal(scale=0.6, size=(4, 5)))
    reference = cycle_displacement(swimmer, gait, resolution=4096)
    errors = [np.abs(cycle_displacement(swimmer, gait, resolution=n) - reference).max() for n in (32, 64)]
    assert 12 < errors[0] / errors[1] < 20  # 2⁴ = 16
    assert np.abs(cycle_displacement(swimmer, gait) - reference).max() < 1e-6


def test_oracle_agrees_with_fine_simulation_without_perturbation():
    # Second method: zero-order-hold integration of the sampled body velocity, 4000 samples/cycle.
    swimmer, gait = PurcellSwimmer(3), seed_gait(2)
    run = simulate(swimmer, gait, 1, samples_per_cycle=4000, perturbation=Perturbation(eta=0), seed=0)
    from geogait import se2

    end = se2.displacement(run.body_velocity, 1 / 4000)
    # Zero-order hold is first order in the step: 1/4000 of a cycle leaves ~1e-5.
    np.testing.assert_allclose(end, cycle_displacement(swimmer, gait), atol=3e-5)


def test_samples_follow_the_model_equations():
    swimmer, gait = PurcellSwimmer(3), seed_gait(2)
    run = simulate(swimmer, gait, 3, samples_per_cycle=50, seed=4)
    phase = 2 * np.pi * (np.arange(150) % 50) / 50
    np.testing.assert_allclose(run.phase, phase)
    np.testing.assert_array_equal(run.cycle, np.repeat([0, 1, 2], 50))
    np.testing.assert_allclose(run.time, np.arange(150) / 50)
    delta = run.shape - gait.shape(phase)
    assert 0.05 < delta.std() < 0.3  # default perturbation std 0.15 rad
    expected = -np.einsum("nij,nj->ni", swimmer.connection(run.shape), run.shape_velocity)
    np.testing.assert_allclose(run.body_velocity, expected, atol=1e-14)
    # The perturbation's rate is the time derivative of its value (smooth SDE path).
    rate = np.gradient(delta, 1 / 50, axis=0)
    nominal = run.shape_velocity - gait.velocity(phase) * 2 * np.pi
    assert np.corrcoef(rate[5:-5].ravel(), nominal[5:-5].ravel())[0, 1] > 0.95


def test_sample_stream_equals_cycle_stream_and_is_seeded():
    options = dict(samples_per_cycle=40, sensor_noise=0.3, shape_noise=0.1, seed=9)
    swimmer, gait = PurcellSwimmer(5), seed_gait(4)
    by_cycle = SwimmerStream(swimmer, gait, **options).next_cycles(2)
    stream = SwimmerStream(swimmer, gait, **options)
    by_sample = Trajectory.concatenate([stream.next_sample() for _ in range(80)])
    for name in ("shape", "shape_velocity", "phase", "cycle"):
        np.testing.assert_array_equal(getattr(by_cycle, name), getattr(by_sample, name))
    # Same draws; only the rounding of batched vs single linear solves differs.
    np.testing.assert_allclose(by_cycle.body_velocity, by_sample.body_velocity, atol=1e-13)
    np.testing.assert_allclose(by_cycle.pose, by_sample.pose, atol=1e-13)
    other = SwimmerStream(swimmer, gait, **{**options, "seed": 10}).next_cycles(2)
    assert not np.allclose(other.shape, by_cycle.shape)


def test_trials_do_not_depend_on_batch_composition():
    seeds = np.random.SeedSequence(5).spawn(3)
    swimmer, gait = PurcellSwimmer(3), seed_gait(2)
    batch = simulate(swimmer, gait, 2, seed=seeds, sensor_noise=0.2)
    alone = simulate(swimmer, gait, 2, seed=[seeds[1]], sensor_noise=0.2)
    assert batch.shape.shape == (3, 200, 2)
    np.testing.assert_array_equal(batch.trial(1).body_velocity, alone.trial(0).body_velocity)


def test_sensor_noise_has_the_requested_fraction_of_rms():
    swimmer, gait = PurcellSwimmer(3), seed_gait(2)
    options = dict(perturbation=Perturbation(eta=0), seed=2, samples_per_cycle=100)
    clean = simulate(swimmer, gait, 50, **options)
    noisy = simulate(swimmer, gait, 50, sensor_noise=0.3, **options)
    rms = np.sqrt(np.mean(clean.body_velocity**2, axis=0))
    np.testing.assert_allclose((noisy.body_velocity - clean.body_velocity).std(axis=0), 0.3 * rms, rtol=0.05)
    np.testing.assert_array_equal(noisy.shape, clean.shape)


def test_gait_change_takes_effect_at_the_next_cycle():
    swimmer = PurcellSwimmer(3)
    old, new = seed_gait(2), seed_gait(2, amplitude=0.5)
    stream = SwimmerStream(swimmer, old, samples_per_cycle=20, perturbation=Perturbation(eta=0), seed=0)
    stream.next_sample()
    stream.set_gait(new)
    rest = stream.next_cycle()
    assert stream.gait == new and rest.n_samples == 19
    np.testing.assert_allclose(rest.shape, old.shape(rest.phase), atol=1e-12)
    following = stream.next_cycle()
    np.testing.assert_allclose(following.shape, new.shape(following.phase), atol=1e-12)
    with pytest.raises(ValueError, match="'gait'"):
        stream.set_gait(seed_gait(3))


def test_environment_schedule_switches_drag_ratio():
    swimmer, gait = PurcellSwimmer(3), seed_gait(2)
    schedule = DragRatioSchedule(swimmer, (2.0, 3.0, 4.0), cycles_per_environment=2)
    run = simulate(swimmer, gait, 7, samples_per_cycle=20, environment=schedule, seed=1)
    for cycle, k in [(0, 2.0), (1, 2.0), (2, 3.0), (5, 4.0), (6, 4.0)]:
        part = run.cycles(cycle, cycle + 1)
        expected = -np.einsum("nij,nj->ni", swimmer.with_drag_ratio(k).connection(part.shape), part.shape_velocity)
        np.testing.assert_allclose(part.body_velocity, expected, atol=1e-14)
    with pytest.raises(ValueError, match="'drag_ratios'"):
        DragRatioSchedule(swimmer, (2.0, -1.0))


def test_trajectory_round_trips_through_parquet_and_csv(tmp_path):
    run = simulate(PurcellSwimmer(4), seed_gait(3), 2, samples_per_cycle=30, seed=0, sensor_noise=0.1)
    frame = run.to_pandas()
    assert list(frame.columns[:3]) == ["time", "phase", "cycle"] and len(frame) == 60
    assert {"shape_2", "shape_velocity_0", "body_velocity_theta", "heading"} <= set(frame.columns)
    back = Trajectory.from_pandas(pd.read_parquet(run.to_parquet(tmp_path / "run.parquet")))
    np.testing.assert_array_equal(back.body_velocity, run.body_velocity)
    csv = Trajectory.from_pandas(pd.read_csv(run.to_csv(tmp_path / "run.csv")))
    np.testing.assert_allclose(csv.shape, run.shape, rtol=1e-15)
    batched = simulate(PurcellSwimmer(3), seed_gait(2), 1, seed=0, n_trials=2).to_pandas()
    assert list(batched["trial"].unique()) == [0, 1]


@pytest.mark.parametrize(
    ("options", "match"),
    [
        (dict(samples_per_cycle=2), "'samples_per_cycle'"),
        (dict(sensor_noise=-0.1), "'sensor_noise'"),
        (dict(cycle_period=0), "'cycle_period'"),
        (dict(n_trials=0), "'n_trials'"),
    ],
)
def test_bad_stream_options_name_the_field(options, match):
    with pytest.raises(ValueError, match=match):
        SwimmerStream(PurcellSwimmer(3), seed_gait(2), **options)
    with pytest.raises(ValueError, match="'gait'"):
        SwimmerStream(PurcellSwimmer(3), seed_gait(4))


# -- any samples per cycle, drifting rates (simulate_rate) ---------------------------------------------
@pytest.mark.parametrize("noise", [0.0, 0.1])
def test_simulate_rate_at_a_whole_period_and_constant_rate_is_simulate(noise):
    # Same generators, same draws: at 100 samples per cycle and a constant rate both simulators agree.
    swimmer, gait = PurcellSwimmer(3), seed_gait(2)
    options = dict(shape_noise=noise, sensor_noise=noise, seed=4, cycle_period=2.0)
    reference = simulate(swimmer, gait, 3, **options)
    run = simulate_rate(swimmer, gait, 3, samples_per_cycle=100.0, **options)
    for name in ("time", "phase", "cycle", "shape", "shape_velocity", "body_velocity", "pose", "commanded_shape"):
        np.testing.assert_allclose(getattr(run, name), getattr(reference, name), rtol=1e-9, atol=1e-12,
                                   err_msg=name)


def test_simulate_rate_follows_the_ramped_phase_law():
    swimmer, gait = PurcellSwimmer(3), seed_gait(2)
    run = simulate_rate(swimmer, gait, 12, samples_per_cycle=86.7, rate_ramp=(0.8, 1.2), cycle_period=0.5,
                        perturbation=Perturbation(eta=0), seed=1)
    dt = 0.5 / 86.7
    np.testing.assert_allclose(np.diff(run.time), dt, rtol=1e-12)
    # φ̇ ramps linearly in time from 0.8 ω0 to 1.2 ω0 over the duration D of 12 cycles, D = 2·12·T / 2.0.
    omega, duration = 2 * np.pi / 0.5, 12 * 0.5
    phase = run.phase + 2 * np.pi * run.cycle
    np.testing.assert_allclose(phase, omega * (0.8 * run.time + 0.4 * run.time**2 / (2 * duration)), atol=1e-9)
    assert run.n_samples == int(np.ceil(duration / dt)) and phase[-1] < 24 * np.pi <= phase[-1] + 1.2 * omega * dt
    assert np.all((run.phase >= 0) & (run.phase < 2 * np.pi)) and run.cycle[-1] == 11
    # No perturbation: r = θ(φ), and ṙ = θ'(φ) φ̇ is the time derivative of the sampled shapes.
    np.testing.assert_allclose(run.shape, gait.shape(phase), atol=1e-12)
    central = (run.shape[2:] - run.shape[:-2]) / (2 * dt)
    np.testing.assert_allclose(central, run.shape_velocity[1:-1], atol=2e-3 * np.abs(run.shape_velocity).max())
    body = -np.einsum("nij,nj->ni", swimmer.connection(run.shape), run.shape_velocity)
    np.testing.assert_allclose(run.body_velocity, body, atol=1e-12)


@pytest.mark.parametrize(("options", "match"), [
    (dict(samples_per_cycle=3.5), "'samples_per_cycle' parameter of simulate_rate must be a finite float in \\[4, "),
    (dict(samples_per_cycle=float("nan")), "'samples_per_cycle'.*finite float"),
    (dict(rate_ramp=(0.8,)), "'rate_ramp'.*pair \\(start, end\\)"),
    (dict(rate_ramp="fast"), "'rate_ramp'.*pair"),
    (dict(rate_ramp=(0.8, -1.0)), "'rate_ramp'.*\\[0.1, 10\\]. Got -1.0"),
    (dict(samples_per_cycle=10.0, rate_ramp=(1.0, 3.0)), "'rate_ramp'.*at most samples_per_cycle / 4 = 2.5"),
    (dict(n_cycles=0), "'n_cycles'.*\\(0, inf\\)"),
    (dict(cycle_period=0.0), "'cycle_period'"),
    (dict(shape_noise=-0.1), "'shape_noise'"),
    (dict(perturbation=0.15), "'perturbation'.*a Perturbation. Got 'float'"),
    (dict(gait=seed_gait(4)), "'gait'.*2 joints"),
])
def test_simulate_rate_names_bad_options(options, match):
    arguments = dict(system=PurcellSwimmer(3), gait=seed_gait(2), n_cycles=2)
    arguments.update({k: options.pop(k) for k in list(options) if k in arguments})
    with pytest.raises(ValueError, match=match):
        simulate_rate(**arguments, **options)


def test_a_principally_kinematic_stream_moves_the_same_per_cycle_at_any_period():
    """ξ = −A(r)ṙ: running the same shape loop faster or slower moves the body by the same amount per
    cycle (to rounding, with the same samples per cycle), and time runs on without a jump."""
    from geogait import se2

    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), perturbation=Perturbation(eta=0), seed=0)
    runs = []
    for period in (1.0, 2.5, 0.5):
        stream.set_cycle_period(period)
        runs.append(stream.next_cycle())
    nets = [se2.between(run.pose[0], run.pose[-1]) for run in runs]  # to the last sample's start
    steps = [se2.between(a.pose[0], b.pose[0]) for a, b in zip(runs, runs[1:], strict=False)]
    np.testing.assert_allclose(steps[0], steps[1], rtol=0, atol=1e-12)  # cycles at 1 s and 2.5 s
    np.testing.assert_allclose(nets[1], nets[2], rtol=0, atol=1e-12)  # and at 0.5 s
    np.testing.assert_allclose(steps[0], cycle_displacement(PurcellSwimmer(3), seed_gait(2)), atol=5e-3)
    assert runs[1].time[0] == pytest.approx(1.0) and runs[2].time[0] == pytest.approx(3.5)
    np.testing.assert_allclose(np.diff(runs[2].time), 0.005)
    np.testing.assert_allclose(runs[1].shape_velocity * 2.5, runs[0].shape_velocity, atol=1e-12)


def test_the_period_changes_only_at_a_cycle_boundary_and_survives_a_saved_state():
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.1, seed=3)
    stream.next_cycle()
    stream.set_cycle_period(1.7)
    stream.next_sample()
    with pytest.raises(ValueError, match="'self'.*cycle boundary"):
        stream.set_cycle_period(2.0)
    with pytest.raises(ValueError, match="'seconds'"):
        SwimmerStream(PurcellSwimmer(3), seed_gait(2)).set_cycle_period(0.0)
    stream.next_cycle()
    state = stream.robot_state()
    expected = stream.next_cycle()
    copy = SwimmerStream(PurcellSwimmer(3), seed_gait(2), sensor_noise=0.1, seed=3)
    copy.restore_robot_state(state)
    assert copy.cycle_period == 1.7
    again = copy.next_cycle()
    for name in ("time", "shape", "shape_velocity", "body_velocity", "pose"):
        np.testing.assert_array_equal(getattr(again, name), getattr(expected, name))


def test_simulate_names_a_bad_argument_as_its_own():
    """A float for the perturbation (its std, as Perturbation.from_std takes it), an array of drag ratios, no
    cycles: each a clear error naming the argument, where they once failed deep inside."""
    from geogait import GeogaitError

    swimmer = PurcellSwimmer(3)
    with pytest.raises(GeogaitError, match=r"'perturbation' parameter of SwimmerStream must be a Perturbation"):
        simulate(swimmer, seed_gait(2), 1, perturbation=0.1)
    with pytest.raises(GeogaitError, match=r"'n_cycles' parameter of simulate must be an int >= 1"):
        simulate(swimmer, seed_gait(2), 0)
    with pytest.raises(GeogaitError, match=r"'drag_ratios' parameter of DragRatioSchedule must be a non-empty"):
        DragRatioSchedule(swimmer, 2.0, 10)
    assert DragRatioSchedule(swimmer, np.array([2.0, 3.0]), 10).drag_ratios == (2.0, 3.0)


@pytest.mark.parametrize(("options", "match"), [
    (dict(seed=-1), "'seed'.*>= 0"),
    (dict(sensor_noise=1e300), "'sensor_noise'"),
    (dict(shape_noise=-0.1), "'shape_noise'"),
    (dict(samples_per_cycle=10**7), "'samples_per_cycle'"),
])
def test_swimmer_stream_bounds(options, match):
    from geogait.gaits import seed_gait as _seed_gait
    from geogait.simulate import SwimmerStream as _Stream
    from geogait.systems import PurcellSwimmer as _Swimmer

    with pytest.raises(ValueError, match=match):
        _Stream(_Swimmer(3), _seed_gait(2), **options)


def test_trajectory_files_are_written_atomically_and_empty_joins_refused(tmp_path):
    from geogait.gaits import seed_gait as _seed_gait
    from geogait.simulate import Trajectory as _Trajectory
    from geogait.simulate import simulate as _simulate
    from geogait.systems import PurcellSwimmer as _Swimmer

    run = _simulate(_Swimmer(3), _seed_gait(2), 2, seed=0)
    link = tmp_path / "link.csv"
    target = tmp_path / "target.csv"
    target.write_text("old")
    link.symlink_to(target)
    run.to_csv(link)
    assert link.is_symlink() and len(pd.read_csv(target)) == run.n_samples
    run.to_parquet(tmp_path / "run.parquet")
    assert _Trajectory.from_pandas(pd.read_parquet(tmp_path / "run.parquet")).n_samples == run.n_samples
    assert not list(tmp_path.glob(".*tmp*"))
    with pytest.raises(ValueError, match="'parts'"):
        _Trajectory.concatenate([])
