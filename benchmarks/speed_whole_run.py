"""Whole runs against BC's: each algorithm's 10 000-update run with its zoo settings on N trajectories of an env's
shipped pool, fit included (a fresh interpreter: imports, data, fit, updates; no evaluation), BC's the same way, in
turn within each repeat; CPU and wall seconds, each algorithm's ratio to the BC run of its repeat, and where each
run's time goes (imports, set-up, the models' fit, the policy updates, and with ``--episodes`` the evaluation).

    python -m benchmarks.speed_whole_run --env LunarLander-v3 --n-trajectories 1 15 --repeats 3 \\
        --csv results/speed_whole_run.csv

The variants: ``mbil`` (the paper's MBIL, factored estimator, its defaults), ``mbil+T`` (the same with
``fit_transition=True``, the cost of fitting T before it was skipped: T cancels from the factored target),
``mbil_fit1000`` (P's fit at up to 1 000 steps, the budget before ``flow_max_steps="auto"``) and ``mbil_c``. Every
run uses one torch thread. The ratio is per repeat (the same machine load), reported as medians.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

from benchmarks.harness.cli import REPO, check_appendable, harness_env, positive_int, run
from benchmarks.harness.grid import git_commit
from benchmarks.harness.results import append_rows

VARIANTS = {"bc": ("bc", {}), "mbil": ("mbil", {}), "mbil+T": ("mbil", {"fit_transition": True}),
            "mbil_fit1000": ("mbil", {"flow_max_steps": 1000}),
            "mbil_c": ("mbil_c", {})}
SPLIT = ["imports_s", "setup_s", "fit_s", "updates_s", "evaluation_s"]
COLUMNS = ["env", "n_trajectories", "repeat", "variant", "cpu_seconds", "wall_seconds", "bc_cpu_seconds",
           "ratio_cpu", "ratio_wall", "steps", *SPLIT, "note", "commit"]

CODE = """
import json, time
t0 = time.perf_counter()
import torch
torch.set_num_threads(1)
from benchmarks.harness.grid import tuned_settings
from sb3_mbil import ALGORITHMS, load_demonstrations
from sb3_mbil.common.evaluation import evaluate
t1 = time.perf_counter()
settings = tuned_settings({algo!r}, {env!r}, {extra!r})
steps = {steps} or int(float(settings.pop("n_timesteps")))
settings.pop("n_timesteps", None)
demos = load_demonstrations({env!r}).sample({n}, seed=0)
model = ALGORITHMS[{algo!r}]("MlpPolicy", {env!r}, expert_data=demos, seed=0, **settings)
t2 = time.perf_counter()
model.learn(steps)
t3 = time.perf_counter()
if {episodes}:
    evaluate(model, {env!r}, {episodes}, seed=1_000_000, n_envs=20)
t4 = time.perf_counter()
fit = float(model.diagnostics().get("fit_seconds") or 0.0)
print(json.dumps(dict(steps=steps, imports_s=t1 - t0, setup_s=t2 - t1, fit_s=fit, updates_s=t3 - t2 - fit,
                      evaluation_s=t4 - t3)))
"""


def timed(variant: str, env: str, n: int, episodes: int = 0, steps: int | None = None) -> tuple[float, float, dict]:
    """CPU and wall seconds of one whole run in a fresh interpreter, and its split: imports, data and model set-up,
    the models' fit (as the algorithm reports it), the policy updates and, with ``episodes``, the evaluation."""
    algo, extra = VARIANTS[variant]
    code = CODE.format(algo=algo, env=env, n=n, extra=extra, episodes=episodes, steps=steps)
    env_vars = harness_env(OMP_NUM_THREADS="1")
    t0, r0 = time.perf_counter(), os.times()
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env_vars, cwd=REPO)
    wall, r1 = time.perf_counter() - t0, os.times()
    if out.returncode != 0:
        raise RuntimeError(f"{variant} on {env} N={n}: {out.stderr.strip().splitlines()[-1]}")
    cpu = (r1.children_user - r0.children_user) + (r1.children_system - r0.children_system)
    return cpu, wall, json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", default="LunarLander-v3")
    p.add_argument("--n-trajectories", type=positive_int, nargs="+", default=[1, 15])
    p.add_argument("--variants", nargs="+", default=["mbil", "mbil+T", "mbil_c"], choices=[v for v in VARIANTS if v != "bc"])
    p.add_argument("--repeats", type=positive_int, default=3)
    p.add_argument("--episodes", type=int, default=0, help="also evaluate each run on this many episodes (its split)")
    p.add_argument("--steps", type=positive_int, default=None, help="updates per run (default: the zoo settings')")
    p.add_argument("--csv", default=None)
    p.add_argument("--note", default="", help="what else ran on the machine (recorded in each row)")
    a = p.parse_args(argv)
    if a.csv:
        check_appendable(a.csv, "--csv")
    commit = git_commit()
    summary: dict[tuple[int, str], list[float]] = {}
    for n in a.n_trajectories:
        for repeat in range(a.repeats):
            order = ["bc", *a.variants] if repeat % 2 == 0 else [*a.variants[::-1], "bc"]  # alternate the order
            times = {v: timed(v, a.env, n, a.episodes, a.steps) for v in order}
            bc_cpu, bc_wall, _ = times["bc"]
            rows = []
            for v in ["bc", *a.variants]:
                cpu, wall, split = times[v]
                rows.append({"env": a.env, "n_trajectories": n, "repeat": repeat, "variant": v,
                             "cpu_seconds": round(cpu, 2), "wall_seconds": round(wall, 2), "bc_cpu_seconds": round(bc_cpu, 2),
                             "ratio_cpu": round(cpu / bc_cpu, 3), "ratio_wall": round(wall / bc_wall, 3),
                             "steps": split["steps"], **{k: round(split[k], 2) for k in SPLIT},
                             "note": a.note, "commit": commit})
                if v != "bc":
                    summary.setdefault((n, v), []).append(cpu / bc_cpu)
                print(json.dumps(rows[-1]), flush=True)
            if a.csv:
                append_rows(a.csv, rows, COLUMNS)
    for (n, v), ratios in sorted(summary.items()):
        print(f"N={n} {v}: median CPU ratio to BC {statistics.median(ratios):.2f} over {len(ratios)} repeats")


if __name__ == "__main__":
    run(main)
