"""Write docs/algorithms/<name>.md for every algorithm of sb3_mbil.ALGORITHMS, from its own docstrings and its
zoo settings (so the pages never drift from the code; a test checks they are up to date).

    python scripts/make_docs.py            # writes docs/algorithms/
"""

import argparse
import inspect
import sys
from pathlib import Path

from sb3_mbil.common.cli import run

REPO = Path(__file__).resolve().parent.parent


def page(name: str, cls: type) -> str:
    import yaml

    from sb3_mbil.zoo import hyperparams_file

    module = sys.modules[cls.__module__]
    spaces = ", ".join(s.__name__ for s in cls.supported_action_spaces)
    with open(hyperparams_file(name)) as f:
        table = yaml.safe_load(f)
    env = next(iter(table))
    lines = [
        f"# `{name}`: {cls.__name__}", "",
        f"Action spaces: {spaces}. Source: `{cls.__module__.replace('.', '/')}.py`.", "",
        "```python",
        f"from sb3_mbil import {cls.__name__}, load_demonstrations",
        "",
        f'demos = load_demonstrations("{env}").sample(1, seed=0)',
        f'model = {cls.__name__}("MlpPolicy", "{env}", expert_data=demos, seed=0).learn(10_000)',
        "```", "",
        f"RL Zoo: `python -m rl_zoo3.train --algo {name} --env {env} --num-threads 1`", "",
        "## The update rule", "", inspect.cleandoc(module.__doc__ or ""), "",
        "## Arguments", "", "```", inspect.cleandoc(cls.__doc__ or ""), "```", "",
        f"## Zoo settings (`zoo_hyperparams/{name}.yml`)", "",
        "| env | settings |", "|---|---|",
    ]
    for env_id, entry in table.items():
        settings = ", ".join(f"`{k}={v}`" for k, v in entry.items() if k != "policy")
        lines.append(f"| {env_id} | {settings} |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default=str(REPO / "docs" / "algorithms"))
    a = p.parse_args(argv)
    from sb3_mbil import ALGORITHMS
    from sb3_mbil.common.files import write_text

    index = ["# Algorithms", "", "| name | class | actions |", "|---|---|---|"]
    for name, cls in ALGORITHMS.items():
        write_text(Path(a.out) / f"{name}.md", page(name, cls))
        index.append(f"| [`{name}`]({name}.md) | `{cls.__name__}` | "
                     f"{', '.join(s.__name__ for s in cls.supported_action_spaces)} |")
    write_text(Path(a.out) / "README.md", "\n".join(index) + "\n")
    print(f"wrote {len(ALGORITHMS)} pages to {a.out}")


if __name__ == "__main__":
    run(main)
