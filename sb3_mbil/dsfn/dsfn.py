"""DSFN: deep successor feature networks for batch apprenticeship learning (Lee, Srinivasan, Doshi-Velez, IJCAI 2019)."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.type_aliases import GymEnv, Schedule
from torch import nn

from sb3_mbil.common.demonstrations import ExpertData
from sb3_mbil.common.networks import make_target, q_at
from sb3_mbil.common.offline import OfflineAlgorithm
from sb3_mbil.common.policies import ImitationPolicy
from sb3_mbil.common.type_aliases import take
from sb3_mbil.common.validation import check_int, check_real, check_sizes
from sb3_mbil.dsfn.policies import DSFNState, SuccessorFeatures


class DSFN(OfflineAlgorithm):
    """Deep successor feature networks, the batch path.

    Paper: "Truly Batch Apprenticeship Learning with Deep Successor Features" (Lee, Srinivasan and
    Doshi-Velez, IJCAI 2019). Discrete actions. Everything is trained on the expert's transitions only.

    1. **Warm start** (``warm_start_steps``): a BC classifier (the policy, cross-entropy). Its last hidden
       layer, frozen, gives the features phi(s, a) = [h(s), onehot(a)] (k = hidden size + actions).
    2. The expert's feature expectation mu_E = mean over trajectories of (1 - gamma) sum_t gamma^t phi(s_t, a_t)
       (a trajectory cut by a time limit: sum_t gamma^t phi(s_t, a_t) / sum_t gamma^t, the discounted mean of
       its observed steps, since the successor features bootstrap past the cut; a deviation for short data).
    3. Apprenticeship iterations (Abbeel and Ng's projection method), starting from pi_0 = the warm-start
       classifier (greedy), as in the reference code:

       - **successor features** of the current policy pi_i (``sf_steps``): psi(s, a) trained by TD on the
         batch, psi(s, a) <- phi(s, a) + gamma (1 - done) psi'(s', pi_i(s')) (psi' a target copy);
         mu_i = (1 - gamma) mean over the trajectories' first states s0 of psi(s0, pi_i(s0));
       - **reward weights**: mu_bar <- the projection of mu_E on the line through mu_bar and mu_i
         (mu_bar = mu_0 at first), margin t_i = ||mu_E - mu_bar||, w = (mu_E - mu_bar) / t_i (unit norm,
         as in the reference); stop when t_i < ``tolerance`` or after ``max_iterations``;
       - **batch DQN** on the reward r = w . phi(s, a) (``dqn_steps``, a fresh Q each iteration, Huber
         loss, target copy): pi_{i+1} = greedy Q.

    The returned policy is the pi_i (pi_0 included) whose mu_i was closest to mu_E (:attr:`returned_iteration`,
    with every ||mu_E - mu_i|| in :attr:`distances`); the reference returns
    the mixture of the pi_i whose mixed mu is closest (a mixture is not one network). ``learn`` stops when
    the schedule is complete; :attr:`schedule_steps` is its length at most. The policy network is the
    classifier during the warm start and Q after it.

    Defaults are the reference settings (CKIL appendix): warm start 50 000 steps, DQN 2x64 30 000 steps,
    successor features 2x64 50 000 steps, Adam 3e-4, gamma 0.99, at most 10 iterations, precision 0.01;
    2x64 ELU networks and batch 64 (the comparison's common settings). The DQN's target network is copied every
    500 steps (the reference's ``baselines`` deepq). The successor features bootstrap from the current network
    (``sf_target_update_interval = 1``): the reference's successor-feature "target" is built in the same variable
    scope with ``AUTO_REUSE``, so it is the online network and its update every 500 steps changes nothing. A target
    copied every 500 steps would cap psi's horizon at one step per copy: 10 copies in a 5 000-step phase give
    about 1 - 0.99^10 = 10% of the scale of mu_E, which swamps the distances that pick the policy. The reference's
    successor-feature head is linear in its input (its output layer reads [s, a], skipping its two hidden layers) and
    samples a Gaussian around that output (a trained log-std that starts at 0) in training and estimation; ours is
    the 2x64 ELU network of ``sf_arch``, read deterministically. Deviations: Abbeel and Ng's projection formula (the
    reference code's parenthesisation of it differs), no early stop on held-out action matching, and the
    time-limit normalisation of mu_E above. Two data bugs of the reference code are not copied: its warm start
    reads the N trajectories through a ``flatten`` that returns inside its loop, so only the first trajectory is
    filled and the other N - 1 are rows of zeros (then it trains on the first 70% of the rows); and its
    apprenticeship stage reads every trajectory of the expert file whatever N is. Here every stage uses the N
    trajectories given, every step of each (as the reference keeps every step).

    :param policy: ``"MlpPolicy"`` or a policy class
    :param env: the env or its id (spaces and evaluation only; never stepped while learning)
    :param expert_data: demonstrations (see :func:`sb3_mbil.as_demonstrations`)
    :param learning_rate: Adam learning rate of every network (constant or schedule)
    :param batch_size: minibatch size
    :param gamma: discount
    :param warm_start_steps: BC steps that train the feature network
    :param dqn_steps: batch DQN steps per iteration
    :param sf_steps: successor-feature steps per iteration
    :param max_iterations: apprenticeship iterations at most
    :param tolerance: stop when the margin ||mu_E - mu_bar|| is below this
    :param target_update_interval: steps between hard updates of the DQN's target network
    :param sf_target_update_interval: steps between hard updates of the successor features' target network (1: the
        TD target uses the current network, as in the reference)
    :param sf_arch: hidden sizes of the successor-feature network
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
    feature_net: ImitationPolicy
    best_policy: ImitationPolicy
    successor: SuccessorFeatures
    state: DSFNState

    def __init__(
        self,
        policy: str | type[ImitationPolicy],
        env: GymEnv | str | None,
        expert_data: ExpertData | None = None,
        learning_rate: float | Schedule = 3e-4,
        batch_size: int = 64,
        gamma: float = 0.99,
        warm_start_steps: int = 50_000,
        dqn_steps: int = 30_000,
        sf_steps: int = 50_000,
        max_iterations: int = 10,
        tolerance: float = 0.01,
        target_update_interval: int = 500,
        sf_target_update_interval: int = 1,
        sf_arch: list[int] | tuple[int, ...] = (64, 64),
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
        self.warm_start_steps = warm_start_steps
        self.dqn_steps = dqn_steps
        self.sf_steps = sf_steps
        self.max_iterations = max_iterations
        self.tolerance = tolerance
        self.target_update_interval = target_update_interval
        self.sf_target_update_interval = sf_target_update_interval
        self.sf_arch = sf_arch
        if _init_setup_model:
            self._setup_model()

    # ------------------------------------------------------------------ setup
    def _check_hyperparameters(self) -> None:
        super()._check_hyperparameters()
        self.gamma = check_real("gamma", self.gamma, low=0.0, high=1.0, high_open=True)
        for name in ("warm_start_steps", "dqn_steps", "sf_steps", "max_iterations", "target_update_interval",
                     "sf_target_update_interval"):
            setattr(self, name, check_int(name, getattr(self, name), low=1))
        self.tolerance = check_real("tolerance", self.tolerance, low=0.0)
        self.sf_arch = check_sizes("sf_arch", self.sf_arch)

    def _setup_model(self) -> None:
        super()._setup_model()
        if not self.policy.net_arch:
            raise ValueError("policy_kwargs['net_arch']: expected at least one hidden layer (its output gives DSFN's "
                             "features), found []")
        kwargs = {**self.default_policy_kwargs, **self.policy_kwargs}
        self.feature_net = self.policy_class(self.observation_space, self.action_space, self.lr_schedule, **kwargs).to(self.device)
        self.feature_net.requires_grad_(False)
        self.best_policy = self.policy_class(self.observation_space, self.action_space, self.lr_schedule, **kwargs).to(self.device)
        self.best_policy.requires_grad_(False)
        self.n_actions = int(self.action_space.n)
        self.n_features = self.policy.net_arch[-1] + self.n_actions
        obs_dim = int(self.policy.features_extractor.features_dim)
        self.successor = SuccessorFeatures(obs_dim, self.n_actions * self.n_features, net_arch=self.sf_arch,
                                           activation_fn=nn.ELU).to(self.device)
        self.successor_target = make_target(self.successor)
        self.successor.optimizer = th.optim.Adam(self.successor.parameters(), lr=self.lr_schedule(1), weight_decay=self.weight_decay)
        self.q_target = make_target(self.policy)
        self.state = DSFNState(self.n_features, self.max_iterations).to(self.device)

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        names, others = super()._get_torch_save_params()
        return [*names, "feature_net", "best_policy", "successor", "successor.optimizer", "successor_target",
                "q_target", "state"], others

    def _optimizers(self) -> list[th.optim.Optimizer]:
        return [*super()._optimizers(), self.successor.optimizer]

    @property
    def schedule_steps(self) -> int:
        """Gradient steps of the whole method when no early stop happens."""
        return self.warm_start_steps + (self.max_iterations + 1) * self.sf_steps + self.max_iterations * self.dqn_steps

    def training_complete(self) -> bool:
        return self.state.phase_name == "done"

    @property
    def margins(self) -> list[float]:
        """t_i = ||mu_E - mu_bar_i|| of the iterations so far."""
        m = self.state.margins
        return [float(v) for v in m[~th.isnan(m)]]

    @property
    def distances(self) -> list[float]:
        """||mu_E - mu_i|| of the policies pi_i evaluated so far (pi_0, the warm-start classifier, first)."""
        d = self.state.distances
        return [float(v) for v in d[~th.isnan(d)]]


    def diagnostics(self) -> dict[str, Any]:
        """Which pi_i the run returned (0: the warm-start classifier)."""
        out = super().diagnostics()
        if self.returned_iteration is not None:
            out["returned_iteration"] = self.returned_iteration
        return out

    @property
    def returned_iteration(self) -> int | None:
        """i of the returned pi_i, the first one closest to mu_E (0: the warm-start classifier); None before the
        schedule is complete, or for a model saved before the distances were kept."""
        d = self.distances
        if not self.training_complete() or len(d) != len(self.margins):
            return None
        return min(range(len(d)), key=d.__getitem__)

    # ------------------------------------------------------------------ features
    def phi(self, obs: th.Tensor, actions: th.Tensor) -> th.Tensor:
        """phi(s, a) = [h(s), onehot(a)], h the frozen warm-start network's last hidden layer."""
        h = self.feature_net.latent(self.feature_net.features(obs))
        return th.cat([h, nn.functional.one_hot(actions.long(), self.n_actions).float()], dim=-1)

    def psi(self, net: nn.Module, obs: th.Tensor) -> th.Tensor:
        """psi(s, .) of shape (batch, actions, k)."""
        return net(self.policy.features(obs))[0].view(len(obs), self.n_actions, self.n_features)

    def _policy_probs(self, obs: th.Tensor) -> th.Tensor:
        """pi_i(. | s), greedy in the policy network (the classifier for pi_0, then Q), one-hot."""
        return nn.functional.one_hot(self.policy.logits(obs).argmax(-1), self.n_actions).float()

    @th.no_grad()
    def _expert_feature_expectation(self) -> th.Tensor:
        mus = []
        for t in self.demonstrations():
            obs, act = self._to_tensor(t.observations[: len(t)], "obs"), self._to_tensor(t.actions, "act")
            discount = self.gamma ** th.arange(len(t), device=self.device, dtype=th.float32)
            # a terminated episode has zero features after its end; one cut by a time limit would go on:
            # normalise by the discount mass of its observed steps (as psi bootstraps past the cut)
            scale = (1 - self.gamma) if t.terminated else 1.0 / discount.sum()
            mus.append(scale * (discount.view(-1, 1) * self.phi(obs, act)).sum(0))
        return th.stack(mus).mean(0)

    @th.no_grad()
    def _policy_feature_expectation(self) -> th.Tensor:
        s0 = self._to_tensor(np.stack([t.observations[0] for t in self.demonstrations()]), "obs")
        psi = self.psi(self.successor, s0)
        return (1 - self.gamma) * (self._policy_probs(s0).unsqueeze(-1) * psi).sum(1).mean(0)

    # ------------------------------------------------------------------ the schedule
    def _train_step(self) -> None:
        st = self.state
        phase = st.phase_name
        if phase == "warm_start":
            self._warm_start_step()
        elif phase == "successor_features":
            self._successor_step()
        else:
            self._dqn_step()
        st.phase_step += 1
        steps = {"warm_start": self.warm_start_steps, "successor_features": self.sf_steps, "dqn": self.dqn_steps}[phase]
        if int(st.phase_step) >= steps:
            self._end_phase(phase)

    def _warm_start_step(self) -> None:
        # Warm start: BC (cross-entropy) on the expert's pairs.
        batch = self.sample(self.expert_pairs())
        loss = nn.functional.cross_entropy(self.policy.logits(batch.observations), batch.actions)
        self._step(self.policy.optimizer, loss)
        self._record("train/bc_loss", loss)

    @th.no_grad()
    def _phase_cache(self) -> dict[str, th.Tensor]:
        """What stays fixed during a phase, over every expert transition, computed once per phase: phi(s, a) (the
        feature network is frozen after the warm start), pi_i(. | s') in a successor-feature phase (pi_i is not
        trained there) and the reward w . phi(s, a) in a DQN phase (w is fixed there). The same values as computing
        them on each minibatch, without the forward passes."""
        key = (self.state.phase_name, int(self.state.iteration))
        if self._cache is None or self._cache["key"] != key:
            tr = self.expert_transitions()
            phi = self.phi(tr.observations, tr.actions)
            cache: dict[str, Any] = {"key": key, "phi": phi}
            if key[0] == "successor_features":
                cache["next_policy"] = self._policy_probs(tr.next_observations)
            elif key[0] == "dqn":
                cache["reward"] = phi @ self.state.w
            self._cache = cache
        return self._cache

    def _on_new_data(self) -> None:
        super()._on_new_data()
        self._cache = None

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "_cache"]

    def _successor_step(self) -> None:
        # Successor features of pi_i: psi(s, a) <- phi(s, a) + gamma (1 - done) E_{a' ~ pi_i(s')} psi'(s', a').
        transitions, cache = self.expert_transitions(), self._phase_cache()
        i = self._sample_indices(len(transitions.observations))
        batch = take(transitions, i)
        # an interval of 1 bootstraps from the current network itself (the same values as a copy at every step)
        target_net = self.successor if self.sf_target_update_interval == 1 else self.successor_target
        with th.no_grad():
            next_psi = (cache["next_policy"][i].unsqueeze(-1) * self.psi(target_net, batch.next_observations)).sum(1)
            target = cache["phi"][i] + self.gamma * (1 - batch.dones).view(-1, 1) * next_psi
        psi = self.psi(self.successor, batch.observations)[th.arange(len(batch.actions)), batch.actions]
        loss = (psi - target).pow(2).sum(-1).mean()
        self._step(self.successor.optimizer, loss)
        self._record("train/successor_loss", loss)
        if self.sf_target_update_interval > 1 and int(self.state.phase_step) % self.sf_target_update_interval == 0:
            self.successor_target.load_state_dict(self.successor.state_dict())

    def _dqn_step(self) -> None:
        # Batch DQN on r = w . phi(s, a): Q(s, a) <- r + gamma (1 - done) max_b Q'(s', b).
        transitions, cache = self.expert_transitions(), self._phase_cache()
        i = self._sample_indices(len(transitions.observations))
        batch = take(transitions, i)
        with th.no_grad():
            reward = cache["reward"][i]
            next_q = self.q_target.logits(batch.next_observations).max(-1).values
            target = reward + self.gamma * (1 - batch.dones) * next_q
        loss = nn.functional.smooth_l1_loss(q_at(self.policy.logits(batch.observations), batch.actions), target)
        self._step(self.policy.optimizer, loss)
        self._record("train/dqn_loss", loss)
        if int(self.state.phase_step) % self.target_update_interval == 0:
            self.q_target.load_state_dict(self.policy.state_dict())

    def _step(self, optimizer: th.optim.Optimizer, loss: th.Tensor) -> None:
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()

    @th.no_grad()
    def _end_phase(self, phase: str) -> None:
        st = self.state
        if phase == "warm_start":
            self.feature_net.load_state_dict(self.policy.state_dict())
            st.mu_expert.copy_(self._expert_feature_expectation())
            self._start_successor_features()
        elif phase == "dqn":
            self._start_successor_features()
        else:
            self._update_reward_weights()

    def _start_successor_features(self) -> None:
        self._reinitialise(self.successor)
        self.successor.optimizer.state.clear()
        self.successor_target.load_state_dict(self.successor.state_dict())
        self.state.enter("successor_features")

    def _update_reward_weights(self) -> None:
        """Abbeel and Ng's projection step, then the next DQN (or the end)."""
        st = self.state
        i = int(st.iteration)
        mu = self._policy_feature_expectation()
        if i == 0:
            st.mu_bar.copy_(mu)
        else:
            d = mu - st.mu_bar
            denom = float(d @ d)
            if denom > 0:
                st.mu_bar.add_(float(d @ (st.mu_expert - st.mu_bar)) / denom * d)
        distance = float((st.mu_expert - mu).norm())
        st.distances[i] = distance
        if distance < float(st.best_distance):
            st.best_distance.fill_(distance)
            self.best_policy.load_state_dict(self.policy.state_dict())
        margin = (st.mu_expert - st.mu_bar).norm()
        st.margins[i] = margin
        st.w.copy_((st.mu_expert - st.mu_bar) / margin.clamp(min=1e-12))
        self.logger.record("train/margin", float(margin))
        if float(margin) < self.tolerance or i >= self.max_iterations:
            self.policy.load_state_dict(self.best_policy.state_dict())
            st.enter("done")
            return
        st.iteration += 1
        # a fresh Q for the new reward (the observation statistics are kept)
        self._reinitialise(self.policy)
        self.policy.optimizer.state.clear()
        self.q_target.load_state_dict(self.policy.state_dict())
        st.enter("dqn")

    @staticmethod
    def _reinitialise(module: nn.Module) -> None:
        """New weights for every linear layer, in place (buffers such as observation statistics are kept)."""
        for m in module.modules():
            if isinstance(m, nn.Linear):
                m.reset_parameters()
