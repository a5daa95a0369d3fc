"""Why weight decay lowers our BC: the size of the decay term against the loss's gradient.

Adam's ``weight_decay`` (what ``weight_decay=`` sets here) adds ``lambda * theta`` to each parameter's gradient before
Adam rescales it: the same as an L2 penalty ``lambda / 2 * |theta|^2`` in the loss. Adam divides every coordinate by
the running size of its gradient, so what matters is the *ratio* of the decay term to the loss gradient: where the
decay is the larger part, Adam's step mostly shrinks the weights, whatever the loss's own scale.
:func:`decay_to_gradient` trains a model and reports, every ``every`` updates, the full-batch loss gradient's norm, the
decay term's norm and their ratio, per group of parameters.
"""

from __future__ import annotations

from typing import Any

import torch as th

GROUPS = ("hidden weights", "biases", "output layer", "other")


def _group(name: str, param: th.Tensor, output_names: set[str]) -> str:
    if name in output_names:
        return "output layer"
    if name.endswith("bias"):
        return "biases"
    if param.dim() == 2:
        return "hidden weights"
    return "other"


def decay_to_gradient(model: Any, updates: int, every: int, weight_decay: float) -> list[dict[str, Any]]:
    """Train ``model`` (an algorithm of ``sb3_mbil.ALGORITHMS`` with a BC term) for ``updates`` gradient steps and,
    every ``every`` steps, measure on all expert pairs: the behaviour-cloning loss, |grad L| and |lambda theta| per
    group of the policy's parameters (``lambda`` = ``weight_decay``, whether or not the model trains with it)."""
    from sb3_mbil.common.losses import bc_heads, bc_loss

    policy = model.policy
    named = [(n, p) for n, p in policy.named_parameters() if p.requires_grad]
    # the output layers: the named heads (mean_head, log_std_head, ...), not the hidden stack's numbered layers
    linears = [n for n, m in policy.named_modules() if isinstance(m, th.nn.Linear)]
    outputs = [n for n in linears if not n.split(".")[-1].isdigit()] or linears[-1:]
    output_names = {f"{n}.{k}" for n in outputs for k in ("weight", "bias")}
    rows = []
    model.learn(0)
    done = 0
    while done <= updates:
        pairs = model.expert_pairs()
        policy.zero_grad(set_to_none=True)
        loss = bc_loss(policy, bc_heads(policy, pairs.observations, model._bc_kind), pairs.actions, model._bc_kind)
        loss.backward()
        row: dict[str, Any] = {"update": done, "bc_loss": float(loss)}
        for group in GROUPS:
            grads = [p.grad.pow(2).sum() for n, p in named if p.grad is not None and _group(n, p, output_names) == group]
            decay = [(weight_decay * p.detach()).pow(2).sum() for n, p in named if _group(n, p, output_names) == group]
            if not decay:
                continue
            g = float(th.stack(grads).sum().sqrt()) if grads else 0.0
            d = float(th.stack(decay).sum().sqrt())
            row[group] = {"grad": g, "decay": d, "ratio": d / g if g > 0 else float("inf")}
        policy.zero_grad(set_to_none=True)
        rows.append(row)
        if done == updates:
            break
        model.learn(every, reset_num_timesteps=False, log_interval=-1)
        done += every
    return rows
