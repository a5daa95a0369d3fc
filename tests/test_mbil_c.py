"""MBIL-C's objective checked on MDPs with known T and pi_D (tests/synthetic.py), and its bookkeeping.

* the balance divergence is the exact KL of torch.distributions (categorical and diagonal Gaussian);
* P(a' | s, a, s') and T(s' | s, a) are fitted close to the true densities (for these MDPs the true
  P(a' | s, a, s') is pi_D(a' | s'));
* the model states are draws of T around the true next state, with T's spread times kappa;
* balance-only training (beta = 0) recovers pi_D; with alpha = alpha_model = 0 MBIL-C is BC, bit for bit.
"""

import numpy as np
import pytest
import torch as th
from synthetic import DiscreteActionMDP, LinearGaussianMDP

from sb3_mbil import BC, MBILC, as_demonstrations, load_demonstrations
from sb3_mbil.mbil_c.balance import balance_kl

T_TOLERANCE = 0.2  # nats per tuple
P_TOLERANCE = 0.2


def _tensor(x):
    return th.as_tensor(x, dtype=th.float32 if x.dtype.kind == "f" else th.int64)


def test_balance_kl_is_the_exact_kl_divergence():
    from torch.distributions import Categorical, Independent, Normal, kl_divergence

    policy_d = MBILC("MlpPolicy", "CartPole-v1", seed=0).policy
    policy_c = MBILC("MlpPolicy", "Pendulum-v1", seed=0).policy
    g = th.Generator().manual_seed(0)
    log_p = th.log_softmax(th.randn(50, 2, generator=g), -1)
    logits = th.randn(50, 2, generator=g)
    expected = kl_divergence(Categorical(logits=log_p), Categorical(logits=logits))
    th.testing.assert_close(balance_kl(policy_d, (log_p,), (logits,)), expected)
    mean_p, log_std_p, mean_pi, log_std_pi = (th.randn(50, 1, generator=g) for _ in range(4))
    expected = kl_divergence(Independent(Normal(mean_p, log_std_p.exp()), 1), Independent(Normal(mean_pi, log_std_pi.exp()), 1))
    th.testing.assert_close(balance_kl(policy_c, (mean_p, log_std_p), (mean_pi, log_std_pi)), expected)


@pytest.fixture(scope="module", params=[LinearGaussianMDP, DiscreteActionMDP], ids=["box", "discrete"])
def fitted(request):
    mdp = request.param()
    model = MBILC("MlpPolicy", mdp.make_env(), expert_data=mdp.trajectories(30, 100, seed=0), alpha=1.0, alpha_model=1.0,
                  beta=0.0, seed=0)
    model.fit_models()
    test = as_demonstrations(mdp.trajectories(20, 100, seed=1)).tuples()
    return mdp, model, {k: test[k] for k in ("observations", "actions", "next_observations", "next_actions")}


def test_models_match_the_true_densities(fitted):
    mdp, model, test = fitted
    s, a, s2, a2 = (_tensor(test[k]) for k in ("observations", "actions", "next_observations", "next_actions"))
    with th.no_grad():
        log_p = model.balance_model.next_action.log_prob(*model.balance_model.next_action_inputs(s, a, s2, a2)).numpy()
        log_t = model.balance_model.transition.log_prob(*model.balance_model.transition_inputs(s, a, s2)).numpy()
    s64, s2_64 = test["observations"].astype(np.float64), test["next_observations"].astype(np.float64)
    assert abs(log_p.mean() - mdp.log_pi(s2_64, test["next_actions"]).mean()) < P_TOLERANCE
    assert abs(log_t.mean() - mdp.log_t(s64, test["actions"], s2_64).mean()) < T_TOLERANCE
    assert np.isfinite(model.model_report["next_action"]["heldout_ll"]) and model.model_report["n_heldout"] > 0


def test_model_states_are_draws_of_t(fitted):
    mdp, model, _ = fitted
    s, a, s2, _ = model.expert_tuples()
    k = model.n_model_states
    states = model.balance_targets().states.numpy().astype(np.float64)
    s64 = s.numpy().astype(np.float64).repeat(k, 0)
    actions = a.numpy().repeat(k, 0)
    true_mean = s64 @ mdp.A.T + (actions.reshape(-1, 1) @ mdp.B.T if isinstance(mdp, LinearGaussianMDP)
                                 else mdp.B[:, actions.astype(int)].T)
    gap = states - true_mean
    with th.no_grad():
        _, std = model.balance_model.transition.mean_std(th.cat([s, model.balance_model.encode_action(a)], 1))
    assert np.abs(gap.mean(0)).max() < 0.03
    assert np.abs(gap.std(0) / std.numpy().mean(0) - 1).max() < 0.1  # spread: T's own
    assert np.abs(gap.std(0) / mdp.sigma_s - 1).max() < 0.4  # and near the truth
    # kappa scales the spread around the same means
    model.model_state_scale = 0.0
    model._cache = None
    still = model.balance_targets().states.numpy()
    assert np.abs(still - states).max() > 0.1
    assert np.allclose(still[::k], still[1::k]) and np.abs(still - true_mean).std(0).max() < 0.1
    model.model_state_scale = 1.0
    model._cache = None
    np.testing.assert_array_equal(model.balance_targets().states.numpy(), states.astype(np.float32))  # seeded


def test_balance_only_training_recovers_the_expert_policy(fitted):
    mdp, model, test = fitted
    states = test["next_observations"]
    model.learn(3000)
    with th.no_grad():
        if isinstance(mdp, LinearGaussianMDP):
            mean, log_std = model.policy.mean_log_std(th.as_tensor(states))
            assert np.sqrt(((mean.numpy() - states @ mdp.K.T) ** 2).mean()) < 0.15
            assert abs(log_std.exp().mean().item() / mdp.sigma_a - 1) < 0.25
        else:
            probs = th.softmax(model.policy.logits(th.as_tensor(states)), -1).numpy()
            assert 0.5 * np.abs(probs - mdp.probs(states)).sum(1).mean() < 0.1


def test_data_targets_belong_to_each_pairs_predecessor():
    demos = load_demonstrations("CartPole-v1").sample(2, seed=0)
    model = MBILC("MlpPolicy", "CartPole-v1", expert_data=demos, alpha_model=0.0, model_max_steps=20, seed=0)
    model.fit_models()
    cache = model.balance_targets()
    pairs = model.expert_pairs()
    first = np.r_[0, np.cumsum(demos.episode_lengths)[:-1]]
    has = cache.has_target.numpy()
    assert not has[first].any() and has.sum() == len(has) - len(first)
    p = int(first[1]) + 5  # the sixth step of the second trajectory
    expected = model.balance_model.next_action_distribution(pairs.observations[p - 1 : p], pairs.actions[p - 1 : p],
                                                            pairs.observations[p : p + 1])[0]
    th.testing.assert_close(cache.data[0][p : p + 1], expected)
    assert "transition" not in model.model_report and cache.states is None  # T is not fitted when unused


def test_without_balance_terms_it_is_bc():
    demos = load_demonstrations("CartPole-v1").sample(1, seed=0)
    bc = BC("MlpPolicy", "CartPole-v1", expert_data=demos, seed=3).learn(200)
    mbil_c = MBILC("MlpPolicy", "CartPole-v1", expert_data=demos, alpha=0.0, alpha_model=0.0, model_max_steps=20,
                   seed=3).learn(200)
    for (name, a), b in zip(bc.policy.state_dict().items(), mbil_c.policy.state_dict().values()):
        th.testing.assert_close(a, b, rtol=0, atol=0, msg=name)


def test_anchored_targets_sit_on_the_observed_actions(pendulum_data):
    model = MBILC("MlpPolicy", "Pendulum-v1", expert_data=pendulum_data, alpha_model=1.0, model_state_scale=0.0,
                  model_max_steps=40, seed=0)
    model.learn(0)
    cache, pairs, tup = model.balance_targets(), model.expert_pairs(), model.expert_tuples()
    has = cache.has_target
    th.testing.assert_close(cache.data[0][has], pairs.actions[has])
    # at kappa = 0 the model state is T's mean: the target is a' plus P's change from s' to that state
    with th.no_grad():
        p_data = model.balance_model.next_action_distribution(tup.observations, tup.actions, tup.next_observations)[0]
        p_model = model.balance_model.next_action_distribution(tup.observations, tup.actions, cache.states[::4])[0]
    th.testing.assert_close(cache.model[0][::4], tup.next_actions + p_model - p_data)
    with pytest.raises(ValueError, match="anchor_to_data: expected False for Discrete actions"):
        MBILC("MlpPolicy", "CartPole-v1", anchor_to_data=True)
    with pytest.raises(ValueError, match="divergence: expected 'kl' or 'auto' for Discrete actions, found 'w2'"):
        MBILC("MlpPolicy", "CartPole-v1", divergence="w2")


@pytest.mark.parametrize("residual", [False, True], ids=["direct", "residual"])
def test_corrective_labels_lead_back_to_the_expert_next_state(residual):
    """CCIL-style labels on the linear-Gaussian MDP: the TRUE dynamics take (s~, a~) close to the expert's s', and
    a~ differs from the expert's a (a label the data does not have). With ``residual_transition`` T models s' - s and
    its mean is s plus the modelled change."""
    mdp = LinearGaussianMDP()
    model = MBILC("MlpPolicy", mdp.make_env(), expert_data=mdp.trajectories(30, 100, seed=0), alpha_model=1.0,
                  model_labels="corrective", corrective_action_noise=1.0, residual_transition=residual, seed=0)
    model.learn(0)
    cache, (s, a, s_next, _) = model.balance_targets(), model.expert_tuples()
    report = model.model_report["corrective_labels"]
    assert report["kept"] > 0.5 * report["tried"] and len(cache.states) == report["kept"]
    x, actions = cache.states.numpy().astype(np.float64), cache.model_actions.numpy().astype(np.float64)
    true_next = x @ mdp.A.T + actions @ mdp.B.T  # the mean of the true T
    tuples = cache.model_tuples.numpy()  # the expert tuple of each kept label
    expert_next = s_next.numpy()[tuples]
    rms = np.sqrt(((true_next - expert_next) ** 2).mean(1)) / s.numpy().std(0).mean()
    assert np.median(rms) < 0.1
    assert np.abs(actions - a.numpy()[tuples]).mean() > 0.1  # new actions, not the data's
    if residual:  # T's mean is s + the network's change: a network that outputs zero change predicts s' = s
        bm = model.balance_model
        for p in bm.transition.net.parameters():
            p.data.zero_()
        mean, _ = bm.transition_mean_std(s, a)
        th.testing.assert_close(mean, s + bm.transition.x_norm.mean)
        x_t, _ = bm.transition_inputs(s, a, s_next)
        th.testing.assert_close(x_t, s_next - s)



def test_discrete_objective_is_one_cross_entropy_with_the_same_gradient():
    """Discrete: beta * CE(onehot(a), pi) + alpha * mean(w * KL(P || pi)) has the gradient of one cross-entropy
    against the cached soft labels beta * onehot(a) + alpha * w * P (the update MBIL-C runs); alpha and beta changed
    after the first learn are taken up."""
    demos = load_demonstrations("LunarLander-v3").sample(1, seed=0)
    model = MBILC("MlpPolicy", "LunarLander-v3", expert_data=demos, alpha=0.7, beta=1.3, seed=0)
    model.learn(5)
    cache, pairs = model.balance_targets(), model.expert_pairs()
    i = th.arange(len(pairs.observations))

    def grads(loss):
        model.policy.zero_grad(set_to_none=True)
        loss.backward()
        return [p.grad.clone() for p in model.policy.parameters() if p.grad is not None]

    logits = model.policy.heads(pairs.observations[i])[0]
    fused = grads(th.nn.functional.cross_entropy(logits, cache.soft_labels[i]))
    log_pi = th.log_softmax(model.policy.heads(pairs.observations[i])[0], -1)
    kl = balance_kl(model.policy, (cache.data[0][i],), (model.policy.heads(pairs.observations[i])[0],))
    kl = th.where(cache.has_target[i], kl, th.zeros_like(kl))  # rows without a predecessor carry no target
    explicit = 1.3 * -log_pi.gather(1, pairs.actions[i].view(-1, 1)).mean() + 0.7 * (kl * cache.weight[i]).mean()
    for a, b in zip(fused, grads(explicit)):
        th.testing.assert_close(a, b, rtol=1e-4, atol=1e-6)
    model.alpha = 0.0
    model.learn(1, reset_num_timesteps=False)
    onehot = th.nn.functional.one_hot(pairs.actions, cache.soft_labels.shape[1]).float()
    th.testing.assert_close(model.balance_targets().soft_labels, 1.3 * onehot)
