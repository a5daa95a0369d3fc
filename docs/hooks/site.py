"""MkDocs hook: the site's pages are the repository's own Markdown, laid out as in the checkout, so that every
relative link that works on the repository works on the site and a broken one fails ``mkdocs build --strict``.

Before the files are collected, the pages (README.md as the home page, docs/, BENCHMARKS.md, CHANGELOG.md, the
Markdown reports and figures under results/, LICENSE) are copied into a staging folder that becomes ``docs_dir``.
"""

from __future__ import annotations

import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PAGES = ["README.md", "BENCHMARKS.md", "CHANGELOG.md", "LICENSE", "CITATION.cff"]
TREES = {"docs": ("*.md", "*.png"), "results": ("*.md", "*.png"), "examples": ("*.py",)}


def on_config(config):
    staging = ROOT / "build" / "site_src"
    if staging.exists():
        shutil.rmtree(staging)
    staging.mkdir(parents=True)
    for name in PAGES:
        shutil.copy2(ROOT / name, staging / ("index.md" if name == "README.md" else name))
    for tree, patterns in TREES.items():
        for pattern in patterns:
            for path in (ROOT / tree).rglob(pattern):
                if "hooks" in path.relative_to(ROOT / tree).parts:
                    continue
                target = staging / path.relative_to(ROOT)
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(path, target)
    # the home page is README.md: links to it from other pages go to the index
    config.docs_dir = str(staging)
    return config
