"""Studies run end to end on a tiny budget: the plateau study (it leans on private optimiser hooks),
the online phase study, the resistance model's geometry-error study, the model-gradient study, the optimiser
settings study, the Swimmer-v5 family study, the model-class study and the snake-variants study."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

STUDIES = Path(__file__).resolve().parents[2] / "studies"


def test_plateau_study_reports_finite_medians():
    output = subprocess.run([sys.executable, str(STUDIES / "plateau.py"), "1", "6", "--walk", "2", "--refit", "2"],
                            capture_output=True, text=True, check=True, timeout=300).stdout
    medians = dict(re.findall(r"(\w+) (-?[\d.]+)", output.splitlines()[-1].removeprefix("median: ")))
    assert {"true", "predicted", "gradient_error", "local_error", "walk_best", "path_to_ceiling"} <= set(medians)
    assert 0.3 < float(medians["true"]) < 1.0  # 6 cycles of the 9-link seed: 55-70 % of the ceiling
    assert float(medians["path_to_ceiling"]) > 0


def test_online_phase_study_quick_meets_the_acceptance_bars():
    output = subprocess.run([sys.executable, str(STUDIES / "online_phase.py"), "--quick"], capture_output=True,
                            text=True, check=True, timeout=300).stdout.splitlines()
    rows = [line[22:].replace(" / ", " ").split() for line in output[1:-1]]  # after the setting's label
    assert len(rows) == 16  # 6 window/period ratios and 2 drifts, without and with noise
    for row in rows:
        noise, offline_median, _, online_median, online_p95, _, delay = map(float, row[:7])
        assert noise in (0.0, 0.1) and online_median <= 2 * offline_median and online_p95 <= 0.3
        assert abs(delay) < 3  # samples (8-cycle records: the ±20 % ramp is steep)
    assert output[-1].endswith("met in every setting")


def test_resistance_study_writes_every_trial(tmp_path):
    """The geometry-error study on 3 links: a hybrid told link lengths 10 % wrong still climbs from half the
    ceiling to over 90 % in 12 cycles."""
    import json

    out = tmp_path / "resistance.json"
    subprocess.run([sys.executable, str(STUDIES / "resistance.py"), "3", "12", "1", "--errors", "0.1", "--models",
                    "hybrid", "--checkpoints", "12", "--out", str(out)], capture_output=True, text=True, check=True,
                   timeout=300)
    result = json.loads(out.read_text())
    (record,) = result["records"]
    assert record["model"] == "hybrid" and record["geometry_error"] == 0.1 and len(record["ceiling_fraction"]) == 12
    assert record["ceiling_fraction"][0] < 0.6 < 0.9 < record["ceiling_fraction"][-1]


def test_model_gradient_study_compares_the_model_with_central_differences(tmp_path):
    """On the built-in 3-link swimmer (inside the model class) the window model's gradient, learned in a few cycles
    of exploration, points along central differences of the clean objective and has about their length."""
    import json

    out = tmp_path / "gradient.json"
    subprocess.run([sys.executable, str(STUDIES / "model_gradient.py"), "swimmer3", "--cycles", "4", "--out",
                    str(out)], capture_output=True, text=True, check=True, timeout=300)
    rows = json.loads(out.read_text())["results"]
    assert [row["gait"] for row in rows] == ["seed", "moved"]
    for row in rows:
        assert len(row["true_gradient"]) == len(row["gradient"]) == 3  # the symmetric family's parameters
        assert row["cosine"] > 0.8 and 0.6 < row["length_ratio"] < 1.5
        assert abs(row["value"] / row["measured_value"] - 1) < 0.1


def test_optimizer_robots_study_runs_each_setting_on_the_benchmark_robot(tmp_path):
    """Three optimiser settings on the built-in 3-link swimmer, one of them on another of the benchmark's geogait
    rows (``"method"``): one row each in the printed table, each paired seed by seed with the stored default, and
    every record (seed, cycles, setting) in the JSON, with the settings as given."""
    import json

    pytest.importorskip("cma", reason="the stored black-box rows come from a benchmark that needs cma")
    variants = {"default": {}, "held radius": {"step__trust_radius": 0.15, "step__min_trust_radius": 0.15},
                "batch": {"method": "geogait-batch"}}
    output = subprocess.run([sys.executable, str(STUDIES / "optimizer_robots.py"), "--cases", "swimmer3", "--seeds",
                             "2", "--budget", "30", "--jobs", "1", "--variants", json.dumps(variants), "--out",
                             str(tmp_path)], capture_output=True, text=True, check=True, timeout=300).stdout
    for name in variants:
        assert re.search(rf"^  {name} +\+0\.\d+ +min \+0\.\d+", output, re.M)
        assert re.search(rf"^  {name} +ahead of the stored default in [012] of 2 \(p [0-9.e-]+\)$", output, re.M)
    payload = json.loads((tmp_path / "optimizer_robots.json").read_text())
    assert payload["variants"] == variants
    records = payload["records"]
    assert sorted({(r["variant"], r["seed"], r["cycles"]) for r in records}) == [
        (v, s, 30) for v in ("batch", "default", "held radius") for s in (0, 1)]
    assert {r["method"] for r in records if r["variant"] == "batch"} == {"geogait-batch"}
    assert {r["method"] for r in records if r["variant"] != "batch"} == {"geogait"}
    assert all(0.3 < r["ceiling_fraction"] <= 1.0 for r in records if r["variant"] != "batch")


def test_swimmer_v5_family_study_scores_each_start_by_its_episode_return(tmp_path):
    """A tiny run of the Swimmer-v5 family study: every start's best gait stays within the joint range, and the
    first start (the seed) cannot end below it (COBYQA keeps the best point it measured)."""
    import json

    pytest.importorskip("mujoco", reason="Swimmer-v5's model runs in MuJoCo")
    pytest.importorskip("gymnasium", reason="Swimmer-v5's model comes with gymnasium")
    out = tmp_path / "family.json"
    subprocess.run([sys.executable, str(STUDIES / "swimmer_v5_family.py"), "--orders", "3", "--starts", "2",
                    "--max-evaluations", "4", "--out", str(out)], capture_output=True, text=True, check=True,
                   timeout=300)
    runs = json.loads(out.read_text())["runs"]
    assert [run["order"] for run in runs] == [3, 3] and all(run["evaluations"] <= 4 for run in runs)
    assert all(run["largest_joint_angle"] <= 1.745 and run["episode_return"] > 0 for run in runs)
    assert runs[0]["improvement"] >= 0 and len(runs[0]["params"]) == 2 * (2 * 3 + 1)
    assert all(run["control"] == "pd" for run in runs)
    # warm-started one order up: its first point is the earlier best gait itself, begun at phase 0 as before;
    # begun half a cycle later a half-wave symmetric gait is its own mirror image, which swims as far
    warm = tmp_path / "warm.json"
    subprocess.run([sys.executable, str(STUDIES / "swimmer_v5_family.py"), "--orders", "5", "--warm-start", str(out),
                    "--max-evaluations", "1", "--start-phases", "4", "--out", str(warm)],
                   capture_output=True, text=True, check=True, timeout=300)
    (lifted,) = json.loads(warm.read_text())["runs"]
    earlier = max(runs, key=lambda run: run["episode_return"])
    assert lifted["order"] == 5 and lifted["period"] == pytest.approx(earlier["period"], rel=1e-9)
    assert lifted["episode_return"] == pytest.approx(earlier["episode_return"], abs=1e-6)
    returns = lifted["start_phase_returns"]
    assert returns[0] == pytest.approx(lifted["episode_return"], abs=1e-6)
    assert returns[2] == pytest.approx(returns[0], abs=1e-6) and returns[3] == pytest.approx(returns[1], abs=1e-6)
    assert abs(returns[1] - returns[0]) > 1  # a quarter cycle later: another start, another episode
    # the return itself searched, the start phase a coordinate: the gait stored (begun at its best phase) returns
    # what the search measured, from phase 0 of its stored series
    from geogait.experiments.robot_benchmark import swimmer_v5_return
    from geogait.gaits import FourierGait

    searched = tmp_path / "return.json"
    subprocess.run([sys.executable, str(STUDIES / "swimmer_v5_family.py"), "--orders", "3", "--warm-start", str(out),
                    "--objective", "return", "--starts", "2", "--max-evaluations", "3", "--out", str(searched)],
                   capture_output=True, text=True, check=True, timeout=300)
    found = json.loads(searched.read_text())["runs"]
    assert [run["objective"] for run in found] == ["return", "return"]
    best = max(found, key=lambda run: run["episode_return"])
    assert best["episode_return"] >= earlier["episode_return"] - 1e-6  # its first point is the earlier best gait
    stored = FourierGait.from_params(best["params"], n_joints=2)
    assert swimmer_v5_return(stored, best["period"]) == pytest.approx(best["episode_return"], rel=1e-6)
    # the joints on inverse dynamics: the seed's return is its own (the PD law realises a smaller gait: 241.8)
    subprocess.run([sys.executable, str(STUDIES / "swimmer_v5_family.py"), "--orders", "1", "--starts", "1",
                    "--max-evaluations", "1", "--control", "computed_torque", "--out", str(out)],
                   capture_output=True, text=True, check=True, timeout=300)
    (run,) = json.loads(out.read_text())["runs"]
    assert run["control"] == "computed_torque" and run["evaluations"] == 1 and run["improvement"] == 0
    assert run["episode_return"] > 260


def test_model_class_study_judges_a_robot_from_logs_and_in_a_run(tmp_path):
    """The built-in 3-link swimmer: consistent at both periods from its log, and the optimiser's own test agrees."""
    import json
    out = tmp_path / "model-class.json"
    subprocess.run([sys.executable, str(STUDIES / "model_class.py"), "--cases", "swimmer3", "--cycles", "10",
                    "--in-run", "2", "--out", str(out)], capture_output=True, text=True, check=True, timeout=300)
    written = json.loads(out.read_text())
    assert [row["system"] for row in written["rows"]] == ["swimmer3"]
    assert written["rows"][0]["principally_kinematic"] is True
    assert [(row["seed"], row["principally_kinematic"]) for row in written["in_run"]] == [(0, True), (1, True)]


def test_snake_variants_study_runs_each_method_on_a_different_snake_per_seed(tmp_path):
    """Two paired seeds are two snakes (friction and stiffness differ, and so does the seed gait's speed); every
    method is judged on its seed's snake."""
    pytest.importorskip("elastica", reason="PyElastica not installed: pip install 'geogait[elastica]'")
    import json

    out = tmp_path / "snakes.json"
    study = [sys.executable, str(STUDIES / "snake_variants.py"), "--seeds", "2", "--budget", "5", "--jobs", "1",
             "--out", str(out)]
    unknown = subprocess.run([*study, "--methods", "geogait-wide"], capture_output=True, text=True, timeout=300)
    assert unknown.returncode == 2 and "geogait-wide not among --variants" in unknown.stderr
    output = subprocess.run([*study, "--methods", "geogait-wide,random-held", "--variants",
                             '{"wide": {"step__max_trust_radius": 0.3}}'],
                            capture_output=True, text=True, check=True, timeout=300).stdout
    assert "geogait-wide" in output and "random-held" in output
    records = json.loads(out.read_text())["records"]
    assert [(r["seed"], r["method"]) for r in records] == [(0, "geogait-wide"), (0, "random-held"),
                                                           (1, "geogait-wide"), (1, "random-held")]
    first, second = records[0], records[2]
    assert first["friction"] != second["friction"] and first["youngs_modulus"] != second["youngs_modulus"]
    assert abs(first["seed_objective"] / second["seed_objective"] - 1) > 1e-3
    assert first["cycles_run"] >= 5 and all(abs(r["improvement"]) < 5 for r in (first, second))
