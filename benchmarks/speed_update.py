"""Cost of BC's update against a bare torch loop on the same network, batch and Adam (CPU time, one process, in
turn: BC, bare, BC, ...).

    python -m benchmarks.speed_update --updates 5000 --repeats 5 --csv results/speed_update.csv

Both train a 64-64 ReLU MLP with a categorical head on one CartPole-v1 trajectory (batch 64, Adam at 1e-3, no weight
decay), the bare loop being what a reader would write by hand: draw indices, cross-entropy, zero_grad, backward,
step. BC's ``learn`` adds what the bare loop has not: callbacks and the logger per step, the learning-rate
schedule, and the checks that the losses and parameters stay finite.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch as th
from torch import nn


def bare_loop(observations: th.Tensor, actions: th.Tensor, n_updates: int, seed: int) -> None:
    th.manual_seed(seed)
    net = nn.Sequential(nn.Linear(observations.shape[1], 64), nn.ReLU(), nn.Linear(64, 64), nn.ReLU(), nn.Linear(64, 2))
    optimizer = th.optim.Adam(net.parameters(), lr=1e-3)
    for _ in range(n_updates):
        idx = th.randint(0, len(observations), (64,))
        loss = nn.functional.cross_entropy(net(observations[idx]), actions[idx])
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--updates", type=int, default=5000)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--csv", default=None)
    a = p.parse_args(argv)
    th.set_num_threads(1)
    from sb3_mbil import BC, load_demonstrations
    from benchmarks.harness.grid import git_commit
    from benchmarks.harness.results import append_rows

    demos = load_demonstrations("CartPole-v1").sample(1, seed=0)
    pairs = demos.pairs()
    observations = th.as_tensor(pairs["observations"], dtype=th.float32)
    actions = th.as_tensor(pairs["actions"], dtype=th.long).view(-1)
    columns = ["updates", "repeat", "bc_us_per_update", "bare_us_per_update", "ratio", "commit"]
    commit, ratios = git_commit(), []
    for r in range(a.repeats):
        model = BC("MlpPolicy", "CartPole-v1", expert_data=demos, seed=r, batch_size=64, learning_rate=1e-3,
                   weight_decay=0.0)
        model.learn(10)  # the one-off set-up (data tensors, logger) outside the timing
        t0 = time.process_time()
        model.learn(a.updates, reset_num_timesteps=False)
        t1 = time.process_time()
        bare_loop(observations, actions, a.updates, seed=r)
        t2 = time.process_time()
        bc_us, bare_us = 1e6 * (t1 - t0) / a.updates, 1e6 * (t2 - t1) / a.updates
        ratios.append(bc_us / bare_us)
        row = {"updates": a.updates, "repeat": r, "bc_us_per_update": round(bc_us, 1),
               "bare_us_per_update": round(bare_us, 1), "ratio": round(ratios[-1], 4), "commit": commit}
        if a.csv:
            append_rows(a.csv, [row], columns)
        print(row, flush=True)
    print(f"BC's update / a bare loop's, median of {a.repeats} pairs: {np.median(ratios):.3f}")


if __name__ == "__main__":
    main()
