"""Build commands that ship sb3_mbil_zoo.pth (RL Zoo registration) and the zoo hyperparameter files.

Metadata and dependencies are in setup.cfg.
"""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent
PTH = "sb3_mbil_zoo.pth"


class BuildPy(build_py):
    """Copy the .pth to the wheel's root and zoo_hyperparams/ into the package (for `pip install .`)."""

    def run(self):
        super().run()
        shutil.copy(ROOT / PTH, Path(self.build_lib) / PTH)
        target = Path(self.build_lib) / "sb3_mbil" / "zoo_hyperparams"
        target.mkdir(parents=True, exist_ok=True)
        for yml in (ROOT / "zoo_hyperparams").glob("*.yml"):
            shutil.copy(yml, target / yml.name)


cmdclass = {"build_py": BuildPy}

try:
    from setuptools.command.editable_wheel import editable_wheel

    class EditableWheel(editable_wheel):
        """An editable install (PEP 660) drops files outside packages: write the .pth into the wheel ourselves."""

        def _select_strategy(self, name, tag, build_lib):
            strategy = super()._select_strategy(name, tag, build_lib)

            class WithPth:
                def __enter__(self):
                    strategy.__enter__()
                    return self

                def __exit__(self, *exc):
                    return strategy.__exit__(*exc)

                def __call__(self, wheel, files, mapping):
                    strategy(wheel, files, mapping)
                    wheel.writestr(PTH, (ROOT / PTH).read_text())

            return WithPth()

    cmdclass["editable_wheel"] = EditableWheel
except ImportError:  # very old setuptools: no PEP 660
    pass

setup(cmdclass=cmdclass)
