"""Fit MBIL's flows on N expert trajectories and print what the balance target looks like.

    python scripts/flow_report.py --env Hopper-v4 --n-trajectories 1 --seed 0

Uses the env's settings from zoo_hyperparams/mbil.yml; prints the held-out log-likelihoods, the
chosen noise levels and the distribution of the balance target log P(a' | s, a, s') over the tuples.
"""

import argparse
import json

import torch


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", required=True)
    p.add_argument("--n-trajectories", type=int, default=1)
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args(argv)
    torch.set_num_threads(1)
    from sb3_mbil import MBIL, load_demonstrations
    from sb3_mbil.benchmark.grid import tuned_settings

    settings = tuned_settings("mbil", a.env)
    settings.pop("n_timesteps", None)
    demos = load_demonstrations(a.env).sample(a.n_trajectories, seed=a.seed)
    model = MBIL("MlpPolicy", a.env, expert_data=demos, seed=a.seed, **settings)
    report = model.fit_flows()
    t = model.tuple_targets().numpy()
    summary = {
        "p_heldout_ll": report["p_heldout_ll"],
        "transition_heldout_ll": report["transition_heldout_ll"],
        "next_action": {k: report["next_action"][k] for k in ("noise", "steps", "heldout_ll", "train_ll")},
        "n_tuples": report["n_tuples"],
        "target": {"mean": float(t.mean()), "std": float(t.std()), "min": float(t.min()), "max": float(t.max())},
    }
    print(json.dumps(summary, indent=2))


if __name__ == "__main__":
    main()
