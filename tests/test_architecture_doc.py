"""docs/architecture.md lists every module of proto/, sdk/ and service/src, and only those.

Each package has a heading naming it in backticks (``### `stook.sdk.stats` ``); the
modules below it, up to the next heading, are named by their file names in backticks
(`` `_bootstrap.py` ``). A module added without a line in the map, or a line left for a
module that is gone, fails here. The figures the doc gives (modules, their median length,
the calls from `stook run` to the write and to the first request) are measured here, the
calls by tracing a real run against the emulator.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
SOURCES = [REPO / "proto" / "src", REPO / "sdk" / "src", REPO / "service" / "src"]
HEADING = re.compile(r"^#+ ")
PACKAGE = re.compile(r"`(stook(?:\.\w+)+)`")
MODULE = re.compile(r"`(\w+)\.py`")


def modules_in_the_tree() -> set[str]:
    found: set[str] = set()
    for root in SOURCES:
        for path in root.rglob("*.py"):
            if path.name != "__init__.py":
                found.add(".".join(path.relative_to(root).with_suffix("").parts))
    return found


def modules_in_the_doc() -> set[str]:
    found: set[str] = set()
    package = None
    for line in (REPO / "docs" / "architecture.md").read_text().splitlines():
        if HEADING.match(line):
            named = PACKAGE.search(line)
            package = named.group(1) if named else None
        elif package is not None:
            found.update(f"{package}.{name}" for name in MODULE.findall(line))
    return found


def test_every_module_is_in_the_architecture_map() -> None:
    assert sorted(modules_in_the_tree() - modules_in_the_doc()) == []


def test_the_architecture_map_lists_no_module_that_is_gone() -> None:
    assert sorted(modules_in_the_doc() - modules_in_the_tree()) == []


# ---- the figures the doc gives are measured here, not asserted by prose ----

PACKAGES = [REPO / "sdk" / "src", REPO / "service" / "src"]
FIGURES = REPO / "docs" / "architecture.md"


def _stated(pattern: str) -> tuple[int, ...]:
    found = re.search(pattern, " ".join(FIGURES.read_text().split()))  # across line breaks
    assert found is not None, f"docs/architecture.md no longer says {pattern!r}"
    return tuple(int(n.replace(",", "")) for n in found.groups())


def test_the_module_count_is_the_trees() -> None:
    import statistics

    files = [path for root in PACKAGES for path in root.rglob("*.py")]
    lines = [len(path.read_text().splitlines()) for path in files]
    (count, median) = _stated(
        r"stook\.sdk and stook\.service hold (\d+) modules, median (\d+) lines"
    )
    assert count == len(files)
    # The median moves with every edit: the doc's figure within 10 %.
    assert abs(statistics.median(lines) - median) <= 0.1 * median


def test_the_hops_are_a_traced_runs(tmp_path: Path) -> None:
    """A real `stook run` (batch mode, against the emulator), traced: the stook functions
    on the stack when `MetricsWriter.write` is called, and the files they are in; and on
    the stack of the first request (a worker task's, run by the loop `stook run` runs)."""
    import json
    import sys

    from stook.sdk import MetricsWriter
    from stook.service.cli import run_cli
    from tests.e2e.support import EmulatorThread, config

    stack: list[str] = []
    request: list[str] = []
    write = MetricsWriter.write.__code__
    ours = tuple(str(root) for root in PACKAGES)
    transport = str(REPO / "service" / "src" / "stook" / "service" / "api" / "_transport.py")

    def frames(frame: Any) -> list[str]:
        found = []
        while frame is not None:
            if frame.f_code.co_filename.startswith(ours):
                found.append(f"{frame.f_code.co_filename}:{frame.f_code.co_qualname}")
            frame = frame.f_back
        return found

    def profile(frame: Any, event: str, _: object) -> None:
        if event != "call":
            return
        if frame.f_code is write and not stack:
            stack.extend(frames(frame))
        elif (
            frame.f_code.co_filename == transport and frame.f_code.co_name == "get" and not request
        ):
            request.extend(frames(frame))

    with EmulatorThread(config(jobs_per_batch=4, seed=3)) as emu:
        inputs = tmp_path / "inputs"
        inputs.mkdir()
        (inputs / "batch_metrics_config.json").write_text(
            json.dumps(
                {
                    "authToken": emu.token,
                    "apiURL": emu.api_url,
                    "batchID": str(emu.batch_id),
                    "projectID": str(emu.project_id),
                }
            )
        )
        sys.setprofile(profile)
        try:
            code = run_cli(["run", "--inputs", str(inputs), "--outputs", str(tmp_path / "out")])
        finally:
            sys.setprofile(None)
    assert code == 0
    calls, files = _stated(r"(\d+) calls across (\d+) files from `stook run` to the write")
    assert (len(stack), len({frame.split(":")[0] for frame in stack})) == (calls, files), stack
    calls, files = _stated(r"(\d+) calls across (\d+) files from `stook run` to the first request")
    assert (len(request), len({f.split(":")[0] for f in request})) == (calls, files), request
