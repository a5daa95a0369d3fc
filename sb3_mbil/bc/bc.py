"""Behaviour cloning, strictly offline, as an SB3 algorithm (the baseline of every imitation paper)."""

from __future__ import annotations

from typing import Any

import torch as th
from stable_baselines3.common.type_aliases import GymEnv, Schedule

from sb3_mbil.common.demonstrations import ExpertData
from sb3_mbil.common.losses import bc_loss, resolve_bc_loss
from sb3_mbil.common.offline import OfflineAlgorithm
from sb3_mbil.common.policies import ImitationPolicy


class BC(OfflineAlgorithm):
    """Behaviour cloning: minimise L_BC(pi, D) on the expert's (s, a) pairs.

    L_BC is the negative log-likelihood -E log pi(a|s) (Discrete; ``bc_loss="nll"`` also for the
    Gaussian policy on Box actions) or the mean squared error of the mean action (Box, default).
    With MSE and one trajectory, weight decay (about 1e-3) keeps BC from collapsing late in
    training (Li et al., 2022).

    :param policy: ``"MlpPolicy"`` or a policy class
    :param env: the env or its id (spaces and evaluation only; never stepped while learning)
    :param expert_data: demonstrations (see :func:`sb3_mbil.as_demonstrations`)
    :param learning_rate: Adam learning rate (constant or schedule)
    :param batch_size: minibatch size
    :param bc_loss: ``"auto"`` (NLL for Discrete, MSE for Box), ``"nll"`` or ``"mse"``
    :param weight_decay: Adam weight decay of the policy
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
        if _init_setup_model:
            self._setup_model()

    def _check_hyperparameters(self) -> None:
        super()._check_hyperparameters()
        self._bc_kind = resolve_bc_loss(self.bc_loss, self.action_space)

    def _train_step(self) -> None:
        batch = self.sample(self.expert_pairs())
        loss = bc_loss(self.policy, self.policy.heads(batch.observations), batch.actions, self._bc_kind)
        self.policy.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.policy.optimizer.step()
        self._record("train/bc_loss", loss)
