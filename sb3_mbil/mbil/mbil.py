"""MBIL: Markov Balance-based Imitation Learning (AAAI 2025), strictly offline.

Update rule (the paper's MBIL objective, arXiv:2408.09125):

    min_theta  alpha * E_D[ (log P(s', a' | s, a) - log pi_theta(a' | s') - log T(s' | s, a))^2 ]
             + beta  * L_BC(pi_theta, D)

The first expectation is the squared *balance residual* over consecutive expert tuples
(s, a, s', a'). P and T are fitted once by maximum likelihood before the policy is trained
and then frozen, so the balance target ``log P - log T`` is computed once per tuple and kept
(see :mod:`sb3_mbil.mbil.policies` for how P and T are modelled so that the target is in the
same measure as pi). ``estimator="joint"`` is the paper's literal estimator instead: a flow over
the joint (s', a') for P and a separate flow for T, the target their difference.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.type_aliases import GymEnv, Schedule

from sb3_mbil.common.demonstrations import ExpertData
from sb3_mbil.common.flows import EVAL_CHUNK, fit_conditional_density
from sb3_mbil.common.losses import bc_loss, resolve_bc_loss
from sb3_mbil.common.offline import OfflineAlgorithm
from sb3_mbil.common.threads import on_training_cpu
from sb3_mbil.common.validation import check_bool, check_choice, check_int, check_levels, check_real, check_sizes
from sb3_mbil.mbil.diagnostics import balance_diagnostics
from sb3_mbil.mbil.policies import ImitationPolicy, MarkovBalanceModel



class MBIL(OfflineAlgorithm):
    """Markov Balance-based Imitation Learning.

    Paper: "Markov Balance Satisfaction Improves Performance in Strictly Batch Offline
    Imitation Learning" (AAAI 2025).

    :param policy: ``"MlpPolicy"`` (two ReLU hidden layers; categorical or Gaussian head)
    :param env: the env or its id (spaces and evaluation only; never stepped while learning)
    :param expert_data: demonstrations (see :func:`sb3_mbil.as_demonstrations`); not saved with the model
    :param alpha: weight of the balance term
    :param beta: weight of the behaviour-cloning term
    :param learning_rate: policy Adam learning rate (constant or schedule)
    :param batch_size: policy minibatch size (for each of the two terms)
    :param bc_loss: ``"auto"`` (NLL for Discrete, MSE of the mean for Box), ``"nll"`` or ``"mse"``
    :param weight_decay: policy Adam weight decay
    :param flow_transforms: affine coupling blocks per flow
    :param flow_hidden: hidden sizes of each coupling block's network (and of the discrete a' model)
    :param flow_embed_dim: output size of the conditioning network NN_c
    :param flow_scale_limit: bound on each coupling block's |log scale|
    :param flow_learning_rate: Adam learning rate of the flows
    :param flow_batch_size: flow minibatch size
    :param flow_max_steps: maximum gradient steps of one fit (early stopping on held-out tuples usually ends it
        sooner). ``"auto"``: 300 for the categorical P(a' | s, a, s') of Discrete actions (factored estimator), 1 000 for
        every flow (P for Box actions, T, the joint estimator). On LunarLander-v3 (deterministic and sampled pools,
        N = 1 and 15, tuning seeds 100-109) 300 steps gave returns level with 1 000 (paired differences -4.2 to +1.3)
        at 0.4x its fit time (``python -m benchmarks.fit_budget``)
    :param flow_eval_every: steps between held-out evaluations (early stopping)
    :param flow_patience: held-out evaluations without improvement before stopping
    :param flow_min_delta: the held-out log-likelihood gain (nats per tuple) that counts as an improvement
    :param noise_grid: Gaussian input-noise levels (standardised units) tried for P(a' | s, a, s');
        the held-out log-likelihood picks one
    :param fit_transition: also fit T(s' | s, a) with the factored estimator, where T cancels from the balance
        target (log P - log T = log P(a' | s, a, s'), see :mod:`sb3_mbil.mbil.policies`) and only its diagnostics
        read it (the held-out log-likelihoods of T and of P, ``flows.log_t`` / ``flows.log_p``). Every fit draws
        its own random numbers, so this setting never changes the policy. The joint estimator always fits T
    :param transition_noise_grid: the levels tried for T(s' | s, a) when it is fitted (``None``: ``noise_grid``)
    :param transition_refit: refit T on all tuples after choosing its noise and step count (by
        default T keeps its fit on the training split, so its reported held-out log-likelihood is
        that of the saved T, at half the cost)
    :param validation_fraction: share of tuples (in blocks of consecutive steps) held out
    :param flow_refit: after choosing noise and step count, refit on all tuples
    :param log_density_floor: lower bound on the balance target (log-densities)
    :param estimator: how the target log P(s', a' | s, a) - log T(s' | s, a) is estimated: ``"factored"`` (default:
        P written as T x P(a' | s, a, s'), so T cancels and the target is log P(a' | s, a, s'), a mass for Discrete
        actions like pi) or ``"joint"`` (the paper's literal estimator: one affine-coupling flow over the joint
        (s', a') given (s, a), a' one-hot for Discrete actions, and a separate flow T; the target is the difference
        of the two fitted log-densities, with both models' errors in it and, for Discrete actions, a density in the
        one-hot a' rather than a mass). With ``"joint"``, T no longer cancels and is fitted like P (``noise_grid``,
        ``flow_refit``); ``transition_noise_grid`` and ``transition_refit`` apply to ``"factored"`` only
    :param policy_kwargs: policy keyword arguments (``net_arch``, ...)
    :param tensorboard_log: tensorboard folder
    :param verbose: verbosity
    :param seed: random seed
    :param device: torch device
    :param _init_setup_model: build the networks at construction
    """

    flows: MarkovBalanceModel

    def __init__(
        self,
        policy: str | type[ImitationPolicy],
        env: GymEnv | str | None,
        expert_data: ExpertData | None = None,
        alpha: float = 1.0,
        beta: float = 1.0,
        learning_rate: float | Schedule = 1e-3,
        batch_size: int = 64,
        bc_loss: str = "auto",
        weight_decay: float = 0.0,
        flow_transforms: int = 4,
        flow_hidden: Sequence[int] = (64, 64),
        flow_embed_dim: int = 32,
        flow_scale_limit: float = 3.0,
        flow_learning_rate: float = 1e-3,
        flow_batch_size: int = 256,
        flow_max_steps: int | str = "auto",
        flow_eval_every: int = 25,
        flow_patience: int = 10,
        flow_min_delta: float = 0.0,
        noise_grid: Sequence[float] = (0.01, 0.03, 0.1, 0.3),
        fit_transition: bool = False,
        transition_noise_grid: Sequence[float] | None = (0.03,),
        transition_refit: bool = False,
        validation_fraction: float = 0.2,
        flow_refit: bool = True,
        log_density_floor: float = -50.0,
        estimator: str = "factored",
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
        self.beta = beta
        self.bc_loss = bc_loss
        self.flow_transforms = flow_transforms
        self.flow_hidden = flow_hidden
        self.flow_embed_dim = flow_embed_dim
        self.flow_scale_limit = flow_scale_limit
        self.flow_learning_rate = flow_learning_rate
        self.flow_batch_size = flow_batch_size
        self.flow_max_steps = flow_max_steps
        self.flow_eval_every = flow_eval_every
        self.flow_patience = flow_patience
        self.flow_min_delta = flow_min_delta
        self.noise_grid = noise_grid
        self.fit_transition = fit_transition
        self.transition_noise_grid = transition_noise_grid
        self.transition_refit = transition_refit
        self.validation_fraction = validation_fraction
        self.flow_refit = flow_refit
        self.log_density_floor = log_density_floor
        self.estimator = estimator
        self.flow_report: dict[str, Any] | None = None
        if _init_setup_model:
            self._setup_model()

    # ------------------------------------------------------------------ setup
    def _check_hyperparameters(self) -> None:
        super()._check_hyperparameters()
        self.alpha = check_real("alpha", self.alpha, low=0.0)
        self.beta = check_real("beta", self.beta, low=0.0)
        if self.alpha == 0 and self.beta == 0:
            raise ValueError("alpha, beta: expected at least one of them > 0, found both 0")
        self._bc_kind = resolve_bc_loss(self.bc_loss, self.action_space, allowed=("nll", "mse"))
        for name in ("flow_transforms", "flow_batch_size", "flow_eval_every", "flow_patience"):
            setattr(self, name, check_int(name, getattr(self, name), low=1))
        if self.flow_max_steps != "auto":
            self.flow_max_steps = check_int("flow_max_steps", self.flow_max_steps, low=1)
        self.flow_embed_dim = check_int("flow_embed_dim", self.flow_embed_dim, low=0)
        self.flow_hidden = check_sizes("flow_hidden", self.flow_hidden)
        self.flow_scale_limit = check_real("flow_scale_limit", self.flow_scale_limit, low=0.0, low_open=True)
        self.flow_learning_rate = check_real("flow_learning_rate", self.flow_learning_rate, low=0.0, low_open=True)
        self.flow_min_delta = check_real("flow_min_delta", self.flow_min_delta, low=0.0)
        self.noise_grid = check_levels("noise_grid", self.noise_grid)
        if self.transition_noise_grid is not None:
            self.transition_noise_grid = check_levels("transition_noise_grid", self.transition_noise_grid)
        self.transition_refit = check_bool("transition_refit", self.transition_refit)
        self.fit_transition = check_bool("fit_transition", self.fit_transition)
        self.flow_refit = check_bool("flow_refit", self.flow_refit)
        self.validation_fraction = check_real("validation_fraction", self.validation_fraction, low=0.0, high=1.0,
                                              low_open=True, high_open=True)
        self.log_density_floor = check_real("log_density_floor", self.log_density_floor)
        self.estimator = check_choice("estimator", self.estimator, ("factored", "joint"))

    def _setup_model(self) -> None:
        super()._setup_model()
        self.flows = MarkovBalanceModel(
            int(np.prod(self.observation_space.shape)),
            self.action_space,
            transforms=self.flow_transforms,
            hidden=self.flow_hidden,
            embed_dim=self.flow_embed_dim,
            scale_limit=self.flow_scale_limit,
            joint=self.estimator == "joint",
        ).to(self.device)
        self.flows.eval()

    def _on_new_data(self) -> None:
        super()._on_new_data()
        self._targets: th.Tensor | None = None  # the balance target of every tuple, once the flows are fitted

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "_targets"]

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        # The flows are saved with the policy: load must not replace them with fresh ones.
        names, others = super()._get_torch_save_params()
        return [*names, "flows"], others

    # ------------------------------------------------------------------ flows
    @on_training_cpu
    def fit_flows(self) -> dict[str, Any]:
        """Fit P(a' | s, a, s') (and T(s' | s, a) when it is used) on the expert tuples (maximum likelihood).

        Called by the first ``learn``; call it yourself to fit without training the policy.
        Returns (and keeps in ``self.flow_report``) the chosen noise levels, step counts and
        held-out log-likelihoods (nats per tuple, raw units).
        """
        tup = self.expert_tuples()
        seed, train_idx, val_idx = self.model_fit_split(self.validation_fraction)
        common = dict(
            noise_grid=self.noise_grid,
            learning_rate=self.flow_learning_rate,
            batch_size=self.flow_batch_size,
            max_steps=self._max_steps(flow=True),
            eval_every=self.flow_eval_every,
            patience=self.flow_patience,
            min_delta=self.flow_min_delta,
            refit=self.flow_refit,
            seed=seed,
        )
        s, a, s_next, a_next = tup
        joint = self.estimator == "joint"
        with_t = joint or self.fit_transition  # T cancels from the factored target: fitted for diagnostics only
        if self.verbose >= 1:
            which = "P(s', a' | s, a)" if joint else "P(a' | s, a, s')"
            fitted = " and ".join([*(["T(s' | s, a)"] if with_t else []), which])
            print(f"MBIL: fitting {fitted} on {len(s)} expert tuples")
        report_t = None
        if with_t:
            t_settings = common if joint else {  # a cheaper fit for diagnostics
                **common, "noise_grid": self.transition_noise_grid or self.noise_grid, "refit": bool(self.transition_refit)}
            fitted_t, report_t = fit_conditional_density(
                self.flows.make_transition, *self.flows.transition_inputs(s, a, s_next), train_idx, val_idx,
                **t_settings, log=self._fit_log("T(s' | s, a)"),
            )
            self.flows.transition.load_state_dict(fitted_t.state_dict())
        if joint:  # the paper's literal estimator: one flow over (s', a')
            fitted_p, report_p = fit_conditional_density(
                self.flows.make_joint, *self.flows.joint_inputs(s, a, s_next, a_next), train_idx, val_idx, **common,
                log=self._fit_log("P(s', a' | s, a)"),
            )
            self.flows.joint.load_state_dict(fitted_p.state_dict())
            p_heldout_ll = report_p.heldout_ll
        else:
            fitted_p, report_p = fit_conditional_density(
                self.flows.make_next_action, *self.flows.next_action_inputs(s, a, s_next, a_next), train_idx, val_idx,
                **{**common, "max_steps": self._max_steps(flow=not self.flows.discrete)},
                log=self._fit_log("P(a' | s, a, s')"),
            )
            self.flows.next_action.load_state_dict(fitted_p.state_dict())
            # log P = log T + log P(a' | s, a, s'), on the same held-out tuples
            p_heldout_ll = report_t.heldout_ll + report_p.heldout_ll if report_t is not None else None
        self.flows.fitted.fill_(True)
        self.flows.eval()
        self.flow_report = {
            "transition": report_t.as_dict() if report_t is not None else None,  # None: T not fitted
            "next_action": report_p.as_dict(),  # with estimator="joint": the joint flow P(s', a' | s, a)
            "p_heldout_ll": p_heldout_ll,
            "transition_heldout_ll": report_t.heldout_ll if report_t is not None else None,
            "fit_seconds": (report_t.seconds if report_t is not None else 0.0) + report_p.seconds,
            "n_tuples": len(s),
            "n_heldout": len(val_idx),
            "estimator": self.estimator,
        }
        self._targets = None
        return self.flow_report

    def _max_steps(self, flow: bool) -> int:
        """``flow_max_steps`` of one fit: with ``"auto"``, 1 000 for a flow and 300 for the categorical P."""
        if self.flow_max_steps != "auto":
            return self.flow_max_steps
        return 1000 if flow else 300

    @th.no_grad()
    def balance_target(self, s: th.Tensor, a: th.Tensor, s_next: th.Tensor, a_next: th.Tensor) -> th.Tensor:
        """log P(s', a' | s, a) - log T(s' | s, a) per tuple, floored at ``log_density_floor``."""
        if not bool(self.flows.fitted):
            raise RuntimeError("the flows are not fitted yet: call fit_flows() or learn()")
        if self.estimator == "joint":  # log P_joint(s', a' | s, a) - log T(s' | s, a), two fitted flows
            def target_of(*chunk):
                return self.flows.log_p_joint(*chunk) - self.flows.log_t(*chunk[:3])
        else:  # T cancels: log P(a' | s, a, s')
            target_of = self.flows.log_p_next_action
        parts = [
            target_of(s[i : i + EVAL_CHUNK], a[i : i + EVAL_CHUNK], s_next[i : i + EVAL_CHUNK], a_next[i : i + EVAL_CHUNK])
            for i in range(0, len(s), EVAL_CHUNK)
        ]
        target = th.cat(parts)
        return th.nan_to_num(target, nan=self.log_density_floor).clamp(min=self.log_density_floor)

    def tuple_targets(self) -> th.Tensor:
        """The balance target of every expert tuple (what the policy's log pi(a' | s') is regressed on); computed
        once per fitted flows and data."""
        if self._targets is None:
            self._targets = self.balance_target(*self.expert_tuples())
        return self._targets

    @th.no_grad()
    def validation_losses(self, expert_data: ExpertData) -> dict[str, float]:
        """The behaviour-cloning loss and the balance loss E[(target - log pi(a'|s'))^2] on (held-out) expert data."""
        losses = super().validation_losses(expert_data)
        if bool(self.flows.fitted):
            s, a, s_next, a_next = self.tuple_tensors(expert_data)
            residual = self.balance_target(s, a, s_next, a_next) - self.policy.log_prob(s_next, a_next)
            losses["balance_loss"] = float(residual.pow(2).mean())
        return losses

    @th.no_grad()
    def balance_diagnostics(self) -> dict[str, Any]:
        """How the current policy meets the balance target on the expert tuples (nats; Box: also the mean's share).

        ``residual_mse`` is the balance loss over all tuples, E[(t - log pi(a' | s'))^2] with t the
        target. For a Gaussian pi, log pi(a' | s') = log pi_max(s') - q with log pi_max(s') =
        -sum(log std) - d/2 log(2 pi) (the density with the mean on a') and q = sum((a' - mean)^2 /
        (2 std^2)) >= 0: the policy can lower log pi either with its std or by moving its mean off the
        expert's action. ``mean_shift_nats`` is E[q] (the part moved by the mean),
        ``residual_mse_mean_on_action`` the balance loss if the mean sat on a' (std alone),
        ``unreachable_targets`` the tuples whose t is below the lowest log pi_max the log-std bound
        allows (only a moved mean reaches them), ``log_std_at_bound`` the share of log-std outputs at a
        bound (the clamp gives them no gradient there) and ``bc_mse`` the mean's squared error on the
        (s, a) pairs (the MSE behaviour-cloning term).
        """
        return balance_diagnostics(self)

    def diagnostics(self) -> dict[str, Any]:
        """The flows' fit: its seconds, the mean balance target, held-out log-likelihoods and P's chosen noise."""
        out = super().diagnostics()
        if self.flow_report:
            out.update(fit_seconds=self.flow_report["fit_seconds"], target_mean=round(float(self.tuple_targets().mean()), 4),
                       next_action_noise=self.flow_report["next_action"]["noise"])
            for key in ("p_heldout_ll", "transition_heldout_ll"):  # with T only (fit_transition or the joint estimator)
                if self.flow_report[key] is not None:
                    out[key] = round(self.flow_report[key], 4)
        return out

    # ------------------------------------------------------------------ policy
    def _prepare_training(self) -> None:
        if not bool(self.flows.fitted):
            self.fit_flows()
        self.tuple_targets()
        if self.flow_report is not None:
            for key in ("p_heldout_ll", "transition_heldout_ll", "fit_seconds"):
                if self.flow_report[key] is not None:
                    self.logger.record(f"flows/{key}", self.flow_report[key])
            if self.flow_report["transition"] is not None:
                self.logger.record("flows/transition_noise", self.flow_report["transition"]["noise"])
            self.logger.record("flows/next_action_noise", self.flow_report["next_action"]["noise"])
        self.logger.record("flows/target_mean", float(self.tuple_targets().mean()))

    def _draw_batch(self) -> tuple[th.Tensor, ...]:
        """(s_i, a_i) expert pairs for the BC term and (s'_j, a'_j, target_j) expert tuples for the balance term (no
        rows for a term whose weight is 0)."""
        pairs, tuples = self.expert_pairs(), self.expert_tuples()
        i = self._sample_indices(len(pairs.observations)) if self.beta > 0 else self._no_rows
        j = self._sample_indices(len(tuples.observations)) if self.alpha > 0 else self._no_rows
        return (pairs.observations[i], pairs.actions[i], tuples.next_observations[j], tuples.next_actions[j],
                self._targets[j])

    def _policy_inputs(self, batch: tuple[th.Tensor, ...]) -> th.Tensor:
        # pi at the expert states s (BC term) and next states s' (balance term), in one forward pass
        return th.cat([batch[0], batch[2]])

    def _loss_from_heads(self, batch: tuple[th.Tensor, ...], heads: tuple[th.Tensor, ...]) -> th.Tensor:
        states, actions, next_states, next_actions, targets = batch
        n = len(states)
        heads_s, heads_next = [h[:n] for h in heads], [h[n:] for h in heads]
        loss = th.zeros((), device=self.device)

        # Balance term: E[(log P(s',a'|s,a) - log T(s'|s,a) - log pi(a'|s'))^2], the first two cached per tuple.
        if self.alpha > 0:
            residual = targets - self.policy.log_prob_from_heads(heads_next, next_actions)
            balance_loss = residual.pow(2).mean()
            loss = loss + self.alpha * balance_loss
            self._record("train/balance_loss", balance_loss)
            self._record("train/residual_mean", residual.detach().mean())

        # BC term: L_BC(pi, D) on the expert's (s, a) pairs.
        if self.beta > 0:
            bc = bc_loss(self.policy, heads_s, actions, self._bc_kind)
            loss = loss + self.beta * bc
            self._record("train/bc_loss", bc)
        return loss

    @property
    def _no_rows(self) -> th.Tensor:
        return th.zeros(0, dtype=th.long, device=self.device)
