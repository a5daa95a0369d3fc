"""Do batched products round like a single layer? For S stacked layers (S x N x in -> out over 144 shapes), count the
slices whose forward or gradients differ bit for bit from ``torch.nn.functional.linear`` on that slice alone: a batched
``baddbmm`` forward, a batched ``bmm`` weight gradient, and the package's ``StackedLinear`` (per-slice products), the
reason lockstep seeds take their products one by one. Then Adam (single-tensor, foreach, fused; with and without
weight decay) on S stacked tensors against the per-model single-tensor Adam over 100 random steps, and BC's NLL as
torch's fused cross-entropy against -mean(log_softmax gathered) (the gradients over 2 000 random cases).

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
    adam()
    cross_entropy()


def adam(s: int = 10, steps: int = 100) -> None:
    shapes = [(64, 8), (64,), (64, 64), (64,), (4, 64), (4,)]
    for kind in ({"foreach": False}, {"foreach": True}, {"fused": True}):
        for weight_decay in (0.0, 1e-3):
            th.manual_seed(0)
            stacked = [th.randn(s, *shape) for shape in shapes]
            separate = [[p[i].clone() for p in stacked] for i in range(s)]  # per model, the runs' Adam
            same_kind = [[p[i].clone() for p in stacked] for i in range(s)]  # per model, this kind of Adam
            optimiser = th.optim.Adam(stacked, lr=1e-3, weight_decay=weight_decay, **kind)
            per_model = [th.optim.Adam(params, lr=1e-3, weight_decay=weight_decay) for params in separate]
            per_model_kind = [th.optim.Adam(params, lr=1e-3, weight_decay=weight_decay, **kind) for params in same_kind]
            for _ in range(steps):
                grads = [th.randn(s, *shape) for shape in shapes]
                for p, g in zip(stacked, grads):
                    p.grad = g.clone()
                optimiser.step()
                for models, optimisers in ((separate, per_model), (same_kind, per_model_kind)):
                    for i in range(s):
                        for p, g in zip(models[i], grads):
                            p.grad = g[i].clone()
                        optimisers[i].step()
            def verdict(models):
                same = all(th.equal(stacked[k][i], models[i][k]) for i in range(s) for k in range(len(shapes)))
                return "the same bits as" if same else "differs from"
            print(f"Adam {kind} weight_decay={weight_decay:g} on {s} stacked models: {verdict(separate)} per-model "
                  f"single-tensor Adam, {verdict(same_kind)} the same kind per model, after {steps} steps")


def cross_entropy(cases: int = 2000) -> None:
    th.manual_seed(0)
    loss_differs = grad_differs = 0
    for t in range(cases):
        k, n = (2, 3, 4)[t % 3], (32, 64, 128)[t % 3]
        logits = th.randn(n, k, requires_grad=True)
        actions = th.randint(0, k, (n,))
        written = -th.log_softmax(logits, -1).gather(1, actions.view(-1, 1)).squeeze(1).mean()
        fused = th.nn.functional.cross_entropy(logits, actions)
        loss_differs += not th.equal(written, fused)
        grad_differs += not th.equal(th.autograd.grad(written, logits)[0], th.autograd.grad(fused, logits)[0])
    print(f"cross-entropy against the written-out NLL: the loss differs in {loss_differs}, the gradient in "
          f"{grad_differs} of {cases} cases")


if __name__ == "__main__":
    main()
