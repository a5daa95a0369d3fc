"""The stochastic-demonstrator study's choice of each algorithm's tuned variant (BC* and the others)."""

import pytest

from benchmarks.stochastic import best_variants


def rows(*entries):
    return [{"env": "CartPole-v1", "pool": "CartPole-v1-sampled", "n_trajectories": "3", "variant": v,
             "mean_return": str(r)} for v, r in entries]


def test_the_best_mean_wins_and_a_tie_goes_to_the_zoo_entry():
    tied = rows(("bc_es", 500.0), ("bc_es", 500.0), ("bc", 500.0), ("bc", 500.0), ("bc_wd0", 480.0), ("bc_wd0", 499.0),
                ("mbil_c_es", 500.0), ("mbil_c_es", 500.0), ("mbil_c_wd0.001", 500.0), ("mbil_c_wd0.001", 500.0))
    # BC: the zoo entry wins the tie at the ceiling whatever order the rows ran in; MBIL-C (no zoo entry among the
    # tied): the first to have run
    assert best_variants(tied, "CartPole-v1", "CartPole-v1-sampled", 3) == {"bc": "bc", "mbil_c": "mbil_c_es"}
    better = rows(("bc", 480.0), ("bc_es", 490.0))
    assert best_variants(better, "CartPole-v1", "CartPole-v1-sampled", 3) == {"bc": "bc_es"}
    # a variant with fewer finished seeds does not compete
    running = rows(("bc", 400.0), ("bc", 400.0), ("bc_es", 500.0))
    assert best_variants(running, "CartPole-v1", "CartPole-v1-sampled", 3) == {"bc": "bc"}
    assert best_variants(running, "CartPole-v1", "CartPole-v1-sampled", 1) == {}


def test_a_cell_in_lockstep_gives_each_seed_its_own_runs_row():
    from benchmarks.stochastic import Variant, run_cell, run_cell_lockstep

    cases = {"bc_es": Variant("bc", {"n_timesteps": 1000}, early_stop=True),
             "mbil_c_ens2": Variant("mbil_c", {"n_timesteps": 300, "model_max_steps": 30}, ensemble=2)}
    same = ("mean_return", "std_return", "best_step", "settings", "seed")
    for name, variant in cases.items():
        separate = [run_cell(name, variant, "CartPole-v1", "CartPole-v1-sampled", 1, seed, 3, "test") for seed in (0, 1)]
        lockstep = list(run_cell_lockstep(name, variant, "CartPole-v1", "CartPole-v1-sampled", 1, [0, 1], 3, "test"))
        assert [[r[c] for c in same] for r in lockstep] == [[r[c] for c in same] for r in separate]
        assert all((r["best_step"] in (500, 1000)) == (name == "bc_es") for r in lockstep)


def test_the_baselines_run_at_their_zoo_entries_seed_by_seed_and_join_the_grid_table():
    from benchmarks.stochastic import Variant, baseline_variants, run_cell, run_cell_lockstep
    from benchmarks.stochastic_report import grid_table

    assert set(baseline_variants("CartPole-v1")) == {"edm", "avril", "rcal", "dsfn", "iq_learn", "valuedice"}
    variant = Variant("avril", {"n_timesteps": 200})  # AVRIL cannot train in lockstep: its seeds run one by one
    cell = run_cell_lockstep("avril", variant, "CartPole-v1", "CartPole-v1-sampled", 1, [0, 1], 3, "test")
    first = next(cell)  # a row as soon as its seed has run
    separate = run_cell("avril", variant, "CartPole-v1", "CartPole-v1-sampled", 1, 0, 3, "test")
    assert first["mean_return"] == separate["mean_return"] and first["seed"] == 0
    rows = [first, *cell]
    assert [r["seed"] for r in rows] == [0, 1]
    bc = [{**r, "variant": "bc", "algo": "bc", "mean_return": r["mean_return"] - 1.0} for r in rows]
    table = grid_table([{k: str(v) for k, v in r.items()} for r in bc + rows], {})
    assert "| AVRIL | 2 |" in table and "+1.0" in table


def test_learning_curves_in_lockstep_are_each_seeds_own_and_an_ensembles_is_scored_as_one():
    import json

    import pytest

    from benchmarks.stochastic import Curve, EnsemblePolicy, Variant, run_cell, run_cell_lockstep, train_variant
    from sb3_mbil.common.evaluation import evaluate

    curve = Curve(every=200, episodes=3)
    single = Variant("bc", {"n_timesteps": 600})
    lockstep = list(run_cell_lockstep("bc", single, "CartPole-v1", "CartPole-v1-sampled", 1, [0, 1], 3, "t", curve))
    separate = [run_cell("bc", single, "CartPole-v1", "CartPole-v1-sampled", 1, s, 3, "t", curve) for s in (0, 1)]
    assert [r["curve"] for r in lockstep] == [r["curve"] for r in separate]
    assert [p[0] for p in json.loads(lockstep[0]["curve"])] == [200, 400, 600]

    ensemble = Variant("bc", {"n_timesteps": 400}, ensemble=2)
    from benchmarks.stochastic import draw, train_variant_lockstep

    policy, _ = train_variant_lockstep(ensemble, "CartPole-v1", {5: draw("CartPole-v1", "CartPole-v1-sampled", 1, 5)},
                                       curve)[5]
    assert isinstance(policy, EnsemblePolicy) and [p[0] for p in policy.curve] == [200, 400]
    final = evaluate(policy, "CartPole-v1", 3, seed=2_000_000 + 5_000, n_envs=3)  # the last point: the final ensemble
    assert policy.curve[-1][1] == round(float(final.mean()), 2)
    with pytest.raises(ValueError, match="curve"):
        train_variant(ensemble, "CartPole-v1", draw("CartPole-v1", "CartPole-v1-sampled", 1, 5), 5, curve)


def test_the_page_shows_figure_4_from_the_curves_rows(tmp_path):
    import json

    from benchmarks.harness.results import append_rows
    from benchmarks.stochastic import CURVE_COLUMNS
    from benchmarks.stochastic_report import plot_curves, sections, load_curves

    rows = [{"variant": v, "algo": v, "env": "CartPole-v1", "pool": "CartPole-v1-sampled", "n_trajectories": 1,
             "seed": s, "mean_return": r + s, "std_return": 0.0, "n_episodes": 100, "train_seconds": 1.0,
             "best_step": "", "settings": "{}", "commit": "t", "curve": json.dumps([[500, r - 50], [1000, r + s]])}
            for v, r in (("bc", 400.0), ("mbil", 420.0)) for s in range(3)]
    append_rows(tmp_path / "curves_CartPole-v1.csv", rows, CURVE_COLUMNS)
    page = sections(str(tmp_path))
    assert "| MBIL | 3 | 421.0 |" in page and "+20.0" in page and "stochastic_curves.png" in page
    # the curves' shape: the mean curve's peak (its update), and its means over the first and the last fifth
    assert "| CartPole-v1, N = 1 | BC | 3 | 401 (1000) | 350 | 401 |" in page
    plot_curves(load_curves(str(tmp_path)), {}, str(tmp_path / "curves.png"))
    assert (tmp_path / "curves.png").stat().st_size > 1000

    # the MuJoCo envs' Figure 4: the grid's one-trajectory runs that recorded their curve (rows without one stay out)
    grid = tmp_path / "grid"
    hopper = [{**r, "env": "Hopper-v4", "pool": "Hopper-v4-sampled"} for r in rows]
    probe = {**hopper[0], "variant": "bc_nll_5k"}  # a probe's curve is drawn and tabled, not counted as planned
    append_rows(grid / "Hopper-v4.csv", [*hopper, {**hopper[0], "n_trajectories": 3, "curve": ""}, probe],
                CURVE_COLUMNS)
    assert len(load_curves(str(grid))) == len(rows) + 1
    page = sections(str(grid))
    assert "| MBIL | 3 | 421.0 |" in page
    # what has run: Hopper-v4's 6 grid rows at N = 1 (all with curves: Figure 4) and 1 at N = 3, waiting on tuning
    assert "| Hopper-v4 | shipped | 0/63 / 0/63 / 0/63 / 0/63 / 0/63 | 6/? / 1/? / 0/? / 0/? / 0/? |" in page
    assert "| 0/30 / 0/30 / 0/30 / 0/30 / 0/30 | 6/? | 0/? |" in page


def test_curves_go_only_to_a_file_that_keeps_them(tmp_path):
    import pytest

    from benchmarks.harness.results import append_rows
    from benchmarks.stochastic import COLUMNS, Curve, run

    old = tmp_path / "CartPole-v1.csv"
    append_rows(old, [{c: "x" for c in COLUMNS}], COLUMNS)
    with pytest.raises(ValueError, match="csv: expected a file with a 'curve' column"):
        run(["bc"], "CartPole-v1", ["CartPole-v1-sampled"], [1], [0], 3, str(old), curve=Curve(100, 2))


def test_a_lockstep_run_resumes_with_the_seeds_that_have_no_row(tmp_path, monkeypatch):
    import benchmarks.stochastic as study
    from benchmarks.harness.results import append_rows

    csv_path = tmp_path / "CartPole-v1.csv"
    ran = []

    def fake_cell(name, variant, env_id, pool, n, seeds, n_episodes, commit, curve):
        ran.append((name, n, list(seeds)))
        for seed in seeds:
            yield {c: "x" for c in study.CURVE_COLUMNS} | {"variant": name, "env": env_id, "pool": pool,
                                                            "n_trajectories": n, "seed": seed, "mean_return": 1.0,
                                                            "train_seconds": 0.0}

    monkeypatch.setattr(study, "run_cell_lockstep", fake_cell)
    done = {c: "x" for c in study.CURVE_COLUMNS} | {"variant": "bc", "env": "CartPole-v1", "pool": "CartPole-v1-sampled",
                                                     "n_trajectories": 1, "seed": 1}
    append_rows(csv_path, [done], study.CURVE_COLUMNS)
    args = (["bc", "mbil"], "CartPole-v1", ["CartPole-v1-sampled"], [1, 3], [0, 1, 2], 3, str(csv_path))
    study.run(*args, lockstep=True)
    assert ran == [("bc", 1, [0, 2]), ("mbil", 1, [0, 1, 2]), ("bc", 3, [0, 1, 2]), ("mbil", 3, [0, 1, 2])]
    ran.clear()
    study.run(*args, lockstep=True)  # everything has its row now
    assert ran == []


def test_a_lockstep_cell_trains_in_groups_of_at_most_lockstep_models_models(tmp_path, monkeypatch):
    import benchmarks.stochastic as study

    ran = []

    def fake_cell(name, variant, env_id, pool, n, seeds, n_episodes, commit, curve):
        ran.append((name, list(seeds)))
        return iter(())

    monkeypatch.setattr(study, "run_cell_lockstep", fake_cell)
    args = (["bc", "bc_ens5"], "CartPole-v1", ["CartPole-v1-sampled"], [1], [0, 1, 2, 3, 4], 3,
            str(tmp_path / "CartPole-v1.csv"))
    study.run(*args, lockstep=True, lockstep_models=4)
    # four single models a group; an ensemble of five is more than four models: one seed a group
    assert ran == [("bc", [0, 1, 2, 3]), ("bc", [4]), *[("bc_ens5", [s]) for s in range(5)]]
    ran.clear()
    study.run(*args, lockstep=True, lockstep_models=10)
    assert ran == [("bc", [0, 1, 2, 3, 4]), ("bc_ens5", [0, 1]), ("bc_ens5", [2, 3]), ("bc_ens5", [4])]
    with pytest.raises(ValueError, match="lockstep_models"):
        study.run(*args, lockstep=True, lockstep_models=0)


def test_the_crossover_table_pairs_mbil_against_bc_star_and_against_bc():
    from benchmarks.stochastic_report import crossover_table

    pool = "benchmarks/pools/Hopper-v4-noise0.1.npz"
    offsets = {"bc": 0.0, "bc_ens5": 10.0, "mbil": 30.0, "mbil_c": 10.0}
    rows = [{"env": "Hopper-v4", "pool": pool, "n_trajectories": "1", "variant": v, "seed": str(s),
             "mean_return": str(100.0 * s + offsets[v])} for v in offsets for s in range(5)]
    chosen = {("Hopper-v4", "Hopper-v4-sampled", 1): {"bc": "bc_ens5"}}
    line = next(x for x in crossover_table(rows, chosen).splitlines() if x.startswith("| 0.1 |"))
    *_, mbil_star, mbil_c_star, mbil_bc, mbil_c_bc, _ = line.split("|")
    # MBIL is 20 above BC* and 30 above BC on every seed, MBIL-C level with BC* and 10 above BC
    assert mbil_star.strip().startswith("+20.0") and mbil_bc.strip().startswith("+30.0")
    assert mbil_c_star.strip().startswith("+0.0") and mbil_c_bc.strip().startswith("+10.0")


def test_the_crossover_table_lists_a_setting_outside_its_columns_against_bc_star_and_bc():
    from benchmarks.stochastic_report import crossover_table

    pool = "benchmarks/pools/Walker2d-v4-noise0.1.npz"
    offsets = {"bc": 0.0, "bc_nll": 10.0, "mbil": 30.0, "mbil_c": 10.0, "mbil_alpha3": 50.0}
    rows = [{"env": "Walker2d-v4", "pool": pool, "n_trajectories": "1", "variant": v, "seed": str(s),
             "mean_return": str(100.0 * s + offsets[v])} for v in offsets for s in range(5)]
    chosen = {("Walker2d-v4", "Walker2d-v4-sampled", 1): {"bc": "bc_nll"}}
    lines = crossover_table(rows, chosen).splitlines()
    (other,) = [x for x in lines if x.startswith("- ")]
    assert other.startswith("- `mbil_alpha3` at noise 0.1: 250.0")
    assert "minus BC* (bc_nll) +40.0" in other and "minus BC +50.0" in other
    rows = [r for r in rows if r["variant"] != "mbil_alpha3"]
    assert not any(x.startswith("- ") for x in crossover_table(rows, chosen).splitlines())


def test_the_crossover_table_shows_the_demonstrators_own_return(tmp_path):
    from benchmarks.stochastic_report import crossover_table
    from sb3_mbil import load_demonstrations

    pool = "benchmarks/pools/Hopper-v4-noise0.1.npz"
    missing = str(tmp_path / "Hopper-v4-noise0.2.npz")  # a pool the page cannot read: its cell stays empty
    rows = [{"env": "Hopper-v4", "pool": p, "n_trajectories": "1", "variant": "bc", "seed": str(s),
             "mean_return": "1.0"} for p in (pool, missing) for s in range(2)]
    lines = crossover_table(rows, {}).splitlines()
    expected = float(load_demonstrations(pool).episode_returns.mean())
    assert next(x for x in lines if x.startswith("| 0.1 |")).split("|")[2].strip() == f"{expected:.1f}"
    assert next(x for x in lines if x.startswith("| 0.2 |")).split("|")[2].strip() == ""


def test_the_goal_scoreboard_counts_settings_above_and_below_bc_star():
    from benchmarks.stochastic_report import goal_table

    env, pool = "CartPole-v1", "CartPole-v1-sampled"
    chosen = {(env, pool, n): {"bc": "bc_es", "mbil": "mbil_ens5", "mbil_c": "mbil_c"} for n in (1, 3)}

    def rows(n, offsets, seeds=range(10)):
        return [{"env": env, "pool": pool, "n_trajectories": str(n), "variant": v, "seed": str(s),
                 "mean_return": str(10.0 * (s % 3) + offsets[v] + (-1) ** s * (v != "bc_es"))}
                for v in offsets for s in seeds]

    level = {"bc": 0.0, "bc_es": 5.0, "mbil": 5.0, "mbil_ens5": 5.0, "mbil_c": 5.0}
    above = {**level, "mbil_ens5": 25.0}
    below = {**level, "mbil_c": -20.0}
    text = goal_table(rows(1, above) + rows(3, above), chosen, envs=(env,))
    assert text.startswith("Settings: 2; finished: 2; above BC*: 2; below BC*: 0.") and "**met**" in text
    assert "= MBIL-C (its zoo entry is the best)" in text
    text = goal_table(rows(1, above) + rows(3, below), chosen, envs=(env,))
    assert "above BC*: 1; below BC*: 1." in text and "**missed (a setting is below BC*)**" in text
    text = goal_table(rows(1, above) + rows(3, level, seeds=range(5)), chosen, envs=(env,))
    assert "finished: 1; above BC*: 1; below BC*: 0." in text and "**not decided yet**" in text
    assert "| level (not finished) |" in text
    text = goal_table(rows(1, level) + rows(3, level), chosen, envs=(env,))
    assert "**missed (too few settings can still be above BC*)**" in text


def test_figure_4_draws_each_algorithms_tuned_variant_and_the_baselines_not_the_other_variants():
    from benchmarks.stochastic import variants_for
    from benchmarks.stochastic_report import curve_label

    grid = variants_for("Walker2d-v4")
    chosen = {"bc": "bc_nll", "mbil": "mbil_ens5", "mbil_c": "mbil_c_wd0.001"}
    labels = {name: curve_label(name, chosen, grid) for name in [*grid, "odice"]}
    assert {k: v for k, v in labels.items() if v is not None} == {
        "bc": "BC", "bc_nll": "BC* (bc_nll)", "mbil": "MBIL", "mbil_ens5": "MBIL* (mbil_ens5)", "mbil_c": "MBIL-C",
        "mbil_c_wd0.001": "MBIL-C* (mbil_c_wd0.001)", "odice": "ODICE"}
    # a zoo entry that is its algorithm's best is drawn once, under its own name
    assert curve_label("mbil", {"mbil": "mbil"}, grid) == "MBIL"


def test_a_probe_outside_the_tuning_grid_is_paired_against_the_family_and_never_becomes_bc_star():
    from benchmarks.stochastic import PROBES, all_variants, best_variants
    from benchmarks.stochastic_report import grid_table

    assert "bc_nll_5k" in all_variants("Walker2d-v4") and "bc_nll_5k" not in all_variants("CartPole-v1")
    assert PROBES["bc_nll_5k"].settings == {"bc_loss": "nll", "n_timesteps": 5000}
    base = {"env": "Walker2d-v4", "pool": "Walker2d-v4-sampled", "n_trajectories": "1", "curve": ""}
    means = {"bc": 700.0, "bc_nll": 1100.0, "mbil_c": 650.0, "mbil_c_wd0.001": 1700.0, "bc_nll_5k": 1600.0}
    rows = [{**base, "variant": v, "algo": v.split("_")[0], "seed": str(s), "mean_return": str(m + 10 * s)}
            for v, m in means.items() for s in range(3)]
    chosen = {("Walker2d-v4", "Walker2d-v4-sampled", 1): {"bc": "bc_nll", "mbil_c": "mbil_c_wd0.001"}}
    table = grid_table(rows, chosen)
    assert "(BC* = bc_nll)" in table and "| bc_nll_5k | 3 | 1610.0 | +500.0" in table
    probe = [line for line in table.splitlines() if line.startswith("Against bc_nll_5k")]
    assert len(probe) == 1 and "MBIL-C minus it -950.0" in probe[0] and "MBIL-C* (mbil_c_wd0.001) minus it +100.0" in probe[0]
    # tuning rows of a probe never make it a tuned variant: only the grid's names are picked
    tuning = [{**r, "seed": str(100 + int(r["seed"])),
               "mean_return": str(float(r["mean_return"]) + (5000 if r["variant"] == "bc_nll_5k" else 0))} for r in rows]
    assert best_variants(tuning, "Walker2d-v4", "Walker2d-v4-sampled", 1)["bc"] == "bc_nll"
