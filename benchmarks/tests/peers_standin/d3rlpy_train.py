"""A stand-in for benchmarks/peers/d3rlpy_train.py with the same command line and outputs, without d3rlpy: the
"policy" is a TorchScript linear classifier fitted by least squares on the exported draw (Discrete actions only)."""

import argparse
import json
import os

import numpy as np
import torch


class Linear(torch.nn.Module):
    def __init__(self, w, b):
        super().__init__()
        self.w = torch.nn.Parameter(torch.as_tensor(w, dtype=torch.float32))
        self.b = torch.nn.Parameter(torch.as_tensor(b, dtype=torch.float32))

    def forward(self, x):
        return torch.argmax(x @ self.w + self.b, dim=1)


p = argparse.ArgumentParser()
for flag in ("--data", "--out-dir", "--batch-size", "--learning-rate", "--steps", "--seed"):
    p.add_argument(flag)
p.add_argument("--hidden", nargs="+")
p.add_argument("--activation", choices=("relu", "elu"))
p.add_argument("--discrete", action="store_true")
p.add_argument("--standardize", action="store_true")
p.add_argument("--linear-decay", action="store_true")
p.add_argument("--weight-decay", type=float)
a = p.parse_args()
d = np.load(a.data)
assert d["terminals"].sum() + d["timeouts"].sum() == 1, "one episode, flagged once at its end"
x = np.c_[d["observations"], np.ones(len(d["observations"]))]
y = np.eye(int(d["actions"].max()) + 1)[d["actions"]]
coef = np.linalg.lstsq(x, y, rcond=None)[0]
os.makedirs(a.out_dir, exist_ok=True)
torch.jit.script(Linear(coef[:-1], coef[-1])).save(os.path.join(a.out_dir, "policy.pt"))
with open(os.path.join(a.out_dir, "fit.json"), "w") as f:
    json.dump({"fit_seconds": 0.5, "steps": int(a.steps), "d3rlpy": "stand-in", "algo": "LeastSquares"}, f)
