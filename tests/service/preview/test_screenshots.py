"""docs/preview.md's screenshots: one per page that tools/screenshot_previews takes, each
with a caption whose numbers are on the page the demo writes today."""

from __future__ import annotations

import html
import re
from pathlib import Path

import pytest

from stook.testing._demo import run_demo
from tools.screenshot_previews import PAGES

DOCS = Path(__file__).resolve().parents[3] / "docs"
_IMAGE = re.compile(r"!\[([^\]]*)\]\(preview-([a-z]+)\.png\)")
_NUMBER = re.compile(r"\d[\d,]*(?:\.\d+)?")


def captions() -> dict[str, str]:
    text = (DOCS / "preview.md").read_text(encoding="utf-8")
    return {name: caption for caption, name in _IMAGE.findall(text)}


def visible_text(page: str) -> str:
    """The page's content as a reader sees it: tags out, entities read, spaces folded."""
    main = page[page.index("<main") : page.index("</main>")]
    return " ".join(html.unescape(re.sub(r"<[^>]+>", " ", main)).split())


def test_every_page_has_its_screenshot_and_a_caption_with_numbers() -> None:
    found = captions()
    assert sorted(found) == sorted(PAGES)
    for name, caption in found.items():
        assert (DOCS / f"preview-{name}.png").is_file(), name
        assert _NUMBER.search(caption), f"the caption of preview-{name}.png quotes no number"


@pytest.mark.slow
def test_the_captions_numbers_are_on_todays_pages(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # `make demo`'s defaults: the screenshots are of its pages.
    assert run_demo(jobs=200, output=tmp_path, seed=7) == 0
    capsys.readouterr()
    for name, caption in captions().items():
        text = visible_text((tmp_path / PAGES[name]).read_text(encoding="utf-8"))
        for number in _NUMBER.findall(caption):
            on_page = rf"(?<![\d.,]){re.escape(number)}(?!\d|[.,]\d)"
            assert re.search(on_page, text), f"preview-{name}.png: {number} is not on the page"
