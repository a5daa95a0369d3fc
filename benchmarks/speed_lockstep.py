"""Seeds in lockstep against one after the other: a grid cell (algo, env, N, seeds) trained and evaluated both ways in
one run, the modes interleaved per algorithm, CPU time and wall time split into training (fits included) and
evaluation; the rows of the two modes compared (each seed's policy is bit for bit the same, so are its returns).

    python -m benchmarks.speed_lockstep --env LunarLander-v3 --algos bc mbil mbil_c --n-trajectories 1 \
        --seeds 0-9 --episodes 300 --csv results/speed_lockstep.csv
"""

from __future__ import annotations

import argparse
import time

from sb3_mbil.common.cli import parse_seeds, positive_int, run

COLUMNS = ["algo", "env", "n_trajectories", "seeds", "mode", "train_cpu_s", "eval_cpu_s", "total_cpu_s", "train_wall_s",
           "eval_wall_s", "same_returns", "mean_return", "commit"]


def measure(algo: str, env: str, n_trajectories: int, seeds: list[int], episodes: int, lockstep: bool) -> dict:
    """One cell's runs in one mode: seconds of training and of evaluation, and the seeds' mean returns."""
    import torch as th

    from benchmarks.harness.grid import Run, _build, _data, _result_row
    from sb3_mbil import learn_lockstep

    th.set_num_threads(1)
    runs = [Run(algo, env, n_trajectories, s) for s in seeds]
    clock = {"train_cpu": 0.0, "train_wall": 0.0}

    def timed(fn):
        c, w = time.process_time(), time.perf_counter()
        out = fn()
        clock["train_cpu"] += time.process_time() - c
        clock["train_wall"] += time.perf_counter() - w
        return out

    if lockstep:
        def train_all():
            built = [_build(r, *_data(r, None, None, "full")) for r in runs]
            return learn_lockstep([m for m, _ in built], built[0][1])
        models = timed(train_all)
    else:
        models = []
        for r in runs:  # each built right before it trains, as the harness does
            def train_one(r=r):
                model, steps = _build(r, *_data(r, None, None, "full"))
                return model.learn(steps)
            models.append(timed(train_one))
    c, w = time.process_time(), time.perf_counter()
    rows = [_result_row(r, m, 0, 0.0, episodes, None, "", 20, None, "full") for r, m in zip(runs, models)]
    return {"train_cpu_s": clock["train_cpu"], "train_wall_s": clock["train_wall"],
            "eval_cpu_s": time.process_time() - c, "eval_wall_s": time.perf_counter() - w,
            "returns": [row["mean_return"] for row in rows]}


def main(argv=None) -> None:
    from benchmarks.harness.grid import git_commit
    from benchmarks.harness.cli import check_appendable
    from benchmarks.harness.results import append_row

    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", default="LunarLander-v3")
    p.add_argument("--algos", nargs="+", default=["bc", "mbil", "mbil_c"])
    p.add_argument("--n-trajectories", type=positive_int, default=1)
    p.add_argument("--seeds", type=parse_seeds, default=list(range(10)))
    p.add_argument("--episodes", type=positive_int, default=300)
    p.add_argument("--csv", default=None, help="CSV the rows are appended to")
    a = p.parse_args(argv)
    if a.csv:
        check_appendable(a.csv, "--csv")
    commit = git_commit()
    for algo in a.algos:
        result = {mode: measure(algo, a.env, a.n_trajectories, a.seeds, a.episodes, mode == "lockstep")
                  for mode in ("sequential", "lockstep")}
        same = result["sequential"]["returns"] == result["lockstep"]["returns"]
        for mode, r in result.items():
            row = {"algo": algo, "env": a.env, "n_trajectories": a.n_trajectories,
                   "seeds": f"{min(a.seeds)}-{max(a.seeds)}" if len(a.seeds) > 1 else str(a.seeds[0]), "mode": mode,
                   "train_cpu_s": round(r["train_cpu_s"], 1), "eval_cpu_s": round(r["eval_cpu_s"], 1),
                   "total_cpu_s": round(r["train_cpu_s"] + r["eval_cpu_s"], 1),
                   "train_wall_s": round(r["train_wall_s"], 1), "eval_wall_s": round(r["eval_wall_s"], 1),
                   "same_returns": same, "mean_return": round(sum(r["returns"]) / len(r["returns"]), 2),
                   "commit": commit}
            print(row, flush=True)
            if a.csv:
                append_row(a.csv, row, COLUMNS)
        seq, lock = result["sequential"], result["lockstep"]
        print(f"{algo}: training {seq['train_cpu_s'] / lock['train_cpu_s']:.2f}x, end to end "
              f"{(seq['train_cpu_s'] + seq['eval_cpu_s']) / (lock['train_cpu_s'] + lock['eval_cpu_s']):.2f}x faster in "
              f"lockstep (CPU); the same returns: {same}", flush=True)


if __name__ == "__main__":
    run(main)
