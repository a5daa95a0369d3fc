"""AVRIL: approximate variational reward imitation learning (Chan and van der Schaar, ICLR 2021), strictly offline."""

from __future__ import annotations

import math
from typing import Any, ClassVar

import torch as th
from gymnasium import spaces
from stable_baselines3.common.type_aliases import GymEnv, Schedule
from torch import nn

from sb3_mbil.avril.policies import RewardEncoder
from sb3_mbil.common.demonstrations import ExpertData
from sb3_mbil.common.networks import q_at
from sb3_mbil.common.offline import OfflineAlgorithm
from sb3_mbil.common.policies import ImitationPolicy
from sb3_mbil.common.validation import check_real, check_sizes

LOG_2PI = math.log(2 * math.pi)


class AVRIL(OfflineAlgorithm):
    """Approximate variational reward imitation learning.

    Paper: "Scalable Bayesian Inverse Reinforcement Learning" (Chan and van der Schaar, ICLR 2021).
    Discrete actions.

    The policy's logits are a Q-function, pi(a|s) = softmax(Q(s, .))[a]; an encoder gives a Gaussian
    posterior over the reward, q(R(s, a)) = N(mu(s)[a], sigma(s)[a]^2). On consecutive expert tuples
    (s, a, s', a') the loss is the negative ELBO

        L = -log pi(a|s) + KL(q(R(s, a)) || N(0, 1)) - lambda * log q(Q(s, a) - gamma Q(s', a'))

    i.e. the TD residual of Q is explained by the reward posterior. Gradients reach Q through both
    Q(s, a) and Q(s', a') (no target network), as in the reference code. Defaults are the reference
    settings: no discount (gamma = 1), weight 1 on every term, Q and encoder 2x64 ELU, Adam 1e-4,
    batch 64, every consecutive tuple of the full trajectories (the last step of each trajectory has
    no a' and is dropped).

    :param policy: ``"MlpPolicy"`` or a policy class
    :param env: the env or its id (spaces and evaluation only; never stepped while learning)
    :param expert_data: demonstrations (see :func:`sb3_mbil.as_demonstrations`)
    :param learning_rate: Adam learning rate of Q and the encoder (constant or schedule)
    :param batch_size: minibatch size of expert tuples
    :param gamma: discount in the TD residual (1 in the reference code)
    :param reward_weight: lambda, the weight of the TD likelihood term
    :param encoder_arch: hidden sizes of the reward encoder
    :param weight_decay: Adam weight decay of Q and the encoder
    :param policy_kwargs: policy keyword arguments (``net_arch``, ...)
    :param tensorboard_log: tensorboard folder
    :param verbose: verbosity
    :param seed: random seed
    :param device: torch device
    :param _init_setup_model: build the networks at construction
    """

    supported_action_spaces: ClassVar[tuple[type[spaces.Space], ...]] = (spaces.Discrete,)
    default_policy_kwargs: ClassVar[dict[str, Any]] = {"activation_fn": nn.ELU}
    encoder: RewardEncoder

    def __init__(
        self,
        policy: str | type[ImitationPolicy],
        env: GymEnv | str | None,
        expert_data: ExpertData | None = None,
        learning_rate: float | Schedule = 1e-4,
        batch_size: int = 64,
        gamma: float = 1.0,
        reward_weight: float = 1.0,
        encoder_arch: list[int] | tuple[int, ...] = (64, 64),
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
        self.reward_weight = reward_weight
        self.encoder_arch = encoder_arch
        if _init_setup_model:
            self._setup_model()

    def _check_hyperparameters(self) -> None:
        super()._check_hyperparameters()
        self.gamma = check_real("gamma", self.gamma, low=0.0, high=1.0)
        self.reward_weight = check_real("reward_weight", self.reward_weight, low=0.0)
        self.encoder_arch = check_sizes("encoder_arch", self.encoder_arch)

    def _setup_model(self) -> None:
        super()._setup_model()
        n_actions = int(self.action_space.n)
        obs_dim = int(self.policy.features_extractor.features_dim)
        self.encoder = RewardEncoder(obs_dim, 2 * n_actions, net_arch=self.encoder_arch, activation_fn=nn.ELU).to(self.device)
        self.encoder.optimizer = th.optim.Adam(self.encoder.parameters(), lr=self.lr_schedule(1), weight_decay=self.weight_decay)

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        names, others = super()._get_torch_save_params()
        return [*names, "encoder", "encoder.optimizer"], others

    def _optimizers(self) -> list[th.optim.Optimizer]:
        return [*super()._optimizers(), self.encoder.optimizer]

    def reward_posterior(self, obs: th.Tensor, actions: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        """Mean and log-std of q(R(s, a))."""
        out = self.encoder(self.policy.features(obs))[0]
        mu, log_sigma = out.chunk(2, dim=-1)
        return q_at(mu, actions), q_at(log_sigma, actions)

    def _train_step(self) -> None:
        batch = self.sample(self.expert_tuples())
        q_all = self.policy.logits(th.cat([batch.observations, batch.next_observations]))
        q, q_next = q_all.chunk(2)

        # Policy term: -log pi(a|s), pi = softmax(Q(s, .)).
        nll = nn.functional.cross_entropy(q, batch.actions)

        # Reward prior: KL(N(mu, sigma^2) || N(0, 1)) at (s, a).
        mu, log_sigma = self.reward_posterior(batch.observations, batch.actions)
        kl = (0.5 * (th.exp(2 * log_sigma) + mu.pow(2) - 1.0) - log_sigma).mean()

        # TD likelihood: log N(Q(s, a) - gamma Q(s', a'); mu, sigma).
        td = q_at(q, batch.actions) - self.gamma * q_at(q_next, batch.next_actions)
        td_ll = (-0.5 * ((td - mu) * th.exp(-log_sigma)).pow(2) - log_sigma - 0.5 * LOG_2PI).mean()

        loss = nll + kl - self.reward_weight * td_ll
        self.policy.optimizer.zero_grad(set_to_none=True)
        self.encoder.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.policy.optimizer.step()
        self.encoder.optimizer.step()
        self._record("train/bc_loss", nll)
        self._record("train/reward_kl", kl)
        self._record("train/td_log_likelihood", td_ll)
        self._record("train/loss", loss)
