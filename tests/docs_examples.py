"""The code blocks of the README and the docs pages, for the tests that run them.

Every Python block of these pages is run by a test: `EXAMPLES` names each one by its page
and a line it holds, `test_docs_examples.py` checks that the list covers every block, and
the tests that run them find them with `block()`.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
DOCS = ROOT / "docs"


def pages() -> list[Path]:
    """The README, every docs page (not the tables `stook bench` writes) and the deploy
    folder's README, which docs/deployment.md includes."""
    docs = [p for p in sorted(DOCS.rglob("*.md")) if "benchmarks" not in p.parts]
    return [README, *docs, ROOT / "deploy" / "README.md"]


def code_blocks(page: Path, language: str = "python") -> list[str]:
    text = page.read_text(encoding="utf-8")
    return re.findall(rf"^```{language}\n(.*?)^```", text, re.S | re.M)


# (page, a line of the block): each Python block of every page, and where it runs.
EXAMPLES: dict[tuple[str, str], str] = {
    ("README.md", "# readme: the mean of each job's speeds"): "e2e/test_fetch_library.py",
    ("docs/library.md", "# fetch_batch: "): "e2e/test_fetch_library.py",
    ("docs/library.md", "# fetch_batch_frame: "): "e2e/test_fetch_library.py",
    ("docs/library.md", "# fetch_report: "): "e2e/test_fetch_library.py",
    ("docs/library.md", "class MaxOfScalar"): "test_docs_examples.py",
    ("docs/library.md", "check_merge_laws("): "test_docs_examples.py",
    ("docs/sdk.md", 'w.write("metrics.binproto")'): "test_docs_examples.py",
    ("docs/sdk.md", "by_label()"): "test_docs_examples.py",
    ("docs/sdk.md", "validate_job_metrics(read_job_metrics"): "test_docs_examples.py",
    ("docs/preview.md", "render_html("): "test_docs_examples.py",
    ("docs/emulator.md", "emulated_batch("): "test_docs_examples.py",
    ("docs/metrics-config.md", "# metrics-config: "): "service/metrics_config/test_docs_example.py",
}


def block(page: str, containing: str, language: str = "python") -> str:
    """The one block of `page` (relative to the checkout) holding `containing`."""
    if language == "python":
        assert (page, containing) in EXAMPLES, f"{page}: {containing!r} is not in EXAMPLES"
    found = [b for b in code_blocks(ROOT / page, language) if containing in b]
    assert len(found) == 1, f"{page}: {len(found)} {language} blocks hold {containing!r}"
    return found[0]
