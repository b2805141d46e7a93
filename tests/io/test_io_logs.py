"""Log ingestion: body velocity from poses, Savitzky–Golay shape velocity, irregular logs, errors."""

import json

import numpy as np
import pandas as pd
import pytest
from _reference import mocap_log

from geogait import se2
from geogait.gaits import seed_gait
from geogait.io import ColumnMapping, Log, load_column_mapping, read_log
from geogait.se2 import body_velocity_from_poses
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer

COLUMNS = dict(time="t", shape=["q0", "q1"], pose=["x", "y", "yaw"])


def relative_rms(estimate, truth):
    return np.sqrt(np.mean((estimate - truth) ** 2, axis=0)) / np.sqrt(np.mean(truth**2, axis=0))


@pytest.fixture(scope="module")
def run():
    return simulate(PurcellSwimmer(3), seed_gait(2), n_cycles=30, seed=0)


# -- body velocity and shape velocity from a simulated run ---------------------------------------
def test_round_trip_with_mocap_noise(run, tmp_path):
    # Body length 1: 1 mm-scale position noise (1e-3), 0.5 deg heading, 0.1 deg joint encoders.
    frame = mocap_log(run, position=1e-3, heading=np.deg2rad(0.5), encoder=np.deg2rad(0.1))
    frame.to_csv(tmp_path / "log.csv", index=False)
    log = read_log(tmp_path / "log.csv", **COLUMNS)
    assert log.phase is None and log.n_segments == 1 and log.n_samples == run.n_samples
    # Measured: xi (0.137, 0.138, 0.157), r_dot (0.101, 0.098). Most of it is the simulator's
    # perturbation rate δ̇, which is not smooth (white noise drives δ̈): the same filter on
    # noise-free shapes already errs by 0.10 (checked below), so no smoothing differentiator
    # does much better on this data.
    assert np.all(relative_rms(log.body_velocity, run.body_velocity) < 0.2)
    assert np.all(relative_rms(log.shape_velocity, run.shape_velocity) < 0.12)
    clean = read_log(mocap_log(run), **COLUMNS)
    assert np.all(relative_rms(clean.shape_velocity, run.shape_velocity) > 0.08)


def test_smoothing_the_poses_is_what_makes_noisy_poses_usable(run):
    frame = mocap_log(run, position=1e-3, heading=np.deg2rad(0.5))
    raw = read_log(frame, **COLUMNS, smooth_poses=False)
    smoothed = read_log(frame, **COLUMNS)
    # Measured: raw (0.55, 0.48, 0.69), smoothed (0.137, 0.138, 0.157).
    assert np.all(relative_rms(raw.body_velocity, run.body_velocity) > 0.4)
    assert np.all(relative_rms(smoothed.body_velocity, run.body_velocity) < 0.2)


def test_se2_logarithm_inverts_the_simulator_exactly_unlike_finite_differences(run):
    log = read_log(mocap_log(run), **COLUMNS, smooth_poses=False)
    # Zero-order hold g_{n+1} = g_n exp(dt ξ_n) is inverted exactly (the last sample repeats).
    np.testing.assert_allclose(log.body_velocity[:-1], run.body_velocity[:-1], atol=1e-10)
    dt = np.diff(run.time)[:, None]
    world = np.diff(run.pose, axis=0) / dt
    heading = run.pose[:-1, 2]
    body_x = np.cos(heading) * world[:, 0] + np.sin(heading) * world[:, 1]
    body_y = -np.sin(heading) * world[:, 0] + np.cos(heading) * world[:, 1]
    naive = np.stack([body_x, body_y, world[:, 2]], axis=1)
    truth = run.body_velocity[:-1]
    # Finite differences of x, y rotated into the body frame ignore the rotation during the
    # step: measured 0.9 % / 0.6 % error in v_x / v_y for this swimmer (ω RMS 1.8 rad/cycle).
    assert np.all(relative_rms(naive, truth)[:2] > 4e-3)
    assert np.all(relative_rms(log.body_velocity[:-1], truth) < 1e-10)
    # Unrotated world-frame differences are not body velocities (measured 0.55 / 0.25 error, though
    # this gait's heading only oscillates by about ±0.4 rad).
    assert np.all(relative_rms(world[:, :2], truth[:, :2]) > 0.2)


def test_body_velocity_schemes_on_a_constant_twist():
    twist = np.array([0.4, -0.2, 3.0])
    dt = np.full(40, 0.02) * (1 + 0.3 * np.sin(np.arange(40)))  # irregular steps are fine here
    poses = se2.integrate_body_velocity(np.tile(twist, (40, 1)), dt)
    time = np.concatenate([[0.0], np.cumsum(dt)])
    for scheme in ("forward", "central"):
        np.testing.assert_allclose(body_velocity_from_poses(time, poses, scheme=scheme),
                                   np.tile(twist, (41, 1)), atol=1e-12)
    wrapped = poses.copy()
    wrapped[:, 2] = se2.wrap_angle(poses[:, 2])
    np.testing.assert_allclose(body_velocity_from_poses(time, wrapped), np.tile(twist, (41, 1)), atol=1e-12)
    with pytest.raises(ValueError, match="'scheme'.*'forward', 'central'"):
        body_velocity_from_poses(time, poses, scheme="backward")
    with pytest.raises(ValueError, match="'time'.*strictly increasing"):
        body_velocity_from_poses(time[::-1], poses)


def test_central_scheme_is_second_order_for_continuous_motion():
    time = np.linspace(0, 2, 201)
    twist = np.stack([np.cos(3 * time), 0.5 * np.sin(3 * time), 2 + np.sin(5 * time)], axis=1)
    fine = np.linspace(0, 2, 200001)
    fine_twist = np.stack([np.cos(3 * fine), 0.5 * np.sin(3 * fine), 2 + np.sin(5 * fine)], axis=1)
    poses = se2.integrate_body_velocity(fine_twist[:-1], np.diff(fine))[::1000]
    forward = body_velocity_from_poses(time, poses)
    central = body_velocity_from_poses(time, poses, scheme="central")
    inner = slice(1, -1)
    assert np.abs(central[inner] - twist[inner]).max() < 1e-3 < np.abs(forward[inner] - twist[inner]).max()


def test_body_velocity_and_shape_velocity_columns_are_used_as_given(run):
    frame = run.to_pandas()
    log = read_log(frame, shape=["shape_0", "shape_1"],
                   shape_velocity=["shape_velocity_0", "shape_velocity_1"],
                   body_velocity=["body_velocity_x", "body_velocity_y", "body_velocity_theta"], phase="phase")
    np.testing.assert_array_equal(log.body_velocity, run.body_velocity)
    np.testing.assert_array_equal(log.shape_velocity, run.shape_velocity)
    np.testing.assert_allclose(log.phase, run.phase)
    assert log.pose is None
    trajectory = log.to_trajectory()
    np.testing.assert_array_equal(trajectory.cycle, run.cycle)
    np.testing.assert_allclose(trajectory.pose, run.pose, atol=1e-12)  # integrated with the same hold


# -- formats, mappings, units ----------------------------------------------------------------------
def test_csv_parquet_and_frame_agree(run, tmp_path):
    frame = mocap_log(run, position=1e-3, heading=0.01)
    frame.to_parquet(tmp_path / "log.parquet", index=False)
    frame.to_csv(tmp_path / "log.csv", index=False)
    sources = (frame, tmp_path / "log.parquet", str(tmp_path / "log.csv"))
    logs = [read_log(source, **COLUMNS) for source in sources]
    for other in logs[1:]:
        np.testing.assert_allclose(other.body_velocity, logs[0].body_velocity, rtol=1e-9, atol=1e-12)
    with pytest.raises(ValueError, match="'source'.*\\.csv, \\.parquet or \\.pq"):
        read_log(tmp_path / "log.xlsx", **COLUMNS)
    with pytest.raises(ValueError, match="'source'.*existing file"):
        read_log(tmp_path / "missing.csv", **COLUMNS)


def test_mapping_files_json_and_toml(run, tmp_path):
    frame = mocap_log(run)
    entries = {"time": "t", "shape": ["q0", "q1"], "pose": ["x", "y", "yaw"]}
    (tmp_path / "map.json").write_text(json.dumps(entries))
    (tmp_path / "map.toml").write_text('time = "t"\nshape = ["q0", "q1"]\npose = ["x", "y", "yaw"]\n')
    expected = read_log(frame, **COLUMNS)
    for name in ("map.json", "map.toml"):
        log = read_log(frame, tmp_path / name)
        np.testing.assert_array_equal(log.body_velocity, expected.body_velocity)
    mapping = load_column_mapping(tmp_path / "map.toml")
    assert mapping == ColumnMapping(time="t", shape=("q0", "q1"), pose=("x", "y", "yaw"))
    # An argument overrides the mapping's entry.
    frame["alt"] = frame["q0"] * 2
    overridden = read_log(frame, mapping, shape=["alt", "q1"])
    np.testing.assert_allclose(overridden.shape[:, 0], 2 * expected.shape[:, 0])
    (tmp_path / "bad.toml").write_text('time = "t"\nshapes = ["q0"]\n')
    with pytest.raises(ValueError, match="unknown key.*'shapes'"):
        load_column_mapping(tmp_path / "bad.toml")
    (tmp_path / "broken.json").write_text("{not json")
    with pytest.raises(ValueError, match="'path'.*valid JSON"):
        load_column_mapping(tmp_path / "broken.json")
    with pytest.raises(ValueError, match="'path'.*\\.json or \\.toml"):
        load_column_mapping(tmp_path / "map.yaml")


def test_mapping_validation():
    with pytest.raises(ValueError, match="'pose'.*3 column names"):
        ColumnMapping(shape=["a"], pose=["x", "y"])
    with pytest.raises(ValueError, match="'body_velocity'.*or 'pose' given"):
        ColumnMapping(shape=["a"])
    with pytest.raises(ValueError, match="used twice"):
        ColumnMapping(shape=["x"], pose=["x", "y", "h"])
    with pytest.raises(ValueError, match="'shape_velocity'.*2 column names"):
        ColumnMapping(shape=["a", "b"], pose=["x", "y", "h"], shape_velocity=["da"])
    with pytest.raises(ValueError, match="'shape'.*list of shape columns"):
        read_log(pd.DataFrame({"time": [0.0, 1.0]}), pose=["x", "y", "h"])


def test_degrees_converts_every_angle(run):
    frame = mocap_log(run)
    in_degrees = frame.assign(q0=np.rad2deg(frame.q0), q1=np.rad2deg(frame.q1), yaw=np.rad2deg(frame.yaw))
    radians = read_log(frame, **COLUMNS)
    degrees = read_log(in_degrees, **COLUMNS, degrees=True)
    np.testing.assert_allclose(degrees.shape, radians.shape, atol=1e-12)
    np.testing.assert_allclose(degrees.body_velocity, radians.body_velocity, atol=1e-9)
    np.testing.assert_allclose(degrees.shape_velocity, radians.shape_velocity, atol=1e-9)


def test_datetime_time_column_becomes_seconds(run):
    frame = mocap_log(run)
    stamped = frame.assign(t=pd.Timestamp("2025-01-01") + pd.to_timedelta(frame.t, unit="s"))
    np.testing.assert_allclose(read_log(stamped, **COLUMNS).time, run.time - run.time[0], atol=1e-6)


@pytest.mark.parametrize("clock", [
    lambda t: (pd.Timestamp("2025-01-01") + pd.to_timedelta(t, unit="s")).dt.strftime("%Y-%m-%dT%H:%M:%S.%f"),
    lambda t: (pd.Timestamp("2025-01-01") + pd.to_timedelta(t, unit="s")).dt.strftime("%Y-%m-%dT%H:%M:%S.%f+02:00"),
    lambda t: pd.to_timedelta(t, unit="s").astype(str),
])
def test_a_csv_of_iso_date_times_or_time_deltas_is_read_in_seconds(run, tmp_path, clock):
    """Issue 58 (confusing): the docs say date-time columns are read; in a CSV (text) they were refused."""
    from geogait import GeogaitError

    frame = mocap_log(run)
    frame.assign(t=clock(frame.t)).to_csv(tmp_path / "log.csv", index=False)
    np.testing.assert_allclose(read_log(tmp_path / "log.csv", **COLUMNS).time, run.time - run.time[0], atol=1e-6)
    with pytest.raises(GeogaitError, match="'time_unit' parameter of read_log must be left out, or 's', for a "
                                           "column of date-times or time deltas"):
        read_log(tmp_path / "log.csv", **COLUMNS, time_unit="ms")


def test_text_that_is_not_a_clock_is_still_named_in_the_time_column(run, tmp_path):
    from geogait import GeogaitError

    frame = mocap_log(run).astype({"t": object})
    frame.loc[5, "t"] = "later"
    frame.to_csv(tmp_path / "log.csv", index=False)
    with pytest.raises(GeogaitError, match=r"'t' parameter of read_log must be a numeric column. Got .*'later'"):
        read_log(tmp_path / "log.csv", **COLUMNS)


@pytest.mark.parametrize(("factor", "change"), [(1000, "seconds, then milliseconds"),
                                                (1e-6, "microseconds, then seconds")])
def test_a_change_of_time_unit_within_a_log_is_named(run, factor, change):
    """Issue 58 (confusing): stamps in s, then ms split the log at the jump, each part regular, and the second
    part's rates were read 1000× off without a word."""
    from geogait import GeogaitError

    frame = mocap_log(run)
    frame.loc[1500:, "t"] = frame.loc[1500:, "t"] * factor + (0 if factor > 1 else 1e3)
    with pytest.raises(GeogaitError, match=rf"'t' parameter of read_log must be time stamps in one unit throughout. "
                                           rf"Got steps of 0.01 until row 1500 and {0.01 * factor:.4g} from it "
                                           rf"\({factor:.4g}×: {change}\?\)"):
        read_log(frame, **COLUMNS)


def test_log_tables_and_trajectory(run):
    log = read_log(mocap_log(run), **COLUMNS)
    table = log.to_pandas()
    assert list(table.columns[:3]) == ["row", "segment", "time"]
    assert {"shape_velocity_1", "body_velocity_theta", "heading"} <= set(table.columns)
    with pytest.raises(ValueError, match="'phase'.*Log.with_phase"):
        log.to_trajectory()
    with pytest.raises(ValueError, match="'phase'.*shape \\(3000,\\)"):
        log.with_phase(np.zeros(10))
    trajectory = log.with_phase(run.phase + 4 * np.pi).to_trajectory()
    np.testing.assert_allclose(trajectory.phase, run.phase, atol=1e-9)
    np.testing.assert_array_equal(trajectory.cycle, run.cycle)
    np.testing.assert_allclose(trajectory.pose[:, 2], run.pose[:, 2], atol=1e-12)  # heading unwrapped


# -- irregular and bad logs ---------------------------------------------------------------------------
def small_log(n=120):
    t = np.arange(n) * 0.01
    return pd.DataFrame({"t": t, "q0": np.sin(2 * np.pi * t), "q1": np.cos(2 * np.pi * t),
                         "x": 0.1 * t, "y": 0.0 * t, "yaw": 0.5 * t})


def test_missing_columns_list_what_is_missing_and_available():
    with pytest.raises(ValueError, match=r"without \['q2', 'yaw2'\].*columns are \['t', 'q0'"):
        read_log(small_log(), time="t", shape=["q0", "q2"], pose=["x", "y", "yaw2"])


def test_text_in_numeric_column_names_the_column_and_row(tmp_path):
    frame = small_log().astype({"q1": object})
    frame.loc[7, "q1"] = "0,5"  # a decimal comma
    frame.to_csv(tmp_path / "text.csv", index=False)
    with pytest.raises(ValueError, match=r"'q1'.*numeric column.*\['0,5'\] in row\(s\) \[7\]"):
        read_log(tmp_path / "text.csv", **COLUMNS)


def test_constant_shape_column_is_rejected():
    with pytest.raises(ValueError, match=r"'shape'.*constant column\(s\) \['q1'\]"):
        read_log(small_log().assign(q1=0.3), **COLUMNS)


def test_non_monotonic_and_duplicated_time_stamps_name_the_row():
    frame = small_log()
    frame.loc[50, "t"] = frame.loc[48, "t"]
    with pytest.raises(ValueError, match="'t'.*strictly increasing.*decreasing.*at row 50"):
        read_log(frame, **COLUMNS)
    frame = small_log()
    frame.loc[31, "t"] = frame.loc[30, "t"]
    with pytest.raises(ValueError, match="'t'.*strictly increasing.*duplicated.*at row 31"):
        read_log(frame, **COLUMNS)


def test_nan_rows_are_an_error_unless_dropped_which_splits_segments():
    frame = small_log()
    frame.loc[[40, 41], "x"] = np.nan
    frame.loc[90, "q0"] = np.nan
    with pytest.raises(ValueError, match=r"3 such row\(s\) \[40, 41, 90\] in column\(s\) \['q0', 'x'\]"):
        read_log(frame, **COLUMNS)
    log = read_log(frame, **COLUMNS, drop_nan=True)
    assert log.n_samples == 117 and log.n_segments == 3
    assert [s.row[[0, -1]].tolist() for s in log.segments()] == [[0, 39], [42, 89], [91, 119]]
    np.testing.assert_allclose(log.body_velocity[:, 2], 0.5, atol=1e-9)
    np.testing.assert_allclose(np.hypot(log.body_velocity[:, 0], log.body_velocity[:, 1]), 0.1, atol=1e-4)


def test_a_clock_column_is_read_in_seconds_once(run):
    """Date-times carry their unit: a time_unit besides them would scale them twice (ṙ and ξ 1000× too large
    with 'ms'), so it is refused; 's' is what they are read in. A first stamp that is NaT, dropped, does not
    take every other stamp with it."""
    from geogait import GeogaitError

    frame = mocap_log(run)
    stamped = frame.assign(t=pd.Timestamp("2025-01-01") + pd.to_timedelta(frame.t, unit="s"))
    with pytest.raises(GeogaitError, match=r"'time_unit' parameter of read_log must be left out, or 's', for a "
                                           r"column of date-times"):
        read_log(stamped, **COLUMNS, time_unit="ms")
    np.testing.assert_allclose(read_log(stamped, **COLUMNS, time_unit="s").time, run.time - run.time[0], atol=1e-6)
    first_missing = stamped.assign(t=stamped.t.where(stamped.index > 0))
    log = read_log(first_missing, **COLUMNS, drop_nan=True)
    assert len(log.time) == len(frame) - 1 and log.time[0] == 0.0
    np.testing.assert_allclose(log.time, run.time[1:] - run.time[1], atol=1e-6)


def test_cells_that_are_not_real_numbers_and_repeated_columns_are_named():
    from geogait import GeogaitError

    frame = small_log(200)
    for odd, what in ((1 + 2j, "boolean or complex value"), (True, "boolean or complex value")):
        cells = frame.astype({"q0": object})
        cells.loc[7, "q0"] = odd
        with pytest.raises(GeogaitError, match=rf"'q0' parameter .* real numbers. Got '{what}.*row\(s\) \[7\]"):
            read_log(cells, **COLUMNS)
    with pytest.raises(GeogaitError, match="a column of complex numbers"):
        read_log(frame.astype({"q1": complex}), **COLUMNS)
    with pytest.raises(GeogaitError, match=r"used columns appear once each. Got \"the column\(s\) \['q1'\]"):
        read_log(pd.concat([frame, frame[["q1"]]], axis=1), **COLUMNS)


@pytest.mark.parametrize("repeated", ["q0", "x"])
def test_a_csv_naming_a_used_column_twice_is_refused_naming_it(tmp_path, repeated):
    """Issue 58, finding 6: pandas reads a repeated CSV header name as `q0.1`, so the first column was used
    silently; a repeated unused column is read as before."""
    from geogait import GeogaitError

    frame = small_log(200)
    pd.concat([frame, frame[[repeated]] + 1.0], axis=1).to_csv(tmp_path / "log.csv", index=False)
    with pytest.raises(GeogaitError, match=rf"used columns appear once each. Got \"the column\(s\) \['{repeated}'\]"):
        read_log(tmp_path / "log.csv", **COLUMNS)
    note = frame[["t"]].rename(columns={"t": "note"})
    pd.concat([frame, note, note], axis=1).to_csv(tmp_path / "notes.csv", index=False)
    assert read_log(tmp_path / "notes.csv", **COLUMNS).n_samples == 200


def test_a_streamed_csv_header_naming_a_used_column_twice_is_refused_naming_it():
    import io

    from geogait import GeogaitError
    from geogait.io import CsvReader

    header = "time,shape_0,shape_1,shape_0,body_velocity_x,body_velocity_y,body_velocity_theta\n"
    with pytest.raises(GeogaitError, match=r"'header' parameter of input line 1 must be a CSV header naming each "
                                           r"column once. Got \"the column\(s\) \['shape_0'\] more than once"):
        list(CsvReader(io.StringIO(header + "0,1,2,3,4,5,6\n"), 2))


def test_a_robot_put_back_between_two_recordings_is_not_an_outlier():
    """Two segments a minute apart, the robot 2 m further on in the second: the pose steps are checked within
    each segment; the same jump inside one recording is still refused."""
    from geogait import GeogaitError

    frame = small_log(400)
    moved = frame.copy()
    moved.loc[200:, "t"] += 60.0
    moved.loc[200:, "x"] += 2.0
    assert read_log(moved, **COLUMNS).n_segments == 2
    jump = frame.copy()
    jump.loc[300:, "x"] += 2.0
    with pytest.raises(GeogaitError, match=r"'x' parameter .*'a step of 2.* at row 300"):
        read_log(jump, **COLUMNS)


def test_gaps_split_the_log_into_independent_segments():
    frame = small_log(200)
    frame.loc[100:, "t"] += 0.5  # a 0.51 s step where 0.01 s is usual
    log = read_log(frame, **COLUMNS)
    assert log.n_segments == 2 and [len(s.time) for s in log.segments()] == [100, 100]
    # Each segment is differentiated on its own, so ṙ stays accurate up to both edges of the gap
    # (a filter across it would see a jump).
    expected = 2 * np.pi * np.cos(2 * np.pi * frame.t[:100].to_numpy())
    np.testing.assert_allclose(log.segments()[0].shape_velocity[:, 0], expected, atol=2e-2)
    assert np.all(log.segments()[1].segment == 1)


def test_jitter_and_short_segments_are_errors_when_filtering():
    frame = small_log()
    frame.loc[60:, "t"] += 0.004  # one step 40 % longer than the rest: neither uniform nor a gap
    with pytest.raises(ValueError, match="'t'.*uniformly sampled.*before row 60"):
        read_log(frame, **COLUMNS)
    frame = small_log()
    frame.loc[115:, "t"] += 1.0
    with pytest.raises(ValueError, match="'window'.*rows 115-119 has 5 samples"):
        read_log(frame, **COLUMNS)


def test_heading_jump_over_quarter_turn_is_an_error():
    frame = small_log()
    frame.loc[70:, "yaw"] += 2.0
    with pytest.raises(ValueError, match="'yaw'.*less than 90 degrees.*before row 70"):
        read_log(frame, **COLUMNS)


def test_option_validation():
    with pytest.raises(ValueError, match="'window'.*odd"):
        read_log(small_log(), **COLUMNS, window=10)
    with pytest.raises(ValueError, match="'polyorder'.*< window"):
        read_log(small_log(), **COLUMNS, window=5, polyorder=5)
    with pytest.raises(ValueError, match="'gap_factor'"):
        read_log(small_log(), **COLUMNS, gap_factor=1.0)
    with pytest.raises(ValueError, match="'mapping'"):
        read_log(small_log(), mapping=3, **COLUMNS)
    assert isinstance(read_log(small_log(), **COLUMNS), Log)


def test_a_measured_velocity_carries_the_low_pass_of_the_one_estimated_beside_it():
    """ξ = −A(r) ṙ must hold between the signals the model sees: with ṙ a Savitzky–Golay derivative, exact ξ
    left unfiltered scores a held-out Γ of 0.65 (the filtered ṙ misses the perturbation's fast part, ξ keeps
    it); filtered alike it scores as the same log's poses do (0.86). With ξ from smoothed poses, exact ṙ left
    unfiltered scores 0.61, filtered alike 0.98."""
    from geogait.gaits import Perturbation
    from geogait.learn import fit_log

    run = simulate(PurcellSwimmer(3), seed_gait(2), 40, seed=0, samples_per_cycle=100,
                   perturbation=Perturbation.from_std(0.15))
    frame = pd.DataFrame({"time": run.time, "phase": run.phase, "q0": run.shape[:, 0], "q1": run.shape[:, 1],
                          "vx": run.body_velocity[:, 0], "vy": run.body_velocity[:, 1], "w": run.body_velocity[:, 2],
                          "x": run.pose[:, 0], "y": run.pose[:, 1], "h": run.pose[:, 2],
                          "dq0": run.shape_velocity[:, 0], "dq1": run.shape_velocity[:, 1]})

    def held_out_gamma(**columns):
        log = read_log(frame, time="time", shape=["q0", "q1"], phase="phase", **columns)
        return fit_log(log).summary()["held_out_gamma"]

    from_velocities = held_out_gamma(body_velocity=["vx", "vy", "w"])
    from_poses = held_out_gamma(pose=["x", "y", "h"])
    assert from_velocities > 0.8 and abs(from_velocities - from_poses) < 0.03
    both_measured = held_out_gamma(body_velocity=["vx", "vy", "w"], shape_velocity=["dq0", "dq1"])
    assert held_out_gamma(pose=["x", "y", "h"], shape_velocity=["dq0", "dq1"]) > max(0.95, from_poses + 0.05)
    assert both_measured > 0.95  # (nothing filtered: both exact)

