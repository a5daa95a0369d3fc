"""Benchmark harness: resumable CSV, Ray runner, local runner, report."""

import csv
import re
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks.harness import RESULT_COLUMNS, Run, make_grid
from benchmarks.harness.report import aggregate, plot, read_rows, table
from benchmarks.harness.runner import pending, run_local, run_ray
from benchmarks.harness.cli import harness_env

TINY_FLOWS = {"flow_max_steps": 30, "noise_grid": [0.1], "flow_hidden": [16]}
TINY = {"mbil": {"n_timesteps": 20, "flow_max_steps": 30, "noise_grid": [0.1], "flow_hidden": [16]},
        "bc": {"n_timesteps": 20}}


def rows_of(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_local_grid_appends_rows_and_resumes(tmp_path):
    out = tmp_path / "r.csv"
    grid = make_grid(["bc"], ["CartPole-v1"], [1, 3], [0])
    assert run_local(grid[:1], str(out), n_episodes=3, overrides=TINY) == 1
    assert len(rows_of(out)) == 1
    # rerun: the finished run is skipped, only the missing one runs
    assert [r.n_trajectories for r in pending(grid, str(out))] == [3]
    assert run_local(grid, str(out), n_episodes=3, overrides=TINY) == 1
    rows = rows_of(out)
    assert len(rows) == 2 and list(rows[0]) == RESULT_COLUMNS
    assert rows[1]["n_episodes"] == "3" and rows[1]["gradient_steps"] == "20"
    # a resumed grid whose settings changed since its rows (another override here; the zoo's entry alike) is refused
    longer = {**TINY, "bc": {"n_timesteps": 30}}
    with pytest.raises(ValueError, match="expected 'bc' on CartPole-v1 to run with the settings of its rows"):
        run_local(make_grid(["bc"], ["CartPole-v1"], [1], [1]), str(out), n_episodes=3, overrides=longer)
    with pytest.raises(ValueError, match="or the protocol changed"):
        run_local(make_grid(["bc"], ["CartPole-v1"], [1], [1]), str(out), n_episodes=3, overrides=TINY,
                  protocol="published")
    assert len(rows_of(out)) == 2


def test_published_protocol_and_second_expert_are_named_in_the_rows(tmp_path):
    from sb3_mbil.common.demonstrations import available_pools

    out = tmp_path / "p.csv"
    grid = make_grid(["bc", "mbil"], ["CartPole-v1"], [1], [0])
    pool = {"CartPole-v1": "CartPole-v1-ppo"} if "CartPole-v1-ppo" in available_pools() else None
    assert run_local(grid, str(out), n_episodes=2, overrides=TINY, pool=pool, protocol="published") == 2
    for row in rows_of(out):
        assert row["protocol"] == "published"
        assert "('every', 20)" in row["settings"] and "('protocol', 'published')" in row["settings"]
        if pool:
            assert "('expert_pool', 'CartPole-v1-ppo')" in row["settings"]


def test_dsfn_rows_name_the_policy_it_returned_and_old_files_gain_the_column(tmp_path):
    """A file written before the returned_iteration column gains it (its rows kept, empty there); a DSFN row fills it
    with the index of the pi_i it returned, other algorithms' rows leave it empty."""
    from benchmarks.harness.results import append_rows

    out = tmp_path / "r.csv"
    before = RESULT_COLUMNS[:RESULT_COLUMNS.index("returned_iteration")]
    append_rows(out, [{**dict.fromkeys(before, "x"), "algo": "bc", "seed": "7"}], before)
    tiny = {**TINY, "dsfn": {"warm_start_steps": 20, "dqn_steps": 10, "sf_steps": 10, "max_iterations": 2,
                             "n_timesteps": 70}}
    assert run_local(make_grid(["dsfn", "bc"], ["CartPole-v1"], [1], [0]), str(out), n_episodes=2, overrides=tiny) == 2
    rows = rows_of(out)
    assert list(rows[0]) == RESULT_COLUMNS and rows[0]["seed"] == "7" and rows[0]["returned_iteration"] == ""
    dsfn, bc = (next(r for r in rows[1:] if r["algo"] == a) for a in ("dsfn", "bc"))
    assert dsfn["returned_iteration"] in {"0", "1", "2"} and bc["returned_iteration"] == ""


def test_rows_of_runs_on_the_same_data_are_reused_not_rerun(tmp_path):
    """AVRIL sees whole trajectories under both protocols: its published row is the full grid's row (the same
    result when run again), copied with the full grid's settings and its source named; BC's every-20th row is not."""
    from benchmarks.harness.grid import run_one, settings_column
    from benchmarks.harness.results import append_rows
    from benchmarks.harness.runner import reuse_rows

    tiny = {**TINY, "avril": {"n_timesteps": 20}}
    source, out = tmp_path / "published.csv", tmp_path / "full.csv"
    grid = make_grid(["avril", "bc"], ["CartPole-v1"], [1], [0])
    assert run_local(grid, str(source), n_episodes=2, overrides=tiny, protocol="published") == 2
    # a file written before the reused_from column: the column is added, its rows kept
    before = RESULT_COLUMNS[:RESULT_COLUMNS.index("reused_from")]
    old = dict.fromkeys(before, "x")
    append_rows(out, [{**old, "algo": "bc", "seed": "7"}], before)
    # other settings, or another number of evaluation episodes, is another run
    assert reuse_rows(grid, str(out), str(source), 2, {**tiny, "avril": {"n_timesteps": 30}}) == 0
    assert reuse_rows(grid, str(out), str(source), 3, tiny) == 0
    assert reuse_rows(grid, str(out), str(source), 2, tiny) == 1
    rows = rows_of(out)
    assert list(rows[0]) == RESULT_COLUMNS and rows[0]["seed"] == "7" and rows[0]["reused_from"] == ""
    copied, original = rows[1], next(r for r in rows_of(source) if r["algo"] == "avril")
    assert copied["reused_from"] == "published.csv" and copied["protocol"] == "full"
    assert copied["settings"] == settings_column("avril", "CartPole-v1", tiny) != original["settings"]
    assert copied["mean_return"] == original["mean_return"] and copied["commit"] == original["commit"]
    rerun = run_one(grid[0], n_episodes=2, overrides=tiny, protocol="full")
    assert rerun["mean_return"] == float(original["mean_return"])
    # the full grid then runs only what it could not reuse, and a second pass copies nothing twice
    assert reuse_rows(grid, str(out), str(source), 2, tiny) == 0
    assert run_local(grid, str(out), n_episodes=2, overrides=tiny) == 1
    assert sorted(r["algo"] for r in rows_of(out)) == ["avril", "bc", "bc"]


@pytest.mark.slow  # minutes under load: run by CI with -m slow
def test_ray_grid(tmp_path):
    out = tmp_path / "r.csv"
    grid = [Run("mbil", "CartPole-v1", 1, 0), Run("bc", "CartPole-v1", 1, 0)]
    assert run_ray(grid, str(out), n_episodes=2, overrides=TINY, num_cpus=1) == 2
    assert {r["algo"] for r in rows_of(out)} == {"mbil", "bc"}
    assert float(rows_of(out)[0]["mean_return"]) > 0
    # the same grid with a cell per task, its seeds in lockstep: the same rows
    lockstep = tmp_path / "lockstep.csv"
    assert run_ray(grid, str(lockstep), n_episodes=2, overrides=TINY, num_cpus=1, lockstep=True) == 2
    key = lambda r: (r["algo"], r["seed"])  # noqa: E731
    assert [(key(r), r["mean_return"]) for r in sorted(rows_of(lockstep), key=key)] == \
        [(key(r), r["mean_return"]) for r in sorted(rows_of(out), key=key)]


def test_lockstep_grid_gives_each_seed_its_own_runs_row(tmp_path):
    tiny = {**TINY, "mbil_c": {"n_timesteps": 200, "model_max_steps": 30}, "bc": {"n_timesteps": 200},
            "dsfn": {"warm_start_steps": 20, "dqn_steps": 10, "sf_steps": 10, "max_iterations": 1}}
    grid = make_grid(["bc", "mbil_c", "dsfn"], ["CartPole-v1"], [1, 2], [0, 1, 2])
    separate, lockstep = tmp_path / "separate.csv", tmp_path / "lockstep.csv"
    assert run_local(grid, str(separate), n_episodes=3, overrides=tiny) == 18
    assert run_local(grid[:4], str(lockstep), n_episodes=3, overrides=tiny, lockstep=True) == 4  # resumes, too
    assert run_local(grid, str(lockstep), n_episodes=3, overrides=tiny, lockstep=True) == 14
    assert list(rows_of(lockstep)[0]) == RESULT_COLUMNS
    same = ("mean_return", "std_return", "n_episodes", "gradient_steps", "settings", "protocol")
    key = lambda r: (r["algo"], r["n_trajectories"], r["seed"])  # noqa: E731
    assert [(key(r), [r[c] for c in same]) for r in sorted(rows_of(lockstep), key=key)] == \
        [(key(r), [r[c] for c in same]) for r in sorted(rows_of(separate), key=key)]


def test_report(tmp_path):
    out = tmp_path / "r.csv"
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=RESULT_COLUMNS)
        w.writeheader()
        for algo, base in (("mbil", 480), ("bc", 400)):
            for n in (1, 3):
                for seed in range(3):
                    w.writerow({"algo": algo, "env": "CartPole-v1", "n_trajectories": n, "seed": seed,
                                "mean_return": base + 5 * n + seed, "std_return": 1, "n_episodes": 300})
    rows = read_rows(str(out))
    text = table(rows)
    assert "| mbil |" in text and "published best" in text
    from benchmarks.harness.report import paired

    assert "| CartPole-v1 | 0 of 3, +80.0 +- 0.0 | 0 of 3, +80.0 +- 0.0 |" in paired(rows)
    agg = aggregate(rows, reps=200)
    assert agg["mbil"]["mean"][0] > agg["bc"]["mean"][0]
    lo, hi = agg["mbil"]["iqm"][1], agg["mbil"]["iqm"][2]
    assert lo <= agg["mbil"]["iqm"][0] <= hi
    assert aggregate(rows, reps=200) == agg  # a seeded bootstrap: the page does not change when regenerated
    plot(rows, str(tmp_path / "fig.png"))
    assert (tmp_path / "fig.png").stat().st_size > 1000


def test_probability_of_improvement_over_bc():
    from benchmarks.harness.report import probability_of_improvement

    rows = [{"algo": algo, "env": env, "n_trajectories": 1, "seed": seed, "settings": "",
             "mean_return": base + {"bc": 0.0, "better": 50.0, "level": 0.0}[algo] + seed}
            for algo in ("bc", "better", "level") for env, base in (("CartPole-v1", 200.0), ("Acrobot-v1", -150.0))
            for seed in range(5)]
    p = probability_of_improvement(rows, "bc", reps=200)
    assert set(p) == {"better", "level"}
    assert p["better"][0] > 0.9 and p["better"][1] <= p["better"][0] <= p["better"][2]
    assert abs(p["level"][0] - 0.5) < 1e-9


def test_unknown_env_is_refused():
    from benchmarks.harness.grid import tuned_settings

    with pytest.raises(ValueError, match="expected an entry for Pendulum-v1"):
        tuned_settings("mbil", "Pendulum-v1")


def test_a_linear_learning_rate_schedule_as_the_zoo_writes_it(cartpole_data):
    from sb3_mbil import BC
    from benchmarks.harness.grid import tuned_settings

    settings = tuned_settings("bc", "CartPole-v1", {"learning_rate": "lin_1e-3"})
    model = BC("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, seed=0, learning_rate=settings["learning_rate"])
    model.learn(10)
    # the last of the 10 updates ran with 1e-3 times the remaining progress, 1/10
    assert model.policy.optimizer.param_groups[0]["lr"] == pytest.approx(1e-4)
    with pytest.raises(ValueError, match="learning_rate: expected a number or 'lin_<initial value>', found 'cos_1e-3'"):
        tuned_settings("bc", "CartPole-v1", {"learning_rate": "cos_1e-3"})


@pytest.mark.parametrize("algo", ["mbil", "bc"])
def test_every_expert_env_has_tuned_settings(algo):
    from benchmarks.harness.grid import tuned_settings
    from sb3_mbil.experts import EXPERTS

    for env in EXPERTS:
        settings = tuned_settings(algo, env)
        assert isinstance(settings.get("policy_kwargs", {}), dict)  # the zoo's string form, evaluated
    assert tuned_settings(algo, "Walker2d-v4")["policy_kwargs"] == {"net_arch": [256, 256], "normalize_observations": True,
                                                                    "bounded_mean": True}
    assert tuned_settings(algo, "Walker2d-v4")["learning_rate"](0.25) == pytest.approx(2.5e-4)  # lin_1e-3
    assert tuned_settings(algo, "Walker2d-v4")["bc_loss"] == "mse"
    # an override in the zoo's string form is evaluated as rl_zoo3 does, with th in scope
    import torch

    kwargs = tuned_settings(algo, "Hopper-v4", {"policy_kwargs": "dict(optimizer_class=th.optim.AdamW)"})["policy_kwargs"]
    assert kwargs == {"optimizer_class": torch.optim.AdamW}


def test_append_keeps_an_existing_header(tmp_path):
    from benchmarks.harness.results import append_row

    out = tmp_path / "r.csv"
    append_row(out, {"a": 1, "b": 2}, ["a", "b"])
    append_row(out, {"a": 3, "b": 4, "c": 5}, ["a", "b", "c"])
    assert rows_of(out) == [{"a": "1", "b": "2"}, {"a": "3", "b": "4"}]


def test_append_rows_lands_a_runs_rows_together(tmp_path, monkeypatch):
    """A run's rows are written in one go: a failure part way through leaves the file as it was."""
    import csv

    from benchmarks.harness.results import append_rows

    out = tmp_path / "r.csv"
    append_rows(out, [{"a": 0, "b": 0}], ["a", "b"])
    real = csv.DictWriter.writerow

    def fail_on_third(self, row):
        if row["a"] == 3:
            raise OSError("interrupted")
        return real(self, row)

    monkeypatch.setattr(csv.DictWriter, "writerow", fail_on_third)
    with pytest.raises(OSError):
        append_rows(out, [{"a": i, "b": -i} for i in range(1, 5)], ["a", "b"])
    monkeypatch.undo()
    assert rows_of(out) == [{"a": "0", "b": "0"}]
    append_rows(out, [{"a": i, "b": -i} for i in range(1, 4)], ["a", "b"])
    assert rows_of(out) == [{"a": str(i), "b": str(-i)} for i in range(4)]


def test_main_job_script_runs(tmp_path):
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, "-m", "benchmarks.compare", "--env", "CartPole-v1", "--algos", "bc", "--steps", "20",
                          "--eval-episodes", "2"], cwd=repo, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "expert" in out.stdout and "bc" in out.stdout and "20 gradient steps" in out.stdout


def test_learning_curves_resume(tmp_path):
    from benchmarks.harness.curves import ABLATION_VARIANTS, curve_summary, run_curves

    out = tmp_path / "curves.csv"
    variants = {"bc": ("bc", {}), "mbil_a1_b0": ("mbil", {**ABLATION_VARIANTS["mbil_a1_b0"][1], **TINY["mbil"]})}
    variants["mbil_a1_b0"][1].pop("n_timesteps")
    n = run_curves(variants, ["CartPole-v1"], [0], str(out), n_updates=40, eval_every=20, n_episodes=2, use_ray=False)
    assert n == 2
    rows = rows_of(out)
    assert sorted((r["algo"], r["gradient_step"]) for r in rows) == [("bc", "20"), ("bc", "40"), ("mbil_a1_b0", "20"),
                                                                     ("mbil_a1_b0", "40")]
    assert run_curves(variants, ["CartPole-v1"], [0], str(out), n_updates=40, eval_every=20, n_episodes=2, use_ray=False) == 0
    summary = curve_summary(rows)
    assert summary[("bc", "CartPole-v1", 40)][2] == 1


def test_learning_curves_refuse_one_name_for_two_settings(tmp_path):
    """A variant inherits the zoo's settings for what it leaves out: two variants that resolve to the same run, or a
    variant whose rows in the CSV ran with other settings, are refused before anything trains."""
    from benchmarks.harness.curves import run_curves
    from benchmarks.harness.grid import tuned_settings

    out = tmp_path / "curves.csv"
    zoo_rate = tuned_settings("bc", "Hopper-v4")["learning_rate"]
    same = {"bc_zoo": ("bc", {}), "bc_zoo_rate": ("bc", {"learning_rate": zoo_rate})}
    with pytest.raises(ValueError, match="'bc_zoo' and 'bc_zoo_rate'"):
        run_curves(same, ["Hopper-v4"], [0], str(out), n_updates=20, eval_every=10, n_episodes=1, use_ray=False)
    assert not out.exists()

    variants = {"bc": ("bc", {"batch_size": 8})}
    assert run_curves(variants, ["CartPole-v1"], [0], str(out), n_updates=20, eval_every=10, n_episodes=1,
                      use_ray=False) == 1
    changed = {"bc": ("bc", {"batch_size": 16})}
    with pytest.raises(ValueError, match="expected 'bc' on CartPole-v1 to run with the settings of its rows"):
        run_curves(changed, ["CartPole-v1"], [1], str(out), n_updates=20, eval_every=10, n_episodes=1, use_ray=False)
    assert len(rows_of(out)) == 2  # nothing appended
    with open(out, "a") as f:  # a run interrupted mid-write: the check must not trip on its unfinished line
        f.write("bc,CartPole-v1,1,10,3")
    assert run_curves(variants, ["CartPole-v1"], [1], str(out), n_updates=20, eval_every=10, n_episodes=1,
                      use_ray=False) == 1
    assert len(rows_of(out)) == 4


def test_curve_table_reports_final_return_and_late_drop():
    from benchmarks.harness.curves import curve_table

    rows = [{"env": "E", "algo": "bc", "seed": s, "gradient_step": step, "mean_return": ret}
            for s in (0, 1) for step, ret in ((500, 100.0), (1000, 900.0 + s), (1500, 300.0), (2000, 100.0 - s))]
    text = curve_table(rows, {"E": 1000.0}, last=2)
    # final: seed 0 (300 + 100) / 2 = 200, seed 1 (300 + 99) / 2 = 199.5; best point 900.5 at 1000 updates
    assert "| E | bc | 200 +- 0 | 0.20 | 900 (1000) | -701 | 2 | 2000 |" in text


def test_draw_table_names_each_seeds_trajectory(tmp_path):
    """Each (env, seed) row shows the trajectory that seed trains on (the same draw as run_curve's) beside its finals."""
    from sb3_mbil import load_demonstrations
    from benchmarks.harness.curves import draw_table

    pool = tmp_path / "small.npz"
    load_demonstrations("CartPole-v1").sample(5, seed=3).save(pool)
    rows = [{"env": "CartPole-v1", "algo": v, "seed": s, "gradient_step": 500, "mean_return": ret, "n_trajectories": 2,
             "settings": repr([("algo", "bc"), ("expert_pool", str(pool))])}
            for s in (0, 1) for v, ret in (("bc", 100.0 + s), ("mbil", 200.0 + s))]
    text = draw_table(rows, last=1)
    for s in (0, 1):
        drawn = load_demonstrations(str(pool)).sample(2, seed=s)
        idx = ", ".join(map(str, drawn.metadata["sampled"]["indices"]))
        length = sum(len(t) for t in drawn.trajectories)
        assert f"| CartPole-v1 | {s} | {idx} | {drawn.episode_returns.mean():.0f} | {length} | {100 + s} | {200 + s} |" in text


def test_pool_experts_follow_the_pool_the_runs_drew_from(tmp_path):
    """A CSV of runs on another pool is measured against that pool's return, not the shipped pool's; mixing two pools
    of one env is an error that names them."""
    import pytest

    from sb3_mbil import load_demonstrations
    from benchmarks.harness.pools import pool_experts

    shipped = load_demonstrations("Acrobot-v1")
    pool = tmp_path / "short.npz"
    short = shipped.sample(5, seed=0)
    short.save(pool)
    row = {"env": "Acrobot-v1", "settings": repr([("algo", "bc"), ("expert_pool", str(pool))])}
    assert pool_experts([row]) == {"Acrobot-v1": float(short.episode_returns.mean())}
    assert pool_experts([{"env": "Acrobot-v1", "settings": ""}]) == {"Acrobot-v1": float(shipped.episode_returns.mean())}
    with pytest.raises(ValueError, match="expert_pool"):
        pool_experts([row, {"env": "Acrobot-v1", "settings": repr([("algo", "bc")])}])


def test_curve_plot_keeps_each_variants_colour_across_panels(tmp_path):
    """A panel that lacks a variant must not shift the colours of the others; the legend lists every variant."""
    from benchmarks.harness.curves import plot_curves

    panels = {"A": ("bc", "mbil"), "B": ("bc", "bc_wd1e-3", "mbil")}
    rows = [{"env": env, "algo": v, "seed": 0, "gradient_step": step, "mean_return": float(step)}
            for env, variants in panels.items() for v in variants for step in (500, 1000)]
    fig = plot_curves(rows, str(tmp_path / "curves.png"), {"A": 1.0, "B": 1.0})
    assert (tmp_path / "curves.png").stat().st_size > 0
    colours = [{line.get_label(): line.get_color() for line in ax.get_lines()} for ax in fig.axes]
    assert colours[0]["mbil"] == colours[1]["mbil"] and colours[0]["bc"] == colours[1]["bc"]
    assert len({colours[1][v] for v in panels["B"]}) == 3
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert sorted(legend) == ["bc", "bc_wd1e-3", "expert", "mbil"]
    # an algorithm keeps its colour in every figure, whatever else the figure holds
    from matplotlib.colors import to_hex

    from benchmarks.harness.report import variant_colors

    other = variant_colors(["edm", "mbil", "zzz_variant"])
    assert to_hex(other["mbil"]) == to_hex(colours[0]["mbil"]) and len({to_hex(c) for c in other.values()}) == 3


@pytest.mark.parametrize("algo", ["mbil", "rcal"])
def test_measure_speed_reports_fit_and_update_times(algo, cartpole_data):
    from benchmarks.speed import measure_speed

    kwargs = TINY_FLOWS if algo == "mbil" else {}
    r = measure_speed("CartPole-v1", cartpole_data, steps=200, repeats=1, budget=1000, algo=algo, algo_kwargs=kwargs)
    assert r["algo"] == algo and r["n_pairs"] > 0 and r["steps"] == 200
    if algo == "mbil":
        assert r["setup_seconds"] > 0 and r["next_action_fit_cpu_seconds"] > 0
        assert r["transition_fit_cpu_seconds"] == 0.0  # T cancels from the factored target: not fitted by default
    expected = (r["setup_seconds"] + r["algo_seconds"] * 5) / (r["bc_seconds"] * 5)  # budget = 5 blocks
    assert r["total_ratio"] == pytest.approx(expected, rel=0.05, abs=0.01)
    assert r["policy_update_ratio"] == pytest.approx(r["algo_seconds"] / r["bc_seconds"], rel=0.05)
    with pytest.raises(ValueError, match="algo: expected one of"):
        measure_speed("CartPole-v1", cartpole_data, algo="nope")


def test_parse_variants_checks_each_entry():
    from benchmarks.harness.curves import parse_variants

    assert parse_variants('{"a": ["mbil", {"alpha": 0.1}]}') == {"a": ("mbil", {"alpha": 0.1})}
    for bad, field in (("{", "variants"), ("[]", "variants"), ('{"a": ["ppo", {}]}', "variants['a']"),
                       ('{"a": ["bc"]}', "variants['a']")):
        with pytest.raises(ValueError, match=re.escape(field)):
            parse_variants(bad)


def test_flow_report_trains_and_reports_the_balance_split():
    import json
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    tiny = json.dumps({**TINY_FLOWS, "policy_kwargs": "dict(net_arch=[16])"})
    out = subprocess.run([sys.executable, "-m", "benchmarks.flow_report", "--env", "Hopper-v4", "--seed", "3", "--updates", "10", "30",
                          "--set", tiny, "--eval-episodes", "1"], cwd=repo, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    points = [json.loads(line) for line in out.stdout.splitlines() if line.startswith('{"updates"')]
    assert [p["updates"] for p in points] == [10, 30]
    assert all(p["mean_shift_nats"] >= 0 and p["residual_mse"] >= 0 for p in points)
    bad = subprocess.run([sys.executable, "-m", "benchmarks.flow_report", "--env", "Hopper-v4", "--updates", "30", "10"], cwd=repo,
                         capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "--updates: expected increasing" in bad.stderr


def test_paired_table_compares_final_returns_on_shared_seeds():
    from benchmarks.harness.curves import final_returns, paired_table

    rows = [{"env": "E", "algo": a, "seed": s, "gradient_step": step, "mean_return": base + s + step / 1000}
            for a, base in (("bc", 100.0), ("mbil", 90.0)) for s in (0, 1, 2) for step in (1000, 2000)]
    rows += [{"env": "E", "algo": "mbil", "seed": 3, "gradient_step": 1000, "mean_return": 0.0}]  # no bc on seed 3
    assert final_returns(rows, last=1)[("E", "bc")][1] == (103.0, 2000)
    # mbil - bc = -10 on every shared seed: mean -10, standard error 0, below on 3 of 3
    assert "| E | mbil | 3 | 93 | -10 +- 0 | [-10, -10] | 3 of 3 |" in paired_table(rows, "bc", last=1)
    # differences -8, -10, -12: the t interval with 2 degrees of freedom, -10 +- 4.303 * 2 / sqrt(3)
    rows[6]["mean_return"] += 2.0  # mbil seed 0 at step 1000 ...
    rows[7]["mean_return"] += 2.0  # ... and 2000
    rows[10]["mean_return"] -= 2.0
    rows[11]["mean_return"] -= 2.0
    assert "| -10 +- 1 | [-15, -5] | 3 of 3 |" in paired_table(rows, "bc", last=1)


def test_curve_tables_name_a_single_seed_instead_of_a_spread():
    """One seed has no spread: the tables say so rather than print '+- 0' or '+- nan'."""
    from benchmarks.harness.curves import curve_table, paired_table

    rows = [{"env": "E", "algo": a, "seed": 0, "gradient_step": 1000, "mean_return": ret}
            for a, ret in (("bc", 100.0), ("odice", 40.0))]
    curves, paired = curve_table(rows, {"E": 100.0}, last=1), paired_table(rows, "bc", last=1)
    assert "| E | odice | 40 (one seed) | 0.40 |" in curves
    assert "| E | odice | 1 | 40 | -60 (one seed) | - | 1 of 1 |" in paired
    assert "nan" not in curves + paired


def test_run_curves_on_another_pool_of_the_env(tmp_path):
    """--pool draws from the given pool, records it in the settings column, and refuses another env's pool."""
    import subprocess
    import sys
    from pathlib import Path

    from sb3_mbil import load_demonstrations

    repo = Path(__file__).resolve().parents[2]
    pool = tmp_path / "cartpole-small.npz"
    load_demonstrations("CartPole-v1").sample(3, seed=0).save(pool)
    out = tmp_path / "curves.csv"
    cmd = [sys.executable, "-m", "benchmarks.run_curves", "--variants", '{"bc": ["bc", {}]}', "--seeds", "0", "--updates", "40",
           "--eval-every", "20", "--episodes", "2", "--csv", str(out), "--local"]
    ok = subprocess.run(cmd + ["--envs", "CartPole-v1", "--pool", str(pool)], cwd=repo, capture_output=True, text=True,
                        timeout=300)
    assert ok.returncode == 0, ok.stderr[-3000:]
    rows = rows_of(out)
    assert len(rows) == 2 and all(f"('expert_pool', '{pool}')" in r["settings"] for r in rows)
    # the table's expert is the given pool's mean return, not the shipped pool's
    mean = load_demonstrations(str(pool)).episode_returns.mean()
    assert f"expert = mean return of the pool {pool}: CartPole-v1 {mean:.1f}." in ok.stdout
    wrong = subprocess.run(cmd + ["--envs", "Acrobot-v1", "--pool", str(pool)], cwd=repo, capture_output=True, text=True,
                           timeout=300)
    assert wrong.returncode == 2 and "expected demonstrations of Acrobot-v1, found a pool of CartPole-v1" in wrong.stderr
    two = subprocess.run(cmd + ["--envs", "CartPole-v1", "Acrobot-v1", "--pool", str(pool)], cwd=repo, capture_output=True,
                         text=True, timeout=300)
    assert two.returncode == 2 and "expected one env" in two.stderr


def test_figure4_has_every_box_algorithm_and_runs_a_chosen_subset(tmp_path):
    import subprocess
    import sys
    from pathlib import Path

    from gymnasium import spaces

    from sb3_mbil import ALGORITHMS
    from benchmarks.harness.curves import FIGURE4_VARIANTS

    box = {name for name, algo in ALGORITHMS.items() if spaces.Box in algo.supported_action_spaces}
    assert box <= {algo for algo, _ in FIGURE4_VARIANTS.values()} and "odice" in box and "edm" not in box
    repo = Path(__file__).resolve().parents[2]
    out = tmp_path / "fig4.csv"
    cmd = [sys.executable, "-m", "benchmarks.run_curves", "--figure", "4", "--envs", "Hopper-v4", "--seeds", "0",
           "--updates", "20", "--eval-every", "10", "--episodes", "1", "--csv", str(out), "--local"]
    ok = subprocess.run(cmd + ["--only", "bc_wd1e-3", "bc"], cwd=repo, capture_output=True, text=True, timeout=300)
    assert ok.returncode == 0, ok.stderr[-3000:]
    assert sorted({r["algo"] for r in rows_of(out)}) == ["bc", "bc_wd1e-3"] and len(rows_of(out)) == 4
    bad = subprocess.run(cmd + ["--only", "edm"], cwd=repo, capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and "--only: expected variants among" in bad.stderr


def test_benchmarks_page_is_generated_from_the_result_files(tmp_path, monkeypatch):
    """BENCHMARKS.md comes from the CSVs: sections for the files that exist, paired CIs, the published check."""
    from benchmarks.harness import page

    rows = [{"algo": algo, "env": "CartPole-v1", "n_trajectories": 1, "seed": seed, "mean_return": ret + seed,
             "settings": "", "commit": "abc"}
            for algo, ret in (("bc", 170.0), ("mbil", 300.0)) for seed in range(4)]
    out = tmp_path / "results"
    out.mkdir()
    with open(out / "classic_control_published.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    monkeypatch.chdir(tmp_path)
    text = page.benchmarks_page(reps=50, notes=tmp_path / "none.md")
    assert "## Figure 3: the published protocol" in text and "8 runs from `results/classic_control_published.csv`" in text
    # its figure, written beside the CSV and linked from the page
    assert (out / "classic_control_published.png").read_bytes()[:4] == b"\x89PNG"
    assert "(results/classic_control_published.png)" in text
    assert "No results yet (`results/classic_control.csv` does not exist)" in text
    assert "| mbil | CartPole-v1 | 1 | 4 | +130.0 | [+130.0, +130.0] | 0 of 4 | above |" in text
    # BC at 171.5 on average against the published 170 at N=1: within 0.15 normalised
    assert "| bc | CartPole-v1 | 1 | 171.5 (4) | 170 |" in text and "Within 0.15 of the published value: 1 of 1" in text


def test_benchmarks_page_counts_the_iteration_dsfn_returned():
    """DSFN's rows say which pi_i it returned; the page counts them per cell, rows before the column apart."""
    from benchmarks.harness.page import returned_iterations

    rows = [{"algo": "dsfn", "env": "CartPole-v1", "n_trajectories": 1, "seed": s, "returned_iteration": it}
            for s, it in enumerate(["0", "2", "0", ""])]
    assert "| CartPole-v1 | 1 | i = 0: 2, i = 2: 1 | 1 |" in returned_iterations(rows)
    assert returned_iterations([{**r, "algo": "bc"} for r in rows]) == ""


def test_rows_name_a_dirty_commit_only_when_code_differs_not_the_results(tmp_path):
    """A running grid changes its own tracked CSV; that must not mark its rows' commit '-dirty', a code change must."""
    from benchmarks.harness.grid import git_commit

    def git(*args):
        subprocess.run(["git", *args], cwd=tmp_path, check=True, capture_output=True)

    git("init", "-q")
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "grid.csv").write_text("algo\n")
    (tmp_path / "code.py").write_text("x = 1\n")
    git("add", ".")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "first")
    clean = git_commit(tmp_path)
    assert re.fullmatch(r"[0-9a-f]{7,}", clean)
    (tmp_path / "results" / "grid.csv").write_text("algo\nbc\n")
    assert git_commit(tmp_path) == clean
    (tmp_path / "code.py").write_text("x = 2\n")
    assert git_commit(tmp_path) == clean + "-dirty"


def test_published_check_separates_an_algorithms_own_gap_from_the_gap_bc_shares():
    """'beyond BC': an algorithm off the published value by as much as our BC is (same seeds) has no gap of its own;
    one that moves relative to BC does."""
    from benchmarks.harness import page

    ours = {"bc": 70.0, "edm": 126.0, "rcal": 300.0}  # published 170, 226, 136: BC and EDM both 100 below
    rows = [{"algo": algo, "env": "CartPole-v1", "n_trajectories": 1, "seed": seed, "mean_return": ret}
            for algo, ret in ours.items() for seed in (0, 1)]
    rows.append({"algo": "bc", "env": "CartPole-v1", "n_trajectories": 1, "seed": 2, "mean_return": 70.0})
    text = page.published_check(rows)
    assert "| edm | CartPole-v1 | 1 | 126.0 (2) | 226 |" in text and "| -0.21 | +0.00 | [0.22, 0.22] | no |" in text
    rcal = next(line for line in text.splitlines() if line.startswith("| rcal |"))
    assert float(rcal.split("|")[9]) > 0.5  # (300 - 70) - (136 - 170), normalised
    assert "Of the 2 cells off by more (BC's own excluded), 1 are also more than 0.15 off beyond BC" in text
    # seeds that agree give a point interval, which holds no published value 100 away
    assert "Of the 3 cells off by more than 0.15, 0 hold the published value inside our 95% interval." in text


def test_curve_summary_tags_pair_two_files_with_the_same_variant_names(tmp_path):
    """--tags: BC of two backbones, in two files under the same name, paired seed by seed."""
    fields = ["algo", "env", "seed", "gradient_step", "mean_return", "n_episodes", "n_trajectories", "settings", "commit"]
    for name, base in (("new.csv", 300.0), ("old.csv", 100.0)):
        with open(tmp_path / name, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=fields)
            w.writeheader()
            for s in (0, 1, 2):
                w.writerow({"algo": "bc", "env": "CartPole-v1", "seed": s, "gradient_step": 500, "mean_return": base + s,
                            "n_episodes": 1, "n_trajectories": 1, "settings": "[('algo', 'bc')]", "commit": "abc"})
    cmd = [sys.executable, "-m", "benchmarks.curve_summary", "new.csv", "old.csv", "--last", "1"]
    out = subprocess.run(cmd + ["--tags", "new", "old", "--paired-against", "bc@old"], cwd=tmp_path, env=harness_env(),
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "| CartPole-v1 | bc@new | 3 | 301 | 200 +- 0 | [+200, +200] | 0 of 3 |" in out.stdout
    out = subprocess.run(cmd + ["--tags", "new"], cwd=tmp_path, env=harness_env(), capture_output=True, text=True, timeout=300)
    assert out.returncode != 0 and "--tags: expected one tag per CSV (2), found 1" in out.stderr


def test_rows_are_measured_against_the_pool_version_of_their_commit(monkeypatch):
    """Walker2d-v4's pool was regenerated: rows run on the first pool (including those run while it was on disk but
    not yet committed, commit 98c88f4) are measured against it, rows of today against the pool installed now."""
    from sb3_mbil import load_demonstrations
    from benchmarks.harness.pools import load_pool_version, pool_experts, pool_version

    monkeypatch.chdir(Path(__file__).resolve().parents[2])  # the checkout whose history holds the pools
    old = "e357c8b8c3c0f375d6926fb2cc9a0dba0d15b599"  # the first Walker2d-v4 pool, committed at 49a8ea7
    assert pool_version("Walker2d-v4", "98c88f4") == old and pool_version("Walker2d-v4", "e3d427e-dirty") == old
    assert pool_version("Walker2d-v4", "unknown") == "current" and pool_version("Hopper-v4", "e3d427e") == "current"
    first = load_pool_version("Walker2d-v4", old)
    assert abs(first.episode_returns.mean() - 4024.4) < 0.1 and first.metadata["pool"] == "Walker2d-v4@e357c8b8c3"
    row = {"env": "Walker2d-v4", "settings": "[('algo', 'bc')]"}
    assert pool_experts([{**row, "commit": "e3d427e"}])["Walker2d-v4"] == pytest.approx(first.episode_returns.mean())
    now = load_demonstrations("Walker2d-v4").episode_returns.mean()
    assert pool_experts([{**row, "commit": "unknown"}])["Walker2d-v4"] == pytest.approx(now)
    with pytest.raises(ValueError, match="one version of the pool per env"):
        pool_experts([{**row, "commit": "e3d427e"}, {**row, "commit": "unknown"}])


def test_fall_report_finds_where_a_clone_leaves_the_expert_states(tmp_path):
    """The distance to the nearest training state is in units of the states' std; a clone has left at the first step
    from which it stays above the threshold for `patience` steps; the script appends one row per episode and resumes."""
    import numpy as np

    from benchmarks.harness.falls import left_at, nearest_distance

    reference = np.array([[0.0, 0.0], [2.0, 0.0]])
    d = nearest_distance(np.array([[0.0, 0.0], [2.0, 2.0], [1.0, 0.0]]), reference, scale=np.array([1.0, 2.0]))
    np.testing.assert_allclose(d, [0.0, np.sqrt(0.5), np.sqrt(0.5)])  # (0, 1) and (1, 0) in std units, RMS over 2
    assert left_at(np.array([0, 2, 0, 2, 2, 2, 0]), threshold=1.0, patience=3) == 3
    assert left_at(np.array([0, 2, 2, 0]), threshold=1.0, patience=3) is None

    out = tmp_path / "falls.csv"
    cmd = [sys.executable, "-m", "benchmarks.fall_report", "--envs", "Hopper-v4", "--seeds", "100", "--updates", "20",
           "--episodes", "2", "--csv", str(out)]
    first = subprocess.run(cmd, capture_output=True, text=True, env=harness_env())
    assert first.returncode == 0, first.stderr
    rows = rows_of(out)
    assert len(rows) == 2 and {r["episode"] for r in rows} == {"0", "1"}
    assert all(int(r["length"]) >= 1 and r["fell"] in ("True", "False") for r in rows)
    assert "| Hopper-v4 | bc | 100 | 2 |" in first.stdout
    again = subprocess.run(cmd, capture_output=True, text=True)  # finished: nothing reruns
    assert again.returncode == 0 and len(rows_of(out)) == 2


def test_transition_report_measures_what_the_action_changes_in_t():
    from benchmarks.harness.dynamics import diagnostics_table, transition_diagnostics

    row = transition_diagnostics("Hopper-v4", 100, {"model_labels": "corrective", "residual_transition": True,
                                                   "model_max_steps": 50})
    assert row["residual_transition"] and row["step"] > 0 and row["error"] > 0 and row["action_effect"] > 0
    kept, tried = (int(x) for x in row["labels_kept"].split(" of "))
    assert tried == 4 * 999 and 0 <= kept <= tried  # n_model_states draws per tuple of the 1000-step trajectory
    assert "| Hopper-v4 | 100 | True |" in diagnostics_table([row])
    with pytest.raises(ValueError, match="alpha_model > 0"):
        transition_diagnostics("Hopper-v4", 100, {"alpha_model": 0.0})


def test_whole_run_speed_rows_split_each_run_and_pair_it_with_bc(tmp_path):
    from benchmarks.speed_whole_run import COLUMNS, SPLIT, main

    out = tmp_path / "speed.csv"
    main(["--env", "CartPole-v1", "--n-trajectories", "1", "--variants", "mbil_c", "--repeats", "1", "--steps", "30",
          "--episodes", "2", "--csv", str(out)])
    rows = rows_of(out)
    assert [r["variant"] for r in rows] == ["bc", "mbil_c"] and list(rows[0]) == COLUMNS
    assert all(float(r[k]) >= 0 for r in rows for k in SPLIT) and float(rows[1]["fit_s"]) > 0
    assert float(rows[0]["ratio_cpu"]) == 1.0 and int(rows[1]["steps"]) == 30
