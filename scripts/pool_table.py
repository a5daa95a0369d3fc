"""Print the provenance table of the shipped expert pools (markdown), from the pools' own metadata.

    python scripts/pool_table.py
"""

import os

from sb3_mbil import load_demonstrations
from sb3_mbil.common.cli import run
from sb3_mbil.common.demonstrations import POOL_DIR, available_pools


def main():
    print("| pool | expert source | expert acceptance (100 episodes) | seed | command | trajectories | return (mean +- std) | episode length | file size |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in available_pools():
        d = load_demonstrations(name)
        m, e = d.metadata, d.metadata["expert"]
        r, n = d.episode_returns, d.episode_lengths
        size = os.path.getsize(POOL_DIR / f"{name}.npz") / 2**20
        print(f"| {name} | {e['source']} | {e['eval_mean_return']:.1f} >= {e['min_return']:g} | {m['seed']} | `{m['command']}` | "
              f"{len(d)} | {r.mean():.1f} +- {r.std():.1f} | {n.mean():.1f} +- {n.std():.1f} | {size:.1f} MiB |")


if __name__ == "__main__":
    run(main)
