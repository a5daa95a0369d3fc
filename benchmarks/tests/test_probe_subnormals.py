"""The subnormal probe counts what it says: subnormal parameters and optimiser moments, not zeros or normal floats."""

import torch as th

from benchmarks.probe_subnormals import SubnormalClock, subnormal_counts
from sb3_mbil import BC, load_demonstrations


def test_the_probe_counts_subnormal_parameters_gradients_and_adam_moments(monkeypatch):
    monkeypatch.setenv("SB3_MBIL_FLUSH_SUBNORMALS", "0")
    model = BC("MlpPolicy", "CartPole-v1", expert_data=load_demonstrations("CartPole-v1").sample(1, seed=0), seed=0)
    clock = SubnormalClock(every=2)
    model.learn(4, callback=clock)
    assert [r["updates"] for r in clock.rows] == [2, 4]
    first = clock.rows[0]
    assert first["of parameters"] == sum(p.numel() for p in model.policy.parameters())
    param = next(model.policy.parameters())
    state = model.policy.optimizer.state[param]
    with th.no_grad():  # the entries about to be overwritten start normal, so each count grows by what is written
        param.view(-1)[:3] = 1.0
        state["exp_avg_sq"].view(-1)[:2] = 1.0
    before = subnormal_counts(model)
    with th.no_grad():
        param.view(-1)[:3] = th.tensor([1e-39, 0.0, 1e-30])  # one subnormal, one zero, one small normal
        state["exp_avg_sq"].view(-1)[:2] = th.tensor([1e-40, 2e-40])
    after = subnormal_counts(model)
    assert after["parameters"] == before["parameters"] + 1
    assert after["optimizer state"] == before["optimizer state"] + 2
