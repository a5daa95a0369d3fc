"""The density fits' noise candidates trained at once (a stacked network) are each bit for bit their separate fit."""

import pytest
import torch as th

import sb3_mbil.common.flows as flows
from sb3_mbil import MBIL, MBILC


@pytest.mark.parametrize("algo, min_delta", [(MBIL, 0.0), (MBIL, 0.02), (MBILC, None)])
def test_stacked_noise_candidates_fit_what_separate_fits_give(algo, min_delta, cartpole_data, monkeypatch):
    def fitted(stacked: bool):
        if not stacked:
            monkeypatch.setattr(flows, "_train_candidates", lambda *args, **kwargs: None)
        kwargs = {"flow_max_steps": 200, "flow_min_delta": min_delta} if algo is MBIL else \
            {"model_max_steps": 200, "model_noise_grid": (0.03, 0.1, 0.3)}
        model = algo("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, seed=4, **kwargs)
        report = model.fit_flows() if algo is MBIL else model.fit_models()
        monkeypatch.undo()
        module = model.flows if algo is MBIL else model.balance_model
        return report, module.state_dict()

    (report_a, state_a), (report_b, state_b) = fitted(False), fitted(True)
    assert state_a.keys() == state_b.keys() and all(th.equal(state_a[k], state_b[k]) for k in state_a)
    key = "next_action"
    assert {k: v for k, v in report_a[key].items() if k != "seconds"} == \
        {k: v for k, v in report_b[key].items() if k != "seconds"}
    assert len(report_b[key]["candidates"]) >= 2  # several candidates were fitted (stacked)


def test_min_delta_stops_a_fit_whose_gains_are_smaller(cartpole_data):
    """A held-out gain below ``flow_min_delta`` does not reset the patience: with a huge one, every candidate stops
    ``patience`` evaluations after its first; the best point is kept either way."""
    settings = dict(flow_max_steps=500, flow_eval_every=10, flow_patience=3, flow_refit=False, seed=1)
    plain = MBIL("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, **settings).fit_flows()
    capped = MBIL("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, flow_min_delta=1e9, **settings).fit_flows()
    assert all(c["steps"] <= 40 for c in capped["next_action"]["candidates"].values())
    assert max(c["steps"] for c in plain["next_action"]["candidates"].values()) > 40
    with pytest.raises(ValueError, match="flow_min_delta"):
        MBIL("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, flow_min_delta=-1.0)


def test_auto_fit_budget_caps_the_categorical_p_at_300_steps(cartpole_data):
    model = MBIL("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, seed=0)
    assert model.flow_max_steps == "auto" and model._max_steps(flow=False) == 300 and model._max_steps(flow=True) == 1000
    report = model.fit_flows()
    assert max(c["steps"] for c in report["next_action"]["candidates"].values()) <= 300
    assert MBIL("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, flow_max_steps=50)._max_steps(flow=False) == 50
    for bad in ("fast", 0, 2.5):
        with pytest.raises(ValueError, match="flow_max_steps"):
            MBIL("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, flow_max_steps=bad)
