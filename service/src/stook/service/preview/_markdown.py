"""TEXT metrics as Markdown: CommonMark and tables, with raw HTML escaped, never passed on.

markdown-it-py with ``html`` off renders any HTML in the text as text, and its link
check refuses ``javascript:`` and other script URLs: a metric's text cannot run code in
the page.
"""

from __future__ import annotations

from functools import cache
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from markdown_it import MarkdownIt


@cache
def _parser() -> MarkdownIt:
    from markdown_it import MarkdownIt

    return MarkdownIt("commonmark", {"html": False, "linkify": False}).enable("table")


def markdown_html(text: str) -> str:
    rendered: str = _parser().render(text)
    return rendered
