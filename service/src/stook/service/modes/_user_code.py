"""Where user code named in stook.toml is imported from.

``[test] metrics = "my_metrics.test:compute"`` and ``[[batch.custom]] class = ...`` name
modules that usually sit beside stook.toml or in the working directory, as the docs'
examples have it. The ``stook`` console script puts neither on Python's import path (its
own folder is what ``sys.path[0]`` holds), so both are put there, first, as ``python -m``
would: the config file's folder, then the working directory.
"""

from __future__ import annotations

import sys
from pathlib import Path


def import_folders(config_file: Path | None) -> list[Path]:
    """The folders user code is looked for in before the rest of the Python path."""
    folders = [config_file.resolve().parent] if config_file is not None else []
    cwd = Path.cwd()
    if cwd not in folders:
        folders.append(cwd)
    return folders


def add_import_folders(config_file: Path | None) -> None:
    """Put :func:`import_folders` at the front of ``sys.path``, each once."""
    for folder in reversed(import_folders(config_file)):
        entry = str(folder)
        if entry in sys.path:
            sys.path.remove(entry)
        sys.path.insert(0, entry)


def describe_search(config_file: Path | None) -> str:
    """What was searched, for an import error: the folders by role, then the Python path."""
    folders = import_folders(config_file)
    roles = []
    if config_file is not None:
        roles.append(f"the config file's folder {str(folders[0])!r}")
    if len(folders) > len(roles):
        roles.append(f"the working directory {str(folders[-1])!r}")
    return "searched " + ", ".join(roles) + " and then the Python path (PYTHONPATH, site-packages)"
