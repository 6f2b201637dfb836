"""The three distributions share one version, and each pins the one below it to it exactly."""

from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# Each distribution, and the one it is built on: proto <- sdk <- service <- service/testing.
LAYERS = {
    "proto": None,
    "sdk": "stook-proto",
    "service": "stook-sdk",
    "service/testing": "stook",
}


def _project(folder: str) -> dict[str, object]:
    document = tomllib.loads((ROOT / folder / "pyproject.toml").read_text(encoding="utf-8"))
    project = document["project"]
    assert isinstance(project, dict)
    return project


def test_the_distributions_share_one_version_and_pin_each_other_to_it() -> None:
    versions = {folder: _project(folder)["version"] for folder in LAYERS}
    assert len(set(versions.values())) == 1, versions
    version = versions["proto"]
    for folder, below in LAYERS.items():
        dependencies = _project(folder).get("dependencies", [])
        assert isinstance(dependencies, list)
        ours = [d for d in dependencies if d.startswith("stook")]
        assert ours == ([f"{below}=={version}"] if below else []), (folder, ours)
