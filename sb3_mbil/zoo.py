"""RL Zoo integration: our algorithms, Optuna samplers and default hyperparameters inside rl_zoo3.

``sb3_mbil_zoo_hook`` (installed with a ``.pth`` file) calls :func:`patch` right after rl_zoo3 imports
``rl_zoo3.utils``, ``rl_zoo3.hyperparams_opt`` and ``rl_zoo3.exp_manager``. Then, with no edit to
rl_zoo3 and no wrapper command::

    python -m rl_zoo3.train --algo mbil --env CartPole-v1
    python -m rl_zoo3.enjoy --algo mbil --env CartPole-v1 -f logs/
    python -m rl_zoo3.train --algo mbil --env CartPole-v1 --optimize --storage URL --study-name NAME

Hyperparameter files (``zoo_hyperparams/<algo>.yml``) have, besides constructor arguments and
``n_timesteps`` (gradient steps), keys of ours: ``expert_pool`` (a shipped pool name, a ``.npz`` path or
``minari:<dataset id>``), ``n_expert_trajectories`` (how many trajectories to draw; default 1) and
``expert_seed`` (the seed of the draw; default: the run's seed, written to the run's ``config.yml`` so that
``python -m rl_zoo3.push_to_hub`` names pool, N and seed in the model card). Every algorithm in
:data:`sb3_mbil.ALGORITHMS` is registered from this one place.
"""

from __future__ import annotations

import functools
import inspect
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
DATA_KEYS = ("expert_pool", "n_expert_trajectories", "expert_seed")
ZOO_DEFAULT_EVAL_FREQ = 25000  # rl_zoo3.train's --eval-freq default



def hyperparams_file(algo: str) -> Path:
    """The default ``<algo>.yml``: inside the installed package, ``zoo_hyperparams/`` of a source checkout, or beside
    the algorithm's own module (an algorithm registered from a package of its own)."""
    folders = [HERE / "zoo_hyperparams", HERE.parent / "zoo_hyperparams"]
    cls = algorithms().get(algo)
    if cls is not None:
        import sys

        module = sys.modules.get(cls.__module__)
        if module is not None and getattr(module, "__file__", None):
            folders.append(Path(module.__file__).resolve().parent)
    for folder in folders:
        if (folder / f"{algo}.yml").is_file():
            return folder / f"{algo}.yml"
    raise FileNotFoundError(f"no zoo hyperparameter file for {algo!r} in sb3_mbil nor beside its module")


def algorithms() -> dict[str, type]:
    from sb3_mbil import ALGORITHMS

    return ALGORITHMS


# ---------------------------------------------------------------------- Optuna samplers
def _zoo_module(name: str):
    """The ``zoo`` module beside the algorithm registered as ``name`` (its folder's ``zoo.py``)."""
    import importlib

    package = algorithms()[name].__module__.rsplit(".", 1)[0]
    try:
        return importlib.import_module(f"{package}.zoo")
    except ModuleNotFoundError:
        return None


class _PerAlgorithm(dict):
    """``{name: its folder's zoo.<attribute>}`` for every registered algorithm that has one (read when first used,
    so that registering an algorithm is its line in ``sb3_mbil.ALGORITHMS`` and its folder's ``zoo.py``)."""

    def __init__(self, attribute: str):
        super().__init__()
        self.attribute = attribute
        self.loaded = False

    def _load(self):
        if not self.loaded:
            self.loaded = True
            for name in algorithms():
                module = _zoo_module(name)
                if module is not None and hasattr(module, self.attribute) and name not in self:
                    super().__setitem__(name, getattr(module, self.attribute))

    def __getitem__(self, key):
        self._load()
        return super().__getitem__(key)

    def __contains__(self, key):
        self._load()
        return super().__contains__(key)

    def __delitem__(self, key):
        self._load()
        super().__delitem__(key)

    def __iter__(self):
        self._load()
        return super().__iter__()


SAMPLERS = _PerAlgorithm("sample_params")
CONVERTERS = _PerAlgorithm("convert_params")


def check_registration(algos: dict[str, type] | None = None) -> None:
    """Every registered algorithm needs its own sampler, converter and hyperparameter file (never BC's by default)."""
    for name in algos or algorithms():
        missing = [what for what, ok in (("an Optuna sampler (sample_params in its folder's zoo.py)", name in SAMPLERS),
                                         ("a converter (convert_params in its folder's zoo.py)", name in CONVERTERS))
                   if not ok]
        try:
            hyperparams_file(name)
        except FileNotFoundError:
            missing.append(f"zoo_hyperparams/{name}.yml")
        if missing:
            raise RuntimeError(f"sb3_mbil.ALGORITHMS[{name!r}]: expected " + " and ".join(missing) + ", found none")


# ---------------------------------------------------------------------- rl_zoo3 patches
def patch(name: str, module) -> None:
    """Called by the import hook after rl_zoo3 module ``name`` has executed."""
    if name == "rl_zoo3.utils":
        check_registration()
        module.ALGOS.update(algorithms())
    elif name == "rl_zoo3.hyperparams_opt":
        check_registration()
        for algo in algorithms():
            module.HYPERPARAMS_SAMPLER[algo] = SAMPLERS[algo]
            module.HYPERPARAMS_CONVERTER[algo] = CONVERTERS[algo]
    elif name == "rl_zoo3.exp_manager":
        _patch_experiment_manager(module.ExperimentManager)
    elif name == "huggingface_sb3.push_to_hub":
        _patch_hub(module)


# ---------------------------------------------------------------------- the Hugging Face Hub
_PACKAGING: list = []  # the model huggingface_sb3.package_to_hub is packaging (a stack, for its model card)


def expert_card_section(info: dict[str, Any] | None) -> str:
    """The model card's account of the expert data a model of ours learned from (``model.expert_info``)."""
    if not info:
        return ""
    indices = info.get("pool_indices")
    drawn = (f"drawn with seed {info['draw_seed']} from the pool `{info.get('pool')}`"
             if info.get("draw_seed") is not None else f"from `{info.get('pool')}`")
    return (f"\n## Expert data (sb3_mbil)\n\nTrained strictly offline on {info.get('n_trajectories')} expert "
            f"trajectories ({info.get('n_steps')} steps) of {info.get('env_id')}, {drawn} (expert: "
            f"{info.get('expert')}){f'; pool indices {indices}' if indices else ''}.\n\n"
            f"- expert pool: `{info.get('pool')}`\n- N (expert trajectories): {info.get('n_trajectories')}\n"
            f"- seed of the draw: {info.get('draw_seed')}\n")


def _patch_hub(module) -> None:
    """huggingface_sb3.push_to_hub: the name rl_zoo3.push_to_hub imports (``generate_metadata``, which
    sb3-team-hf-integration 3.x renamed ``_generate_metadata``), and the expert data in the model card that
    ``package_to_hub`` writes for a model of ours."""
    if getattr(module, "_sb3_mbil_patched", False):
        return
    module._sb3_mbil_patched = True
    if not hasattr(module, "generate_metadata") and hasattr(module, "_generate_metadata"):
        module.generate_metadata = module._generate_metadata
    package, card = module.package_to_hub, module._generate_model_card

    @functools.wraps(package)
    def package_to_hub(model, *args, **kwargs):
        _PACKAGING.append(model)
        try:
            return package(model, *args, **kwargs)
        finally:
            _PACKAGING.pop()

    @functools.wraps(card)
    def _generate_model_card(*args, **kwargs):
        model_card = card(*args, **kwargs)
        info = getattr(_PACKAGING[-1], "expert_info", None) if _PACKAGING else None
        if info:
            model_card.text += expert_card_section(info)
        return model_card

    module.package_to_hub = package_to_hub
    module._generate_model_card = _generate_model_card


def _exit(message: str):
    raise SystemExit(f"sb3_mbil: {message}")


def _patch_experiment_manager(cls) -> None:
    if getattr(cls, "_sb3_mbil_patched", False):
        return
    cls._sb3_mbil_patched = True
    ours = algorithms()
    init, read, preprocess = cls.__init__, cls.read_hyperparameters, cls._preprocess_hyperparams

    @functools.wraps(init)
    def __init__(self, *args, **kwargs):
        init(self, *args, **kwargs)
        bound = inspect.signature(init).bind(self, *args, **kwargs).arguments
        n = bound.get("n_timesteps", -1)
        if self.algo in ours and n != -1 and n < 1:  # -1 is rl_zoo3's "not given"
            _exit(f"-n/--n-timesteps: expected a number of gradient steps >= 1, found {n}")
        config = bound.get("config")
        if self.algo in ours and config is None:
            self.config = str(hyperparams_file(self.algo))

    @functools.wraps(read)
    def read_hyperparameters(self):
        if self.algo in ours:
            import yaml

            with open(self.config) as f:
                table = yaml.safe_load(f) if self.config.endswith((".yml", ".yaml")) else None
            if table is not None and self.env_name.gym_id not in table and "default" not in table:
                _exit(
                    f"no hyperparameters for {self.algo} on {self.env_name.gym_id} in {self.config} "
                    f"(entries: {', '.join(sorted(table))}); add one, or pass --conf-file with yours"
                )
            hyperparams, saved = read(self)
            # the draw's seed (the run's unless given) goes into config.yml: push_to_hub's card shows it
            saved["expert_seed"] = hyperparams.setdefault("expert_seed", self.seed)
            return hyperparams, saved
        return read(self)

    @functools.wraps(preprocess)
    def _preprocess_hyperparams(self, hyperparams):
        if self.algo not in ours:
            return preprocess(self, hyperparams)
        data_spec = {k: hyperparams.pop(k) for k in DATA_KEYS if k in hyperparams}
        _check_keys(self.algo, ours[self.algo], hyperparams)
        for key, value in hyperparams.items():  # rl_zoo3 reads "lin_<x>" as a linear schedule from float(x)
            if isinstance(value, str) and value.startswith("lin_"):
                try:
                    float(value[len("lin_"):])
                except ValueError:
                    _exit(f"{key}: expected a number or 'lin_<initial value>', found {value!r}")
        try:
            result = preprocess(self, hyperparams)
        except (ValueError, TypeError) as e:
            _exit(f"hyperparameters: {e}")
        if isinstance(self.n_timesteps, bool) or not isinstance(self.n_timesteps, int) or self.n_timesteps < 1:
            _exit(f"n_timesteps: expected a number of gradient steps >= 1 (-n or n_timesteps), found {self.n_timesteps!r}")
        if self.eval_freq == ZOO_DEFAULT_EVAL_FREQ and self.n_timesteps <= ZOO_DEFAULT_EVAL_FREQ:
            # the zoo's default would never evaluate our (short) runs: evaluate 10 times instead
            self.eval_freq = max(self.n_timesteps // 10, 1)
        if "expert_data" not in result[0]:
            result[0]["expert_data"] = _expert_data(self.env_name.gym_id, data_spec, data_spec.get("expert_seed", self.seed))
        return result

    def _one_line(method):
        """Our algorithms' ValueErrors (bad settings, bad data) end the command with one ``sb3_mbil:`` line."""

        @functools.wraps(method)
        def wrapped(self, *args, **kwargs):
            if self.algo not in ours:
                return method(self, *args, **kwargs)
            try:
                return method(self, *args, **kwargs)
            except ValueError as e:
                _exit(str(e))

        return wrapped

    cls.__init__ = __init__
    cls.read_hyperparameters = read_hyperparameters
    cls._preprocess_hyperparams = _preprocess_hyperparams
    cls.setup_experiment = _one_line(cls.setup_experiment)
    cls.learn = _one_line(cls.learn)


# keys rl_zoo3 itself reads from a hyperparameter entry (not constructor arguments)
ZOO_KEYS = {"n_timesteps", "policy", "n_envs", "normalize", "env_wrapper", "vec_env_wrapper", "callback", "frame_stack",
            "normalize_kwargs", "policy_kwargs"}


def _check_keys(algo: str, cls: type, hyperparams: dict[str, Any]) -> None:
    """An unknown key (e.g. another algorithm's ``n_steps``) is one ``sb3_mbil:`` line naming it."""
    known = set(inspect.signature(cls.__init__).parameters) - {"self", "env", "_init_setup_model"}
    unknown = sorted(k for k in hyperparams if k not in known and k not in ZOO_KEYS)
    if unknown:
        _exit(f"hyperparameters {', '.join(unknown)}: expected settings of {cls.__name__} "
              f"({', '.join(sorted(known - {'policy', 'expert_data'}))}) or rl_zoo3's own keys, found unknown keys")


def _expert_data(env_id: str, spec: dict[str, Any], seed: int | None):
    """Draw ``n_expert_trajectories`` from ``expert_pool`` with the run's seed; check it fits the env."""
    import gymnasium as gym

    from sb3_mbil.common.demonstrations import load_demonstrations
    from sb3_mbil.common.validation import check_int

    pool = spec.get("expert_pool", env_id)
    n = spec.get("n_expert_trajectories", 1)
    try:
        n = check_int("n_expert_trajectories", n, low=1)
    except ValueError as e:
        _exit(str(e))
    try:
        demos = load_demonstrations(pool)
    except (ValueError, FileNotFoundError) as e:
        _exit(f"expert_pool: {e}")
    pool_env = demos.metadata.get("env_id")
    if pool_env is not None and pool_env != env_id:
        _exit(f"expert_pool: expected demonstrations of {env_id}, found a pool of {pool_env} ({pool!r})")
    env = gym.make(env_id)
    try:
        demos.check_spaces(env.observation_space, env.action_space)
    except ValueError as e:
        _exit(f"expert_pool {pool!r} does not fit {env_id}: {e}")
    finally:
        env.close()
    if n > len(demos):
        _exit(f"n_expert_trajectories: expected at most the {len(demos)} trajectories of expert_pool {pool!r}, found {n}")
    try:
        return demos.sample(n, seed=seed)
    except ValueError as e:
        _exit(f"expert_seed: {e}")
