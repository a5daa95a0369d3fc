"""Does the reference code's warm-start data explain the published DSFN curve?

The published DSFN (CKIL's figure; the values are in docs/benchmarks_notes.md) is far below ours on the same draws. DSFN's warm start in
dtak/batch-apprenticeship-learning (`src/core/data_util.py::GymDataset`, read by `src/model/bc.py::train_bc`) passes
the N trajectories through a `flatten` whose `return` sits inside its loop: only the first trajectory is copied, the
other N - 1 trajectories' rows stay zeros (observation 0, action 0), and BC trains on the first 70% of those rows.
This script runs our DSFN (its zoo settings, on the published grid's whole-trajectory draws) with its warm start on
exactly those rows, and everything after the warm start on the N trajectories as our DSFN does. Not copied: the
reference's apprenticeship stage reads every trajectory of its expert file, and its BC adds a next-state regulariser.

One row per run appended to --csv: DSFN's return, and the return of its warm-start classifier pi_0 (the policy DSFN
starts its iterations from) on the same evaluation seeds.

    python -m benchmarks.dsfn_reference_warm_start --envs CartPole-v1 Acrobot-v1 LunarLander-v3 --n-trajectories 1 3 15 \
        --seeds 0-1 --csv results/tuning/dsfn_reference_warm_start.csv
"""

import argparse

from benchmarks.harness.cli import parse_seeds, positive_int, run


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--envs", nargs="+", required=True)
    p.add_argument("--n-trajectories", type=positive_int, nargs="+", default=[1, 3, 15])
    p.add_argument("--seeds", type=parse_seeds, default=[0, 1], help="e.g. 0-1")
    p.add_argument("--episodes", type=positive_int, default=100)
    p.add_argument("--csv", required=True)
    a = p.parse_args(argv)
    import numpy as np
    import torch

    torch.set_num_threads(1)
    from benchmarks.harness.grid import git_commit, tuned_settings
    from benchmarks.harness.protocol import demonstrations_for
    from benchmarks.harness.results import append_row
    from sb3_mbil.common.evaluation import evaluate
    from sb3_mbil.common.type_aliases import PairSamples
    from sb3_mbil.dsfn.dsfn import DSFN

    def reference_rows(demos, train_fraction=0.7):
        """The reference's warm-start rows: the first trajectory, then zeros for the others; the first 70% kept."""
        first = demos.trajectories[0]
        n_rows = sum(len(t) for t in demos.trajectories)
        obs = np.zeros((n_rows, *first.observations.shape[1:]), dtype=np.float32)
        act = np.zeros(n_rows, dtype=np.int64)
        obs[: len(first)], act[: len(first)] = first.observations[: len(first)], first.actions
        keep = int(n_rows * train_fraction)
        return obs[:keep], act[:keep]

    class ReferenceWarmStartDSFN(DSFN):
        """DSFN whose warm start (its only reader of expert_pairs) trains on the reference's rows (set before learn)."""

        def expert_pairs(self):
            return PairSamples(self._to_tensor(self.reference_obs, "obs"), self._to_tensor(self.reference_act, "act"))

    commit = git_commit()
    for s in a.seeds:
        for env in a.envs:
            settings = tuned_settings("dsfn", env)
            steps = int(float(settings.pop("n_timesteps")))
            for n in a.n_trajectories:
                demos = demonstrations_for("dsfn", env, n, s, "published")
                model = ReferenceWarmStartDSFN("MlpPolicy", env, expert_data=demos, seed=s, **settings)
                model.reference_obs, model.reference_act = reference_rows(demos)
                model.learn(steps)
                dsfn_return = evaluate(model, env, a.episodes, seed=1_000_000 + s).mean()
                model.policy.load_state_dict(model.feature_net.state_dict())  # pi_0, the warm-start classifier
                warm_return = evaluate(model, env, a.episodes, seed=1_000_000 + s).mean()
                row = {"env": env, "n_trajectories": n, "seed": s, "warm_start_rows": len(model.reference_act),
                       "zero_rows": int((model.reference_obs == 0).all(1).sum()),
                       "dsfn_return": float(dsfn_return), "warm_start_return": float(warm_return),
                       "iterations": len(model.margins), "n_episodes": a.episodes, "commit": commit}
                append_row(a.csv, row, list(row))
                print(row, flush=True)


if __name__ == "__main__":
    run(main)
