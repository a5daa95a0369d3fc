"""The balance ablation's P(a' | s') variants: P no longer sees the predecessor (s, a), the paper's P does."""

import pytest
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


@pytest.mark.parametrize("with_mse", [False, True])
def test_summary_pairs_the_nll_variants_and_leaves_out_algorithms_without_rows(tmp_path, with_mse):
    from benchmarks.balance_ablation import COLUMNS, summary
    from benchmarks.harness.results import append_rows

    csv_path = tmp_path / "ablation.csv"
    returns = {"mbil_nll": [900.0, 700.0, 800.0], "mbil_nll_alpha0": [500.0, 400.0, 450.0]}
    if with_mse:
        returns["mbil"] = [510.0, 410.0, 460.0]
    append_rows(str(csv_path), [{"variant": name, "env": "Walker2d-v4", "pool": "noise0.1", "n_trajectories": 1,
                                 "seed": 100 + i, "mean_return": r, "std_return": 0.0, "n_episodes": 100,
                                 "settings": "{}", "commit": "x"}
                                for name, rs in returns.items() for i, r in enumerate(rs)], COLUMNS)
    lines = summary(str(csv_path)).splitlines()
    nll = [line for line in lines if "| MBIL, NLL |" in line]
    assert len(nll) == 1 and "800.0 (3)" in nll[0] and "450.0 (3)" in nll[0]
    assert "+350.0" in nll[0] and "above" in nll[0]  # the paired difference against alpha = 0
    assert not any("| MBIL-C |" in line for line in lines)
    against_nll = [line for line in lines if "minus the NLL without it" in line]
    assert [("| MBIL |" in line) for line in lines].count(True) == with_mse and len(against_nll) == with_mse
    if with_mse:  # MBIL 10 above the NLL on every seed
        assert "+10.0" in against_nll[0] and "above" in against_nll[0]
    assert "- noise0.1, N = 1, mbil_nll: 800.0 (900.0, 700.0, 800.0)" in lines  # each variant's seeds, in order


def test_summary_pairs_mbil_c_with_weight_decay_against_its_mean_part_alone(tmp_path):
    """MBIL-C* on Walker2d-v4 (weight decay 1e-3) taken apart: its triple row, and the full term against alpha = 0
    with the MSE 7 times as large (the anchored W2's mean part summed over 6 action dimensions)."""
    from benchmarks.balance_ablation import COLUMNS, VARIANTS, summary
    from benchmarks.harness.results import append_rows

    assert VARIANTS["mbil_c_wd0.001_alpha0_beta7"][2] == {"weight_decay": 1e-3, "alpha": 0.0, "beta": 7.0}
    csv_path = tmp_path / "ablation.csv"
    returns = {"mbil_c_wd0.001": [1900.0, 1500.0, 2100.0], "mbil_c_wd0.001_alpha0": [800.0, 900.0, 700.0],
               "mbil_c_wd0.001_alpha0_beta7": [1800.0, 1600.0, 1900.0],
               "mbil_c_wd0.003": [2000.0, 1600.0, 2200.0]}  # 100 above MBIL-C* on every seed
    append_rows(str(csv_path), [{"variant": name, "env": "Walker2d-v4", "pool": "Walker2d-v4-sampled",
                                 "n_trajectories": 1, "seed": 100 + i, "mean_return": r, "std_return": 0.0,
                                 "n_episodes": 100, "settings": "{}", "commit": "x"}
                                for name, rs in returns.items() for i, r in enumerate(rs)], COLUMNS)
    lines = summary(str(csv_path)).splitlines()
    row = [line for line in lines if "| MBIL-C, weight decay 1e-3 |" in line]
    assert len(row) == 1 and "1833.3 (3)" in row[0] and "800.0 (3)" in row[0]
    assert "+1033.3" in row[0] and "above" in row[0]  # against alpha = 0
    doubled = [line for line in lines if "the MSE 7 times as large" in line]
    assert len(doubled) == 1 and "+66.7" in doubled[0] and "level" in doubled[0]
    pushed = [line for line in lines if "minus MBIL-C at alpha 1 and weight decay 1e-3" in line]
    assert len(pushed) == 1 and "weight decay 3e-3" in pushed[0] and "+100.0" in pushed[0] and "above" in pushed[0]
