"""SB3 contract of every algorithm: learn, predict, save/load, continue, determinism, callbacks, logging."""

import csv
import warnings

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from gymnasium import spaces
from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback, EvalCallback
from stable_baselines3.common.logger import configure
from stable_baselines3.common.monitor import Monitor

from sb3_mbil import ALGORITHMS, BC, DSFN, MBIL, ODICE, IQLearn, ValueDICE

# Small settings so the contract tests stay fast (flow quality: test_correctness.py; behaviour: test_baselines.py).
FAST = {
    "mbil": dict(flow_max_steps=60, flow_eval_every=20, noise_grid=(0.1,), flow_hidden=(32,), flow_transforms=2),
    "mbil_c": dict(model_max_steps=60, model_eval_every=20, model_hidden=(32,)),
    "edm": dict(sgld_steps=2, sgld_buffer_size=200),
    "valuedice": dict(policy_kwargs=dict(net_arch=[32, 32]), nu_arch=[32, 32], batch_size=64),
    "dsfn": dict(warm_start_steps=8, dqn_steps=6, sf_steps=5, max_iterations=4, target_update_interval=3),
}
ALGOS = list(ALGORITHMS.values())
ENVS = ["CartPole-v1", "Pendulum-v1"]
SPACE = {"CartPole-v1": spaces.Discrete, "Pendulum-v1": spaces.Box}
# for the tests over every algorithm: CartPole-v1 where the algorithm takes Discrete actions, else Pendulum-v1
ENV_OF = {algo: "CartPole-v1" if spaces.Discrete in algo.supported_action_spaces else "Pendulum-v1" for algo in ALGOS}
# every (algorithm, env) pair the algorithm supports
CASES = [pytest.param(algo, env, id=f"{name}-{env}") for name, algo in ALGORITHMS.items() for env in ENVS
         if SPACE[env] in algo.supported_action_spaces]


def make(algo, env_id, data, **kwargs):
    name = next(n for n, a in ALGORITHMS.items() if a is algo)
    return algo("MlpPolicy", env_id, expert_data=data, **{"seed": 0, **FAST.get(name, {}), **kwargs})


@pytest.fixture
def data(request, cartpole_data, pendulum_data):
    return {"CartPole-v1": cartpole_data, "Pendulum-v1": pendulum_data}


def params(model):
    """Every saved torch state of the model (modules and optimisers), flattened."""
    out = {}
    for name in model._get_torch_save_params()[0]:
        obj = model
        for part in name.split("."):
            obj = getattr(obj, part)
        state = obj.state_dict()
        if isinstance(obj, th.optim.Optimizer):
            state = {f"{i}.{k}": v for i, s in state["state"].items() for k, v in s.items()}
        out.update({f"{name}.{k}": v.clone() for k, v in state.items()})
    return out


def assert_same_params(a, b):
    assert a.keys() == b.keys()
    for k in a:
        th.testing.assert_close(a[k], b[k], rtol=0, atol=0, equal_nan=True, msg=k)


@pytest.mark.parametrize("algo, env_id", CASES)
def test_learn_and_predict(algo, env_id, data):
    model = make(algo, env_id, data[env_id]).learn(50)
    assert model.num_timesteps == 50
    env = gym.make(env_id)
    obs, _ = env.reset(seed=0)
    action, _ = model.predict(obs, deterministic=True)
    assert env.action_space.contains(np.asarray(action, dtype=env.action_space.dtype).reshape(env.action_space.shape))
    batch = np.stack([obs] * 4)
    actions, _ = model.predict(batch, deterministic=True)
    assert len(actions) == 4


@pytest.mark.parametrize("algo, env_id", CASES)
def test_save_load_identical(algo, env_id, data, tmp_path):
    model = make(algo, env_id, data[env_id]).learn(30)
    model.save(tmp_path / "model.zip")
    obs = np.stack([gym.make(env_id).observation_space.sample() for _ in range(16)])
    before, _ = model.predict(obs, deterministic=True)
    for env, safe in ((None, False), (gym.make(env_id), False), (gym.make(env_id), True)):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            loaded = algo.load(tmp_path / "model.zip", env=env, safe=safe)  # safe: every zip we write, nothing unpickled
        assert not [w for w in caught if "model.zip" in str(w.message)]  # a zip we wrote loads without a word
        assert_same_params(params(model), params(loaded))
        after, _ = loaded.predict(obs, deterministic=True)
        np.testing.assert_array_equal(before, after)
    # the dataset stays out of the zip
    assert loaded.expert_data is None


def test_mbil_load_restores_flows_without_refitting(data, tmp_path, monkeypatch):
    model = make(MBIL, "CartPole-v1", data["CartPole-v1"]).learn(20)
    target = model.tuple_targets().clone()
    model.save(tmp_path / "m.zip")
    loaded = MBIL.load(tmp_path / "m.zip", env=gym.make("CartPole-v1"), expert_data=data["CartPole-v1"])
    assert bool(loaded.flows.fitted)
    assert loaded.flow_report == model.flow_report

    def refit(*_, **__):
        raise AssertionError("fit_flows must not run again after load")

    monkeypatch.setattr(MBIL, "fit_flows", refit)
    loaded.learn(5, reset_num_timesteps=False)
    th.testing.assert_close(loaded.tuple_targets(), target)


@pytest.mark.parametrize("algo", ALGOS)
def test_learning_continues_after_load(algo, data, tmp_path):
    model = make(algo, ENV_OF[algo], data[ENV_OF[algo]]).learn(20)
    model.save(tmp_path / "m.zip")
    loaded = algo.load(tmp_path / "m.zip", env=gym.make(ENV_OF[algo]), expert_data=data[ENV_OF[algo]])
    before = params(loaded)
    loaded.learn(20, reset_num_timesteps=False)
    assert loaded.num_timesteps == 40
    changed = [k for k in before if k.startswith("policy.") and not th.equal(before[k], params(loaded)[k])]
    assert changed


@pytest.mark.parametrize("algo, env_id", CASES)
def test_same_seed_same_result(algo, env_id, data):
    a = make(algo, env_id, data[env_id]).learn(40)
    b = make(algo, env_id, data[env_id]).learn(40)
    assert_same_params(params(a), params(b))
    c = make(algo, env_id, data[env_id], seed=1).learn(40)
    assert any(not th.equal(params(a)[k], params(c)[k]) for k in params(a) if k.startswith("policy."))


@pytest.mark.parametrize("env_id", ENVS)
def test_transition_fit_never_changes_the_policy(env_id, data):
    # T cancels from the balance target and its fit draws its own random numbers: whether and how T is
    # fitted changes T, never P(a' | s, a, s'), the target or the policy. By default it is not fitted.
    a = make(MBIL, env_id, data[env_id], fit_transition=True, transition_noise_grid=(0.1,)).learn(40)
    b = make(MBIL, env_id, data[env_id], fit_transition=True, transition_noise_grid=(0.01, 0.3),
             transition_refit=True).learn(40)
    c = make(MBIL, env_id, data[env_id]).learn(40)
    pa, pb, pc = params(a), params(b), params(c)
    not_t = [k for k in pa if not k.startswith("flows.transition.")]
    assert_same_params({k: pa[k] for k in not_t}, {k: pb[k] for k in not_t})
    assert_same_params({k: pa[k] for k in not_t}, {k: pc[k] for k in not_t})
    assert any(not th.equal(pa[k], pb[k]) for k in pa if k.startswith("flows.transition."))
    assert a.flow_report["transition"]["candidates"].keys() == {"0.1"}
    assert b.flow_report["transition"]["candidates"].keys() == {"0.01", "0.3"}
    assert c.flow_report["transition"] is None and c.flow_report["transition_heldout_ll"] is None
    assert c.flow_report["fit_seconds"] < a.flow_report["fit_seconds"]
    assert "transition_heldout_ll" not in c.diagnostics() and np.isfinite(c.diagnostics()["target_mean"])


def test_tuple_targets_are_the_cached_balance_targets(data):
    model = make(MBIL, "Pendulum-v1", data["Pendulum-v1"]).learn(5)
    assert th.equal(model.tuple_targets(), model.balance_target(*model.expert_tuples()))
    assert len(model.tuple_targets()) == model.flow_report["n_tuples"]


@pytest.mark.parametrize("algo", ALGOS)
def test_callbacks_count_gradient_steps(algo, data, tmp_path):
    eval_env = Monitor(gym.make(ENV_OF[algo]))
    eval_cb = EvalCallback(eval_env, eval_freq=10, n_eval_episodes=1, best_model_save_path=str(tmp_path), log_path=str(tmp_path))
    ckpt = CheckpointCallback(save_freq=15, save_path=str(tmp_path / "ckpt"), name_prefix="m")
    make(algo, ENV_OF[algo], data[ENV_OF[algo]]).learn(30, callback=[eval_cb, ckpt])
    assert len(eval_cb.evaluations_timesteps) == 3
    assert eval_cb.evaluations_timesteps == [10, 20, 30]
    assert (tmp_path / "best_model.zip").exists()
    assert sorted(p.name for p in (tmp_path / "ckpt").iterdir()) == ["m_15_steps.zip", "m_30_steps.zip"]


@pytest.mark.parametrize("algo", ALGOS)
def test_callback_can_stop_training(algo, data):
    class StopAt(BaseCallback):
        def _on_step(self):
            return self.n_calls < 7

    model = make(algo, ENV_OF[algo], data[ENV_OF[algo]]).learn(100, callback=StopAt())
    assert model.num_timesteps == 7


@pytest.mark.parametrize("algo", ALGOS)
def test_progress_bar(algo, data, capsys):
    """SB3's ProgressBarCallback counts our gradient steps: it reaches the total and is closed."""
    from stable_baselines3.common.callbacks import ProgressBarCallback

    seen = []
    real = ProgressBarCallback._on_training_end

    def closing(self):
        seen.append(self.pbar.n)
        real(self)

    ProgressBarCallback._on_training_end = closing
    try:
        model = make(algo, ENV_OF[algo], data[ENV_OF[algo]]).learn(10, progress_bar=True)
    finally:
        ProgressBarCallback._on_training_end = real
    assert model.num_timesteps == 10 and seen == [10]


@pytest.mark.parametrize("algo", ALGOS)
def test_logged_values(algo, data, tmp_path):
    model = make(algo, ENV_OF[algo], data[ENV_OF[algo]])
    model.set_logger(configure(str(tmp_path), ["csv"]))
    model.learn(20, log_interval=10)
    with open(tmp_path / "progress.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 2
    keys = set(rows[0])
    assert "time/total_timesteps" in keys
    train = [k for k in keys if k.startswith("train/") and k != "train/n_updates" and rows[0][k] != ""]
    assert train and all(np.isfinite(float(rows[0][k])) for k in train)
    if algo is ODICE:  # V's two terms and the weighted BC
        assert {"train/value_forward", "train/value_backward", "train/policy_loss", "train/weight_mean"} <= keys
    elif algo is IQLearn:  # no classification term: the IQ loss and its critic diagnostics
        assert {"train/critic_loss", "train/chi2", "train/q_expert", "train/q_random", "train/v_expert"} <= keys
    elif algo is ValueDICE:  # the objective J(pi, nu) and its parts
        assert {"train/objective", "train/nu_expert", "train/nu_initial", "train/orthogonal"} <= keys
    elif algo is not DSFN:  # DSFN's warm start is BC; its other terms appear in later phases
        assert "train/bc_loss" in keys or "train/classification_loss" in keys
    if algo is MBIL:
        assert {"train/balance_loss", "train/residual_mean", "flows/fit_seconds", "flows/next_action_noise"} <= keys
        assert "flows/transition_heldout_ll" not in keys  # T is not fitted by default (it cancels from the target)


def test_alpha_beta_variants(data):
    for alpha, beta in [(1.0, 0.0), (0.0, 1.0), (1.0, 0.001)]:
        model = make(MBIL, "Pendulum-v1", data["Pendulum-v1"], alpha=alpha, beta=beta).learn(10)
        assert model.num_timesteps == 10


def test_box_bc_losses(data):
    """MSE trains the mean only (the log-std head gets no gradient); the Gaussian NLL fits a state-dependent std too;
    both lower their own loss on the expert pairs."""
    for kind in ("mse", "nll"):
        model = make(BC, "Pendulum-v1", data["Pendulum-v1"], bc_loss=kind, weight_decay=0.0)
        model.learn(1)
        head = model.policy.log_std_head.weight.detach().clone()
        before = model.validation_losses(data["Pendulum-v1"])["bc_loss"]
        model.learn(300, reset_num_timesteps=False)
        after = model.validation_losses(data["Pendulum-v1"])["bc_loss"]
        assert after < before, (kind, before, after)
        moved = not th.equal(model.policy.log_std_head.weight.detach(), head)
        assert moved == (kind == "nll"), kind


@pytest.mark.parametrize("algo", [BC, ALGORITHMS["mbil_c"]], ids=["bc", "mbil_c"])
def test_logit_penalty_bounds_the_logits_and_is_discrete_only(algo, data):
    """d3rlpy's DiscreteBC regulariser: lambda * mean(logits^2) keeps the logits small where plain BC grows them."""
    obs = th.as_tensor(np.concatenate([o for o, _ in data["CartPole-v1"]]), dtype=th.float32)
    size = {}
    for penalty in (0.0, 0.5):
        model = make(algo, "CartPole-v1", data["CartPole-v1"], logit_penalty=penalty).learn(2000)
        with th.no_grad():
            size[penalty] = float(model.policy.heads(obs)[0].pow(2).mean())
    assert size[0.5] < 0.5 * size[0.0], size
    with pytest.raises(ValueError, match="logit_penalty: expected 0 for Box actions"):
        make(algo, "Pendulum-v1", data["Pendulum-v1"], logit_penalty=0.5)
    with pytest.raises(ValueError, match="logit_penalty"):
        make(algo, "CartPole-v1", data["CartPole-v1"], logit_penalty=-1.0)


def test_bc_label_smoothing_is_torchs_and_caps_the_policys_confidence(data):
    """(1 - eps) L_BC + eps * uniform cross-entropy is torch's cross_entropy(label_smoothing=eps); trained with it, the
    policy's probability of its greedy action stays near 1 - eps + eps / K instead of going to 1; Discrete only."""
    from sb3_mbil.common.losses import uniform_cross_entropy

    logits, actions, eps = th.randn(32, 3), th.randint(0, 3, (32,)), 0.2
    ours = (1 - eps) * th.nn.functional.cross_entropy(logits, actions) + eps * uniform_cross_entropy((logits,))
    assert th.allclose(ours, th.nn.functional.cross_entropy(logits, actions, label_smoothing=eps))
    obs = th.as_tensor(np.concatenate([o for o, _ in data["CartPole-v1"]]), dtype=th.float32)
    confidence = {}
    for smoothing in (0.0, 0.2):
        model = make(BC, "CartPole-v1", data["CartPole-v1"], label_smoothing=smoothing).learn(2000)
        with th.no_grad():
            confidence[smoothing] = float(th.softmax(model.policy.heads(obs)[0], -1).max(-1).values.median())
    assert confidence[0.0] > 0.97 and confidence[0.2] < 0.93, confidence
    with pytest.raises(ValueError, match="label_smoothing: expected 0 for Box actions"):
        make(BC, "Pendulum-v1", data["Pendulum-v1"], label_smoothing=0.1)
    with pytest.raises(ValueError, match="label_smoothing"):
        make(BC, "CartPole-v1", data["CartPole-v1"], label_smoothing=1.5)


def test_bc_observation_noise_smooths_the_policy_around_the_expert_states(data):
    """Training on s + sigma * std(s) * eps with the expert's action kept: the mean action moves less when the state
    is perturbed by that much than plain BC's does."""
    obs = th.as_tensor(np.concatenate([o[:-1] for o, _ in data["Pendulum-v1"]]), dtype=th.float32)
    delta = 0.3 * obs.std(0) * th.randn(obs.shape, generator=th.Generator().manual_seed(0))
    change = {}
    for sigma in (0.0, 0.3):
        model = make(BC, "Pendulum-v1", data["Pendulum-v1"], observation_noise=sigma).learn(2000)
        with th.no_grad():
            change[sigma] = float((model.policy.heads(obs + delta)[0] - model.policy.heads(obs)[0]).abs().mean())
    assert change[0.3] < 0.8 * change[0.0], change
    with pytest.raises(ValueError, match="observation_noise: expected a finite number >= 0"):
        make(BC, "Pendulum-v1", data["Pendulum-v1"], observation_noise=-0.1)


def test_gaussian_log_prob_is_a_density_in_raw_units(data):
    """pi(a|s) for Box actions is the Gaussian density in env units: it integrates to 1 over a."""
    model = make(BC, "Pendulum-v1", data["Pendulum-v1"])
    obs = th.zeros(1, 3)
    grid = th.linspace(-30, 30, 20001).view(-1, 1)
    with th.no_grad():
        dens = model.policy.log_prob(obs.expand(len(grid), 3), grid).exp()
    assert abs(th.trapezoid(dens, grid.view(-1)).item() - 1.0) < 1e-3


def test_importing_the_flows_keeps_torch_distribution_validation():
    """zuko switches torch.distributions argument validation off process-wide when imported; we restore it."""
    import subprocess
    import sys

    code = ("import torch; before = torch.distributions.Distribution._validate_args; import sb3_mbil; "
            "print(before, torch.distributions.Distribution._validate_args)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.stdout.split() == ["True", "True"], out.stderr


def test_balance_diagnostics_split_the_residual(data):
    model = make(MBIL, "Pendulum-v1", data["Pendulum-v1"])
    with pytest.raises(RuntimeError, match="not fitted"):
        model.balance_diagnostics()
    model.learn(50)
    d = model.balance_diagnostics()
    target = model.tuple_targets()
    tup = model.expert_tuples()
    with th.no_grad():
        log_pi = model.policy.log_prob(tup.next_observations, tup.next_actions)
        mean, log_std = model.policy.mean_log_std(tup.next_observations)
    assert d["residual_mse"] == pytest.approx(float((target - log_pi).pow(2).mean()), rel=1e-5)
    # Gaussian: log pi = log pi_max - q, q the mean's share, >= 0
    q = (0.5 * ((tup.next_actions.view_as(mean) - mean) / log_std.exp()).pow(2)).sum(1)
    assert d["mean_shift_nats"] == pytest.approx(float(q.mean()), rel=1e-4) and d["mean_shift_nats"] >= 0
    assert d["residual_mse_mean_on_action"] == pytest.approx(float((target - log_pi - q).pow(2).mean()), rel=1e-4)
    assert d["n_tuples"] == len(target) and 0 <= d["unreachable_targets"] <= len(target)
    assert 0.0 <= d["log_std_at_bound"] <= 1.0
    with pytest.raises(ValueError, match="log_std_bounds"):
        make(MBIL, "Pendulum-v1", data["Pendulum-v1"], policy_kwargs={"log_std_bounds": (2.0, -5.0)})
    assert d["bc_mse"] > 0
    discrete = make(MBIL, "CartPole-v1", data["CartPole-v1"]).learn(5).balance_diagnostics()
    assert "mean_shift_nats" not in discrete and discrete["residual_mse"] >= 0


BOX_ALGOS = [a for a in ALGOS if spaces.Box in a.supported_action_spaces]


@pytest.mark.parametrize("algo", BOX_ALGOS)
def test_observation_normalisation_uses_expert_stats_and_is_saved(algo, data, tmp_path):
    trajs = data["Pendulum-v1"]
    model = make(algo, "Pendulum-v1", trajs, policy_kwargs={"normalize_observations": True}).learn(20)
    obs = np.concatenate([o[:-1] for o, _ in trajs]).astype(np.float32)
    pol = model.policy
    np.testing.assert_allclose(pol.obs_mean.numpy(), obs.mean(0), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(pol.obs_std.numpy(), np.maximum(obs.std(0), 1e-3), rtol=1e-4)
    x = th.as_tensor(obs[:8])
    with th.no_grad():
        expected = pol.heads_from_latent(pol.latent(((x - pol.obs_mean) / pol.obs_std).clamp(-10, 10)))[0]
        np.testing.assert_allclose(pol.mean_action(x).numpy(), expected.numpy(), rtol=1e-6)
    stats = pol.obs_mean.clone()
    model.learn(5)  # a second learn keeps the statistics
    assert th.equal(pol.obs_mean, stats)
    model.save(tmp_path / "m.zip")
    loaded = algo.load(tmp_path / "m.zip", env=gym.make("Pendulum-v1"))
    assert loaded.policy.normalize_observations and th.equal(loaded.policy.obs_mean, stats)
    np.testing.assert_array_equal(model.predict(obs[:8], deterministic=True)[0], loaded.predict(obs[:8], deterministic=True)[0])
    # off by default (unless the algorithm's reference settings standardise, as ValueDICE's do)
    plain = make(algo, "Pendulum-v1", trajs, policy_kwargs={"normalize_observations": False}).learn(5)
    assert not plain.policy.normalize_observations and not bool(plain.policy.obs_stats_set)
    default = make(algo, "Pendulum-v1", trajs).learn(5)
    assert default.policy.normalize_observations == bool(algo.default_policy_kwargs.get("normalize_observations"))


@pytest.mark.parametrize("algo", BOX_ALGOS)
def test_bounded_mean_stays_inside_the_action_bounds_and_is_saved(algo, data, tmp_path):
    """``bounded_mean``: the Gaussian's mean is tanh-squashed into the Box bounds; the density around it
    stays an unsquashed Gaussian in raw units (it still integrates to 1 over the real line)."""
    model = make(algo, "Pendulum-v1", data["Pendulum-v1"], policy_kwargs={"bounded_mean": True}).learn(20)
    pol = model.policy
    with th.no_grad():
        pol.mean_head.bias.fill_(50.0)  # the raw head far outside the bounds
        mean = pol.mean_action(th.zeros(4, 3))
        assert th.all(mean <= 2.0) and th.all(mean >= 1.99)  # Pendulum's bound is 2
        grid = th.linspace(-40, 40, 40001).view(-1, 1)
        dens = pol.log_prob(th.zeros(len(grid), 3), grid).exp()
    assert abs(th.trapezoid(dens, grid.view(-1)).item() - 1.0) < 1e-3
    model.save(tmp_path / "m.zip")
    loaded = algo.load(tmp_path / "m.zip")
    assert loaded.policy.bounded_mean and th.equal(loaded.policy.mean_action(th.zeros(4, 3)), mean)
    if spaces.Discrete in algo.supported_action_spaces:
        with pytest.raises(ValueError, match="bounded_mean"):
            make(algo, "CartPole-v1", data["CartPole-v1"], policy_kwargs={"bounded_mean": True})


def test_bc_tanh_nll_is_the_squashed_gaussian_likelihood(data):
    """``bc_loss="tanh_nll"``: -log pi(a|s) of a = center + half_range * tanh(u), u ~ N(raw mean, std), the same as
    torch's transformed distribution inside the bounds, finite for actions at the bounds (clipped), and refused
    without a bounded mean or by an algorithm that does not implement it."""
    from torch.distributions import AffineTransform, Normal, TanhTransform, TransformedDistribution

    from sb3_mbil.common.losses import bc_loss, tanh_gaussian_log_prob

    model = make(BC, "Pendulum-v1", data["Pendulum-v1"], bc_loss="tanh_nll", policy_kwargs={"bounded_mean": True})
    pol = model.policy
    obs = th.randn(64, 3)
    actions = 1.9 * (2 * th.rand(64, 1) - 1)  # inside Pendulum's bounds [-2, 2]
    with th.no_grad():
        raw_mean, log_std = pol.raw_heads(obs)
        ours = tanh_gaussian_log_prob(pol, (raw_mean, log_std), actions)
        squashed = TransformedDistribution(Normal(raw_mean, log_std.exp()), [TanhTransform(), AffineTransform(0.0, 2.0)])
        np.testing.assert_allclose(ours.numpy(), squashed.log_prob(actions).sum(1).numpy(), rtol=1e-4, atol=1e-4)
        at_bounds = bc_loss(pol, (raw_mean, log_std), th.full((64, 1), 2.0), "tanh_nll")
    assert th.isfinite(at_bounds)
    before = float(bc_loss(pol, pol.raw_heads(model.expert_pairs().observations), model.expert_pairs().actions, "tanh_nll"))
    model.learn(300)
    after = float(bc_loss(pol, pol.raw_heads(model.expert_pairs().observations), model.expert_pairs().actions, "tanh_nll"))
    assert after < before - 0.5
    with pytest.raises(ValueError, match="bounded_mean=True"):
        make(BC, "Pendulum-v1", data["Pendulum-v1"], bc_loss="tanh_nll")
    with pytest.raises(ValueError, match="bc_loss"):
        make(MBIL, "Pendulum-v1", data["Pendulum-v1"], bc_loss="tanh_nll", policy_kwargs={"bounded_mean": True})
    with pytest.raises(ValueError, match="Discrete"):
        make(BC, "CartPole-v1", data["CartPole-v1"], bc_loss="tanh_nll")


@pytest.mark.parametrize("algo", ALGOS)
def test_training_continued_after_load_equals_training_continued_in_memory(algo, data, tmp_path):
    """Every torch state (networks, optimisers, an algorithm's own buffers) is in the zip."""
    model = make(algo, ENV_OF[algo], data[ENV_OF[algo]]).learn(20)
    model.save(tmp_path / "m.zip")
    loaded = algo.load(tmp_path / "m.zip", env=gym.make(ENV_OF[algo]), expert_data=data[ENV_OF[algo]])
    assert_same_params(params(model), params(loaded))
    th.manual_seed(123)  # the caller's own use of the global generators between learns does not matter
    th.rand(5)
    for m in (model, loaded):
        m.learn(15, reset_num_timesteps=False)
    assert_same_params(params(model), params(loaded))


class NoStepping(gym.Wrapper):
    """Raises if the env is stepped, or reset once armed (SB3's set-up resets it once before training)."""

    armed = False

    def step(self, action):
        raise AssertionError("learn stepped the env")

    def reset(self, **kwargs):
        if NoStepping.armed:
            raise AssertionError("learn reset the env after set-up")
        return super().reset(**kwargs)


@pytest.mark.parametrize("algo, env_id", CASES)
def test_learn_never_steps_the_env(algo, env_id, data):
    class Arm(BaseCallback):
        def _on_training_start(self):
            NoStepping.armed = True

        def _on_step(self):
            return True

    NoStepping.armed = False
    try:
        make(algo, NoStepping(gym.make(env_id)), data[env_id]).learn(30, callback=Arm())
    finally:
        NoStepping.armed = False


# Every constructor argument of every algorithm given a wrong type or range raises a ValueError naming it: the
# cases of benchmarks/robustness.py, asserted clean by
# benchmarks/tests/test_harness_reliability.py::test_every_tried_fault_gives_a_clean_error.


@pytest.mark.parametrize("algo", [a for a in ALGOS if spaces.Box not in a.supported_action_spaces])
def test_discrete_only_algorithms_refuse_box_actions(algo):
    with pytest.raises(ValueError, match="action_space: expected Discrete"):
        algo("MlpPolicy", "Pendulum-v1")


@pytest.mark.parametrize("algo", ALGOS)
def test_learn_refuses_a_step_count_that_is_not_one(algo, data):
    model = make(algo, ENV_OF[algo], data[ENV_OF[algo]])
    for bad in (-5, 1.5, True, "10"):
        with pytest.raises(ValueError, match="total_timesteps"):
            model.learn(bad)
    assert model.learn(0).num_timesteps == 0


@pytest.mark.parametrize("env_id", ["CartPole-v1", "Pendulum-v1"])
def test_mbil_joint_estimator_is_the_difference_of_two_flows(env_id, tmp_path):
    """The paper's literal estimator: target = log P_joint(s', a' | s, a) - log T(s' | s, a), one flow over (s', a')
    and one over s'; saved and restored with the model."""
    from sb3_mbil import load_demonstrations
    from sb3_mbil.experts.controllers import controller_demonstrations

    demos = (load_demonstrations("CartPole-v1").sample(1, seed=0) if env_id == "CartPole-v1"
             else controller_demonstrations("Pendulum-v1", 1, seed=0))
    tiny = dict(flow_max_steps=40, flow_hidden=[16], noise_grid=[0.1], seed=0)
    joint = MBIL("MlpPolicy", env_id, expert_data=demos, estimator="joint", **tiny)
    report = joint.fit_flows()
    assert report["estimator"] == "joint" and np.isfinite(report["p_heldout_ll"])
    s, a, s_next, a_next = joint.expert_tuples()
    with th.no_grad():
        expected = joint.flows.log_p_joint(s, a, s_next, a_next) - joint.flows.log_t(s, a, s_next)
    th.testing.assert_close(joint.tuple_targets(), expected.clamp(min=joint.log_density_floor))
    factored = MBIL("MlpPolicy", env_id, expert_data=demos, **tiny)
    factored.fit_flows()
    assert factored.flows.joint is None
    assert not th.allclose(factored.tuple_targets(), joint.tuple_targets())
    joint.learn(20)
    joint.save(tmp_path / "joint.zip")
    loaded = MBIL.load(tmp_path / "joint.zip", expert_data=demos)
    assert loaded.estimator == "joint" and bool(loaded.flows.fitted)
    th.testing.assert_close(loaded.tuple_targets(), joint.tuple_targets())
    with pytest.raises(ValueError, match="estimator: expected one of 'factored', 'joint'"):
        MBIL("MlpPolicy", env_id, expert_data=demos, estimator="paper")


@pytest.mark.parametrize("algo, env_id", CASES)
def test_diagnostics_are_plain_values_with_the_fit_time(algo, env_id, data):
    """The one way a harness reads an algorithm's own results: ``diagnostics()``, numbers and strings only."""
    out = make(algo, env_id, data[env_id]).learn(10).diagnostics()
    assert isinstance(out, dict) and out["fit_seconds"] >= 0.0
    assert all(isinstance(v, (int, float, str)) and not isinstance(v, bool) for v in out.values()), out
