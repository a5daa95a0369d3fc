"""RCAL: reward-regularised classification for apprenticeship learning (Piot, Geist, Pietquin, AAMAS 2014)."""

from __future__ import annotations

from typing import Any, ClassVar

import torch as th
from gymnasium import spaces
from stable_baselines3.common.type_aliases import GymEnv, Schedule
from torch import nn

from sb3_mbil.common.demonstrations import ExpertData
from sb3_mbil.common.networks import q_at, soft_q
from sb3_mbil.common.offline import OfflineAlgorithm
from sb3_mbil.common.policies import ImitationPolicy
from sb3_mbil.common.type_aliases import TransitionSamples
from sb3_mbil.common.validation import check_bool, check_choice, check_real

CLASSIFICATION_LOSSES = ("cross_entropy", "margin")


class RCAL(OfflineAlgorithm):
    """Reward-regularised classification.

    Paper: "Boosted and Reward-regularized Classification for Apprenticeship Learning" (Piot, Geist and
    Pietquin, AAMAS 2014). Discrete actions.

    A score function Q(s, .) (the policy's logits; the policy is greedy in Q) is fitted as a classifier
    of the expert's actions while the reward it implies, r(s, a) = Q(s, a) - gamma max_b Q(s', b), is
    kept sparse. On expert transitions (s, a, s', done):

        L = L_class(Q(s, .), a) + lambda * E|Q(s, a) - gamma (1 - done) max_b Q(s', b)|

    with L_class the large margin max_b [Q(s, b) + margin * 1(b != a)] - Q(s, a) (the paper) or the
    cross-entropy -log softmax(Q(s, .))[a] (the published port behind the classic-control comparisons).
    ``soft_max`` replaces max_b Q(s', b) by logsumexp_b Q(s', b) (the port). Gradients reach Q through
    both terms. No public code of the original exists; the defaults follow the port (cross-entropy,
    soft maximum, lambda 1e-2) with the comparison's common settings (2x64 ELU, Adam 1e-3, batch 64);
    ``classification_loss="margin", soft_max=False`` gives the paper's form.

    :param policy: ``"MlpPolicy"`` or a policy class
    :param env: the env or its id (spaces and evaluation only; never stepped while learning)
    :param expert_data: demonstrations (see :func:`sb3_mbil.as_demonstrations`)
    :param learning_rate: Adam learning rate (constant or schedule)
    :param batch_size: minibatch size of expert transitions
    :param classification_loss: ``"cross_entropy"`` or ``"margin"``
    :param margin: the margin of ``"margin"``
    :param reward_weight: lambda, the weight of the sparsity penalty on the implied reward
    :param soft_max: logsumexp instead of max over the next state's scores
    :param gamma: discount
    :param weight_decay: Adam weight decay
    :param policy_kwargs: policy keyword arguments (``net_arch``, ...)
    :param tensorboard_log: tensorboard folder
    :param verbose: verbosity
    :param seed: random seed
    :param device: torch device
    :param _init_setup_model: build the networks at construction
    """

    supported_action_spaces: ClassVar[tuple[type[spaces.Space], ...]] = (spaces.Discrete,)
    default_policy_kwargs: ClassVar[dict[str, Any]] = {"activation_fn": nn.ELU}

    def __init__(
        self,
        policy: str | type[ImitationPolicy],
        env: GymEnv | str | None,
        expert_data: ExpertData | None = None,
        learning_rate: float | Schedule = 1e-3,
        batch_size: int = 64,
        classification_loss: str = "cross_entropy",
        margin: float = 1.0,
        reward_weight: float = 1e-2,
        soft_max: bool = True,
        gamma: float = 0.99,
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
        self.classification_loss = classification_loss
        self.margin = margin
        self.reward_weight = reward_weight
        self.soft_max = soft_max
        self.gamma = gamma
        if _init_setup_model:
            self._setup_model()

    def _check_hyperparameters(self) -> None:
        super()._check_hyperparameters()
        self.classification_loss = check_choice("classification_loss", self.classification_loss, CLASSIFICATION_LOSSES)
        self.margin = check_real("margin", self.margin, low=0.0)
        self.reward_weight = check_real("reward_weight", self.reward_weight, low=0.0)
        self.soft_max = check_bool("soft_max", self.soft_max)
        self.gamma = check_real("gamma", self.gamma, low=0.0, high=1.0)

    def implied_reward(self, q: th.Tensor, q_next: th.Tensor, actions: th.Tensor, dones: th.Tensor) -> th.Tensor:
        """r(s, a) = Q(s, a) - gamma (1 - done) max_b Q(s', b) (soft maximum with ``soft_max``)."""
        next_value = soft_q(q_next)[1] if self.soft_max else q_next.max(dim=-1).values
        return q_at(q, actions) - self.gamma * (1.0 - dones) * next_value

    def _draw_batch(self) -> TransitionSamples:
        return self.sample(self.expert_transitions())

    def _policy_inputs(self, batch: TransitionSamples) -> th.Tensor:
        return th.cat([batch.observations, batch.next_observations])

    def _loss_from_heads(self, batch: TransitionSamples, heads: tuple[th.Tensor, ...]) -> th.Tensor:
        q, q_next = heads[0].chunk(2)  # Q(s, .) and Q(s', .) are the policy's logits

        # Classification of the expert's action.
        if self.classification_loss == "cross_entropy":
            classification = nn.functional.cross_entropy(q, batch.actions)
        else:
            margins = self.margin * (1.0 - nn.functional.one_hot(batch.actions, q.shape[-1]).float())
            classification = ((q + margins).max(dim=-1).values - q_at(q, batch.actions)).mean()

        # Sparsity of the implied reward.
        sparsity = self.implied_reward(q, q_next, batch.actions, batch.dones).abs().mean()

        self._record("train/classification_loss", classification)
        self._record("train/reward_sparsity", sparsity)
        return classification + self.reward_weight * sparsity
