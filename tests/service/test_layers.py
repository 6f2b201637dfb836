"""stook.service's layers, read from the source: no lower layer imports a higher one.

Every import of every module under service/src/stook/service is parsed (ast), including
those inside functions and ``if TYPE_CHECKING:`` blocks, since a lazy import is a
dependency all the same. The layers, lowest first:

    api      transport, retry policy, limits, clients, models, errors, redaction
    fetch    the batch and report fetch cores, on top of api
    preview  metrics.binproto drawn as HTML; reads files with stook.sdk only, so it needs
             no layer below it, and the layers above it (run --preview, stook preview) use it
    metrics_config  the platform's config-defined metrics (YAML, SQL on DuckDB, Liquid);
             stook.sdk only below it; modes and the CLI use it
    modes    test, batch and report mode and what they run on, on top of fetch
    cli      the `stook` command, on top of modes

A module may import its own layer and the layers below it; a lower layer only through its
package (``stook.service.api``), never its ``_``-modules. Inside the API layer the modules
are ordered too (the transport below the retry policy, the clients on top). The package
``stook.service`` itself re-exports api and fetch (and the fetch library from modes); nothing
inside imports it. The
stook-testing distribution uses the layers' packages only.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SERVICE = ROOT / "service" / "src" / "stook" / "service"
TESTING = ROOT / "service" / "testing" / "src" / "stook"
PACKAGE = "stook.service"

LAYERS = ["api", "fetch", "preview", "metrics_config", "modes", "cli"]
# Within the API layer, lowest first: each may import only those before it.
API_ORDER = [
    "_config",
    "_redact",
    "_errors",
    "_limits",
    "_models",
    "_paging",
    "_transport",
    "_retry",
    "_storage",
    "_client",
]
# Modules of the package root: the facade (__init__) and what every layer may use.
ROOT_MODULES = {PACKAGE: "facade"}


def module_name(path: Path) -> str:
    parts = path.relative_to(SERVICE.parent.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(path): path for path in sorted(SERVICE.rglob("*.py"))}


def imports(path: Path, name: str) -> Iterator[tuple[int, str]]:
    """(line, module imported) for every import of stook.service in the file."""
    is_package = path.name == "__init__.py"
    tree = ast.parse(path.read_text(), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")
                base = base if is_package else base[:-1]
                base = base[: len(base) - node.level + 1]
                source = ".".join([*base, node.module] if node.module else base)
            else:
                source = node.module or ""
            for alias in node.names:
                # `from package import _module` imports the module.
                submodule = f"{source}.{alias.name}"
                yield node.lineno, submodule if submodule in MODULES else source


def layer_of(module: str) -> str:
    if module in ROOT_MODULES:
        return ROOT_MODULES[module]
    return module.split(".")[2]


def rank(layer: str) -> int:
    return -1 if layer == "base" else LAYERS.index(layer)


def violations() -> Iterator[str]:
    for name, path in MODULES.items():
        source_layer = layer_of(name)
        for line, target in imports(path, name):
            if target != PACKAGE and not target.startswith(PACKAGE + "."):
                continue
            where = f"{path.relative_to(ROOT)}:{line} imports {target}"
            target_layer = layer_of(target)
            if source_layer == "facade":
                # modes: the fetch library (fetch_batch, ...), which reads the platform's inputs.
                if target_layer not in ("base", "api", "fetch", "modes") or target.count(".") > 2:
                    yield f"{where}: the facade re-exports the api, fetch and modes packages only"
                continue
            if target_layer == "facade":
                yield f"{where}: nothing inside stook.service imports its facade"
            elif target_layer == "base":
                continue
            elif rank(target_layer) > rank(source_layer):
                yield f"{where}: {source_layer} must not import the {target_layer} layer above it"
            elif target_layer != source_layer and target != f"{PACKAGE}.{target_layer}":
                yield f"{where}: another layer is imported through its package only"
            elif source_layer == target_layer == "api" and name != f"{PACKAGE}.api":
                mine, theirs = name.rsplit(".", 1)[1], target.rsplit(".", 1)[1]
                if API_ORDER.index(theirs) >= API_ORDER.index(mine):
                    yield f"{where}: in the API layer, {mine} comes before {theirs}"


def test_every_module_belongs_to_a_layer() -> None:
    for name in MODULES:
        if name in ROOT_MODULES:
            continue
        assert layer_of(name) in LAYERS, f"{name} is in no layer"
    api_modules = {n.rsplit(".", 1)[1] for n in MODULES if n.startswith(f"{PACKAGE}.api._")}
    assert api_modules == set(API_ORDER)


def test_no_layer_imports_a_higher_one() -> None:
    assert list(violations()) == []


def test_the_check_sees_what_it_should() -> None:
    # The parser finds function-level and TYPE_CHECKING imports, and relative ones.
    main = MODULES[f"{PACKAGE}.cli._main"]
    found = {target for _, target in imports(main, f"{PACKAGE}.cli._main")}
    assert {f"{PACKAGE}.cli._run", f"{PACKAGE}.modes", f"{PACKAGE}.cli._signals"} <= found
    assert layer_of(f"{PACKAGE}.api._transport") == "api"
    assert rank("api") < rank("fetch") < rank("modes") < rank("cli")


@pytest.mark.parametrize("path", sorted(TESTING.rglob("*.py")), ids=lambda p: p.name)
def test_stook_testing_uses_the_layers_packages_only(path: Path) -> None:
    tree = ast.parse(path.read_text())
    private = [
        f"{path.relative_to(ROOT)}:{node.lineno} imports {node.module}"
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom)
        and node.module is not None
        and node.module.startswith(PACKAGE)
        and any(part.startswith("_") for part in node.module.split(".")[2:])
    ]
    assert private == []
