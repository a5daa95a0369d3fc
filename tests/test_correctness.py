"""The density bookkeeping (the README's method section), checked on MDPs with known T and pi_D.

For a linear-Gaussian MDP (Box actions) and a softmax-policy MDP (Discrete actions):
the fitted flows' held-out log-likelihoods are close to the true ones, the mean balance
residual log P - log T - log pi_D at the *true* expert policy is about zero (no offset from
units, normalisation or dequantisation), and balance-only MBIL (beta = 0) recovers pi_D.
"""

import numpy as np
import pytest
import torch as th
from synthetic import DiscreteActionMDP, LinearGaussianMDP

from sb3_mbil import MBIL, as_demonstrations

# Tolerances, nats per tuple (the models are fitted on 2970 tuples).
T_TOLERANCE = 0.2
P_TOLERANCE = 0.3
RESIDUAL_TOLERANCE = 0.1


def _tensor(x):
    return th.as_tensor(x, dtype=th.float32 if x.dtype.kind == "f" else th.int64)


@pytest.fixture(scope="module", params=[LinearGaussianMDP, DiscreteActionMDP], ids=["box", "discrete"])
def fitted(request):
    mdp = request.param()
    model = MBIL("MlpPolicy", mdp.make_env(), expert_data=mdp.trajectories(30, 100, seed=0), alpha=1.0, beta=0.0, seed=0,
                 fit_transition=True)
    model.fit_flows()
    test = as_demonstrations(mdp.trajectories(20, 100, seed=1)).tuples()
    s, a, s2, a2 = (test[k] for k in ("observations", "actions", "next_observations", "next_actions"))
    with th.no_grad():
        log_t = model.flows.log_t(_tensor(s), _tensor(a), _tensor(s2)).numpy()
        log_p = model.flows.log_p(_tensor(s), _tensor(a), _tensor(s2), _tensor(a2)).numpy()
    s, s2 = s.astype(np.float64), s2.astype(np.float64)
    true_log_t = mdp.log_t(s, a, s2)
    true_log_pi = mdp.log_pi(s2, a2)
    return mdp, model, log_t, log_p, true_log_t, true_log_pi, s2.astype(np.float32)


def test_transition_flow_matches_true_density(fitted):
    _, _, log_t, _, true_log_t, _, _ = fitted
    assert abs(log_t.mean() - true_log_t.mean()) < T_TOLERANCE


def test_p_flow_matches_true_density(fitted):
    _, _, _, log_p, true_log_t, true_log_pi, _ = fitted
    assert abs(log_p.mean() - (true_log_t + true_log_pi).mean()) < P_TOLERANCE


def test_balance_residual_is_zero_at_true_expert(fitted):
    _, _, log_t, log_p, _, true_log_pi, _ = fitted
    residual = log_p - log_t - true_log_pi
    assert abs(residual.mean()) < RESIDUAL_TOLERANCE


def test_heldout_loglik_is_reported(fitted):
    _, model, *_ = fitted
    report = model.flow_report
    assert np.isfinite(report["transition_heldout_ll"]) and np.isfinite(report["p_heldout_ll"])
    assert report["n_heldout"] > 0


def test_balance_only_training_recovers_expert_policy(fitted):
    mdp, model, *_, states = fitted  # held-out states from the expert's own state distribution
    model.learn(5000)
    with th.no_grad():
        if isinstance(mdp, LinearGaussianMDP):
            mean, log_std = model.policy.mean_log_std(th.as_tensor(states))
            rms = np.sqrt(((mean.numpy() - states @ mdp.K.T) ** 2).mean())
            assert rms < 0.15
            assert abs(log_std.exp().mean().item() / mdp.sigma_a - 1) < 0.25
        else:
            probs = th.softmax(model.policy.logits(th.as_tensor(states)), -1).numpy()
            tv = 0.5 * np.abs(probs - mdp.probs(states)).sum(1).mean()
            assert tv < 0.1
