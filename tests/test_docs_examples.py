"""Every Python block of the README and the docs is run by a test, and every TOML block is
a stook.toml that stook reads as written."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from stook.service.modes import parse
from tests.docs_examples import EXAMPLES, ROOT, code_blocks, pages


@pytest.mark.parametrize("page", pages(), ids=lambda p: p.name)
def test_every_python_block_is_run_by_a_test(page: Path) -> None:
    name = str(page.relative_to(ROOT))
    markers = [marker for (where, marker) in EXAMPLES if where == name]
    for code in code_blocks(page):
        held = [m for m in markers if m in code]
        assert len(held) == 1, f"{name}: a block no test runs:\n{code}"


def test_every_example_is_on_its_page() -> None:
    for page, marker in EXAMPLES:
        assert any(marker in code for code in code_blocks(ROOT / page)), (page, marker)
        assert (ROOT / "tests" / EXAMPLES[page, marker]).is_file()


@pytest.mark.parametrize("page", pages(), ids=lambda p: p.name)
def test_every_toml_block_is_a_config_stook_reads(page: Path) -> None:
    for code in code_blocks(page, "toml"):
        doc = tomllib.loads(code)
        # Custom classes live in the reader's own modules; the rest is built as written.
        for section in ("batch", "report"):
            doc.get(section, {}).pop("custom", None)
        parse(doc, source=page.name)
