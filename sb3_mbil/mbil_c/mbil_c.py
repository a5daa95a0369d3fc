"""MBIL-C: the Markov balance equation imposed over every next action and at model next states.

The Markov balance equation of the expert's state-action chain (the paper, arXiv:2408.09125),

    P(s', a' | s, a) = pi_D(a' | s') T(s' | s, a)       for every (s', a'),

divided by its s'-marginal T(s' | s, a) (integrate it over a'), reads

    P(a' | s, a, s') = pi_D(a' | s')                     for every a' and every s' that T can reach from (s, a).

The paper's MBIL (``sb3_mbil.MBIL``) penalises the squared log residual of this equation at the one
observed tuple (s, a, s', a'). MBIL-C ("complete") asks for the whole equation: the whole conditional
over a' (a divergence D that is zero exactly when the equation holds for every a'), at the observed s'
and at next states drawn from the fitted dynamics T, where the data has no label:

    min_theta  beta    * L_BC(pi_theta, D)
             + alpha   * E_{(s, a, s') ~ D}                         D( P_eta(. | s, a, s') || pi_theta(. | s') )
             + alpha_T * E_{(s, a) ~ D, s~' ~ T_psi^kappa(. | s, a)} D( P_eta(. | s, a, s~') || pi_theta(. | s~') )

D is the KL divergence for Discrete actions (categorical against categorical) and, by default, the squared
2-Wasserstein distance for Box actions (diagonal Gaussian against diagonal Gaussian,
``|mean_P - mean_pi|^2 + |std_P - std_pi|^2``, in the units of the MSE behaviour-cloning term; KL is an option).
For Box actions P is by default anchored on the data (``anchor_to_data``): P's mean at the data is replaced by
the observed a' (its std kept), and at a model state by a' + mean_P(s, a, s~') - mean_P(s, a, s').

Defaults: ``alpha = beta = 1`` and ``alpha_T = 0``, so by default T is neither fitted nor used and MBIL-C is BC
plus the balance divergence at the data (why, with the tuning runs behind it: docs/method.md).

T_psi^kappa is the fitted Gaussian T with its standard deviation multiplied by kappa
(``model_state_scale``). P_eta and T_psi are fitted once by maximum likelihood (Gaussian input noise,
early-stopped on held-out trajectory blocks) and frozen; P_eta's conditionals at the data and at
``n_model_states`` draws of T per tuple are computed once and kept, so a policy update is one forward
pass over one minibatch of expert states and one of model states.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.type_aliases import GymEnv, Schedule

from sb3_mbil.common.demonstrations import ExpertData
from sb3_mbil.common.losses import bc_loss, check_logit_penalty, logit_penalty, resolve_bc_loss
from sb3_mbil.common.offline import OfflineAlgorithm
from sb3_mbil.common.validation import check_bool, check_choice, check_int, check_levels, check_real, check_sizes
from sb3_mbil.mbil_c.balance import DIVERGENCES, BalanceTargets, Draws, balance_divergence
from sb3_mbil.mbil_c.models import BalanceModels
from sb3_mbil.mbil_c.policies import BalanceModel, ImitationPolicy

class MBILC(BalanceModels, OfflineAlgorithm):
    """MBIL-C: Markov balance over every next action, at the data's and the dynamics model's next states.

    Objective (module docstring): ``beta * L_BC + alpha * D at data s' + alpha_T * D at s~' ~ T``, plus BC's
    optional logit penalty for Discrete actions (``logit_penalty``).
    With ``alpha = alpha_T = 0`` it is BC. Deviations from the paper's MBIL: a divergence over the whole conditional
    instead of the squared log residual at the observed a'; P is written as T(s' | s, a) P(a' | s, a, s')
    (as in our MBIL), both models are MLPs (categorical / diagonal Gaussian), not flows; the balance term
    is also imposed at states drawn from T.

    :param policy: ``"MlpPolicy"`` (two ReLU hidden layers; categorical or Gaussian head)
    :param env: the env or its id (spaces and evaluation only; never stepped while learning)
    :param expert_data: demonstrations (see :func:`sb3_mbil.as_demonstrations`); not saved with the model
    :param alpha: weight of the balance term at the data's next states
    :param alpha_model: weight of the balance term at next states drawn from T (``alpha_T``; 0 by default, where T is
        not fitted)
    :param beta: weight of the behaviour-cloning term
    :param learning_rate: policy Adam learning rate (constant or schedule)
    :param batch_size: minibatch size (expert states; as many model states)
    :param bc_loss: ``"auto"`` (NLL for Discrete, MSE of the mean for Box), ``"nll"`` or ``"mse"``
    :param divergence: the balance divergence D(P || pi): ``"auto"`` (KL for Discrete, W2 for Box), ``"kl"`` or
        ``"w2"`` (squared 2-Wasserstein distance of the Gaussians; Box only)
    :param weight_decay: policy Adam weight decay
    :param logit_penalty: (Discrete) weight lambda of BC's logit penalty, lambda * mean of the squared logits at the
        expert states (d3rlpy's DiscreteBC regulariser; 0: none), added to the objective
    :param n_model_states: draws of T per expert tuple (kept for the whole run)
    :param model_state_scale: kappa, the factor on T's standard deviation when drawing model states
    :param anchor_to_data: ``"auto"`` (True for Box, False for Discrete) or a bool. (Box) P's targets anchored on
        the observed actions: at the data the target mean is the
        expert's a' (P's std kept); at a model state s~' it is a' + mean_P(s, a, s~') - mean_P(s, a, s'), P's change
        from the data rather than its level (P fitted on one trajectory is a smoother, biased copy of BC)
    :param model_labels: what the policy is fitted to at the model states: ``"balance"`` (P's conditional at
        s~' ~ T^kappa, the balance term above) or ``"corrective"`` (CCIL-style corrective labels, Ke et al. 2024:
        for each expert tuple and a perturbed action a~, the state s~ from which T's mean takes a~ to the expert's
        s', found by fixed-point iteration from s; kept where T then lands within ``corrective_tolerance`` of s'
        (RMS in units of the expert states' std); the pair (s~, a~) is a behaviour-cloning label)
    :param corrective_action_noise: (Box) std of a~ - a in units of the expert actions' std; Discrete: every action
    :param corrective_tolerance: largest RMS gap |mean_T(s~, a~) - s'| / std(s) of a kept corrective label
    :param corrective_iterations: fixed-point iterations s~ <- s~ + s' - mean_T(s~, a~), from s~ = s
    :param model_hidden: hidden sizes of P's and T's MLPs
    :param residual_transition: T models s' - s (its mean added to s, as model-based RL and CCIL do) instead of s'
    :param model_learning_rate: Adam learning rate of P and T
    :param model_batch_size: their minibatch size
    :param model_max_steps: maximum gradient steps of one fit
    :param model_eval_every: steps between held-out evaluations (early stopping)
    :param model_patience: held-out evaluations without improvement before stopping
    :param model_noise_grid: Gaussian input-noise levels (standardised units) tried; the held-out
        log-likelihood picks one for each model
    :param validation_fraction: share of tuples (in blocks of consecutive steps) held out to stop the fits
    :param model_refit: after choosing noise and step count, refit each model on all tuples
    :param policy_kwargs: policy keyword arguments (``net_arch``, ``bounded_mean``, ...)
    :param tensorboard_log: tensorboard folder
    :param verbose: verbosity
    :param seed: random seed
    :param device: torch device
    :param _init_setup_model: build the networks at construction
    """

    balance_model: BalanceModel

    def __init__(
        self,
        policy: str | type[ImitationPolicy],
        env: GymEnv | str | None,
        expert_data: ExpertData | None = None,
        alpha: float = 1.0,
        alpha_model: float = 0.0,
        beta: float = 1.0,
        learning_rate: float | Schedule = 1e-3,
        batch_size: int = 64,
        bc_loss: str = "auto",
        divergence: str = "auto",
        weight_decay: float = 0.0,
        logit_penalty: float = 0.0,
        n_model_states: int = 4,
        model_state_scale: float = 1.0,
        anchor_to_data: bool | str = "auto",
        model_labels: str = "balance",
        corrective_action_noise: float = 0.1,
        corrective_tolerance: float = 0.05,
        corrective_iterations: int = 10,
        model_hidden: Sequence[int] = (64, 64),
        residual_transition: bool = False,
        model_learning_rate: float = 1e-3,
        model_batch_size: int = 256,
        model_max_steps: int = 2000,
        model_eval_every: int = 25,
        model_patience: int = 10,
        model_noise_grid: Sequence[float] = (0.1,),
        validation_fraction: float = 0.2,
        model_refit: bool = False,
        policy_kwargs: dict[str, Any] | None = None,
        tensorboard_log: str | None = None,
        verbose: int = 0,
        seed: int | None = None,
        device: th.device | str = "auto",
        _init_setup_model: bool = True,
    ):
        super().__init__(
            policy=policy, env=env, expert_data=expert_data, learning_rate=learning_rate, batch_size=batch_size,
            weight_decay=weight_decay, policy_kwargs=policy_kwargs, tensorboard_log=tensorboard_log, verbose=verbose,
            seed=seed, device=device, _init_setup_model=_init_setup_model,
        )
        self.alpha = alpha
        self.alpha_model = alpha_model
        self.beta = beta
        self.bc_loss = bc_loss
        self.divergence = divergence
        self.logit_penalty = logit_penalty
        self.n_model_states = n_model_states
        self.model_state_scale = model_state_scale
        self.anchor_to_data = anchor_to_data
        self.model_labels = model_labels
        self.corrective_action_noise = corrective_action_noise
        self.corrective_tolerance = corrective_tolerance
        self.corrective_iterations = corrective_iterations
        self.model_hidden = model_hidden
        self.residual_transition = residual_transition
        self.model_learning_rate = model_learning_rate
        self.model_batch_size = model_batch_size
        self.model_max_steps = model_max_steps
        self.model_eval_every = model_eval_every
        self.model_patience = model_patience
        self.model_noise_grid = model_noise_grid
        self.validation_fraction = validation_fraction
        self.model_refit = model_refit
        self.model_report: dict[str, Any] | None = None
        if _init_setup_model:
            self._setup_model()

    # ------------------------------------------------------------------ setup
    def _check_hyperparameters(self) -> None:
        super()._check_hyperparameters()
        self.alpha = check_real("alpha", self.alpha, low=0.0)
        self.alpha_model = check_real("alpha_model", self.alpha_model, low=0.0)
        self.beta = check_real("beta", self.beta, low=0.0)
        if self.alpha == 0 and self.alpha_model == 0 and self.beta == 0:
            raise ValueError("alpha, alpha_model, beta: expected at least one of them > 0, found all 0")
        self._bc_kind = resolve_bc_loss(self.bc_loss, self.action_space, allowed=("nll", "mse"))
        self.divergence = check_choice("divergence", self.divergence, DIVERGENCES)
        self.logit_penalty = check_logit_penalty(self.logit_penalty, self.action_space)
        discrete = isinstance(self.action_space, spaces.Discrete)
        if self.divergence == "w2" and discrete:
            raise ValueError("divergence: expected 'kl' or 'auto' for Discrete actions, found 'w2'")
        self._divergence = ("kl" if discrete else "w2") if self.divergence == "auto" else self.divergence
        for name in ("n_model_states", "model_batch_size", "model_max_steps", "model_eval_every", "model_patience"):
            setattr(self, name, check_int(name, getattr(self, name), low=1))
        self.model_state_scale = check_real("model_state_scale", self.model_state_scale, low=0.0)
        if self.anchor_to_data == "auto":
            self.anchor_to_data = not discrete
        self.anchor_to_data = check_bool("anchor_to_data", self.anchor_to_data)
        if self.anchor_to_data and discrete:
            raise ValueError("anchor_to_data: expected False for Discrete actions (it moves a Gaussian mean), found True")
        self.model_hidden = check_sizes("model_hidden", self.model_hidden)
        self.residual_transition = check_bool("residual_transition", self.residual_transition)
        self.model_labels = check_choice("model_labels", self.model_labels, ("balance", "corrective"))
        self.corrective_action_noise = check_real("corrective_action_noise", self.corrective_action_noise, low=0.0)
        self.corrective_tolerance = check_real("corrective_tolerance", self.corrective_tolerance, low=0.0, low_open=True)
        self.corrective_iterations = check_int("corrective_iterations", self.corrective_iterations, low=1)
        self.model_learning_rate = check_real("model_learning_rate", self.model_learning_rate, low=0.0, low_open=True)
        self.model_noise_grid = check_levels("model_noise_grid", self.model_noise_grid)
        self.validation_fraction = check_real("validation_fraction", self.validation_fraction, low=0.0, high=1.0,
                                              low_open=True, high_open=True)
        self.model_refit = check_bool("model_refit", self.model_refit)

    def _setup_model(self) -> None:
        super()._setup_model()
        with th.random.fork_rng(devices=[]):  # P and T are refitted from their own seeds: keep the policy's stream
            self.balance_model = BalanceModel(
                int(np.prod(self.observation_space.shape)), self.action_space, hidden=self.model_hidden,
                residual_transition=self.residual_transition,
            ).to(self.device)
        self.balance_model.eval()

    def _on_new_data(self) -> None:
        super()._on_new_data()
        self._cache: BalanceTargets | None = None  # P's conditionals and T's draws, once the models are fitted

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "_cache"]

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        names, others = super()._get_torch_save_params()
        return [*names, "balance_model"], others

    @th.no_grad()
    def validation_losses(self, expert_data: ExpertData) -> dict[str, float]:
        """The behaviour-cloning loss and the balance loss E[D(P(.|s,a,s') || pi(.|s'))] on (held-out) expert data."""
        losses = super().validation_losses(expert_data)
        if bool(self.balance_model.fitted):
            s, a, s_next, _ = self.tuple_tensors(expert_data)
            target = self.balance_model.next_action_distribution(s, a, s_next)
            losses["balance_loss"] = float(balance_divergence(self._divergence, self.policy, target,
                                                              self.policy.heads(s_next)).mean())
        return losses

    def diagnostics(self) -> dict[str, Any]:
        """The fit of P (and T when used): its seconds."""
        out = super().diagnostics()
        if self.model_report:
            out["fit_seconds"] = self.model_report["fit_seconds"]
        return out

    # ------------------------------------------------------------------ policy
    def _prepare_training(self) -> None:
        if not bool(self.balance_model.fitted):
            self.fit_models()
        self.balance_targets()
        if self.model_report is not None:
            self.logger.record("model/fit_seconds", self.model_report["fit_seconds"])
            self.logger.record("model/next_action_heldout_ll", self.model_report["next_action"]["heldout_ll"])
            if "transition" in self.model_report:
                self.logger.record("model/transition_heldout_ll", self.model_report["transition"]["heldout_ll"])

    def _draw_batch(self) -> Draws:
        """Draw the update's expert pairs, model states and orphan tuples, and gather their rows of the targets."""
        pairs, targets = self.expert_pairs(), self.balance_targets()
        i = self._sample_indices(len(pairs.observations))
        use_model = self.alpha_model > 0 and len(targets.states) > 0
        j = self._sample_indices(len(targets.states)) if use_model else None
        use_orphans = self.alpha > 0 and targets.orphan_states is not None
        k = self._sample_indices(len(targets.orphan_states)) if use_orphans else None
        # Discrete, KL, no model or orphan states: the BC and the data balance terms are one cross-entropy
        fused = targets.soft_labels is not None and self._divergence == "kl" and not use_model and not use_orphans
        discrete_kl = self.policy.discrete and self._divergence == "kl"
        records_terms = fused and self.num_timesteps % 10 == 0  # the fused loss's two terms, every 10th update
        balance = self.alpha > 0 and not fused
        with_probs = (balance and discrete_kl) or records_terms
        balance_labels = use_model and self.model_labels == "balance"
        return Draws(
            states=pairs.observations[i], actions=pairs.actions[i],
            soft_labels=targets.soft_labels[i] if fused else None,
            weight=targets.weight[i] if balance or records_terms else None,
            probs=targets.probs[i] if with_probs else None,
            neg_entropy=targets.neg_entropy[i] if with_probs else None,
            data=tuple(d[i] for d in targets.data) if balance and not discrete_kl else None,
            model_states=targets.states[j] if use_model else None,
            model=tuple(d[j] for d in targets.model) if balance_labels else None,
            model_actions=targets.model_actions[j] if use_model and not balance_labels else None,
            orphan_states=targets.orphan_states[k] if use_orphans else None,
            orphan_target=tuple(d[k] for d in targets.orphan_target) if use_orphans else None,
            inner_share=th.tensor(targets.inner_share, device=self.device) if use_orphans else None,
        )

    def _policy_inputs(self, draws: Draws) -> th.Tensor:
        states = [draws.states, *(s for s in (draws.model_states, draws.orphan_states) if s is not None)]
        return th.cat(states) if len(states) > 1 else states[0]  # one forward pass

    def _loss_from_heads(self, draws: Draws, heads: tuple[th.Tensor, ...]) -> th.Tensor:
        n = len(draws.states)
        n_model = len(draws.model_states) if draws.model_states is not None else 0
        heads_s = [h[:n] for h in heads]
        heads_model, heads_orphan = [h[n:n + n_model] for h in heads], [h[n + n_model:] for h in heads]
        if draws.soft_labels is not None:
            return self._fused_loss(draws, heads_s)
        # (Discrete) log pi(. | s_i), shared by the BC and the balance term
        log_pi = th.log_softmax(heads_s[0], dim=-1) if self.policy.discrete else None
        loss = th.zeros((), device=self.device)
        if self.beta > 0:
            loss = loss + self.beta * self._bc_term(draws, heads_s, log_pi)
        if self.logit_penalty > 0:
            loss = loss + self.logit_penalty * self._logit_penalty_term(heads_s)
        if self.alpha > 0:
            loss = loss + self.alpha * self._data_balance_term(draws, heads_s, log_pi, heads_orphan)
        if draws.model_states is not None:
            loss = loss + self.alpha_model * self._model_term(draws, heads_model)
        return loss

    def _fused_loss(self, draws: Draws, heads: list[th.Tensor]) -> th.Tensor:
        """beta * L_BC + alpha * KL at the data = CE(soft labels, pi) + const (the same gradient, one op), plus the
        logit penalty; its two terms are recomputed without gradient every 10th update."""
        # torch's cross-entropy with probability targets, written out as ATen computes it (the same bits): vmap has
        # no fast rule for the fused op, and seeds in lockstep evaluate this loss under vmap
        logits = heads[0]
        loss = -(th.log_softmax(logits, dim=1) * draws.soft_labels).sum() / (logits.numel() // logits.shape[1])
        if self.logit_penalty > 0:
            loss = loss + self.logit_penalty * logit_penalty(heads)
        self._record("train/loss", loss)
        if draws.weight is not None:
            log_pi = th.log_softmax(heads[0].detach(), dim=-1)
            self._record("train/bc_loss", -log_pi.gather(1, draws.actions.view(-1, 1)).mean())
            kl = draws.neg_entropy - (draws.probs * log_pi).sum(dim=1)
            self._record("train/balance_loss", (kl * draws.weight).mean())
        return loss

    def _bc_term(self, draws: Draws, heads: list[th.Tensor], log_pi: th.Tensor | None) -> th.Tensor:
        """BC term: L_BC(pi, D) on the expert's (s, a) pairs."""
        log_prob = None if log_pi is None else log_pi.gather(1, draws.actions.view(-1, 1)).squeeze(1)
        bc = bc_loss(self.policy, heads, draws.actions, self._bc_kind, log_prob=log_prob)
        self._record("train/bc_loss", bc)
        return bc

    def _logit_penalty_term(self, heads: list[th.Tensor]) -> th.Tensor:
        """Logit penalty (Discrete): mean of the squared logits at the expert states."""
        penalty = logit_penalty(heads)
        self._record("train/logit_penalty", penalty)
        return penalty

    def _data_balance_term(self, draws: Draws, heads: list[th.Tensor], log_pi: th.Tensor | None,
                           heads_orphan: list[th.Tensor]) -> th.Tensor:
        """Balance at the data: D(P(. | s, a, s') || pi(. | s')) over the pairs that have a predecessor (weight 0 at a
        trajectory's first step; the weights average 1, and are all 0 when every tuple is an orphan), mixed with the
        orphan tuples in proportion to their numbers."""
        if draws.probs is not None:  # Discrete, KL
            divergence = draws.neg_entropy - (draws.probs * log_pi).sum(dim=1)
        else:
            divergence = balance_divergence(self._divergence, self.policy, draws.data, heads)
        balance = (divergence * draws.weight).mean()
        if draws.orphan_states is not None:  # tuples whose s' is not an expert pair's state (subsampled data)
            orphan = balance_divergence(self._divergence, self.policy, draws.orphan_target, heads_orphan).mean()
            balance = draws.inner_share * balance + (1 - draws.inner_share) * orphan
        self._record("train/balance_loss", balance)
        return balance

    def _model_term(self, draws: Draws, heads: list[th.Tensor]) -> th.Tensor:
        """At model states: corrective labels, L_BC(pi) on the kept (s~, a~) (``model_labels="corrective"``); or the
        balance D(P(. | s, a, s~') || pi(. | s~')) with s~' ~ T^kappa(. | s, a)."""
        if self.model_labels == "corrective":
            corrective = bc_loss(self.policy, heads, draws.model_actions, self._bc_kind)
            self._record("train/corrective_loss", corrective)
            return corrective
        model_kl = balance_divergence(self._divergence, self.policy, draws.model, heads).mean()
        self._record("train/model_balance_loss", model_kl)
        return model_kl
