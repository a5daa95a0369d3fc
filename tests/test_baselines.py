"""Behaviour of every algorithm, and one property of each baseline's own objective.

The behaviour test: on a synthetic discrete MDP with plenty of expert data from a near-deterministic
expert (tests/synthetic.py, its logits scaled by 10), the greedy policy agrees with the expert's most
likely action on >= 95% of the expert's states.
"""

import csv

import numpy as np
import pytest
import torch as th
from gymnasium import spaces
from stable_baselines3.common.logger import configure
from synthetic import DiscreteActionMDP

from sb3_mbil import ALGORITHMS, AVRIL, DSFN, EDM, RCAL, IQLearn


class SharpMDP(DiscreteActionMDP):
    W = DiscreteActionMDP.W * 10


# Enough steps for each method on this small problem. DSFN: a discount with which its successor features converge
# inside these short phases (test_dsfn_successor_features_reach_the_expert_scale checks gamma 0.99).
BEHAVIOUR = {
    "mbil": dict(flow_max_steps=200),
    "edm": dict(sgld_steps=5),
    "iq_learn": dict(learning_rate=1e-3),
    # ValueDICE: the objective J alone (its default gradient penalty, 10, smooths nu and leaves the greedy policy
    # at 0.92 of the expert's choices after 3000 updates here; the penalty has its own test)
    "valuedice": dict(learning_rate=1e-3, policy_kwargs=dict(net_arch=[64, 64]), nu_arch=[64, 64], gradient_penalty=0.0),
    "dsfn": dict(warm_start_steps=1000, dqn_steps=1500, sf_steps=1500, max_iterations=2, gamma=0.9,
                 target_update_interval=100),
}


@pytest.fixture(scope="module")
def sharp():
    mdp = SharpMDP()
    data = mdp.trajectories(20, 50, seed=0)
    obs = np.concatenate([o[:-1] for o, _ in data])
    return mdp, data, obs, mdp.probs(obs).argmax(1)


_TRAINED = {}


def trained(name, sharp):
    """The algorithm trained on the sharp MDP's data (once per test session)."""
    if name not in _TRAINED:
        mdp, data, _, _ = sharp
        model = ALGORITHMS[name]("MlpPolicy", mdp.make_env(), expert_data=data, seed=0, **BEHAVIOUR.get(name, {}))
        _TRAINED[name] = model.learn(getattr(model, "schedule_steps", 3000))
    return _TRAINED[name]


@pytest.mark.parametrize("name", [n for n, a in ALGORITHMS.items() if spaces.Discrete in a.supported_action_spaces])
def test_greedy_policy_agrees_with_the_expert(name, sharp):
    _, _, obs, expert = sharp
    predicted, _ = trained(name, sharp).predict(obs, deterministic=True)
    assert np.mean(predicted == expert) >= 0.95


def test_edm_langevin_raises_the_energy_term(sharp):
    """SGLD moves states towards higher LSE f (the model's unnormalised state log-density)."""
    mdp, data, _, _ = sharp
    model = EDM("MlpPolicy", mdp.make_env(), expert_data=data, seed=0, sgld_steps=20).learn(1000)
    z0 = th.rand(512, 2) * 2 - 1
    with th.no_grad():
        before = model.energy(model.sgld.to_raw(z0))
    after = model.langevin(z0)
    with th.no_grad():
        gained = model.energy(model.sgld.to_raw(after)) - before
    assert gained.mean() > 0 and (gained > 0).float().mean() > 0.8
    # the chains are in standardised coordinates: the expert states' statistics
    np.testing.assert_allclose(model.sgld.obs_mean.numpy(), np.concatenate([o[:-1] for o, _ in data]).mean(0), atol=1e-5)


def test_avril_elbo_improves_with_a_finite_reward_posterior(sharp, tmp_path):
    """The negative ELBO falls; the KL of the reward posterior to its prior stays finite (it grows as the
    posterior learns to explain the TD residuals, so it is not required to fall)."""
    mdp, data, _, _ = sharp
    model = AVRIL("MlpPolicy", mdp.make_env(), expert_data=data, seed=0)
    model.set_logger(configure(str(tmp_path), ["csv"]))
    model.learn(2000, log_interval=250)
    with open(tmp_path / "progress.csv") as f:
        rows = list(csv.DictReader(f))
    kl = np.array([float(r["train/reward_kl"]) for r in rows])
    loss = np.array([float(r["train/loss"]) for r in rows])
    assert np.all(np.isfinite(kl)) and np.all(kl >= 0)
    assert loss[-1] < 0.8 * loss[0]


def test_rcal_penalty_makes_the_implied_reward_sparse(sharp):
    mdp, data, _, _ = sharp

    def mean_abs_reward(weight):
        model = RCAL("MlpPolicy", mdp.make_env(), expert_data=data, seed=0, reward_weight=weight).learn(2000)
        t = model.expert_transitions()
        with th.no_grad():
            q, q_next = model.policy.logits(t.observations), model.policy.logits(t.next_observations)
            return float(model.implied_reward(q, q_next, t.actions, t.dones).abs().mean())

    assert mean_abs_reward(1.0) < 0.5 * mean_abs_reward(0.0)


def test_dsfn_margin_shrinks_across_iterations(sharp):
    model = trained("dsfn", sharp)
    assert isinstance(model, DSFN)
    margins = model.margins
    assert len(margins) == 3 and model.training_complete()
    assert all(b <= a + 1e-6 for a, b in zip(margins, margins[1:])) and margins[-1] < margins[0]
    # learn stops once the schedule is complete
    n = model.num_timesteps
    model.learn(100, reset_num_timesteps=False)
    assert model.num_timesteps == n


def test_dsfn_returns_the_policy_closest_to_the_expert_and_says_which(sharp, tmp_path):
    model = trained("dsfn", sharp)
    d, i = model.distances, model.returned_iteration
    assert len(d) == len(model.margins) == 3 and d[i] == min(d) == pytest.approx(float(model.state.best_distance))
    model.save(tmp_path / "dsfn.zip")
    loaded = DSFN.load(tmp_path / "dsfn.zip")
    assert loaded.distances == d and loaded.returned_iteration == i
    # a file saved before the distances were kept still loads (strictly, as SB3 loads), the iteration unknown
    loaded.state.load_state_dict({k: v for k, v in model.state.state_dict().items() if k != "distances"})
    assert loaded.returned_iteration is None and loaded.training_complete()


def test_dsfn_successor_features_reach_the_expert_scale(sharp):
    """With gamma 0.99, mu_0 (the warm-start policy, which matches the expert here) comes out near mu_E after one
    successor-feature phase. A target network copied every 500 steps would leave psi at one step of horizon per copy
    and mu_0 at a few percent of mu_E's scale (a margin of about ||mu_E||), whatever the policy."""
    mdp, data, _, _ = sharp
    model = DSFN("MlpPolicy", mdp.make_env(), expert_data=data, warm_start_steps=1000, sf_steps=3000, dqn_steps=10,
                 max_iterations=1, seed=0)
    model.learn(4000)
    assert len(model.margins) == 1
    assert model.margins[0] < 0.4 * float(model.state.mu_expert.norm())


def test_dsfn_phase_cache_holds_what_each_minibatch_would_compute(sharp):
    """phi(s, a), pi_i(s') and w . phi(s, a) are computed once per phase over every transition: at each phase they
    equal the direct computation, and a new phase (or new data) rebuilds them."""
    mdp, data, _, _ = sharp
    model = DSFN("MlpPolicy", mdp.make_env(), expert_data=data, warm_start_steps=20, dqn_steps=10, sf_steps=10,
                 max_iterations=2, seed=0)
    tr = model.expert_transitions()
    seen = set()
    for _ in range(model.schedule_steps):
        if model.training_complete():
            break
        model.learn(1, reset_num_timesteps=False)
        if model.state.phase_name in ("successor_features", "dqn"):
            cache = model._phase_cache()
            seen.add(cache["key"])
            with th.no_grad():
                th.testing.assert_close(cache["phi"], model.phi(tr.observations, tr.actions))
                if cache["key"][0] == "successor_features":
                    th.testing.assert_close(cache["next_policy"], model._policy_probs(tr.next_observations))
                else:
                    th.testing.assert_close(cache["reward"], model.phi(tr.observations, tr.actions) @ model.state.w)
    assert {k[0] for k in seen} == {"successor_features", "dqn"} and len(seen) >= 4
    model.set_expert_data(data)
    assert model._cache is None


def test_shared_networks():
    """The shared critics, target copies and soft policy over Q (sb3_mbil.common.networks)."""
    from sb3_mbil.common.networks import MlpCritic, make_target, q_at, soft_q, soft_update

    q = th.tensor([[1.0, 2.0, 3.0]])
    log_pi, v = soft_q(q, temperature=0.5)
    th.testing.assert_close(log_pi.exp().sum(), th.tensor(1.0))
    th.testing.assert_close(v, 0.5 * th.logsumexp(q / 0.5, dim=-1))
    assert soft_q(q, 1e-3)[1].item() == pytest.approx(3.0, abs=1e-2)  # a cold soft maximum is the maximum
    assert q_at(q, th.tensor([2])).item() == 3.0
    critic = MlpCritic(4, 1, action_dim=2, n_critics=2)
    assert critic(th.zeros(5, 4), th.zeros(5, 2)).shape == (2, 5, 1)
    target = make_target(critic)
    assert not any(p.requires_grad for p in target.parameters())
    with th.no_grad():
        for p in critic.parameters():
            p.add_(1.0)
    before = [p.clone() for p in target.parameters()]
    soft_update(target, critic, tau=0.25)
    for b, t, c in zip(before, target.parameters(), critic.parameters()):
        th.testing.assert_close(t, 0.75 * b + 0.25 * c)


@pytest.mark.parametrize("env_id, steps", [("CartPole-v1", 10_000), ("Pendulum-v1", 1_000)])
def test_iq_learn_critic_stays_finite_and_ranks_expert_actions_first(env_id, steps, cartpole_data, pendulum_data):
    """Strictly offline, IQ-Learn's critic is known to diverge: over 10 000 updates on CartPole-v1 (1 000 on
    Pendulum-v1, whose critic is larger) Q at the expert's actions, Q at random actions and V at expert states stay
    finite, and Q ranks the expert's actions above random ones."""
    from stable_baselines3.common.logger import KVWriter, Logger

    data = {"CartPole-v1": cartpole_data, "Pendulum-v1": pendulum_data}[env_id]
    model = IQLearn("MlpPolicy", env_id, expert_data=data, seed=0)
    seen = []

    class Recorder(KVWriter):
        def write(self, key_values, key_excluded, step=0):
            seen.append(dict(key_values))

    model.set_logger(Logger(None, [Recorder()]))
    model.learn(steps, log_interval=steps // 10)
    assert len(seen) == 10
    for row in seen:
        for key in ("train/q_expert", "train/q_random", "train/v_expert", "train/critic_loss"):
            assert np.isfinite(row[key]), (key, row)
    assert seen[-1]["train/q_expert"] > seen[-1]["train/q_random"]
    if env_id == "Pendulum-v1":  # V(s)'s gradient pushes Q down at the policy's actions: a clear gap, not a tie
        assert seen[-1]["train/q_expert"] - seen[-1]["train/q_random"] > 1.0


@pytest.mark.slow  # minutes under load: run by CI with -m slow
@pytest.mark.parametrize("name, env_id, keys", [
    ("valuedice", "CartPole-v1", ("train/objective", "train/nu_expert", "train/nu_initial")),
    ("odice", "Pendulum-v1", ("train/value_forward", "train/value_backward", "train/weight_mean")),
])
def test_dice_critics_stay_finite_over_10000_updates(name, env_id, keys, cartpole_data, pendulum_data):
    """Strictly offline, the DICE critics (nu, V) stay finite and bounded over 10 000 updates."""
    from stable_baselines3.common.logger import KVWriter, Logger

    data = {"CartPole-v1": cartpole_data, "Pendulum-v1": pendulum_data}[env_id]
    small = {"odice": dict(policy_kwargs=dict(net_arch=[64, 64]), value_arch=[64, 64], batch_size=64),
             "valuedice": dict(policy_kwargs=dict(net_arch=[64, 64]), nu_arch=[64, 64], batch_size=64)}[name]
    model = ALGORITHMS[name]("MlpPolicy", env_id, expert_data=data, seed=0, **small)
    seen = []

    class Recorder(KVWriter):
        def write(self, key_values, key_excluded, step=0):
            seen.append(dict(key_values))

    model.set_logger(Logger(None, [Recorder()]))
    model.learn(10_000, log_interval=1000)
    assert len(seen) == 10
    for row in seen:
        for key in keys:
            assert np.isfinite(row[key]) and abs(row[key]) < 1e4, (key, row)


def test_valuedice_gradient_penalty_holds_nu_near_unit_slope_on_expert_inputs(pendulum_data):
    """With the gradient penalty on interpolates of expert inputs, ||grad_x nu|| stays near 1 at the expert's
    inputs; without it (the offline default) nu steepens freely. The penalty is logged."""
    from stable_baselines3.common.logger import KVWriter, Logger

    from sb3_mbil import ValueDICE

    distance_from_one, logged = {}, []

    class Recorder(KVWriter):
        def write(self, key_values, key_excluded, step=0):
            logged.append(dict(key_values))

    for weight in (0.0, 10.0):
        model = ValueDICE("MlpPolicy", "Pendulum-v1", expert_data=pendulum_data, seed=0, batch_size=64,
                          policy_kwargs=dict(net_arch=[64, 64]), nu_arch=[64, 64], gradient_penalty=weight)
        model.set_logger(Logger(None, [Recorder()]))
        model.learn(600, log_interval=300)
        transitions, absorbing, _ = model.absorbing_transitions()
        x = model._nu_inputs(transitions.observations, absorbing, model._action_features(transitions.actions))
        x = x.detach().requires_grad_(True)
        (grad_x,) = th.autograd.grad(model._nu(x).sum(), x)
        distance_from_one[weight] = float((grad_x.norm(dim=1) - 1.0).abs().mean())
    assert distance_from_one[10.0] < 0.3 < 2.0 < distance_from_one[0.0], distance_from_one
    assert "train/gradient_penalty" not in logged[0]
    assert np.isfinite(logged[-1]["train/gradient_penalty"])


def test_valuedice_absorbing_states_and_orthogonal_regulariser(pendulum_data):
    """A terminated episode leads to the absorbing state, which leads to itself with the zero action; a time-limit
    end bootstraps; the orthogonal regulariser is 0 for orthogonal weights and positive otherwise."""
    from sb3_mbil import Trajectory, ValueDICE
    from sb3_mbil.valuedice.valuedice import orthogonal_regulariser

    rng = np.random.default_rng(0)
    ended = Trajectory((0.1 * rng.normal(size=(6, 4))).astype(np.float32), rng.integers(0, 2, 5), terminated=True)
    cut = Trajectory((0.1 * rng.normal(size=(6, 4))).astype(np.float32), rng.integers(0, 2, 5), truncated=True)
    model = ValueDICE("MlpPolicy", "CartPole-v1", expert_data=[ended, cut], seed=0)
    transitions, absorbing, next_absorbing = model.absorbing_transitions()
    assert len(absorbing) == 5 + 5 + 1
    assert next_absorbing.tolist() == [0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 1]  # the terminated step, then the self-loop
    assert absorbing.tolist() == [0] * 10 + [1] and int(transitions.actions[-1]) == 0
    assert float(transitions.next_observations[4].abs().sum()) == 0.0  # the absorbing state's observation part
    th.testing.assert_close(transitions.next_observations[9], th.as_tensor(cut.observations[5]))  # bootstrapped

    # The reference's Gram matrix is over a layer's output units (K^T K of a Keras kernel K = W W^T of a torch
    # weight W): 3 orthonormal output rows cost nothing; 8 output units in 3 inputs cannot be orthogonal.
    wide = th.nn.init.orthogonal_(th.empty(3, 8))
    assert float(orthogonal_regulariser([wide])) < 1e-10
    assert float(orthogonal_regulariser([wide.T.contiguous()])) > 1e-3
    off_diagonal = wide.T @ wide - th.diag(th.diagonal(wide.T @ wide))
    th.testing.assert_close(orthogonal_regulariser([wide.T.contiguous()]), off_diagonal.pow(2).sum())

    # The Box actor's output layer is the reference's single Dense(2 * action_dim): mean and log-std rows together.
    box = ValueDICE("MlpPolicy", "Pendulum-v1", expert_data=pendulum_data, seed=0)
    weights = box.actor_weights()
    assert [tuple(w.shape) for w in weights] == [(256, 3), (256, 256), (2, 256)]
    th.testing.assert_close(weights[-1], th.cat([box.policy.mean_head.weight, box.policy.log_std_head.weight]))
    assert tuple(model.actor_weights()[-1].shape) == (2, 256)  # CartPole: the logits head alone


def test_odice_weighted_bc_recovers_a_linear_gaussian_expert():
    """ODICE's value-weighted BC on the linear-Gaussian MDP: the policy's mean matches the expert's K s on its
    states, and the orthogonal-gradient update keeps V finite."""
    from synthetic import LinearGaussianMDP

    from sb3_mbil import ODICE

    mdp = LinearGaussianMDP()
    data = mdp.trajectories(20, 50, seed=0)
    model = ODICE("MlpPolicy", mdp.make_env(), expert_data=data, learning_rate=1e-3, value_learning_rate=1e-3,
                  batch_size=128, policy_kwargs=dict(net_arch=[64, 64]), value_arch=[64, 64], seed=0).learn(1500)
    states = np.concatenate([o[:-1] for o, _ in data]).astype(np.float32)
    with th.no_grad():
        mean = model.policy.mean_action(th.as_tensor(states)).numpy()
        v = model._v(model.value, th.as_tensor(states))
    assert np.sqrt(((mean - states @ mdp.K.T) ** 2).mean()) < 0.15
    assert bool(th.isfinite(v).all())
