"""Do batched products round like a single layer? For S stacked layers (S x N x in -> out over 144 shapes), count the
slices whose forward or gradients differ bit for bit from ``torch.nn.functional.linear`` on that slice alone: a batched
``baddbmm`` forward, a batched ``bmm`` weight gradient, and the package's ``StackedLinear`` (per-slice products), the
reason lockstep seeds take their products one by one.

    python -m benchmarks.probe_stacked_linear
"""

from __future__ import annotations

import itertools

import torch as th

from sb3_mbil.common.policies import StackedLinear


def main() -> None:
    th.manual_seed(0)
    th.set_num_threads(1)
    counts = {"baddbmm forward": 0, "bmm weight gradient": 0, "StackedLinear (all outputs and gradients)": 0}
    slices = 0
    for s, n, n_in, n_out in itertools.product([2, 3, 10], [64, 128], [3, 4, 8, 11, 17, 64], [1, 2, 4, 64]):
        weight = th.randn(s, n_out, n_in, requires_grad=True)
        bias = th.randn(s, n_out, requires_grad=True)
        x = th.randn(s, n, n_in, requires_grad=True)
        grad = th.randn(s, n, n_out)
        y = StackedLinear.apply(x, weight, bias)
        y.backward(grad)
        batched_forward = th.baddbmm(bias.detach().unsqueeze(1), x.detach(), weight.detach().transpose(1, 2))
        batched_weight_grad = th.bmm(grad.transpose(1, 2), x.detach())
        for i in range(s):
            w = weight[i].detach().clone().requires_grad_()
            b = bias[i].detach().clone().requires_grad_()
            xi = x[i].detach().clone().requires_grad_()
            yi = th.nn.functional.linear(xi, w, b)
            yi.backward(grad[i])
            slices += 1
            counts["baddbmm forward"] += not th.equal(batched_forward[i], yi.detach())
            counts["bmm weight gradient"] += not th.equal(batched_weight_grad[i], w.grad)
            counts["StackedLinear (all outputs and gradients)"] += not (
                th.equal(y[i].detach(), yi.detach()) and th.equal(weight.grad[i], w.grad)
                and th.equal(bias.grad[i], b.grad) and th.equal(x.grad[i], xi.grad))
    for name, count in counts.items():
        print(f"{name}: {count} of {slices} slices differ")


if __name__ == "__main__":
    main()
