"""The balance ablation's P(a' | s') variants: P no longer sees the predecessor (s, a), the paper's P does."""

import torch as th

from benchmarks.balance_ablation import MBILCNextStateOnly, MBILNextStateOnly
from sb3_mbil import MBIL, load_demonstrations


def test_next_state_only_models_ignore_the_predecessor():
    demos = load_demonstrations("CartPole-v1-sampled").sample(2, seed=0)
    ablated = MBILNextStateOnly("MlpPolicy", "CartPole-v1", expert_data=demos, seed=0, flow_max_steps=50)
    paper = MBIL("MlpPolicy", "CartPole-v1", expert_data=demos, seed=0, flow_max_steps=50)
    ablated.fit_flows(), paper.fit_flows()
    s, a, s_next, a_next = ablated.expert_tuples()
    other = (s.flip(0), 1 - a, s_next, a_next)  # another predecessor for every (s', a')
    assert th.equal(ablated.balance_target(s, a, s_next, a_next), ablated.balance_target(*other))
    assert not th.equal(paper.balance_target(s, a, s_next, a_next), paper.balance_target(*other))
    model_c = MBILCNextStateOnly("MlpPolicy", "CartPole-v1", expert_data=demos, seed=0, model_max_steps=50)
    model_c.fit_models()
    p = model_c.balance_model
    assert th.equal(p.next_action_distribution(s, a, s_next)[0], p.next_action_distribution(*other[:3])[0])
