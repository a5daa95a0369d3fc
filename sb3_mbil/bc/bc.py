"""Behaviour cloning, strictly offline, as an SB3 algorithm (the baseline of every imitation paper)."""

from __future__ import annotations

from typing import Any

import torch as th
from stable_baselines3.common.type_aliases import GymEnv, Schedule

from sb3_mbil.common.demonstrations import ExpertData
from sb3_mbil.common.losses import (
    bc_loss,
    check_discrete_weight,
    check_logit_penalty,
    logit_penalty,
    resolve_bc_loss,
    uniform_cross_entropy,
)
from sb3_mbil.common.offline import OfflineAlgorithm
from sb3_mbil.common.policies import ImitationPolicy
from sb3_mbil.common.type_aliases import PairSamples
from sb3_mbil.common.validation import check_real


class BC(OfflineAlgorithm):
    """Behaviour cloning: minimise L_BC(pi, D) on the expert's (s, a) pairs.

    L_BC is the negative log-likelihood -E log pi(a|s) (Discrete; ``bc_loss="nll"`` also for the
    Gaussian policy on Box actions) or the mean squared error of the mean action (Box, default).
    With MSE and one trajectory, weight decay (about 1e-3) keeps BC from collapsing late in
    training (Li et al., 2022). For Discrete actions, ``logit_penalty`` (lambda) adds d3rlpy's DiscreteBC
    regulariser, lambda * mean over the minibatch and the actions of logits(s)^2 (d3rlpy's default: 0.5):

        min_theta  L_BC(pi_theta, D) + lambda * E_{s ~ D} mean_a logits_theta(s, a)^2

    ``observation_noise`` (sigma) trains on s + sigma * std(s) * eps, eps ~ N(0, I), with the expert's action kept
    (std per dimension over the expert states): a smoothness prior that labels states near the expert's with the
    expert's action.

    ``label_smoothing`` (epsilon, Discrete) fits the soft label (1 - epsilon) onehot(a) + epsilon / K (K actions)
    instead of onehot(a), torch's ``cross_entropy(label_smoothing=...)``:

        min_theta  (1 - epsilon) L_BC(pi_theta, D) + epsilon * E_{s ~ D}[-(1/K) sum_b log pi_theta(b|s)]

    It is the control of MBIL-C's soft labels beta * onehot(a) + alpha * w * P(. | s, a, s'): the same
    kind of target with a label that knows nothing of the expert.

    :param policy: ``"MlpPolicy"`` or a policy class
    :param env: the env or its id (spaces and evaluation only; never stepped while learning)
    :param expert_data: demonstrations (see :func:`sb3_mbil.as_demonstrations`)
    :param learning_rate: Adam learning rate (constant or schedule)
    :param batch_size: minibatch size
    :param bc_loss: ``"auto"`` (NLL for Discrete, MSE for Box), ``"nll"``, ``"mse"`` or ``"tanh_nll"`` (Box with
        ``policy_kwargs=dict(bounded_mean=True)``: the NLL of the tanh-squashed Gaussian, ValueDICE's and Li et al.'s
        BC, actions within 1e-4 of a bound clipped)
    :param weight_decay: Adam weight decay of the policy
    :param logit_penalty: (Discrete) weight lambda of the squared logits (0: none)
    :param label_smoothing: (Discrete) epsilon in [0, 1], the uniform label's share of the target (0: none)
    :param observation_noise: sigma, std of the Gaussian noise on each minibatch's expert states in units of the expert
        states' std per dimension (0: none)
    :param policy_kwargs: policy keyword arguments (``net_arch``, ...)
    :param tensorboard_log: tensorboard folder
    :param verbose: verbosity
    :param seed: random seed
    :param device: torch device
    :param _init_setup_model: build the networks at construction
    """

    def __init__(
        self,
        policy: str | type[ImitationPolicy],
        env: GymEnv | str | None,
        expert_data: ExpertData | None = None,
        learning_rate: float | Schedule = 1e-3,
        batch_size: int = 64,
        bc_loss: str = "auto",
        weight_decay: float = 0.0,
        logit_penalty: float = 0.0,
        observation_noise: float = 0.0,
        label_smoothing: float = 0.0,
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
        self.bc_loss = bc_loss
        self.logit_penalty = logit_penalty
        self.observation_noise = observation_noise
        self.label_smoothing = label_smoothing
        if _init_setup_model:
            self._setup_model()

    def _check_hyperparameters(self) -> None:
        super()._check_hyperparameters()
        self._bc_kind = resolve_bc_loss(self.bc_loss, self.action_space,
                                        bounded_mean=bool((self.policy_kwargs or {}).get("bounded_mean", False)))
        self.logit_penalty = check_logit_penalty(self.logit_penalty, self.action_space)
        self.observation_noise = check_real("observation_noise", self.observation_noise, low=0.0)
        self.label_smoothing = check_discrete_weight("label_smoothing", self.label_smoothing, self.action_space, high=1.0)

    def _on_new_data(self) -> None:
        super()._on_new_data()
        self._obs_scale: th.Tensor | None = None  # the expert states' std per dimension (observation_noise)

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "_obs_scale"]

    def _draw_batch(self) -> PairSamples:
        """The minibatch of expert pairs, its states noised when ``observation_noise`` > 0."""
        pairs = self.expert_pairs()
        batch = self.sample(pairs)
        if self.observation_noise <= 0:
            return batch
        if self._obs_scale is None:
            self._obs_scale = pairs.observations.flatten(1).std(0, unbiased=False).view_as(batch.observations[0])
        noise = th.randn(batch.observations.shape, generator=self._generator(), dtype=batch.observations.dtype,
                         device=batch.observations.device)
        # s + sigma * std(s) * eps, the expert's action kept
        return PairSamples(batch.observations + self.observation_noise * self._obs_scale * noise, batch.actions)

    def _policy_inputs(self, batch: PairSamples) -> th.Tensor:
        return batch.observations

    def _raw_heads(self) -> bool:
        return self._bc_kind == "tanh_nll"  # the squashed Gaussian's likelihood is written in its pre-squash parameters

    def _loss_from_heads(self, batch: PairSamples, heads: tuple[th.Tensor, ...]) -> th.Tensor:
        # BC term: L_BC(pi, D).
        loss = bc_loss(self.policy, heads, batch.actions, self._bc_kind)
        self._record("train/bc_loss", loss)

        # Label smoothing (Discrete): the cross-entropy against (1 - epsilon) onehot(a) + epsilon / K.
        if self.label_smoothing > 0:
            uniform = uniform_cross_entropy(heads)
            loss = (1.0 - self.label_smoothing) * loss + self.label_smoothing * uniform
            self._record("train/uniform_cross_entropy", uniform)

        # Logit penalty (Discrete): lambda * mean of the squared logits.
        if self.logit_penalty > 0:
            penalty = logit_penalty(heads)
            loss = loss + self.logit_penalty * penalty
            self._record("train/logit_penalty", penalty)
        return loss
