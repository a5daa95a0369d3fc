"""ValueDICE (Kostrikov, Nachum, Tompson, ICLR 2020), strictly offline (replay regularisation 0)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any, ClassVar

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.type_aliases import GymEnv, Schedule
from torch import nn

from sb3_mbil.common.demonstrations import ExpertData
from sb3_mbil.common.networks import MlpCritic
from sb3_mbil.common.offline import OfflineAlgorithm
from sb3_mbil.common.policies import ImitationPolicy
from sb3_mbil.common.type_aliases import TransitionSamples
from sb3_mbil.common.validation import check_real, check_sizes


def orthogonal_regulariser(weights: Iterable[th.Tensor]) -> th.Tensor:
    """ValueDICE's actor regulariser: over the layers, the sum of the squared off-diagonal entries of the Gram matrix
    of the layer's output units.

    The reference (``keras_utils.orthogonal_regularization``) computes ``K^T K`` of each Keras kernel ``K``, whose
    shape is (inputs, outputs); a torch weight ``W`` is (outputs, inputs), so the same matrix is ``W W^T``.
    """
    total = th.zeros(())
    for weight in weights:
        gram = weight @ weight.T
        total = total + (gram - th.diag(th.diagonal(gram))).pow(2).sum()
    return total


class ValueDICE(OfflineAlgorithm):
    """ValueDICE, offline: distribution matching through a value function nu, no replay data.

    Paper: "Imitation Learning via Off-Policy Distribution Matching" (Kostrikov, Nachum, Tompson, ICLR 2020).
    Box, and Discrete through a Gumbel-softmax actor (as in the published classic-control comparison).

    With replay regularisation 0 the objective is, over expert transitions (s, a, s') and expert states s0
    (every expert state an initial state),

        J(pi, nu) = log E_D[exp(nu(s, a) - gamma nu(s', a'))] - (1 - gamma) E_{s0}[nu(s0, a0)],
        a' ~ pi(s'), a0 ~ pi(s0) (reparameterised samples),

    nu minimises J and pi maximises J - its orthogonal regulariser (weight ``orthogonal_weight``).
    The log-E-exp is over the minibatch (the biased minibatch estimate of the paper's code).

    Absorbing states: the states get an indicator dimension; a transition that ends an episode by
    termination (not by the time limit) leads to the absorbing state, which leads to itself with a zero
    action; time-limit ends bootstrap as usual. pi is never asked to act in the absorbing state (its
    action there is the zero action). The gradient penalty of the paper interpolates expert and replay inputs;
    offline there are no replay inputs, and the public offline port of the reference code that we could read
    (gkswamy98/valuedice, the classic-control setting: Gumbel-softmax actor, 2x64 networks) keeps the penalty at
    its weight 10 and interpolates each expert input (s, a) with a shuffled (s', a' ~ pi) of the same minibatch.
    So does this class: ``gradient_penalty * E[(||grad_x nu(x)|| - 1)^2]`` is added to nu's loss (weight 10 by
    default; 0 drops it, as DeepMind's Acme does offline).
    Networks: nu and the actor 2x256 ReLU (Box; 2x64 for Discrete, set in the zoo settings), orthogonal
    initialisation; tanh-Gaussian actor (its mean squashed into the action bounds: ``predict``
    returns the squashed mean), log-std in [-5, 2]; Adam 1e-3 (nu) and 1e-5 (actor), batch 256, gamma 0.99,
    orthogonal regulariser 1e-4 (:func:`orthogonal_regulariser` over :meth:`actor_weights`); states standardised with
    the expert's statistics. Deviations from the reference code: the log-std is clamped to [-5, 2] where the
    reference maps it there through a tanh; minibatches are drawn with replacement and the initial states are a
    second draw of expert states (the reference reuses the minibatch's states).

    :param policy: ``"MlpPolicy"`` or a policy class
    :param env: the env or its id (spaces and evaluation only; never stepped while learning)
    :param expert_data: demonstrations (see :func:`sb3_mbil.as_demonstrations`)
    :param learning_rate: Adam learning rate of the actor (constant or schedule)
    :param batch_size: minibatch size of expert transitions (and of initial states)
    :param gamma: discount
    :param nu_learning_rate: Adam learning rate of nu
    :param nu_arch: hidden sizes of nu
    :param orthogonal_weight: weight of the actor's orthogonal regulariser
    :param gradient_penalty: weight of nu's gradient penalty between (s, a) and (s', a' ~ pi) inputs (0: none)
    :param gumbel_temperature: (Discrete) temperature of the Gumbel-softmax samples
    :param weight_decay: Adam weight decay of the actor
    :param policy_kwargs: policy keyword arguments (``net_arch``, ...)
    :param tensorboard_log: tensorboard folder
    :param verbose: verbosity
    :param seed: random seed
    :param device: torch device
    :param _init_setup_model: build the networks at construction
    """

    supported_action_spaces: ClassVar[tuple[type[spaces.Space], ...]] = (spaces.Discrete, spaces.Box)
    default_policy_kwargs: ClassVar[dict[str, Any]] = {"net_arch": [256, 256], "normalize_observations": True}
    nu: MlpCritic

    def __init__(
        self,
        policy: str | type[ImitationPolicy],
        env: GymEnv | str | None,
        expert_data: ExpertData | None = None,
        learning_rate: float | Schedule = 1e-5,
        batch_size: int = 256,
        gamma: float = 0.99,
        nu_learning_rate: float = 1e-3,
        nu_arch: list[int] | tuple[int, ...] = (256, 256),
        orthogonal_weight: float = 1e-4,
        gradient_penalty: float = 10.0,
        gumbel_temperature: float = 1.0,
        weight_decay: float = 0.0,
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
        self.gamma = gamma
        self.nu_learning_rate = nu_learning_rate
        self.nu_arch = nu_arch
        self.orthogonal_weight = orthogonal_weight
        self.gradient_penalty = gradient_penalty
        self.gumbel_temperature = gumbel_temperature
        if _init_setup_model:
            self._setup_model()

    def _check_hyperparameters(self) -> None:
        super()._check_hyperparameters()
        self.gamma = check_real("gamma", self.gamma, low=0.0, high=1.0, high_open=True)
        self.nu_learning_rate = check_real("nu_learning_rate", self.nu_learning_rate, low=0.0, low_open=True)
        self.nu_arch = check_sizes("nu_arch", self.nu_arch)
        self.orthogonal_weight = check_real("orthogonal_weight", self.orthogonal_weight, low=0.0)
        self.gradient_penalty = check_real("gradient_penalty", self.gradient_penalty, low=0.0)
        self.gumbel_temperature = check_real("gumbel_temperature", self.gumbel_temperature, low=0.0, low_open=True)

    @property
    def _discrete(self) -> bool:
        return isinstance(self.action_space, spaces.Discrete)

    def _setup_model(self) -> None:
        if not self._discrete:
            self.policy_kwargs = {"bounded_mean": True, **self.policy_kwargs}
        super()._setup_model()
        self._action_dim = int(self.action_space.n) if self._discrete else int(np.prod(self.action_space.shape))
        obs_dim = self.policy.features_extractor.features_dim + 1  # + the absorbing indicator
        self.nu = MlpCritic(obs_dim, 1, self._action_dim, self.nu_arch, nn.ReLU).to(self.device)
        for module in (self.nu, self.policy):  # orthogonal initialisation, as in the reference code
            for layer in module.modules():
                if isinstance(layer, nn.Linear):
                    nn.init.orthogonal_(layer.weight)
                    nn.init.zeros_(layer.bias)
        self.nu.optimizer = th.optim.Adam(self.nu.parameters(), lr=self.nu_learning_rate)

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        names, others = super()._get_torch_save_params()
        return [*names, "nu", "nu.optimizer"], others

    # ------------------------------------------------------------------ data
    def absorbing_transitions(self) -> tuple[TransitionSamples, th.Tensor, th.Tensor]:
        """Expert transitions with absorbing states: (transitions, absorbing(s), absorbing(s')), cached.

        A terminated transition leads to the absorbing state (observation zeros, indicator 1); one
        absorbing -> absorbing transition with the zero action is added per terminated episode.
        """
        key = "valuedice_absorbing"
        if key not in self._expert_cache:
            t = self.expert_transitions()
            done = t.dones.bool()
            n_extra = int(done.sum())
            zeros_obs = th.zeros((n_extra, *t.observations.shape[1:]), device=self.device)
            zero_act = th.zeros((n_extra, *t.actions.shape[1:]), dtype=t.actions.dtype, device=self.device)
            obs = th.cat([t.observations, zeros_obs])
            acts = th.cat([t.actions, zero_act])
            next_obs = th.cat([th.where(done.view(-1, *[1] * (t.next_observations.dim() - 1)),
                                        th.zeros_like(t.next_observations), t.next_observations), zeros_obs])
            absorbing = th.cat([th.zeros(len(done), device=self.device), th.ones(n_extra, device=self.device)])
            next_absorbing = th.cat([done.float(), th.ones(n_extra, device=self.device)])
            self._expert_cache[key] = (TransitionSamples(obs, acts, next_obs, th.zeros_like(next_absorbing)),
                                       absorbing, next_absorbing)
        return self._expert_cache[key]

    # ------------------------------------------------------------------ networks
    def actor_weights(self) -> list[th.Tensor]:
        """The actor's layers as the reference's trunk has them: the hidden layers, then one output layer (for Box the
        mean and log-std heads stacked, the reference's single ``Dense(2 * action_dim)``)."""
        hidden = [layer.weight for layer in self.policy.latent.modules() if isinstance(layer, nn.Linear)]
        if self._discrete:
            return [*hidden, self.policy.logits_head.weight]
        return [*hidden, th.cat([self.policy.mean_head.weight, self.policy.log_std_head.weight])]

    def _action_features(self, actions: th.Tensor) -> th.Tensor:
        """Actions as nu's input: one-hot (Discrete) or flat (Box)."""
        if self._discrete:
            return nn.functional.one_hot(actions.long().view(-1), self._action_dim).float()
        return actions.float().view(len(actions), -1)

    def _sample_actions(self, obs: th.Tensor) -> th.Tensor:
        """Reparameterised actions of pi: a relaxed one-hot (Gumbel-softmax) or a tanh-Gaussian sample."""
        if self._discrete:
            return nn.functional.gumbel_softmax(self.policy.logits(obs), tau=self.gumbel_temperature, hard=False)
        raw, log_std = self.policy.raw_heads(obs)
        return self.policy.squash(raw + th.randn_like(raw) * log_std.exp())

    def _nu_inputs(self, obs: th.Tensor, absorbing: th.Tensor, action_features: th.Tensor) -> th.Tensor:
        """nu's input: the standardised state (zeros in the absorbing state), the absorbing indicator, the action."""
        features = self.policy.features(obs) * (1.0 - absorbing).unsqueeze(-1)
        return th.cat([features, absorbing.unsqueeze(-1), action_features], dim=1)

    def _nu(self, inputs: th.Tensor) -> th.Tensor:
        n_state = inputs.shape[1] - self._action_dim
        return self.nu(inputs[:, :n_state], inputs[:, n_state:])[0].squeeze(-1)

    def _train_step(self) -> None:
        transitions, absorbing, next_absorbing = self.absorbing_transitions()
        i = self._sample_indices(len(absorbing))
        pairs = self.expert_pairs()
        j = self._sample_indices(len(pairs.observations))  # initial states: every expert state
        s, a, s_next = transitions.observations[i], transitions.actions[i], transitions.next_observations[i]
        absorbing_i, next_absorbing_i = absorbing[i], next_absorbing[i]
        s0 = pairs.observations[j]

        # pi's actions at s' (the zero action in the absorbing state) and at the initial states
        a_next = self._sample_actions(s_next) * (1.0 - next_absorbing_i).unsqueeze(-1)
        a0 = self._sample_actions(s0)

        # The ValueDICE objective J(pi, nu).
        # the absorbing state's action is the zero vector (for Discrete too, not the one-hot of action 0)
        expert_inputs = self._nu_inputs(s, absorbing_i, self._action_features(a) * (1.0 - absorbing_i).unsqueeze(-1))
        next_inputs = self._nu_inputs(s_next, next_absorbing_i, a_next)
        nu_expert = self._nu(expert_inputs)
        nu_next = self._nu(next_inputs)
        nu_initial = self._nu(self._nu_inputs(s0, th.zeros(len(s0), device=self.device), a0))
        residual = nu_expert - self.gamma * nu_next
        nonlinear = th.logsumexp(residual, dim=0) - np.log(len(residual))
        linear = (1.0 - self.gamma) * nu_initial.mean()
        objective = nonlinear - linear

        # The actor's orthogonal regulariser.
        orthogonal = orthogonal_regulariser(self.actor_weights())

        # nu's gradient penalty: E[(||grad_x nu(x)|| - 1)^2] at x = u (s, a) + (1 - u) (s', a' ~ pi) of a shuffled
        # row of the batch, u ~ U(0, 1) per row (the offline reference's pairing; pi gets no gradient from it).
        penalty = th.zeros((), device=self.device)
        if self.gradient_penalty > 0:
            partner = next_inputs.detach()[th.randperm(len(next_inputs), device=self.device)]
            mix = th.rand(len(partner), 1, device=self.device)
            between = (mix * expert_inputs.detach() + (1.0 - mix) * partner).requires_grad_(True)
            (grad_x,) = th.autograd.grad(self._nu(between).sum(), between, create_graph=True)
            penalty = (grad_x.norm(dim=1) - 1.0).pow(2).mean()

        # nu descends J; pi ascends J - orthogonal_weight * R(pi).
        nu_params = list(self.nu.parameters())
        pi_params = [p for p in self.policy.parameters() if p.requires_grad]
        nu_grads = th.autograd.grad(objective + self.gradient_penalty * penalty, nu_params, retain_graph=True)
        pi_grads = th.autograd.grad(-objective + self.orthogonal_weight * orthogonal, pi_params, allow_unused=True)
        for p, g in zip(nu_params, nu_grads):
            p.grad = g
        for p, g in zip(pi_params, pi_grads):
            p.grad = g
        self.nu.optimizer.step()
        self.policy.optimizer.step()
        self._record("train/objective", objective)
        self._record("train/nu_expert", nu_expert.detach().mean())
        self._record("train/nu_initial", nu_initial.detach().mean())
        self._record("train/orthogonal", orthogonal)
        if self.gradient_penalty > 0:
            self._record("train/gradient_penalty", penalty)
