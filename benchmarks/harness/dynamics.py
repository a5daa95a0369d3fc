"""What MBIL-C's dynamics model T(s' | s, a) knows after a fit on the expert data: does it see the action?

CCIL-style corrective labels (``model_labels="corrective"``) ask T which state s~ a perturbed action a~ takes to the
expert's next state. That is only informative if T's next state depends on the action by more than T errs. On the
expert tuples of one draw this reports, in units of the expert states' std per dimension (RMS over dimensions,
medians over tuples):

* ``step``: |s' - s|, how far one expert step moves the state;
* ``error``: |mean_T(s, a) - s'|, T's error on the tuples it was fitted on;
* ``action_effect``: |mean_T(s, a~) - mean_T(s, a)| for a~ = a + ``action_noise`` * std(a) * eps (clipped to the
  bounds), what a perturbed action changes in T's prediction;
* ``label_shift``: |s~ - s| of the corrective labels, and how many the tolerance kept;
* T's held-out and training log-likelihoods (nats per tuple) and its chosen noise and step count.
"""

from __future__ import annotations

from typing import Any

import torch as th


def _rms(x: th.Tensor, scale: th.Tensor) -> float:
    return float((x / scale).pow(2).mean(1).sqrt().median())


def transition_diagnostics(env: str, seed: int, settings: dict[str, Any], action_noise: float = 0.1) -> dict[str, Any]:
    """Fit MBIL-C (the zoo's settings for ``env``, overridden by ``settings``; T is fitted when ``alpha_model`` > 0) on
    the seed's one-trajectory draw (the Figure 4 draw) and measure T (module docstring)."""
    from sb3_mbil import MBILC
    from benchmarks.harness.curves import _resolved_settings, drawn_demonstrations

    th.set_num_threads(1)
    resolved = _resolved_settings("mbil_c", env, {"alpha_model": 1.0, **settings})
    if resolved["alpha_model"] <= 0:
        raise ValueError(f"settings: expected alpha_model > 0 (T is fitted only then), found {resolved['alpha_model']}")
    model = MBILC("MlpPolicy", env, expert_data=drawn_demonstrations(env, seed, 1), seed=seed, **resolved)
    report = model.fit_models()
    cache = model.balance_targets()
    s, a, s_next, _ = model.expert_tuples()
    scale = s.std(0, unbiased=False).clamp(min=1e-6)
    bm = model.balance_model
    g = th.Generator().manual_seed(seed)
    low, high = (th.as_tensor(b, dtype=a.dtype).view(-1) for b in (model.action_space.low, model.action_space.high))
    perturbed = (a + action_noise * a.std(0, unbiased=False) * th.randn(a.shape, generator=g)).clamp(low, high)
    with th.no_grad():
        mean = bm.transition_mean_std(s, a)[0]
        moved = bm.transition_mean_std(s, perturbed)[0]
    out = {"env": env, "seed": seed, "residual_transition": bool(resolved.get("residual_transition", False)),
           "noise": report["transition"]["noise"], "steps": report["transition"]["steps"],
           "heldout_ll": round(report["transition"]["heldout_ll"], 2), "train_ll": round(report["transition"]["train_ll"], 2),
           "step": round(_rms(s_next - s, scale), 4), "error": round(_rms(mean - s_next, scale), 4),
           "action_effect": round(_rms(moved - mean, scale), 4)}
    if cache.model_tuples is not None:
        kept = model.model_report["corrective_labels"]
        out["labels_kept"] = f"{kept['kept']} of {kept['tried']}"
        out["label_shift"] = round(_rms(cache.states - s[cache.model_tuples], scale), 4) if kept["kept"] else ""
    return out


def diagnostics_table(rows: list[dict[str, Any]]) -> str:
    columns = ["env", "seed", "residual_transition", "noise", "steps", "heldout_ll", "train_ll", "step", "error",
               "action_effect", "labels_kept", "label_shift"]
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(str(r.get(c, "")) for c in columns) + " |" for r in rows]
    return "\n".join(lines)
