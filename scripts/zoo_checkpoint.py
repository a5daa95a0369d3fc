"""Carry a zoo expert training across machines whose cache starts empty: export its newest checkpoint (the model,
without the replay buffer) to a folder small enough to commit, and import it on the next machine, where
``generate_expert_data.py --source zoo`` then continues from it (an off-policy algorithm on a replay buffer refilled
by the checkpoint's own policy, --refill-steps transitions).

    python scripts/zoo_checkpoint.py export --env Ant-v4 --dir results/experts/sac-Ant-v4-seed0
    python scripts/zoo_checkpoint.py import --env Ant-v4 --dir results/experts/sac-Ant-v4-seed0
"""

import argparse
import logging

from sb3_mbil.common.cli import positive_int, run, seed


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("action", choices=("export", "import"))
    parser.add_argument("--env", required=True, help="gymnasium env id")
    parser.add_argument("--algo", default=None, help="RL Zoo algorithm (default: the env's expert's)")
    parser.add_argument("--seed", type=seed, default=0, help="the zoo run's training seed")
    parser.add_argument("--dir", required=True, help="folder of the carried checkpoint")
    parser.add_argument("--refill-steps", type=positive_int, default=50_000,
                        help="import: transitions of the checkpoint's policy in the refilled replay buffer (off-policy)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    from sb3_mbil.experts import EXPERTS, export_zoo_checkpoint, import_zoo_checkpoint

    algo = args.algo or (EXPERTS[args.env].algo if args.env in EXPERTS else None)
    if algo is None:
        raise ValueError(f"--algo: expected the RL Zoo algorithm of the expert for {args.env!r} (no default), found None")
    if args.action == "export":
        print(f"wrote {export_zoo_checkpoint(args.env, algo, args.dir, args.seed)}")
    elif import_zoo_checkpoint(args.env, algo, args.dir, args.seed, refill_steps=args.refill_steps):
        print(f"the next zoo training of {algo} on {args.env} (seed {args.seed}) continues from {args.dir}")
    else:
        print(f"nothing imported: no checkpoint in {args.dir}, or the cache already holds a run as far")


if __name__ == "__main__":
    run(main)
