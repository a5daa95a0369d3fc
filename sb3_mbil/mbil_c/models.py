"""MBIL-C's models P_eta(a' | s, a, s') and T_psi(s' | s, a): their fit, and the targets they give the policy
(:class:`~sb3_mbil.mbil_c.balance.BalanceTargets`), computed once per fitted models and data. A part of
:class:`~sb3_mbil.MBILC`, kept in its own file: it reads the algorithm's settings and data through ``self``."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch as th

from sb3_mbil.common.flows import fit_conditional_density
from sb3_mbil.common.threads import on_training_cpu
from sb3_mbil.mbil_c.balance import BalanceTargets


class BalanceModels:
    """Fitting P and T and computing the balance targets (mixed into :class:`~sb3_mbil.MBILC`)."""

    @on_training_cpu
    def fit_models(self) -> dict[str, Any]:
        """Fit P_eta(a' | s, a, s') and T_psi(s' | s, a) on the expert tuples (maximum likelihood).

        Called by the first ``learn``. Returns (and keeps in ``self.model_report``) the chosen noise levels,
        step counts and held-out log-likelihoods (nats per tuple, raw units).
        """
        tup = self.expert_tuples()
        seed, train_idx, val_idx = self.model_fit_split(self.validation_fraction)
        common = dict(noise_grid=self.model_noise_grid, learning_rate=self.model_learning_rate,
                      batch_size=self.model_batch_size, max_steps=self.model_max_steps, eval_every=self.model_eval_every,
                      patience=self.model_patience, refit=self.model_refit, seed=seed)
        model = self.balance_model
        s, a, s_next, a_next = tup
        if self.verbose >= 1:
            which = "P(a' | s, a, s') and T(s' | s, a)" if self.alpha_model > 0 else "P(a' | s, a, s')"
            print(f"MBILC: fitting {which} on {len(s)} expert tuples")
        fitted_p, report_p = fit_conditional_density(
            model.make_next_action, *model.next_action_inputs(s, a, s_next, a_next), train_idx, val_idx, **common,
            log=self._fit_log("P(a' | s, a, s')"))
        model.next_action.load_state_dict(fitted_p.state_dict())
        report = {"next_action": report_p.as_dict(), "fit_seconds": report_p.seconds,
                  "n_tuples": len(s), "n_heldout": len(val_idx)}
        if self.alpha_model > 0:  # T is fitted only when its states are used
            fitted_t, report_t = fit_conditional_density(
                model.make_transition, *model.transition_inputs(s, a, s_next), train_idx, val_idx, **common,
                log=self._fit_log("T(s' | s, a)"))
            model.transition.load_state_dict(fitted_t.state_dict())
            report["transition"] = report_t.as_dict()
            report["fit_seconds"] += report_t.seconds
        model.fitted.fill_(True)
        model.eval()
        self.model_report = report
        self._cache = None
        return report

    def _predecessors(self) -> tuple[th.Tensor, th.Tensor]:
        """For every expert pair (s, a), the index of the tuple whose s' it is (-1 at a trajectory's first step); and
        the tuples whose s' is no expert pair's state (the last tuple of a piece with a ``final_action``, e.g. every
        tuple of subsampled data), whose s' the policy is evaluated at separately."""
        out, orphans, n_tuples = [], [], 0
        for traj in self.demonstrations():
            length = len(traj)
            prev = np.full(length, -1, dtype=np.int64)
            if length >= 2:
                prev[1:] = n_tuples + np.arange(length - 1)
                n_tuples += length - 1
            if traj.final_action is not None:
                orphans.append(n_tuples)
                n_tuples += 1
            out.append(prev)
        return (th.as_tensor(np.concatenate(out), device=self.device),
                th.as_tensor(np.asarray(orphans, dtype=np.int64), device=self.device))

    @th.no_grad()
    def balance_targets(self) -> BalanceTargets:
        """P_eta's conditionals the policy is fitted to (:class:`~sb3_mbil.mbil_c.balance.BalanceTargets`),
        computed once per fitted models and data: at every expert pair (s', a') whose predecessor (s, a) is known,
        at the orphan tuples, and at the ``n_model_states`` draws s~' ~ T^kappa(. | s, a) per tuple."""
        if self._cache is not None:
            if self._cache.soft_labels is not None and self._cache.label_weights != (self.alpha, self.beta):
                self._cache.soft_labels, self._cache.label_weights = self._soft_labels(self._cache)  # alpha or beta changed
            return self._cache
        if not bool(self.balance_model.fitted):
            raise RuntimeError("the models are not fitted yet: call fit_models() or learn()")
        s, a, s_next, _ = self.expert_tuples()
        model = self.balance_model
        prev, orphans = self._predecessors()
        has = prev >= 0
        data = model.next_action_distribution(s, a, s_next)
        n_pairs = len(prev)
        # the balance term is the mean over all tuples: those whose s' is a pair's state (in the BC minibatch, weight
        # 1 on pairs with a predecessor) and the orphans (their own minibatch), in proportion to their numbers
        n_inner, n_orphan = int(has.sum()), len(orphans)
        at_data = tuple(th.zeros((n_pairs, *d.shape[1:]), device=self.device).index_copy(0, th.nonzero(has).view(-1),
                                                                                         d[prev[has]]) for d in data)
        targets = BalanceTargets(has_target=has, weight=has.float() / has.float().mean().clamp(min=1e-12),
                                 inner_share=n_inner / max(n_inner + n_orphan, 1), data=at_data)
        if n_orphan:
            a_next_all = self.expert_tuples().next_actions
            targets.orphan_states = s_next[orphans]
            targets.orphan_target = tuple(d[orphans] for d in data)
            if self.anchor_to_data:
                targets.orphan_target = (a_next_all[orphans].view(n_orphan, -1), targets.orphan_target[1])
        if model.discrete:  # KL(P || pi) = sum P log P - sum P log pi: the first sum once per pair
            probs = targets.data[0].exp() * has.float().unsqueeze(1)
            targets.probs, targets.neg_entropy = probs, (probs * targets.data[0]).sum(1)
            targets.soft_labels, targets.label_weights = self._soft_labels(targets)
        if self.anchor_to_data:  # Box: P's mean at the data moved onto the observed a' (its std kept)
            a_next = self.expert_tuples().next_actions
            targets.data = (targets.data[0].index_copy(0, th.nonzero(has).view(-1),
                                                       a_next[prev[has]].view(-1, data[0].shape[1])), targets.data[1])
        if self.alpha_model > 0 and self.model_labels == "corrective":
            targets.states, targets.model_actions, targets.model_tuples = self._corrective_labels()
        elif self.alpha_model > 0:
            generator = th.Generator(device=self.device).manual_seed(int(self.seed or 0) + 7919)
            k = self.n_model_states
            states = model.sample_next_states(s, a, k, self.model_state_scale, generator)
            targets.states = states
            target = model.next_action_distribution(s.repeat_interleave(k, 0), a.repeat_interleave(k, 0), states)
            if self.anchor_to_data:  # a' + (mean_P(s, a, s~') - mean_P(s, a, s')): P's change, not its level
                a_next = self.expert_tuples().next_actions.view(len(s), -1)
                shift = (a_next - data[0]).repeat_interleave(k, 0)
                target = (target[0] + shift, target[1])
            targets.model = target
        self._cache = targets
        return targets

    def _soft_labels(self, targets: BalanceTargets) -> tuple[th.Tensor, tuple[float, float]]:
        """(Discrete) beta * CE(onehot(a), pi) + alpha * w * KL(P || pi) = CE(Y, pi) + const with the soft label
        Y = beta * onehot(a) + alpha * w * P per expert pair: the objective at the data as one cross-entropy."""
        pairs = self.expert_pairs()
        onehot = th.nn.functional.one_hot(pairs.actions, self.balance_model.n_actions).float()
        return self.beta * onehot + self.alpha * targets.weight.unsqueeze(1) * targets.probs, (self.alpha, self.beta)

    @th.no_grad()
    def _corrective_labels(self) -> tuple[th.Tensor, th.Tensor, th.Tensor]:
        """CCIL-style labels (``model_labels="corrective"``): states s~ near the expert's from which T's mean takes a
        perturbed action a~ to the expert's next state s', kept where T lands within the tolerance. Returns the kept
        states, their actions and the tuple each came from."""
        s, a, s_next, _ = self.expert_tuples()
        model = self.balance_model
        generator = th.Generator(device=self.device).manual_seed(int(self.seed or 0) + 7919)
        if model.discrete:  # every action from every expert state
            k = model.n_actions
            actions = th.arange(k, device=self.device).repeat(len(s))
        else:
            k = self.n_model_states
            a_std = a.std(0, unbiased=False).clamp(min=1e-6)
            noise = th.randn((len(s) * k, *a.shape[1:]), generator=generator, device=self.device)
            low, high = (th.as_tensor(b, dtype=a.dtype, device=self.device).view(-1) for b in
                         (self.action_space.low, self.action_space.high))
            actions = (a.repeat_interleave(k, 0) + self.corrective_action_noise * a_std * noise).clamp(low, high)
        target = s_next.repeat_interleave(k, 0)
        x = s.repeat_interleave(k, 0).clone()
        step = lambda x: model.transition_mean_std(x, actions)[0]  # noqa: E731
        for _ in range(self.corrective_iterations):
            x = x + (target - step(x))
        s_std = s.std(0, unbiased=False).clamp(min=1e-6)
        gap = ((step(x) - target) / s_std).pow(2).mean(1).sqrt()
        keep = th.isfinite(gap) & (gap < self.corrective_tolerance)
        if self.model_report is not None:
            self.model_report["corrective_labels"] = {"kept": int(keep.sum()), "tried": len(keep),
                                                      "median_gap": float(gap.nan_to_num(float("inf")).median())}
        return x[keep], actions[keep], th.nonzero(keep).view(-1) // k

