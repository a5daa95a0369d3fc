"""How an MBIL policy meets its balance target on the expert tuples (:meth:`sb3_mbil.MBIL.balance_diagnostics`)."""

from __future__ import annotations

import math
from typing import Any

import torch as th


@th.no_grad()
def balance_diagnostics(model) -> dict[str, Any]:
    """The balance loss over the expert tuples and, for a Gaussian policy, how much of it the mean carries (the
    quantities are described in :meth:`sb3_mbil.MBIL.balance_diagnostics`)."""
    tup = model.expert_tuples()
    target = model.balance_target(*tup)
    heads = model.policy.heads(tup.next_observations)
    log_pi = model.policy.log_prob_from_heads(heads, tup.next_actions)
    out: dict[str, Any] = {
        "n_tuples": len(target),
        "target_mean": float(target.mean()), "target_std": float(target.std()),
        "target_min": float(target.min()), "target_max": float(target.max()),
        "residual_mse": float((target - log_pi).pow(2).mean()),
    }
    if model.policy.discrete:
        return out
    mean, log_std = heads
    d = mean.shape[1]
    log_pi_max = -log_std.sum(1) - 0.5 * d * math.log(2 * math.pi)
    lowest = -d * model.policy.log_std_bounds[1] - 0.5 * d * math.log(2 * math.pi)
    pairs = model.expert_pairs()
    bc_mean = model.policy.mean_action(pairs.observations)
    out.update(
        mean_shift_nats=float((log_pi_max - log_pi).mean()),
        residual_mse_mean_on_action=float((target - log_pi_max).pow(2).mean()),
        unreachable_targets=int((target < lowest).sum()),
        log_std_at_bound=float(((log_std <= model.policy.log_std_bounds[0] + 1e-3)
                                | (log_std >= model.policy.log_std_bounds[1] - 1e-3)).float().mean()),
        bc_mse=float((bc_mean - pairs.actions.view_as(bc_mean)).pow(2).mean()),
    )
    return out
