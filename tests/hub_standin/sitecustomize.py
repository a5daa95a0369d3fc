"""A stand-in for the Hugging Face Hub API (no network): uploads are copied to $SB3_MBIL_HUB_STANDIN/<repo_id>/.

Put this folder on PYTHONPATH (Python imports ``sitecustomize`` at start-up) or call :func:`install`.
"""

import os
import shutil
from pathlib import Path


def install(root=None):
    from huggingface_hub import HfApi, RepoUrl

    target = Path(root or os.environ["SB3_MBIL_HUB_STANDIN"])

    def create_repo(self, repo_id, *args, **kwargs):
        (target / repo_id).mkdir(parents=True, exist_ok=True)
        return RepoUrl(f"https://huggingface.co/{repo_id}")

    def snapshot_download(self, repo_id, *args, local_dir=None, **kwargs):
        Path(local_dir).mkdir(parents=True, exist_ok=True)  # a new repository: nothing to download
        return str(local_dir)

    def upload_folder(self, repo_id, folder_path, *args, **kwargs):
        shutil.copytree(folder_path, target / repo_id, dirs_exist_ok=True)
        return f"https://huggingface.co/{repo_id}/tree/main"

    HfApi.create_repo, HfApi.snapshot_download, HfApi.upload_folder = create_repo, snapshot_download, upload_folder


if os.environ.get("SB3_MBIL_HUB_STANDIN"):
    install()
