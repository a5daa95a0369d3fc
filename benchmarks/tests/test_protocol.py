"""The `published` data protocol: every k-th step of each trajectory, with true successors (Demonstrations.subsample)."""

from __future__ import annotations

import numpy as np
import pytest
import torch as th

from sb3_mbil import ALGORITHMS, Demonstrations, Trajectory, load_demonstrations
from benchmarks.harness.protocol import PROTOCOLS, demonstrations_for, published_every
from sb3_mbil.experts.controllers import native_demo, native_env


def _labelled(lengths=(23, 9), terminated=(True, False)) -> Demonstrations:
    """Observations encode (episode, step): obs = [episode, step]; action = 10 * episode + step (as a float)."""
    trajs = []
    for e, (n, term) in enumerate(zip(lengths, terminated)):
        steps = np.arange(n + 1, dtype=np.float32)
        obs = np.stack([np.full(n + 1, e, dtype=np.float32), steps], axis=1)
        act = (10 * e + steps[:n]).reshape(-1, 1)
        trajs.append(Trajectory(obs, act, terminated=term, truncated=not term))
    return Demonstrations(trajs, {"env_id": "none"})


@pytest.mark.parametrize("every, offset", [(20, 0), (5, 3), (1, 0)])
def test_subsampling_keeps_true_successors_inside_episodes(every, offset):
    demos = _labelled()
    sub = demos.subsample(every, offset)
    kept = [(e, t) for e, n in enumerate((23, 9)) for t in range(offset, n, every)]
    pairs = sub.pairs()
    assert [tuple(o) for o in pairs["observations"].astype(int)] == kept
    np.testing.assert_array_equal(pairs["actions"][:, 0], [10 * e + t for e, t in kept])

    tr = sub.transitions()
    assert len(tr["observations"]) == len(kept)  # every kept step has its true next observation
    np.testing.assert_array_equal(tr["next_observations"][:, 0], tr["observations"][:, 0])  # never across episodes
    np.testing.assert_array_equal(tr["next_observations"][:, 1], tr["observations"][:, 1] + 1)  # one step on
    last = [(e, t) == (e, n - 1) for (e, t), n in zip(kept, [(23, 9)[e] for e, _ in kept])]
    np.testing.assert_array_equal(tr["dones"], [is_last and e == 0 for is_last, (e, _) in zip(last, kept)])

    tu = sub.tuples()
    inner = [(e, t) for (e, t), is_last in zip(kept, last) if not is_last]  # a kept last step has no a'
    assert [tuple(o) for o in tu["observations"].astype(int)] == inner
    np.testing.assert_array_equal(tu["next_observations"][:, 1], tu["observations"][:, 1] + 1)
    np.testing.assert_array_equal(tu["next_actions"][:, 0], tu["actions"][:, 0] + 1)  # the expert's true a'
    assert sub.metadata["subsampled"] == {"every": every, "offset": offset, "n_episodes": 2, "n_steps": 32}


def test_random_offsets_start_each_trajectory_at_its_own_step_with_true_successors():
    demos = _labelled(lengths=(60, 61, 62, 63), terminated=(True, False, True, False))
    sub = demos.subsample(20, "random", seed=3)
    offsets = sub.metadata["subsampled"]["offsets"]
    assert len(offsets) == 4 and all(0 <= o < 20 for o in offsets) and len(set(offsets)) > 1
    assert demos.subsample(20, "random", seed=3).metadata == sub.metadata  # the same draw for a seed
    kept = [(e, t) for e, (n, o) in enumerate(zip((60, 61, 62, 63), offsets)) for t in range(o, n, 20)]
    assert [tuple(o) for o in sub.pairs()["observations"].astype(int)] == kept
    tr = sub.transitions()
    np.testing.assert_array_equal(tr["next_observations"][:, 0], tr["observations"][:, 0])  # never across episodes
    np.testing.assert_array_equal(tr["next_observations"][:, 1], tr["observations"][:, 1] + 1)
    with pytest.raises(ValueError, match="or 'random', found 'sometimes'"):
        demos.subsample(20, "sometimes")


def test_subsampled_data_round_trips_through_a_file(tmp_path):
    sub = _labelled().subsample(4, 1)
    back = Demonstrations.load(sub.save(tmp_path / "sub.npz"))
    for key in ("observations", "next_observations", "next_actions"):
        np.testing.assert_array_equal(back.tuples()[key], sub.tuples()[key])
    np.testing.assert_array_equal(back.transitions()["dones"], sub.transitions()["dones"])


def test_subsample_refuses_bad_arguments():
    demos = _labelled()
    with pytest.raises(ValueError, match="every: expected"):
        demos.subsample(0)
    with pytest.raises(ValueError, match=r"offset: expected an integer in \[0, 4\]"):
        demos.subsample(5, 5)
    with pytest.raises(ValueError, match="final_action: expected the shape of one action"):
        Trajectory(np.zeros((2, 2)), np.zeros((1, 1)), final_action=np.zeros(3))


def test_published_rates_follow_the_reference_codes():
    assert published_every("bc", "LunarLander-v3") == 20
    assert published_every("iq_learn", "CartPole-v1") == 20
    assert published_every("iq_learn", "Acrobot-v1") == 5
    assert published_every("avril", "CartPole-v1") == 1
    assert published_every("valuedice", "LunarLander-v3") == 1  # the value_dice code keeps whole trajectories
    assert published_every("dsfn", "Acrobot-v1") == 1  # so does the DSFN code
    # a rate of 1 keeps the trajectories whole (DSFN's feature expectations are sums along each trajectory)
    whole = demonstrations_for("dsfn", "Acrobot-v1", 2, seed=0, protocol="published")
    assert len(whole) == 2 and "subsampled" not in whole.metadata
    assert published_every("mbil", "Acrobot-v1") == published_every("bc", "Acrobot-v1")
    full = demonstrations_for("bc", "CartPole-v1", 2, seed=0, protocol="full")
    pub = demonstrations_for("bc", "CartPole-v1", 2, seed=0, protocol="published")
    assert full.metadata["sampled"]["indices"] == pub.metadata["sampled"]["indices"]  # the same draw
    # each trajectory starts at its own step, drawn with the run's seed (IQ-Learn's code starts at step 0)
    offsets = pub.metadata["subsampled"]["offsets"]
    assert pub.metadata["subsampled"]["offset"] == "random" and pub.metadata["subsampled"]["seed"] == 0
    assert pub.n_steps == sum(len(range(o, n, 20)) for n, o in zip(full.episode_lengths, offsets))
    acro = demonstrations_for("bc", "Acrobot-v1", 10, seed=0, protocol="published").metadata["subsampled"]["offsets"]
    assert len(set(acro)) > 1 and acro != demonstrations_for("bc", "Acrobot-v1", 10, seed=1, protocol="published"
                                                             ).metadata["subsampled"]["offsets"]
    assert demonstrations_for("iq_learn", "Acrobot-v1", 10, seed=0, protocol="published").metadata["subsampled"]["offset"] == 0
    assert set(PROTOCOLS) == {"full", "published", "published_next"}
    both = demonstrations_for("bc", "CartPole-v1", 2, seed=0, protocol="published_next")
    assert both.n_steps == sum(min(2, n - t) for n, o in zip(full.episode_lengths, offsets) for t in range(o, n, 20))
    with pytest.raises(ValueError, match="protocol: expected one of"):
        demonstrations_for("bc", "CartPole-v1", 1, seed=0, protocol="every-other")


@pytest.mark.parametrize("name", sorted(ALGORITHMS))
def test_every_algorithm_trains_on_subsampled_data(name):
    algo = ALGORITHMS[name]
    env_id = native_env(algo)
    demos = native_demo(algo, 2).subsample(5)
    model = algo("MlpPolicy", env_id, expert_data=demos, seed=0, batch_size=16)
    model.learn(30)
    assert all(th.isfinite(p).all() for p in model.policy.parameters())
    obs = demos.pairs()["observations"][:3]
    assert model.predict(obs, deterministic=True)[0].shape[0] == 3


def test_mbil_c_balances_at_the_true_successors_of_subsampled_steps():
    demos = load_demonstrations("CartPole-v1").sample(1, seed=0).subsample(20)
    model = ALGORITHMS["mbil_c"]("MlpPolicy", "CartPole-v1", expert_data=demos, seed=0)
    model.learn(5)
    cache = model.balance_targets()
    assert not bool(cache.has_target.any())  # no kept state is another kept step's successor
    tuples = model.expert_tuples()
    assert len(cache.orphan_states) == len(tuples.observations)
    th.testing.assert_close(cache.orphan_states, tuples.next_observations)


def test_with_next_keeps_each_kept_step_and_its_next_step():
    sub = _labelled().subsample(5, 0, with_next=True)
    pairs = sub.pairs()["observations"].astype(int)
    expected = [(e, t + k) for e, n in enumerate((23, 9)) for t in range(0, n, 5) for k in range(2) if t + k < n]
    assert [tuple(o) for o in pairs] == expected
    tu = sub.tuples()  # (s_t, a_t, s_t+1, a_t+1) and (s_t+1, a_t+1, s_t+2, a_t+2), never across kept steps
    np.testing.assert_array_equal(tu["next_observations"][:, 1], tu["observations"][:, 1] + 1)
    np.testing.assert_array_equal(tu["next_actions"][:, 0], tu["actions"][:, 0] + 1)
    assert sub.metadata["subsampled"]["with_next"] is True


def test_the_grid_records_where_subsampling_starts_and_refuses_to_mix_starts(tmp_path):
    """A published run's settings name its start; rows that started every trajectory at step 0 (before the start
    became the reference codes') are not resumed into."""
    import csv

    from benchmarks.harness.grid import Run, check_grid_settings, settings_column

    bc = settings_column("bc", "Acrobot-v1", protocol="published")
    assert "('start', 'random')" in bc and "('every', 20)" in bc
    assert "('start', 0)" in settings_column("iq_learn", "Acrobot-v1", protocol="published")
    assert "start" not in settings_column("bc", "Acrobot-v1")  # full trajectories
    path = tmp_path / "grid.csv"
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=["algo", "env", "settings"])
        writer.writeheader()
        writer.writerow({"algo": "bc", "env": "Acrobot-v1", "settings": bc.replace("('start', 'random'), ", "")})
    with pytest.raises(ValueError, match="write the new runs to another CSV"):
        check_grid_settings([Run("bc", "Acrobot-v1", 1, 0)], str(path), protocol="published")
    check_grid_settings([Run("mbil", "Acrobot-v1", 1, 0)], str(path), protocol="published")  # no rows of its own


def test_same_data_means_whole_trajectories_under_both_protocols():
    from benchmarks.harness.protocol import same_data

    for algo in ("avril", "valuedice", "dsfn"):
        assert same_data(algo, "LunarLander-v3", "published", "full") and same_data(algo, "CartPole-v1", "full", "published")
        assert not same_data(algo, "CartPole-v1", "published_next", "full")
    for algo in ("bc", "mbil", "iq_learn"):
        assert not same_data(algo, "Acrobot-v1", "published", "full") and same_data(algo, "Acrobot-v1", "published", "published")
    with pytest.raises(ValueError, match="protocol"):
        same_data("bc", "Acrobot-v1", "full", "subsampled")


@pytest.mark.parametrize("algo", ["valuedice", "avril"])
def test_one_step_pieces_train_like_whole_trajectories(algo):
    """ValueDICE's and AVRIL's published rows before the rate-1 shortcut trained on one-step pieces
    (``subsample(1)``); they are the same runs as on the whole trajectories, a terminated episode included."""
    whole = load_demonstrations("LunarLander-v3").sample(2, seed=3)
    pieces = whole.subsample(1, "random", seed=3)
    assert len(pieces) == whole.n_steps > len(whole)
    params = []
    for data in (whole, pieces):
        model = ALGORITHMS[algo]("MlpPolicy", "LunarLander-v3", expert_data=data, batch_size=32, seed=0)
        model.learn(30)
        params.append(th.cat([p.detach().flatten() for p in model.policy.parameters()]))
    assert th.equal(params[0], params[1])
