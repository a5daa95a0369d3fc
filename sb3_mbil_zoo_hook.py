"""Register sb3_mbil's algorithms with the RL Zoo, lazily (loaded at interpreter start-up by sb3_mbil_zoo.pth).

rl_zoo3 fixes ``--algo`` choices from ``rl_zoo3.utils.ALGOS`` before it imports any user module, and
has no plugin entry point. This module, standard library only, installs an import hook that waits
for ``rl_zoo3.utils``, ``rl_zoo3.hyperparams_opt`` and ``rl_zoo3.exp_manager`` to be imported and then
lets ``sb3_mbil.zoo`` add our algorithms, samplers and default hyperparameter files (and, after
``huggingface_sb3.push_to_hub``, the expert data in the Hub model card and the name rl_zoo3.push_to_hub imports). Nothing else
is imported at start-up: an interpreter that never imports rl_zoo3 never imports torch because of us.
"""

import sys

_TARGETS = ("rl_zoo3.utils", "rl_zoo3.hyperparams_opt", "rl_zoo3.exp_manager", "huggingface_sb3.push_to_hub")


class _PatchingLoader:
    def __init__(self, loader, name):
        self._loader = loader
        self._name = name

    def create_module(self, spec):
        return self._loader.create_module(spec)

    def exec_module(self, module):
        self._loader.exec_module(module)
        try:
            from sb3_mbil.zoo import patch
        except ImportError:  # sb3_mbil was uninstalled but this file stayed: do nothing
            return
        patch(self._name, module)

    def __getattr__(self, item):
        return getattr(self._loader, item)


class ZooFinder:
    """Wraps the loader of the three rl_zoo3 modules so that sb3_mbil.zoo.patch runs after each."""

    def find_spec(self, fullname, path, target=None):
        if fullname not in _TARGETS:
            return None
        for finder in sys.meta_path:
            if finder is self or not hasattr(finder, "find_spec"):
                continue
            spec = finder.find_spec(fullname, path, target)
            if spec is not None:
                break
        else:
            return None
        if spec.loader is not None and not isinstance(spec.loader, _PatchingLoader):
            spec.loader = _PatchingLoader(spec.loader, fullname)
        return spec


def install():
    if not any(isinstance(f, ZooFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, ZooFinder())


install()
