"""Where weight decay's slowdown comes from: subnormal floats. Trains one model (default: MBIL-C with weight decay
1e-3 on Walker2d-v4's sampled pool, one trajectory, tuning seed 100, the tuning grid's ``mbil_c_wd0.001``) and prints,
every ``--every`` updates, the seconds those updates took and how many parameters, gradients and Adam moments are
subnormal (non-zero, below 1.2e-38 in magnitude, where the CPU computes many times slower). ``learn`` flushes them to
zero unless ``SB3_MBIL_FLUSH_SUBNORMALS=0`` (:mod:`sb3_mbil.common.threads`); run it both ways to see the difference:

    SB3_MBIL_FLUSH_SUBNORMALS=0 python -m benchmarks.probe_subnormals --updates 12000
    SB3_MBIL_FLUSH_SUBNORMALS=1 python -m benchmarks.probe_subnormals --updates 12000
"""

from __future__ import annotations

import argparse
import time

import torch as th
from stable_baselines3.common.callbacks import BaseCallback

from benchmarks.harness.grid import tuned_settings
from benchmarks.stochastic import draw, variants_for
from sb3_mbil import ALGORITHMS

TINY = th.finfo(th.float32).tiny


def subnormal_counts(model) -> dict[str, int]:
    """Subnormal entries of the model's parameters, their gradients and its optimisers' state tensors."""
    modules = [model.policy] + [v for v in vars(model).values() if isinstance(v, th.nn.Module)]
    params = list({id(p): p for m in modules for p in m.parameters()}.values())
    optimizers = list(model._optimizers())
    for module in modules:
        for sub in module.modules():
            optimizers += [v for v in vars(sub).values()
                           if isinstance(v, th.optim.Optimizer) and all(v is not o for o in optimizers)]

    def count(t: th.Tensor) -> int:
        return int(((t != 0) & (t.abs() < TINY)).sum())

    return {
        "parameters": sum(count(p) for p in params),
        "gradients": sum(count(p.grad) for p in params if p.grad is not None),
        "optimizer state": sum(count(v) for o in optimizers for state in o.state.values() for v in state.values()
                               if th.is_tensor(v) and v.is_floating_point() and v.dim() > 0),
        "of parameters": sum(p.numel() for p in params),
    }


class SubnormalClock(BaseCallback):
    """Every ``every`` updates: the seconds since the last report and :func:`subnormal_counts`."""

    def __init__(self, every: int):
        super().__init__()
        self.every, self.rows = every, []
        self._t = time.perf_counter()

    def _on_step(self) -> bool:
        if self.num_timesteps % self.every == 0:
            now = time.perf_counter()
            row = {"updates": self.num_timesteps, "seconds": round(now - self._t, 2), **subnormal_counts(self.model)}
            print(row, flush=True)
            self.rows.append(row)
            self._t = now
        return True


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env", default="Walker2d-v4")
    parser.add_argument("--variant", default="mbil_c_wd0.001", help="a configuration of the tuning grid")
    parser.add_argument("--updates", type=int, default=12_000)
    parser.add_argument("--every", type=int, default=2_000)
    parser.add_argument("--seed", type=int, default=100)
    args = parser.parse_args(argv)
    table = variants_for(args.env)
    if args.variant not in table:
        raise ValueError(f"--variant: expected one of {sorted(table)}, found {args.variant!r}")
    if args.updates < 1 or args.every < 1:
        raise ValueError(f"--updates, --every: expected integers >= 1, found {args.updates}, {args.every}")
    variant = table[args.variant]
    settings = tuned_settings(variant.algo, args.env, variant.settings)
    settings.pop("n_timesteps")
    demos = draw(args.env, f"{args.env}-sampled", 1, args.seed)
    model = ALGORITHMS[variant.algo]("MlpPolicy", args.env, expert_data=demos, seed=args.seed, **settings)
    model.learn(args.updates, callback=SubnormalClock(args.every))


if __name__ == "__main__":
    main()
