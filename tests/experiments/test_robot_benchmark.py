"""The robot benchmark: every method charged for every cycle, paired seeds, clean evaluation, outputs."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from geogait.experiments import robot_benchmark as bench
from geogait.gaits import seed_gait
from geogait.optimize import InSituOptimizer, ModelStep
from geogait.optimize._setup import gait_family
from geogait.robots import read_robot_spec

ROOT = Path(__file__).resolve().parents[2]
pytest.importorskip("cma", reason="the robot benchmark's baselines need cma (pip install 'geogait[baselines]')")
pytest.importorskip("optuna", reason="the robot benchmark's baselines need optuna (pip install 'geogait[baselines]')")


class _SelfCountingRobot:
    """Wraps a case's robot and counts, on its own, every cycle it is asked to run."""

    log: list = []

    def __init__(self, robot, seed, explore):
        self.robot, self.ran = robot, 0
        _SelfCountingRobot.log.append((self, seed, explore))

    def __getattr__(self, name):
        return getattr(self.robot, name)

    @property
    def gait(self):
        return self.robot.gait

    def set_gait(self, gait):
        self.robot.set_gait(gait)

    def next_cycle(self):
        self.ran += 1
        return self.robot.next_cycle()


def _counting_case(name="swimmer3", **changes):
    case = bench.CASES[name]

    def make(seed, explore, noise, gait=None):
        return _SelfCountingRobot(case.make_robot(seed, explore=explore, noise=noise, gait=gait), seed, explore)

    return dataclasses.replace(case, make_robot=make, **changes)


@pytest.mark.parametrize("settle", [0, 2])
def test_every_method_is_charged_for_every_cycle_the_robot_ran(monkeypatch, settle):
    """The cycles a method is charged are the cycles its robot counted itself (settling included),
    never more than the budget; a black-box method stops only when one more candidate (settle + 1
    cycles) would exceed it."""
    case = _counting_case(settle_cycles=settle)
    monkeypatch.setitem(bench.CASES, "swimmer3", case)
    budget = 13
    for method in bench.METHODS:
        _SelfCountingRobot.log.clear()
        child = np.random.SeedSequence(5).spawn(1)[0]
        trace, charged = bench._run_method(case, method, child, budget, seed_value=0.05)
        (robot, seed, explore), = _SelfCountingRobot.log
        assert charged == robot.ran <= budget, method
        assert explore == method.startswith("geogait"), method
        if method.startswith("geogait"):
            assert charged == budget
        else:
            assert budget - charged < settle + 1, method
        assert all(used <= charged for used, *_ in trace.events)


def test_all_methods_see_the_same_robot(monkeypatch):
    """Trial s of every method drives a robot built from the same seed; two robots of that seed give
    identical measurements (same sensor noise) for the same commands."""
    case = _counting_case()
    monkeypatch.setitem(bench.CASES, "swimmer3", case)
    methods = ["geogait", "cmaes", "random"]
    _SelfCountingRobot.log.clear()
    frame = bench.benchmark_trials(np.arange(6), None, case="swimmer3", methods=methods, n_seeds=2, root_seed=3,
                                   budget=4, checkpoints=[4], seed_value=0.05, ceiling_value=0.1)
    seeds = [(s.entropy, s.spawn_key) for _, s, _ in _SelfCountingRobot.log if s is not None]
    assert seeds == [(3, (0,))] * 3 + [(3, (1,))] * 3  # method i % 3 on paired seed i // 3
    assert set(frame["method"]) == set(methods) and set(frame["seed"]) == {0, 1}
    child = np.random.SeedSequence(3).spawn(2)[1]
    first, second = (bench.CASES["swimmer3"].make_robot(child, explore=False, noise=True) for _ in range(2))
    a, b = first.next_cycle(), second.next_cycle()
    np.testing.assert_array_equal(a.body_velocity, b.body_velocity)
    assert not np.array_equal(a.body_velocity, bench.CASES["swimmer3"].make_robot(
        np.random.SeedSequence(3).spawn(2)[0], explore=False, noise=True).next_cycle().body_velocity)


def test_clean_evaluation_matches_the_exact_displacement():
    """A clean re-run on the built-in swimmer measures the gait's exact net motion per cycle (to the
    simulator's zero-order hold, ≈ 1 %), and the swimmer's ceiling gait beats the seed."""
    from geogait.simulate import cycle_displacement
    from geogait.systems import PurcellSwimmer

    case = bench.CASES["swimmer3"]
    gait = seed_gait(2)
    exact = cycle_displacement(PurcellSwimmer(3), gait)
    result = bench.evaluate_gait(case, gait)
    assert result["objective"] == pytest.approx(np.hypot(*exact[:2]), rel=0.02)
    assert abs(result["rotation"]) < 1e-9
    assert bench.evaluate_gait(case, case.ceiling())["objective"] > 1.5 * result["objective"]


def test_black_box_candidates_respect_the_joint_limit_and_stay_in_the_family():
    case = bench.CASES["swimmer5"]
    family = bench._Family(case, seed_gait(4), 1.0)
    rng = np.random.default_rng(0)
    for _ in range(20):
        params = rng.normal(0, 3, family.seed_params.size)
        gait = family.gait(params)
        assert gait.joint_limit().max() <= case.max_joint_angle
        assert family.family.residual(gait) < 1e-9  # still a symmetric (rotation-free) gait
    inside = family.seed_params * 0.5
    np.testing.assert_allclose(family.gait(inside).params, family.family.gait(inside).params)


def test_held_variant_penalises_rotation_beyond_the_limit():
    """The same turning gait scores its progress free, and loses the seed's progress for every
    half limit beyond the limit when held."""
    case = bench.CASES["swimmer3"]
    values = {}
    for held in (False, True):
        robot = bench._CountingRobot(case.make_robot(None, explore=False, noise=False))
        family = bench._Family(dataclasses.replace(case, family="free"), robot.gait, robot.cycle_period)
        params = family.seed_params.copy()
        params[0] = 0.5  # an offset on the first joint makes the gait turn
        objective = bench._Objective(case, robot, family, 10, held, seed_value=0.05)
        values[held] = objective(params)
    net = bench.evaluate_gait(case, family.gait(params))
    assert abs(net["rotation"]) > case.rotation_limit
    assert values[False] == pytest.approx(net["objective"], rel=1e-6)
    expected = values[False] - 2 * 0.05 / case.rotation_limit * (abs(net["rotation"]) - case.rotation_limit)
    assert values[True] == pytest.approx(expected, rel=1e-6)


def test_missing_extras_skip_their_case_with_one_line(monkeypatch):
    case = dataclasses.replace(bench.CASES["swimmer3"], requires=("no_such_module_geogait",))
    monkeypatch.setitem(bench.CASES, "swimmer3", case)
    lines = []
    result = bench.run_robot_benchmark(["swimmer3"], ["random"], n_seeds=1, budget=2, progress=False, log=lines.append)
    assert lines == ["skipped case swimmer3: needs no_such_module_geogait (pip install 'geogait[mujoco]')"]
    find_spec = bench.importlib.util.find_spec  # the Control Suite's case names its own extra
    monkeypatch.setattr(bench.importlib.util, "find_spec", lambda name, *a: None if name == "dm_control"
                        else find_spec(name, *a))
    assert bench.available_cases(["dm-control-swimmer"])[1] == {
        "dm-control-swimmer": "needs dm_control (pip install 'geogait[dmcontrol]')"}
    assert result["records"].empty and "swimmer3" in result["skipped"]
    assert bench.benchmark_table(result) == "No case ran.\n"


def test_bad_arguments_are_refused_with_the_field_named():
    from geogait._validation import GeogaitError

    with pytest.raises(GeogaitError, match="cases"):
        bench.run_robot_benchmark(["no-such-robot"], progress=False)
    with pytest.raises(GeogaitError, match="methods"):
        bench.run_robot_benchmark(["swimmer3"], ["annealing"], progress=False)
    with pytest.raises(GeogaitError, match="checkpoints"):
        bench.run_robot_benchmark(["swimmer3"], ["random"], budget=10, checkpoints=[20], progress=False)
    with pytest.raises(GeogaitError, match="min_trust_radiu"):
        bench.run_robot_benchmark(["swimmer3"], ["geogait"], geogait_options={"min_trust_radiu": 0.1}, progress=False)
    with pytest.raises(GeogaitError, match="geogait_options"):
        bench.run_robot_benchmark(["swimmer3"], ["geogait"], geogait_options=[0.1], progress=False)


def test_geogait_options_replace_the_optimisers_own_and_leave_black_box_methods_alone(monkeypatch):
    """Options given to the benchmark reach every geogait run (the batch variant's too) and are recorded;
    the black-box runs are the same with or without them."""


    seen = []
    original = InSituOptimizer.run

    def run(self, robot, n_cycles, **kwargs):
        seen.append(self.get_params(deep=True))
        return original(self, robot, n_cycles, **kwargs)

    monkeypatch.setattr(InSituOptimizer, "run", run)
    options = {"step__min_trust_radius": 0.05, "step__max_trust_radius": 0.2}
    runs = [bench.run_robot_benchmark(["swimmer3"], ["geogait", "geogait-batch", "random"], n_seeds=1, budget=6,
                                      checkpoints=[6], progress=False, geogait_options=given)
            for given in (options, None)]
    assert [{k: p[k] for k in options} for p in seen[:2]] == [options, options]
    # the batch variant is the prior work's loop: steps from its model alone, no revert to the best gait measured
    assert (seen[1]["climb"], seen[1]["safety__revert_tolerance"]) == (False, None)
    assert seen[0]["safety__revert_tolerance"] == 2.0
    assert [p["step__min_trust_radius"] for p in seen[2:]] == [ModelStep().min_trust_radius] * 2
    assert runs[0]["config"]["geogait_options"] == options and runs[1]["config"]["geogait_options"] is None
    random = [r["records"].query("method == 'random'")["objective"].to_numpy() for r in runs]
    np.testing.assert_array_equal(*random)


def test_quick_benchmark_writes_table_manifest_and_figure_and_redraws(tmp_path):
    """``benchmarks/robots.py --quick`` end to end (CI's path); the manifest is strict JSON with
    versions, the command and every record, and redrawing from it gives the same table."""
    out = tmp_path / "robots"
    run = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "robots.py"), "--quick",
                          "--methods", "geogait,cmaes-tuned,tpe-held,random", "--out", str(out)],
                         capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert run.returncode == 0, run.stderr
    manifest = json.loads((out / "robots.json").read_text(), parse_constant=lambda c: pytest.fail(c))
    assert manifest["versions"]["cma"] and manifest["versions"]["optuna"]
    assert "--quick" in manifest["command"]
    records = manifest["records"]
    ran = {r["case"] for r in records}
    assert "swimmer3" in ran and ran | set(manifest["skipped"]) == {"swimmer3", "mujoco-purcell5-unequal"}
    assert {r["method"] for r in records if r["case"] == "swimmer3"} == {"geogait", "cmaes-tuned", "random"}
    assert all(r["cycles_run"] <= 20 for r in records)
    assert (out / "robots.png").stat().st_size > 10_000
    table = (out / "robots.md").read_text()
    redraw = tmp_path / "redraw"
    again = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "robots.py"), "--from-json",
                            str(out / "robots.json"), "--out", str(redraw)], capture_output=True, text=True, cwd=ROOT)
    assert again.returncode == 0, again.stderr
    assert (redraw / "robots.md").read_text() == table
    assert not (redraw / "robots.json").exists()


def test_merge_replaces_the_rerun_methods_and_keeps_the_rest():
    import pandas as pd

    from geogait._validation import GeogaitError

    def result(rows, methods, n_seeds=2):
        frame = pd.DataFrame([{"case": c, "method": m, "seed": s, "cycles": 10, "objective": v}
                              for c, m, s, v in rows])
        return {"records": frame, "cases": {"swimmer3": {}}, "skipped": {},
                "config": {"cases": ["swimmer3"], "methods": methods, "n_seeds": n_seeds, "budget": 10, "seed": 0},
                "command": "first"}

    old = result([("swimmer3", "geogait", 0, 1.0), ("swimmer3", "random", 0, 2.0), ("swimmer3", "cmaes", 0, 3.0)],
                 ["geogait", "cmaes", "random"])
    new = result([("swimmer3", "geogait", 0, 9.0)], ["geogait"])
    merged, command = bench.merge_results(old, new, "second")
    assert merged["records"]["method"].tolist() == ["geogait", "cmaes", "random"]  # METHODS order
    assert merged["records"]["objective"].tolist() == [9.0, 3.0, 2.0]
    assert command == "first && second"
    with pytest.raises(GeogaitError, match="n_seeds"):
        bench.merge_results(old, result([("swimmer3", "cmaes", 0, 1.0)], ["cmaes"], n_seeds=3), "third")
    other = result([("swimmer5", "cmaes", 2, 1.0)], ["cmaes"], n_seeds=3)  # a case of its own: seeds stay paired
    other["config"]["cases"] = ["swimmer5"]
    merged, _ = bench.merge_results(old, other, "third")
    assert merged["config"]["seeds_per_case"] == {"swimmer3": 2, "swimmer5": 3} and merged["config"]["n_seeds"] == 3
    # a case searched in another family since: its old records (the held variants too) are not comparable
    old["cases"]["swimmer3"] = {"family": "free"}
    old["records"] = pd.concat([old["records"], result([("swimmer3", "random-held", 0, 4.0)], [])["records"]])
    new["cases"]["swimmer3"] = {"family": "mirror"}
    merged, _ = bench.merge_results(old, new, "fourth")
    assert merged["records"]["method"].tolist() == ["geogait"]
    # a case evaluated otherwise since (more settling cycles from rest): the same; a manifest from before
    # eval_settle_cycles evaluated after the case's settling cycles
    old["cases"]["swimmer3"] = {"family": "mirror", "settle_cycles": 1}
    old["records"] = result([("swimmer3", "random", 0, 2.0)], [])["records"]
    new["cases"]["swimmer3"] = {"family": "mirror", "settle_cycles": 1, "eval_settle_cycles": 1}
    said = []
    assert bench.merge_results(old, new, "fifth", log=said.append)[0]["records"]["method"].tolist() == ["geogait",
                                                                                                     "random"]
    new["cases"]["swimmer3"]["eval_settle_cycles"] = 4
    assert bench.merge_results(old, new, "sixth", log=said.append)[0]["records"]["method"].tolist() == ["geogait"]
    assert len(said) == 1 and "swimmer3" in said[0] and "replaced" in said[0]  # said, not silent
    # the same settings on a robot that changed since (its seed gait evaluates otherwise), or other measured cycles
    old["cases"]["swimmer3"] = {"family": "mirror", "eval_settle_cycles": 4, "eval_cycles": 2,
                                "seed": {"objective": 0.22}}
    new["cases"]["swimmer3"] = {"family": "mirror", "eval_settle_cycles": 4, "eval_cycles": 2,
                                "seed": {"objective": 0.22 * (1 + 1e-9)}}
    assert bench.merge_results(old, new, "seventh", log=said.append)[0]["records"]["method"].tolist() == [
        "geogait", "random"]
    for changed in ({"seed": {"objective": 0.2287}}, {"eval_cycles": 3}):
        new["cases"]["swimmer3"] = {**old["cases"]["swimmer3"], **changed}
        assert bench.merge_results(old, new, "eighth", log=said.append)[0]["records"]["method"].tolist() == [
            "geogait"]
    assert len(said) == 3


@pytest.mark.parametrize(("settle", "eval_settle", "ran"), [(1, None, 3), (1, 4, 6), (0, 2, 4)])
def test_a_gait_is_evaluated_from_rest_after_the_evaluation_settling_cycles(monkeypatch, settle, eval_settle, ran):
    """A clean evaluation runs ``eval_settle_cycles`` (default the case's ``settle_cycles``) on a fresh robot, then
    ``eval_cycles`` measured ones, and is recorded in the case's description."""
    _SelfCountingRobot.log = []
    case = _counting_case(settle_cycles=settle, eval_settle_cycles=eval_settle, eval_cycles=2)
    bench.evaluate_gait(case, seed_gait(2))
    assert [robot.ran for robot, _, _ in _SelfCountingRobot.log] == [ran]
    monkeypatch.setitem(bench.CASES, case.name, case)
    result = bench.run_robot_benchmark([case.name], ["random"], n_seeds=1, budget=2, progress=False)
    assert result["cases"][case.name]["eval_settle_cycles"] == (settle if eval_settle is None else eval_settle)


def test_a_manifest_with_cases_without_ceiling_or_score_redraws(tmp_path):
    """JSON nulls (no ceiling, no score) come back as NaN columns the figure and table can use."""
    result = bench.run_robot_benchmark(["swimmer3"], ["random"], n_seeds=1, budget=4, progress=False)
    result["records"]["ceiling_fraction"] = np.nan  # as for a robot without a known ceiling
    result["cases"]["swimmer3"]["ceiling"] = None
    paths = bench.write_outputs(result, tmp_path, "test", 1.0, budgets=(4,))
    loaded = bench.from_manifest(paths["manifest"])
    assert loaded["records"]["ceiling_fraction"].dtype == float
    bench.plot_benchmark(loaded, tmp_path / "again.png")
    assert "improvement over seed" in bench.benchmark_table(loaded, (4,))


@pytest.mark.parametrize("name", ["swimmer5", "mujoco-purcell5-unequal", "gymnasium-swimmer", "dm-control-swimmer",
                                  "elastica-snake"])
def test_geogait_defaults_search_the_family_every_black_box_method_searches(name):
    """The rules' "same gait family": a case with a rotation-free family gets it for the black-box methods from the
    case, and geogait (family="auto") finds the same one from what the robot declares."""


    case = bench.CASES[name]
    if case.missing():
        pytest.skip(f"needs {', '.join(case.missing())}")
    robot = case.make_robot(None, explore=False, noise=False)
    shared = bench._Family(case, robot.gait, robot.cycle_period).family
    optimizer = InSituOptimizer(family="free" if case.family == "free" else "auto")
    own = gait_family(optimizer, read_robot_spec(robot), robot.gait)
    assert type(own) is type(shared)
    assert np.allclose(own.matrix, shared.matrix)


def test_settings_of_ones_own_are_not_merged_into_a_manifest(tmp_path):
    """``--geogait-options`` with ``--merge`` is refused in one line (exit 1) and the manifest is left as it was;
    options that are not a JSON object are refused the same way."""
    manifest = ROOT / "docs" / "results" / "robots" / "robots.json"
    before = manifest.read_bytes()
    script = str(ROOT / "benchmarks" / "robots.py")
    for extra in (["--geogait-options", '{"min_trust_radius": 0.05}', "--merge", str(manifest)],
                  ["--geogait-options", "{min"]):
        run = subprocess.run([sys.executable, script, "--cases", "swimmer3", "--methods", "geogait", "--seeds", "1",
                              "--budget", "4", *extra, "--out", str(tmp_path)], capture_output=True, text=True,
                             timeout=300)
        assert run.returncode == 1 and run.stderr.count("\n") == 1 and "--geogait-options" in run.stderr
    assert manifest.read_bytes() == before and not any(tmp_path.iterdir())


def test_the_cobyqa_baseline_is_scipys_cobyqa_from_the_seed(monkeypatch):
    """The cobyqa method runs scipy's COBYQA from the seed gait at radius r_max / 8: its candidates are the
    method's published initial design (seed, then seed + r_max / 8 along each parameter in turn), each
    charged its cycles, and the best so far is what it hands over."""
    case = bench.CASES["swimmer5"]
    robot = bench._CountingRobot(case.make_robot(np.random.SeedSequence(0), explore=False, noise=False))
    family = bench._Family(case, seed_gait(4), 1.0)
    objective = bench._Objective(case, robot, family, budget=5, held=False, seed_value=0.05)
    asked, values = [], []
    measure = bench._Objective.__call__

    def recording(self, params):
        asked.append(np.array(params, copy=True))
        values.append(measure(self, params))
        return values[-1]

    monkeypatch.setattr(bench._Objective, "__call__", recording)
    trace = bench._Trace(robot, seed_gait(4))
    bench.BLACK_BOX["cobyqa"](objective, trace, np.random.default_rng(0))
    seed = family.seed_params
    assert len(asked) == robot.cycles == 5 and seed.size >= 4
    np.testing.assert_allclose(asked[0], seed)
    for k in range(1, 5):
        np.testing.assert_allclose(asked[k] - seed, case.max_joint_angle / 8 * np.eye(seed.size)[k - 1], atol=1e-12)
    best = int(np.argmax(values))
    np.testing.assert_allclose(trace.at(5)[0].params, family.gait(asked[best]).params)


def test_a_candidate_outside_the_declared_region_is_answered_unrun_with_the_worst_value():
    """The wheeled snake declares a margin from its singular line: a black-box candidate that crosses it is not
    run and not charged; it gets the worst value measured so far, as geogait's own climb answers it."""
    case = bench.CASES["wheeled-snake"]
    robot = bench._CountingRobot(case.make_robot(None, explore=False, noise=False))
    family = bench._Family(case, robot.gait, robot.cycle_period)
    objective = bench._Objective(case, robot, family, 10, held=False, seed_value=0.28)
    assert objective.region is not None
    seed_value = objective(family.seed_params)
    assert robot.cycles == 1 and seed_value == pytest.approx(0.28, rel=0.01)
    smaller = family.seed_params.copy()
    smaller[[1, 2, 4, 5]] *= 0.5  # the seed's offsets ±0.6, half its amplitude: inside, and slower
    slower = objective(smaller)
    assert slower < seed_value
    crossing = family.seed_params.copy()
    crossing[[0, 3]] = 0.0  # no offsets: the two joints cross each other, r0 = r1, every cycle
    assert objective(crossing) == slower and robot.cycles == 2 and objective.refused == 1
    objective.refused = objective.MAX_REFUSALS_PER_CYCLE * objective.budget
    assert not objective.affordable()  # a method that only asks for such candidates stops


def test_the_wheeled_snakes_ceiling_keeps_its_margin():
    case = bench.CASES["wheeled-snake"]
    snake = case.make_robot(None, explore=False, noise=False).current_system()
    phases = np.linspace(0, 2 * np.pi, 4096, endpoint=False)
    assert snake.feasibility(case.ceiling().shape(phases)).min() >= 0


def test_the_paired_comparison_takes_the_best_method_within_the_rotation_limit_seed_by_seed():
    """geogait against the best black-box median among methods that keep the rotation limit (a faster method
    that turns is not the rival), paired by seed; six wins of six is the exact two-sided Wilcoxon p = 2 / 2⁶,
    and identical runs tie (p = 1)."""
    import pandas as pd

    seeds = range(6)
    ours = [0.90, 0.91, 0.92, 0.93, 0.94, 0.95]
    rows = [("geogait", s, c, v, 0.0) for s, v in zip(seeds, ours, strict=True) for c in (30, 60)]
    # behind by 1…6 pt after 30 cycles, level after 60
    rows += [("cobyqa", s, c, v - (0.01 * (s + 1) if c == 30 else 0.0), 0.0)
             for s, v in zip(seeds, ours, strict=True) for c in (30, 60)]
    rows += [("tpe", s, c, 0.99, 0.5) for s in seeds for c in (30, 60)]  # ahead, but turns 0.5 rad per cycle
    rows += [("random-held", s, c, 0.5, 0.0) for s in seeds for c in (30, 60)]
    records = pd.DataFrame([{"case": "swimmer3", "method": m, "seed": s, "cycles": c, "objective": v,
                             "ceiling_fraction": v, "improvement": v, "rotation": r, "score": np.nan,
                             "cycles_run": c} for m, s, c, v, r in rows])
    info = {"description": "test", "objective": "progress", "seed": {"objective": 1.0}, "ceiling": {"objective": 2.0},
            "rotation_limit": 0.02, "score": None}
    result = {"records": records, "cases": {"swimmer3": info}}
    comparison = bench.paired_comparison(result, (30, 60, 100)).set_index("cycles")
    assert list(comparison.index) == [30, 60]
    assert (comparison["rival"] == "cobyqa").all()
    assert comparison.loc[30, "ahead"] == 6 and comparison.loc[30, "seeds"] == 6
    assert comparison.loc[30, "median_difference"] == pytest.approx(0.035)
    assert comparison.loc[30, "p_value"] == pytest.approx(2 / 2**6)
    assert comparison.loc[60, "ahead"] == 0 and comparison.loc[60, "p_value"] == 1.0
    table = bench.benchmark_table(result, (30, 60))
    assert "| swimmer3 | 30 | best black-box | cobyqa (89.0 %) | 92.5 % | 6 of 6 | +3.5 pt | 0.031 | 0.062 | " \
        "**level** |" in table  # (Holm over the two cells: 2 × 0.031)
    # a run against its manifest's ten decimals ties; seeds in only one of the two are left out
    tie = bench.paired_test(pd.Series([0.5, 0.6123456789012, 0.7], index=[0, 1, 2]),
                            pd.Series([0.5, 0.6123456789, 0.1], index=[0, 1, 5]))
    assert tie == {"ahead": 0, "seeds": 2, "median_difference": 0.0, "p_value": 1.0}


def test_a_case_with_a_bad_setting_says_which():
    for setting, match in (({"eval_settle_cycles": -1}, "'eval_settle_cycles' parameter of BenchmarkCase 'x'"),
                           ({"eval_cycles": 0}, "'eval_cycles'"), ({"settle_cycles": 1.5}, "'settle_cycles'"),
                           ({"family": "odd"}, "'family'"), ({"objective": "speed"}, "'objective'")):
        with pytest.raises(ValueError, match=match):
            bench.BenchmarkCase(name="x", description="", make_robot=None, **setting)


def test_evaluate_gait_refuses_a_gait_or_period_the_case_does_not_allow():
    """A gait beyond the joint limit scored above the ceiling; a period on a case that has none was taken."""
    from geogait import GeogaitError
    from geogait.experiments.robot_benchmark import CASES, evaluate_gait
    from geogait.gaits import seed_gait

    case = CASES["swimmer3"]
    with pytest.raises(GeogaitError, match="'gait' parameter of evaluate_gait must be a FourierGait within"):
        evaluate_gait(case, seed_gait(2, amplitude=3.0))
    with pytest.raises(GeogaitError, match="'period' parameter of evaluate_gait must be None for case 'swimmer3'"):
        evaluate_gait(case, seed_gait(2), period=1.5)


@pytest.mark.parametrize("method, module", [("ngopt", "nevergrad"), ("gp-bayes", "bayes_opt")])
def test_the_stronger_anchors_start_from_the_seed_in_the_box_and_hand_over_their_gait(monkeypatch, method, module):
    """NGOpt and the Gaussian-process optimiser search the box [−r_max, r_max]ⁿ of the shared family, the seed gait
    their first candidate; what they hand over is a gait of the family they measured (NGOpt: its recommendation;
    the GP: its best measured candidate); without their package they are skipped in one line."""
    pytest.importorskip(module)
    case = bench.CASES["swimmer5"]
    robot = bench._CountingRobot(case.make_robot(np.random.SeedSequence(1), explore=False, noise=True))
    family = bench._Family(case, seed_gait(4), 1.0)
    objective = bench._Objective(case, robot, family, budget=8, held=False, seed_value=0.05)
    asked, values = [], []
    measure = bench._Objective.__call__

    def recording(self, params):
        asked.append(np.array(params, copy=True))
        values.append(measure(self, params))
        return values[-1]

    monkeypatch.setattr(bench._Objective, "__call__", recording)
    trace = bench._Trace(robot, seed_gait(4))
    bench.BLACK_BOX[method](objective, trace, np.random.default_rng(0))
    assert len(asked) == robot.cycles == 8
    np.testing.assert_allclose(asked[0], family.seed_params)
    assert all(np.abs(a).max() <= case.max_joint_angle for a in asked)
    held = trace.at(8)[0]
    assert family.family.residual(held) < 1e-9 and held.joint_limit().max() <= case.max_joint_angle + 1e-9
    if method == "gp-bayes":
        np.testing.assert_allclose(held.params, family.gait(asked[int(np.argmax(values))]).params)
    find_spec = bench.importlib.util.find_spec
    monkeypatch.setattr(bench.importlib.util, "find_spec", lambda name, *a: None if name == module
                        else find_spec(name, *a))
    lines = []
    result = bench.run_robot_benchmark(["swimmer3"], [method, "random"], n_seeds=1, budget=2, progress=False,
                                       log=lines.append)
    assert lines == [f"skipped method {method}: needs {module} (pip install 'geogait[baselines]')"]
    assert set(result["records"]["method"]) == {"random"}


def test_the_climb_alone_takes_no_model_step_and_every_method_counts_its_steps():
    """geogait-climb is geogait's measured climb from the first decision on, never handing a step to its model;
    geogait's own steps split into model and measured ones as its log records them; a black-box method's steps are
    its candidates. The table reports both counts."""
    result = bench.run_robot_benchmark(["swimmer3"], ["geogait", "geogait-climb", "cobyqa"], n_seeds=1, budget=40,
                                       checkpoints=[20, 40], progress=False)
    records = result["records"].set_index(["method", "cycles"])
    assert records.loc[("geogait-climb", 40), "model_steps"] == 0
    assert records.loc[("geogait-climb", 40), "measured_steps"] >= 5
    assert records.loc[("cobyqa", 40), "measured_steps"] == records.loc[("cobyqa", 40), "cycles_run"] == 40
    assert records.loc[("cobyqa", 20), "measured_steps"] == 20 and records.loc[("cobyqa", 20), "model_steps"] == 0
    ours = records.loc[("geogait", 40)]
    assert 0 < ours["model_steps"] + ours["measured_steps"] < 40
    assert ours["model_steps"] + ours["measured_steps"] >= records.loc[("geogait", 20), "model_steps"] + \
        records.loc[("geogait", 20), "measured_steps"]
    table = bench.benchmark_table(result, (20, 40))
    assert "steps in 40 cycles: model · measured" in table
    climb_row = next(line for line in table.splitlines() if line.startswith("| geogait-climb |"))
    assert climb_row.endswith(f"| 0 · {records.loc[('geogait-climb', 40), 'measured_steps']:.0f} |")


def test_the_motionless_model_predicts_no_motion_and_its_jacobian_has_the_gaits_shape():
    gait = seed_gait(3)
    model = bench._MotionlessModel()
    np.testing.assert_array_equal(model.predict_displacement(gait), np.zeros(3))
    pose, jacobian = model.predict_displacement(gait, jacobian=True)
    assert jacobian.shape == (3, gait.params.size) and not jacobian.any() and not pose.any()


def test_a_change_case_is_judged_after_the_change_on_the_changed_robot(monkeypatch):
    """A change case runs its change cycle plus the budget; every gait is judged on the changed robot against its
    ceiling, every 5 cycles; the table reports the shares after the change, the recovery and the offline error."""
    from geogait.experiments.changes import swimmer_link_drag
    from geogait.simulate import cycle_displacement
    from geogait.systems import PurcellSwimmer

    ends = ((1.0, 0.3), (1.0, 1.0), (1.0, 0.3))
    case = bench._change_case(bench.CASES["swimmer3"], "swimmer3-ends", "ends lose drag", swimmer_link_drag(ends),
                              at_cycle=10, ceiling=lambda: seed_gait(2, amplitude=1.0))
    monkeypatch.setitem(bench.CASES, "swimmer3-ends", case)
    result = bench.run_robot_benchmark(["swimmer3-ends"], ["cobyqa"], n_seeds=2, budget=10, progress=False)
    records = result["records"]
    assert sorted(set(records["cycles"])) == [0, 5, 10, 15, 20] and (records["cycles_run"] == 20).all()
    exact = {scale: np.hypot(*cycle_displacement(PurcellSwimmer(3, link_drag_scale=scale), seed_gait(2))[:2])
             for scale in (ends, None)}
    assert result["cases"]["swimmer3-ends"]["seed"]["objective"] == pytest.approx(exact[ends], rel=0.03)
    assert abs(exact[ends] - exact[None]) > 0.1 * exact[None]
    seed = records[records["seed"] == 0].set_index("cycles")
    assert seed.loc[0, "objective"] == pytest.approx(exact[ends], rel=0.03)  # the seed gait, judged changed
    assert seed["offline_error"].iloc[0] == pytest.approx(1 - seed["ceiling_fraction"].loc[[15, 20]].mean())
    table = bench.benchmark_table(result)
    assert "| method | +10 | cycles to 90 % (seeds) | offline error | rotation at +10 |" in table
    assert "the changed robot's ceiling" in table


def test_recovery_and_offline_error_are_read_from_the_checkpoints_after_the_change():
    rows = [{"cycles": c, "ceiling_fraction": v} for c, v in ((50, 1.0), (60, 0.95), (65, 0.2), (70, 0.6), (75, 0.92),
                                                              (80, 0.97))]
    assert bench.after_change(rows, 60) == {"offline_error": pytest.approx(1 - np.mean([0.2, 0.6, 0.92, 0.97])),
                                            "recovery_cycles": 15.0}
    never = bench.after_change(rows[:4], 60)
    assert np.isnan(never["recovery_cycles"]) and never["offline_error"] == pytest.approx(0.6)


def test_every_change_case_changes_its_robot_before_its_change_cycle():
    """The change cases the benchmark lists: each one's robot is its base case's robot until the change cycle,
    and is judged on the robot changed from the start."""
    names = set(bench.CHANGE_CASES)
    assert {"swimmer5-ends-drag", "swimmer5-head-drag", "mujoco-purcell5-damaged", "gymnasium-swimmer-weak-joint",
            "elastica-snake-new-floor"} <= names
    for name in bench.CHANGE_CASES:
        case = bench.CASES[name]
        if case.missing():
            continue
        robot = case.make_robot(None, explore=False, noise=False)
        judged = case.judged_robot()
        assert robot.at_cycle == bench.CHANGE_AT and judged.at_cycle == 0 and not robot.changed


def test_detect_and_restart_restarts_from_the_held_gait_when_two_cycles_fall_beyond_noise():
    """Every tenth candidate, the held gait runs two measured cycles; both below the record (the best pair's
    mean) by more than 3 pooled standard deviations of a cycle restart the method from that gait; a pair within
    the noise does not, and the first pair (no noise known yet) never does."""
    case = bench.CASES["swimmer3"]
    family = bench._Family(case, seed_gait(2), 1.0)

    class Scripted:
        def __init__(self, pairs):
            self.pairs, self.case, self.budget = list(pairs), case, 1000
            self.robot = type("R", (), {"cycles": 0})()

        def measure(self, gait, period, n):
            assert n == 2
            return np.array(self.pairs.pop(0))

    trace = bench._Trace(type("R", (), {"cycles": 0})(), family.gait(family.seed_params * 0.9))
    watch = bench._Watch(trace, family)
    objective = Scripted([(1.0, 1.2), (1.1, 0.9), (1.0, 0.95), (0.5, 0.6)])  # σ ≈ 0.12: 0.5 and 0.6 beyond 3σ
    for _ in range(39):
        watch.before_candidate(objective)
    assert len(watch.pairs) == 3 and watch.record == pytest.approx(1.1) and not trace.restarts
    with pytest.raises(bench._Restart) as restart:
        watch.before_candidate(objective)
    np.testing.assert_allclose(restart.value.params, family.seed_params * 0.9)
    assert watch.record == -np.inf and trace.restarts == [0]


def test_a_restart_variant_restarts_after_the_change_and_runs_within_the_budget():
    """COBYQA converges before the change; its held gait falls with the change and it restarts, charged for its
    checks within the budget."""
    from geogait.experiments.changes import swimmer_link_drag

    ends = ((1.0, 0.3), (1.0, 1.0), (1.0, 1.0), (1.0, 1.0), (1.0, 0.3))
    case = bench._change_case(bench.CASES["swimmer5"], "swimmer5-ends-soon", "ends lose drag",
                              swimmer_link_drag(ends), at_cycle=40)
    child = np.random.SeedSequence(0).spawn(1)[0]
    trace, used = bench._run_method(case, "cobyqa-restart", child, 80, seed_value=0.08)
    assert used <= 80 and trace.restarts and min(trace.restarts) > 40
    assert "cobyqa-restart" in bench.METHODS and "cmaes-tuned-restart" in bench.METHODS


def test_an_undeclared_case_declares_only_joints_period_and_objective():
    """Each stationary robot also comes as a user brings it: no resistive medium, chain geometry, symmetry,
    settling or truth; every black-box method searches the free family, geogait chooses its own (the half-wave one on
    trial) and measures its settling, and the chain's resistance model is skipped in one line."""
    from geogait.gaits import FreeGaitFamily, MirrorGaitFamily


    assert set(bench.UNDECLARED_CASES) == {f"{n}-undeclared" for n in bench.CASES
                                           if n not in bench.CHANGE_CASES + bench.UNDECLARED_CASES}
    case = bench.CASES["swimmer5-undeclared"]
    assert (case.family, case.settle_cycles, case.ceiling) == ("free", 0, bench.CASES["swimmer5"].ceiling)
    robot = case.make_robot(None, explore=False, noise=False)
    for hidden in ("chain_geometry", "front_back_symmetric", "mirror_symmetric", "resistive_medium",
                   "current_system", "robot_state"):
        assert not hasattr(robot, hidden), hidden
    assert robot.n_joints == 4 and robot.cycle_period == 1.0 and callable(robot.set_excitation)
    # no symmetry declared: the half-wave family on trial with the Adaptation, else the free family
    assert isinstance(gait_family(InSituOptimizer(), read_robot_spec(robot), robot.gait), MirrorGaitFamily)
    assert isinstance(gait_family(InSituOptimizer(checks=[]), read_robot_spec(robot), robot.gait), FreeGaitFamily)
    lines = []
    result = bench.run_robot_benchmark(["swimmer3-undeclared"], ["geogait", "geogait-resistance", "random-held"],
                                       n_seeds=1, budget=4, checkpoints=[4], progress=False, log=lines.append)
    assert lines == ["skipped method geogait-resistance on swimmer3-undeclared: its robot gives no chain geometry"]
    assert set(result["records"]["method"]) == {"geogait", "random-held"}
    mujoco = bench.CASES["mujoco-purcell5-unequal-undeclared"]
    if not mujoco.missing():
        chain = mujoco.make_robot(None, explore=False, noise=False)
        assert not hasattr(chain, "resistive_medium") and chain.joint_ranges.shape == (4, 2)
        assert mujoco.eval_settle_cycles == bench.CASES["mujoco-purcell5-unequal"].settle_cycles == 1


def test_an_undeclared_robot_keeps_the_region_its_shapes_may_take():
    """The undeclared wheeled snake hid its singular set with its system: black boxes' candidates crossed it and the
    robot's body velocity went non-finite (GP, seeds 2 and 3). Its region is declared as a user's robot declares one,
    and a candidate beyond it is refused unrun, as on the declared robot."""
    from geogait.optimize import robot_feasibility

    snake = bench.CASES["wheeled-snake-undeclared"].make_robot(None, explore=False, noise=False)
    assert not hasattr(snake, "current_system") and callable(snake.feasibility)
    declared = bench.CASES["wheeled-snake"].make_robot(None, explore=False, noise=False)
    shapes = np.array([[0.0, 0.0], [1.0, -1.0], [0.5, 0.45]])
    np.testing.assert_array_equal(snake.feasibility(shapes), declared.current_system().feasibility(shapes))
    assert robot_feasibility(snake, 2, 1) is not None
    swimmer = bench.CASES["swimmer3-undeclared"].make_robot(None, explore=False, noise=False)
    assert not hasattr(swimmer, "feasibility") and robot_feasibility(swimmer, 2, 1) is None


def test_holm_adjusts_the_ith_smallest_p_value_by_the_cells_left_and_keeps_the_order():
    np.testing.assert_allclose(bench.holm(np.array([0.01, 0.04, 0.03, 0.5])), [0.04, 0.09, 0.09, 0.5])
    np.testing.assert_allclose(bench.holm(np.array([0.2, 0.9])), [0.4, 0.9])
    assert bench.holm(np.array([0.6, 0.7])).max() == 1.0


def test_a_cell_is_ahead_or_behind_only_past_the_holm_corrected_wilcoxon_test():
    """Twelve seeds all ahead (p = 2 / 2¹² ≈ 0.0005) stay ahead after Holm over the four cells, and all behind stay
    behind; a gap in three seeds, the rest tied, is level."""
    import pandas as pd

    rows = []
    for s in range(12):
        for cycles in (30, 60):
            rows += [("geogait", s, cycles, 0.9 + 0.001 * s), ("cobyqa", s, cycles, 0.8 + 0.001 * s),
                     ("geogait-climb", s, cycles, 0.95 + 0.001 * s if cycles == 30 or s < 3 else 0.9 + 0.001 * s)]
    records = pd.DataFrame([{"case": "swimmer3", "method": m, "seed": s, "cycles": c, "objective": v,
                             "ceiling_fraction": v, "improvement": v, "rotation": 0.0, "score": np.nan,
                             "cycles_run": c} for m, s, c, v in rows])
    info = {"description": "test", "objective": "progress", "seed": {"objective": 1.0}, "ceiling": {"objective": 2.0},
            "rotation_limit": 0.02, "score": None}
    table = bench.verdicts({"records": records, "cases": {"swimmer3": info}}, (30, 60)).set_index(["versus", "cycles"])
    assert len(table) == 4
    assert (table.loc["best black-box", "verdict"] == "ahead").all()
    assert table.loc[("climb alone", 30), "verdict"] == "behind"
    assert table.loc[("climb alone", 60), "verdict"] == "level"  # nine of twelve seeds tie: p = 2 / 2³
    assert table.loc[("best black-box", 30), "holm_p"] == pytest.approx(4 * 2 / 2**12)
    records.loc[records["method"] == "geogait", "rotation"] = 0.05  # beyond the limit: said in its cell
    lines = bench.verdict_lines({"records": records, "cases": {"swimmer3": info}}, (30,))
    assert "| 90.5 % (turns 0.050 rad per cycle) | 12 of 12 |" in "\n".join(lines)


def test_the_long_search_holds_a_gait_of_the_family_better_than_the_seed():
    """Where no ceiling is known (Gymnasium's swimmer, the changed swimmer and snake), the reference is the gait a
    long clean CMA-ES search holds: a gait of the case's family and period range that beats the seed."""
    assert bench.CASES["gymnasium-swimmer"].ceiling.func is bench.long_search_ceiling
    case = bench.CASES["swimmer3"]
    gait, period = bench.long_search_ceiling("swimmer3", cycles=40)
    family = bench._Family(case, seed_gait(2), 1.0)
    assert period is None and family.family.residual(gait) < 1e-9
    assert bench.evaluate_gait(case, gait)["objective"] > 1.2 * bench.evaluate_gait(case, seed_gait(2))["objective"]


def test_the_figure_gives_every_method_a_line_and_marks_the_change(monkeypatch, tmp_path):
    """More methods than a ten-colour palette (the free and restart variants of every black box) each get a line, a
    variant sharing its method's colour; a change case's panel marks the change."""
    import pandas as pd

    methods = [m for m in bench.METHODS if not m.endswith("-held")]
    records = pd.DataFrame([{"case": "c", "method": m, "seed": s, "cycles": c, "ceiling_fraction": 0.5 + 0.01 * i,
                             "improvement": 0.0, "rotation": 0.0} for i, m in enumerate(methods)
                            for s in range(2) for c in (0, 5, 10)])
    figures = []
    monkeypatch.setattr(bench, "save_figure", lambda figure, path: figures.append(figure) or path)
    bench.plot_benchmark({"records": records, "cases": {"c": {"ceiling": {"objective": 1.0}, "change_at": 5}}},
                         tmp_path / "f.png")
    lines = figures[0].axes[0].get_lines()
    colours = {line.get_label(): line.get_color() for line in lines}
    assert set(methods) <= set(colours)
    assert colours["cmaes"] == colours["cmaes-restart"] != colours["ngopt"] != colours["geogait"]
    assert any(list(line.get_xdata()) == [5, 5] for line in lines)  # the change, a vertical line at its cycle
    bench.plt.close(figures[0])
