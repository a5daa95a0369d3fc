"""Train d3rlpy's BC (Box) or DiscreteBC (Discrete) on one exported draw and export its policy as TorchScript.

Runs in the d3rlpy venv (benchmarks/peers/make_venv.sh), not in this package's: it imports numpy, torch and d3rlpy only.
The draw is an .npz of flat arrays (observations, actions, rewards, terminals, timeouts) written by
benchmarks.harness.peers.export_draw. Writes OUT_DIR/policy.pt (d3rlpy's save_policy) and OUT_DIR/fit.json (the
wall time of the updates alone, d3rlpy's version, the settings).

    .venv-d3rlpy/bin/python benchmarks/peers/d3rlpy_train.py --data draw.npz --out-dir out --discrete --hidden 64 64 \\
        --batch-size 64 --learning-rate 1e-3 --steps 10000 --seed 0
"""

import argparse
import dataclasses
import json
import os
import time

import d3rlpy
import numpy as np
import torch


@dataclasses.dataclass()
class VectorEncoderFactory(d3rlpy.models.encoders.VectorEncoderFactory):
    """d3rlpy's vector encoder, with ELU (our classic-control policies' activation, which d3rlpy does not offer) as a
    choice besides its own."""

    def create(self, observation_shape):
        if self.activation != "elu":
            return super().create(observation_shape)
        from d3rlpy.models.torch.encoders import VectorEncoder

        return VectorEncoder(observation_shape=tuple(observation_shape), hidden_units=self.hidden_units,
                             activation=torch.nn.ELU())

    @staticmethod
    def get_type() -> str:
        return "vector_with_elu"


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", required=True)
    p.add_argument("--out-dir", required=True)
    p.add_argument("--discrete", action="store_true")
    p.add_argument("--hidden", nargs="+", type=int, default=[64, 64])
    p.add_argument("--activation", choices=("relu", "elu"), default="relu", help="the hidden layers' activation")
    p.add_argument("--batch-size", type=int, default=64)
    p.add_argument("--learning-rate", type=float, default=1e-3)
    p.add_argument("--steps", type=int, default=10_000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--standardize", action="store_true", help="d3rlpy's StandardObservationScaler")
    p.add_argument("--weight-decay", type=float, default=0.0, help="Adam's L2 weight decay, as our BC's weight_decay")
    p.add_argument("--linear-decay", action="store_true",
                   help="decay the learning rate linearly to 0 over --steps (rl_zoo3's lin_<lr>, as our BC's zoo entry)")
    a = p.parse_args()
    torch.set_num_threads(1)
    d3rlpy.seed(a.seed)
    with np.load(a.data) as d:
        arrays = {k: d[k] for k in ("observations", "actions", "rewards", "terminals", "timeouts")}
    space = d3rlpy.constants.ActionSpace.DISCRETE if a.discrete else d3rlpy.constants.ActionSpace.CONTINUOUS
    dataset = d3rlpy.dataset.MDPDataset(**arrays, action_space=space,
                                        action_size=int(arrays["actions"].max()) + 1 if a.discrete else None)
    encoder = VectorEncoderFactory(hidden_units=a.hidden, activation=a.activation)
    scaler = d3rlpy.preprocessing.StandardObservationScaler() if a.standardize else None
    config_class = d3rlpy.algos.DiscreteBCConfig if a.discrete else d3rlpy.algos.BCConfig
    scheduler = None
    if a.linear_decay:
        from torch.optim.lr_scheduler import LinearLR

        @dataclasses.dataclass()
        class LinearDecayFactory(d3rlpy.optimizers.LRSchedulerFactory):
            total_steps: int

            def create(self, optim):  # update i runs at lr * (1 - i / total_steps), as SB3's progress schedule
                return LinearLR(optim, start_factor=1.0, end_factor=0.0, total_iters=self.total_steps)

            @staticmethod
            def get_type() -> str:
                return "linear_decay"

        scheduler = LinearDecayFactory(a.steps)
    optim = d3rlpy.optimizers.AdamFactory(weight_decay=a.weight_decay, lr_scheduler_factory=scheduler)
    algo = config_class(batch_size=a.batch_size, learning_rate=a.learning_rate, encoder_factory=encoder,
                        observation_scaler=scaler, optim_factory=optim).create(device=None)
    os.makedirs(a.out_dir, exist_ok=True)
    algo.build_with_dataset(dataset)  # the networks first: the timing below is the updates alone
    t0 = time.perf_counter()
    algo.fit(dataset, n_steps=a.steps, n_steps_per_epoch=a.steps, show_progress=False, save_interval=10**9,
             logger_adapter=d3rlpy.logging.NoopAdapterFactory())
    fit_seconds = time.perf_counter() - t0
    tmp = os.path.join(a.out_dir, "policy.tmp.pt")  # d3rlpy picks the format by the extension
    algo.save_policy(tmp)
    os.replace(tmp, os.path.join(a.out_dir, "policy.pt"))
    with open(os.path.join(a.out_dir, "fit.json"), "w") as f:
        json.dump({"fit_seconds": fit_seconds, "steps": a.steps, "d3rlpy": d3rlpy.__version__,
                   "algo": config_class.__name__, "hidden": a.hidden, "activation": a.activation, "batch_size": a.batch_size,
                   "learning_rate": a.learning_rate, "weight_decay": a.weight_decay, "linear_decay": a.linear_decay,
                   "standardize": a.standardize, "seed": a.seed}, f)


if __name__ == "__main__":
    main()
