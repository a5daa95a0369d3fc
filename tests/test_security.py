"""What the package reads or writes must not run code or write outside its target."""

import os
import stat

import numpy as np
import pytest

from sb3_mbil import BC, Demonstrations, Trajectory, load_demonstrations
from sb3_mbil.common.files import atomic_write


@pytest.fixture(scope="module")
def demo():
    return load_demonstrations("CartPole-v1").sample(1, seed=0)


def _plant_links(folder, name, victim):
    """Symlinks to ``victim`` at every temporary name the old scheme (``.NAME.PID.tmp``) could use, and one at the
    target itself."""
    links = [folder / f".{name}.{os.getpid()}.tmp", folder / f".{name}.{os.getpid() + 1}.tmp"]
    for link in links:
        link.symlink_to(victim)
    return links


@pytest.mark.parametrize("what", ["demonstrations", "model"])
def test_a_planted_symlink_is_never_written_through(demo, tmp_path, what):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    folder = tmp_path / "out"
    folder.mkdir()
    name = "x.npz" if what == "demonstrations" else "m.zip"
    _plant_links(folder, name, victim)
    (folder / name).symlink_to(victim)  # the target itself is a link: it is replaced, not followed
    if what == "demonstrations":
        demo.save(folder / name)
        assert len(Demonstrations.load(folder / name)) == 1
    else:
        BC("MlpPolicy", "CartPole-v1", expert_data=demo).save(folder / name)
        BC.load(folder / name)
    assert victim.read_text() == "precious"
    assert not (folder / name).is_symlink() and (folder / name).is_file()


def test_an_atomic_write_gets_the_permissions_of_a_new_file(tmp_path):
    umask = os.umask(0o022)
    try:
        with atomic_write(tmp_path / "f.bin") as tmp:
            assert tmp.is_file() and not tmp.is_symlink()
            tmp.write_bytes(b"abc")
    finally:
        os.umask(umask)
    assert stat.S_IMODE((tmp_path / "f.bin").stat().st_mode) == 0o644
    assert os.listdir(tmp_path) == ["f.bin"]


def test_an_atomic_write_whose_temporary_was_swapped_for_a_link_refuses(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    with pytest.raises(OSError, match="expected the regular file this write created"):
        with atomic_write(tmp_path / "f.bin") as tmp:
            tmp.unlink()
            tmp.symlink_to(victim)
    assert victim.read_text() == "precious"
    assert sorted(os.listdir(tmp_path)) == ["victim.txt"]


def test_demonstrations_round_trip_without_pickles(tmp_path):
    t = Trajectory(np.zeros((3, 4), dtype=np.float32), np.zeros(2, dtype=np.int64))
    path = Demonstrations([t]).save(tmp_path / "d.npz")
    with np.load(path, allow_pickle=False) as data:  # every member is a plain array
        assert all(data[k].dtype != object for k in data.files)


def test_settings_strings_are_parsed_never_run(tmp_path):
    import torch as th

    from sb3_mbil.common.settings import parse_policy_kwargs

    assert parse_policy_kwargs("dict(net_arch=[256, 256], activation_fn=nn.ELU, optimizer_class=th.optim.AdamW, "
                               "optimizer_kwargs=dict(eps=1e-5), log_std_init=-2, bounded_mean=True)") == {
        "net_arch": [256, 256], "activation_fn": th.nn.ELU, "optimizer_class": th.optim.AdamW,
        "optimizer_kwargs": {"eps": 1e-5}, "log_std_init": -2, "bounded_mean": True}
    assert parse_policy_kwargs("{'net_arch': (32,)}") == {"net_arch": (32,)}
    marker = tmp_path / "ran"
    for attack in (f"dict(x=open({str(marker)!r}, 'w'))", "__import__('os').system('true')",
                   "dict(a=nn.Module.__subclasses__())", "dict(**{'a': 1})", "dict(a=th.load)", "os.system",
                   "dict(a=(lambda: 1)())", "[1, 2]"):
        with pytest.raises(ValueError, match="policy_kwargs: expected"):
            parse_policy_kwargs(attack)
    assert not marker.exists()


@pytest.mark.parametrize("org, trust, expected", [("sb3", None, "True"), ("someone-else", None, None),
                                                  ("someone-else", True, "True"), ("sb3", False, None)])
def test_remote_code_is_trusted_for_the_rl_zoo_only_unless_the_caller_says(monkeypatch, org, trust, expected):
    import huggingface_sb3

    from sb3_mbil.experts.agents import load_hub_expert

    seen = {}

    def fake_load_from_hub(repo_id, filename):
        seen["trust"] = os.environ.get("TRUST_REMOTE_CODE")
        raise OSError("offline")

    monkeypatch.delenv("TRUST_REMOTE_CODE", raising=False)
    monkeypatch.setattr(huggingface_sb3, "load_from_hub", fake_load_from_hub)
    with pytest.raises(LookupError):
        load_hub_expert("CartPole-v1", "dqn", org=org, online=True, trust_remote_code=trust)
    assert seen["trust"] == expected
    assert "TRUST_REMOTE_CODE" not in os.environ
    with pytest.raises(ValueError, match="trust_remote_code: expected True, False or None"):
        load_hub_expert("CartPole-v1", "dqn", trust_remote_code="yes")


@pytest.mark.parametrize("dataset_id", ["../../escaped/x-v0", "/abs/x-v0", "ns/../x-v0", ".hidden-v0", "x", "x-v0/..",
                                        "a b-v0", 5])
def test_a_minari_id_outside_the_store_is_refused_before_anything_is_written(demo, tmp_path, monkeypatch, dataset_id):
    from sb3_mbil.common.demonstrations import check_minari_id

    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "store" / "a" / "b"))
    with pytest.raises(ValueError, match="dataset_id: expected"):
        demo.to_minari(dataset_id)
    assert os.listdir(tmp_path) == []
    assert check_minari_id("ns/sub/cartpole-expert-v0") == "ns/sub/cartpole-expert-v0"


def _crafted_zip(source, target, marker, key="policy_class"):
    """A copy of ``source`` whose data entry ``key`` is a cloudpickle payload that creates ``marker`` when unpickled."""
    import base64
    import json
    import zipfile

    import cloudpickle

    class Payload:
        def __reduce__(self):
            return (open, (str(marker), "w"))

    with zipfile.ZipFile(source) as src, zipfile.ZipFile(target, "w") as dst:
        for item in src.namelist():
            content = src.read(item)
            if item == "data":
                data = json.loads(content)
                data[key] = {":type:": "<class 'x'>", ":serialized:": base64.b64encode(cloudpickle.dumps(Payload())).decode()}
                content = json.dumps(data).encode()
            dst.writestr(item, content)
    return target


def test_a_crafted_zip_runs_no_code_in_safe_mode(demo, tmp_path):
    model = BC("MlpPolicy", "CartPole-v1", expert_data=demo, seed=0)
    model.save(tmp_path / "m.zip")
    marker = tmp_path / "code-ran"
    crafted = _crafted_zip(tmp_path / "m.zip", tmp_path / "crafted.zip", marker)
    loaded = BC.load(crafted, safe=True)  # policy_class is rebuilt from the class, the payload never unpickled
    assert not marker.exists()
    assert loaded.policy_class is BC.policy_aliases["MlpPolicy"]
    unknown = _crafted_zip(tmp_path / "m.zip", tmp_path / "unknown.zip", marker, key="evil")
    with pytest.raises(ValueError, match="evil: expected entries safe mode can rebuild"):
        BC.load(unknown, safe=True)
    assert not marker.exists()
    with pytest.raises(TypeError):  # the default (SB3's own) load unpickles, which is what the docstring warns about:
        BC.load(crafted)  # the payload runs (and its result is no policy class)
    assert marker.exists()


def test_a_zip_without_the_plain_description_is_refused_in_safe_mode(demo, tmp_path):
    import zipfile

    BC("MlpPolicy", "CartPole-v1", expert_data=demo).save(tmp_path / "m.zip")
    with zipfile.ZipFile(tmp_path / "m.zip") as src, zipfile.ZipFile(tmp_path / "old.zip", "w") as dst:
        for item in src.namelist():
            if item != "sb3_mbil.json":
                dst.writestr(item, src.read(item))
    with pytest.raises(ValueError, match="expected a zip with sb3_mbil.json"):
        BC.load(tmp_path / "old.zip", safe=True)
