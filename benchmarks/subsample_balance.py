"""What keeping every k-th step does to the actions a classifier sees (the published protocol).

An expert that acts in a rhythm (a CartPole controller alternating its pushes) can be sampled in phase by a fixed
stride: the kept steps then hold one action far more often than the trajectory does. Per pool: how often the
action k steps later equals the current one, against chance (the sum of the squared action shares), over all
trajectories of the pool; and, for the one-trajectory draws of seeds 0-4 (``sample(1, seed)``), the share of the
most frequent action in the whole trajectory and in its kept steps.

    python -m benchmarks.subsample_balance --markdown results/subsample_balance.md --overwrite
"""

import argparse

import numpy as np

from sb3_mbil import load_demonstrations
from benchmarks.harness.cli import check_output, emit, positive_int, run

POOLS = ["CartPole-v1", "Acrobot-v1", "LunarLander-v3", "CartPole-v1-ppo", "Acrobot-v1-dqn", "LunarLander-v3-dqn"]


def lag_agreement(actions: list[np.ndarray], lag: int) -> float:
    same = [a[:-lag] == a[lag:] for a in actions if len(a) > lag]
    return float(np.concatenate(same).mean())


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--pools", nargs="+", default=POOLS)
    p.add_argument("--every", type=positive_int, default=20, help="the stride of the published protocol")
    p.add_argument("--markdown", default=None)
    p.add_argument("--overwrite", action="store_true", help="replace output files that are committed to git")
    a = p.parse_args(argv)
    check_output(a.markdown, a.overwrite, "--markdown")
    k = a.every
    lines = [f"Action agreement at lag t -> t + lag over every trajectory of the pool, against chance; then the share of "
             f"the most frequent action in each one-trajectory draw (seeds 0-4) and in its kept steps (every {k}th, "
             f"from step 0).", "",
             f"| pool | lag 1 | lag 2 | lag {k} | chance | seed: whole trajectory -> kept steps (n kept) |", "|---|---|---|---|---|---|"]
    for name in a.pools:
        d = load_demonstrations(name)
        actions = [np.asarray(t.actions).astype(int) for t in d]
        shares = np.bincount(np.concatenate(actions)) / sum(len(x) for x in actions)
        draws = []
        for seed in range(5):
            draw = d.sample(1, seed=seed)  # the grid's draw, and its kept steps as the published protocol keeps them
            act = np.asarray(draw.pairs()["actions"]).astype(int)
            kept = np.asarray(draw.subsample(k).pairs()["actions"]).astype(int)
            top = int(np.bincount(act).argmax())
            draws.append(f"{seed}: {np.mean(act == top):.2f} -> {np.mean(kept == top):.2f} ({len(kept)})")
        lines.append(f"| {name} | {lag_agreement(actions, 1):.2f} | {lag_agreement(actions, 2):.2f} | "
                     f"{lag_agreement(actions, k):.2f} | {float(np.sum(shares ** 2)):.2f} | {'; '.join(draws)} |")
    emit("\n".join(lines) + "\n", a.markdown)


if __name__ == "__main__":
    run(main)
