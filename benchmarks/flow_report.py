"""Fit MBIL's flows on N expert trajectories and print what the balance target looks like; with
--updates, also train the policy and print how it meets the target (MBIL.balance_diagnostics) after
each of those numbers of gradient updates.

    python -m benchmarks.flow_report --env Hopper-v4 --n-trajectories 1 --seed 0
    python -m benchmarks.flow_report --env Hopper-v4 --seed 100 --updates 5000 20000 50000 --set '{"alpha": 0.01}'

Uses the env's settings from zoo_hyperparams/mbil.yml (--set overrides them); prints the held-out
log-likelihoods, the chosen noise levels and the distribution of the balance target
log P(a' | s, a, s') over the tuples.
"""

import argparse
import json

import torch

from benchmarks.harness.cli import positive_int, run, seed


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", required=True)
    p.add_argument("--n-trajectories", type=positive_int, default=1)
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument("--updates", type=positive_int, nargs="*", default=[], help="report after these cumulative gradient updates")
    p.add_argument("--set", default="{}", help="JSON settings overriding zoo_hyperparams/mbil.yml")
    p.add_argument("--eval-episodes", type=positive_int, default=10, help="episodes scored at each --updates point")
    a = p.parse_args(argv)
    try:
        overrides = json.loads(a.set)
    except json.JSONDecodeError as e:
        p.error(f"--set: expected a JSON object, found {a.set!r} ({e})")
    if not isinstance(overrides, dict):
        p.error(f"--set: expected a JSON object, found {a.set!r}")
    if sorted(a.updates) != a.updates or any(n <= 0 for n in a.updates):
        p.error(f"--updates: expected increasing positive numbers, found {a.updates}")
    torch.set_num_threads(1)
    import numpy as np

    from sb3_mbil import MBIL, load_demonstrations
    from benchmarks.harness.grid import tuned_settings
    from sb3_mbil.common.evaluation import evaluate

    settings = tuned_settings("mbil", a.env, overrides)
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
    done = 0
    for n in a.updates:
        model.learn(n - done, reset_num_timesteps=done == 0)
        done = n
        returns = evaluate(model, a.env, a.eval_episodes, seed=10_000 + a.seed)
        print(json.dumps({"updates": n, "mean_return": float(np.mean(returns)), **model.balance_diagnostics()}))


if __name__ == "__main__":
    run(main)
