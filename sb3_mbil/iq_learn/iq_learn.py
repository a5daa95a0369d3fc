"""IQ-Learn: inverse soft-Q learning (Garg, Chakraborty, Cundy, Song, Ermon, NeurIPS 2021), strictly offline."""

from __future__ import annotations

from typing import Any, ClassVar

import torch as th
from gymnasium import spaces
from stable_baselines3.common.type_aliases import GymEnv, Schedule
from torch import nn

from sb3_mbil.common.demonstrations import ExpertData
from sb3_mbil.common.networks import MlpCritic, make_target, q_at, soft_q, soft_update
from sb3_mbil.common.offline import OfflineAlgorithm
from sb3_mbil.common.policies import ImitationPolicy
from sb3_mbil.common.type_aliases import TransitionSamples
from sb3_mbil.common.validation import check_real, check_sizes


class IQLearn(OfflineAlgorithm):
    """Inverse soft-Q learning, offline, on expert batches only.

    Paper: "IQ-Learn: Inverse soft-Q Learning for Imitation" (Garg et al., NeurIPS 2021). Discrete and Box.

    One soft Q-function stands for both the reward and the policy. On expert transitions (s, a, s', done),
    with y = gamma (1 - done) V(s') (its ``value_expert`` loss and the chi^2 regulariser):

        L(Q) = -E[Q(s, a) - y] + E[V(s) - y] + 1 / (4 alpha) E[(Q(s, a) - y)^2],   alpha = 0.5

    * Discrete: Q(s, .) is the policy's logits, V(s) = t logsumexp(Q(s, .) / t), pi = softmax(Q / t);
      no target network, as in its code. ``predict`` is greedy in Q (its code samples even when
      evaluating: a deviation, so that every algorithm here is evaluated the same way).
    * Box: a critic Q(s, a) with a target copy (tau), V(s) = Q(s, a~) - t log pi(a~ | s) with a~ ~ pi(s)
      (the target critic for V(s')), and a SAC-style actor on the expert states,
      min E_s[t log pi(a~ | s) - Q(s, a~)]. Deviations: the actor is this package's Gaussian policy
      (its mean bounded into the action box, ``bounded_mean``), sampled actions are clipped to the
      bounds rather than tanh-squashed, one critic instead of a twin, and a fixed temperature t.

    The critic is known to diverge strictly offline (its issues 5, 11, 13, 14): ``train/q_expert``,
    ``train/q_random`` (Q at uniformly random actions) and ``train/v_expert`` are logged so that a
    reader sees it, and a non-finite loss stops training with a clear error.

    :param policy: ``"MlpPolicy"`` or a policy class
    :param env: the env or its id (spaces and evaluation only; never stepped while learning)
    :param expert_data: demonstrations (see :func:`sb3_mbil.as_demonstrations`)
    :param learning_rate: Adam learning rate of Q (Discrete) or of the actor (Box)
    :param batch_size: minibatch size of expert transitions
    :param gamma: discount
    :param alpha: the chi^2 regulariser's alpha (the weight is 1 / (4 alpha))
    :param temperature: t, the soft value's temperature (entropy weight)
    :param critic_learning_rate: (Box) Adam learning rate of the critic
    :param critic_arch: (Box) hidden sizes of the critic
    :param tau: (Box) target critic update rate
    :param weight_decay: Adam weight decay
    :param policy_kwargs: policy keyword arguments (``net_arch``, ...)
    :param tensorboard_log: tensorboard folder
    :param verbose: verbosity
    :param seed: random seed
    :param device: torch device
    :param _init_setup_model: build the networks at construction
    """

    supported_action_spaces: ClassVar[tuple[type[spaces.Space], ...]] = (spaces.Discrete, spaces.Box)
    default_policy_kwargs: ClassVar[dict[str, Any]] = {"activation_fn": nn.ELU}
    critic: MlpCritic | None
    critic_target: MlpCritic | None

    def __init__(
        self,
        policy: str | type[ImitationPolicy],
        env: GymEnv | str | None,
        expert_data: ExpertData | None = None,
        learning_rate: float | Schedule = 1e-4,
        batch_size: int = 32,
        gamma: float = 0.99,
        alpha: float = 0.5,
        temperature: float = 0.01,
        critic_learning_rate: float = 3e-4,
        critic_arch: list[int] | tuple[int, ...] = (256, 256),
        tau: float = 0.005,
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
        self.alpha = alpha
        self.temperature = temperature
        self.critic_learning_rate = critic_learning_rate
        self.critic_arch = critic_arch
        self.tau = tau
        if _init_setup_model:
            self._setup_model()

    def _check_hyperparameters(self) -> None:
        super()._check_hyperparameters()
        self.gamma = check_real("gamma", self.gamma, low=0.0, high=1.0)
        self.alpha = check_real("alpha", self.alpha, low=0.0, low_open=True)
        self.temperature = check_real("temperature", self.temperature, low=0.0, low_open=True)
        self.critic_learning_rate = check_real("critic_learning_rate", self.critic_learning_rate, low=0.0, low_open=True)
        self.critic_arch = check_sizes("critic_arch", self.critic_arch)
        self.tau = check_real("tau", self.tau, low=0.0, high=1.0, low_open=True)

    def _setup_model(self) -> None:
        if isinstance(self.action_space, spaces.Box):
            self.policy_kwargs = {"bounded_mean": True, **self.policy_kwargs}
        super()._setup_model()
        self.critic = self.critic_target = None
        if isinstance(self.action_space, spaces.Box):
            obs_dim = self.policy.features_extractor.features_dim
            act_dim = int(self.action_space.shape[0])
            self.critic = MlpCritic(obs_dim, 1, act_dim, self.critic_arch, nn.ReLU).to(self.device)
            self.critic.optimizer = th.optim.Adam(self.critic.parameters(), lr=self.critic_learning_rate,
                                                  weight_decay=self.weight_decay)
            self.critic_target = make_target(self.critic)

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        names, others = super()._get_torch_save_params()
        if isinstance(self.action_space, spaces.Box):
            names = [*names, "critic", "critic.optimizer", "critic_target"]
        return names, others

    # ------------------------------------------------------------------ values
    def _box_value(self, critic: MlpCritic, obs: th.Tensor, heads: tuple[th.Tensor, ...] | None = None
                   ) -> tuple[th.Tensor, th.Tensor, th.Tensor]:
        """(V(s), log pi(a~ | s), Q(s, a~)) with a~ ~ pi(s) reparameterised and clipped to the bounds (``heads``: the
        policy's outputs at ``obs`` if already computed, e.g. without gradient)."""
        mean, log_std = self.policy.heads(obs) if heads is None else heads
        sample = mean + th.randn_like(mean) * log_std.exp()
        log_pi = self.policy.log_prob_from_heads((mean, log_std), sample)
        low, high = self.policy.action_center - self.policy.action_half_range, self.policy.action_center + self.policy.action_half_range
        q = critic(self.policy.features(obs), th.maximum(th.minimum(sample, high), low))[0].squeeze(-1)
        return q - self.temperature * log_pi, log_pi, q

    def supports_lockstep(self) -> bool:
        """Discrete only: Box actions train a critic and an actor with their own optimisers and draws."""
        return isinstance(self.action_space, spaces.Discrete)

    def _draw_batch(self) -> TransitionSamples:
        return self.sample(self.expert_transitions())

    def _policy_inputs(self, batch: TransitionSamples) -> th.Tensor:
        return th.cat([batch.observations, batch.next_observations])

    def _loss_from_heads(self, batch: TransitionSamples, heads: tuple[th.Tensor, ...]) -> th.Tensor:
        """Discrete: the IQ loss of the soft Q-function that is the policy's logits."""
        q_all, q_all_next = heads[0].chunk(2)
        q = q_at(q_all, batch.actions)
        v = soft_q(q_all, self.temperature)[1]
        v_next = soft_q(q_all_next, self.temperature)[1]
        return self._iq_loss(q, v, v_next, q_all.mean(dim=-1), batch)

    def _iq_loss(self, q: th.Tensor, v: th.Tensor, v_next: th.Tensor, q_random: th.Tensor,
                 batch: TransitionSamples) -> th.Tensor:
        """The IQ loss on expert transitions, y = gamma (1 - done) V(s')."""
        y = self.gamma * (1.0 - batch.dones) * v_next
        loss_expert = -(q - y).mean()
        loss_value = (v - y).mean()
        chi2 = (q - y).pow(2).mean() / (4.0 * self.alpha)
        critic_loss = loss_expert + loss_value + chi2
        self._record("train/critic_loss", critic_loss)
        self._record("train/chi2", chi2)
        self._record("train/q_expert", q.detach().mean())
        self._record("train/q_random", q_random.detach().mean())
        self._record("train/v_expert", v.detach().mean())
        return critic_loss

    def _train_step(self) -> None:
        if isinstance(self.action_space, spaces.Discrete):  # Q is pi's logits: one step of the policy's optimiser
            return super()._train_step()
        batch = self._draw_batch()
        features = self.policy.features(batch.observations)
        q = self.critic(features, batch.actions)[0].squeeze(-1)
        # V(s) = Q(s, a~) - t log pi(a~ | s): its gradient reaches Q (it pushes Q down at the policy's actions);
        # the actor's sample is held fixed here. V(s') comes from the target critic.
        with th.no_grad():
            policy_heads = self.policy.heads(batch.observations)
        v = self._box_value(self.critic, batch.observations, heads=policy_heads)[0]
        with th.no_grad():
            v_next = self._box_value(self.critic_target, batch.next_observations)[0]
            low = self.policy.action_center - self.policy.action_half_range
            random_actions = low + 2 * self.policy.action_half_range * th.rand_like(batch.actions.float())
            q_random = self.critic(features, random_actions)[0].squeeze(-1)
        critic_loss = self._iq_loss(q, v, v_next, q_random, batch)
        self.critic.optimizer.zero_grad(set_to_none=True)
        critic_loss.backward()
        self.critic.optimizer.step()
        self._actor_step(batch)

    def _actor_step(self, batch) -> None:
        """Box: the SAC-style actor on expert states, then the target critic's Polyak update."""
        # The SAC-style actor on expert states: min E[t log pi(a~ | s) - Q(s, a~)].
        value, log_pi, q_pi = self._box_value(self.critic, batch.observations)
        actor_loss = (self.temperature * log_pi - q_pi).mean()
        self.policy.optimizer.zero_grad(set_to_none=True)
        self.critic.optimizer.zero_grad(set_to_none=True)
        actor_loss.backward()
        self.policy.optimizer.step()
        soft_update(self.critic_target, self.critic, self.tau)
        self._record("train/actor_loss", actor_loss)
