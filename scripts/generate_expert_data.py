"""Generate expert demonstrations with an RL Zoo agent.

    python scripts/generate_expert_data.py --env CartPole-v1 --n-trajectories 1000 --source hub --seed 0 \\
        --out sb3_mbil/data/CartPole-v1.npz

--source hub: the RL Zoo's agent on the Hugging Face Hub (falls back to zoo when unreachable);
--source zoo: train it locally with rl_zoo3's own hyperparameters; or a path to a saved model;
--source controller: the env's hand-written controller (sb3_mbil.experts.controllers; Pendulum-v1), an expert
that is not an RL agent:

    python scripts/generate_expert_data.py --env Pendulum-v1 --n-trajectories 100 --source controller \
        --out runs/pendulum_controller.npz
"""

import argparse
import logging
import shlex
import sys

import torch

from sb3_mbil.common.cli import check_output, finite_float, positive_int, run, seed


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", required=True, help="gymnasium env id")
    parser.add_argument("--n-trajectories", type=positive_int, required=True)
    parser.add_argument("--source", default="hub", help="hub | zoo | controller | PATH_TO_MODEL.zip")
    parser.add_argument("--seed", type=seed, default=0, help="episode i is reset with seed + i; zoo training seed")
    parser.add_argument("--out", required=True, help="output .npz (written atomically)")
    parser.add_argument("--algo", default=None, help="RL Zoo algorithm of the expert (default: the paper's for the env)")
    parser.add_argument("--min-return", type=finite_float, default=None, help="acceptance threshold (default: per env)")
    parser.add_argument("--eval-episodes", type=positive_int, default=100, help="episodes of the acceptance test")
    parser.add_argument("--sampled-actions", action="store_true",
                        help="record actions sampled from the expert's policy instead of its deterministic ones")
    parser.add_argument("--dqn-epsilon", type=finite_float, default=0.05,
                        help="with --sampled-actions, the epsilon of a DQN expert's epsilon-greedy sampling")
    parser.add_argument("--action-noise", type=finite_float, default=0.0,
                        help="a noisy demonstrator: noise on the deterministic action, executed and recorded (Discrete: "
                             "epsilon; Box: Gaussian sigma as a share of the action range, clipped)")
    parser.add_argument("--overwrite", action="store_true", help="replace output files that are committed to git")
    args = parser.parse_args(argv)
    check_output(args.out, args.overwrite, "--out")
    torch.set_num_threads(1)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    from sb3_mbil.experts import generate_demonstrations

    if args.source == "controller":
        from sb3_mbil.experts.controllers import controller_demonstrations

        demos = controller_demonstrations(args.env, args.n_trajectories, args.seed)
        path = demos.save(args.out)
        r = demos.episode_returns
        print(f"controller {demos.metadata['source']}: return {r.mean():.1f} +- {r.std():.1f} over {len(r)} "
              f"trajectories; wrote {path}")
        return
    demos, path = generate_demonstrations(
        args.env, args.n_trajectories, args.source, args.seed, args.out, args.algo, args.min_return, args.eval_episodes,
        sampled_actions=args.sampled_actions, action_noise=args.action_noise, dqn_epsilon=args.dqn_epsilon, command=shlex.join(["python", "scripts/generate_expert_data.py", *(argv if argv is not None else sys.argv[1:])]),
    )
    r, n = demos.episode_returns, demos.episode_lengths
    print(f"expert {demos.metadata['expert']['source']}: return {r.mean():.1f} +- {r.std():.1f}, "
          f"episode length {n.mean():.1f} +- {n.std():.1f} over {len(demos)} trajectories -> {path}")


if __name__ == "__main__":
    run(main)
