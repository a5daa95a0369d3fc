"""Why weight decay lowers our BC. The decay term lambda * theta against the loss gradient, per parameter
group, during training on one trajectory (benchmarks.weight_decay).

    python -m benchmarks.weight_decay_scale --env Hopper-v4 --seed 100 --updates 20000 --every 5000 \\
        --markdown results/tuning/weight_decay_scale.md
"""

import argparse

from benchmarks.harness.cli import check_output, emit, positive_int, run


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", default="Hopper-v4")
    p.add_argument("--seed", type=int, default=100, help="draw and initialisation (tuning seeds are >= 100)")
    p.add_argument("--n-trajectories", type=positive_int, default=1)
    p.add_argument("--updates", type=positive_int, default=20_000)
    p.add_argument("--every", type=positive_int, default=5_000)
    p.add_argument("--weight-decay", type=float, default=1e-3)
    p.add_argument("--markdown", default=None)
    p.add_argument("--overwrite", action="store_true", help="replace output files that are committed to git")
    a = p.parse_args(argv)
    check_output(a.markdown, a.overwrite, "--markdown")
    import torch as th

    from sb3_mbil import BC, load_demonstrations
    from benchmarks.harness.grid import git_commit, tuned_settings
    from benchmarks.weight_decay import GROUPS, decay_to_gradient

    th.set_num_threads(1)
    demos = load_demonstrations(a.env).sample(a.n_trajectories, seed=a.seed)
    lines = [f"`python -m benchmarks.weight_decay_scale --env {a.env} --seed {a.seed} --updates {a.updates} --every {a.every}"
             f" --weight-decay {a.weight_decay}` at commit {git_commit()}: BC with the zoo's {a.env} settings, trained"
             f" with and without the decay; |lambda theta| / |grad L| per group on all expert pairs"
             f" (lambda = {a.weight_decay}). Above 1, Adam's step is mostly decay.\n",
             "| bc_loss | trained with decay | update | BC loss | " + " | ".join(f"{g}: grad / decay / ratio" for g in GROUPS) + " |",
             "|---|---|---|---|" + "---|" * len(GROUPS)]
    for loss in ("mse", "nll"):
        for wd in (0.0, a.weight_decay):
            settings = tuned_settings("bc", a.env, {"bc_loss": loss, "weight_decay": wd})
            settings.pop("n_timesteps")
            model = BC("MlpPolicy", a.env, expert_data=demos, seed=a.seed, **settings)
            for row in decay_to_gradient(model, a.updates, a.every, a.weight_decay):
                cells = [f"{row[g]['grad']:.3g} / {row[g]['decay']:.3g} / {row[g]['ratio']:.3g}" if g in row else ""
                         for g in GROUPS]
                lines.append(f"| {loss} | {wd > 0} | {row['update']} | {row['bc_loss']:.4g} | " + " | ".join(cells) + " |")
                print(lines[-1], flush=True)
    text = "\n".join(lines)
    emit(text, a.markdown)


if __name__ == "__main__":
    run(main)
