"""`stook demo` previews each of its outputs and prints where."""

from __future__ import annotations

from pathlib import Path

import pytest

from stook.testing._demo import run_demo


@pytest.mark.slow
def test_the_demo_writes_and_prints_a_preview_of_each_output(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert run_demo(jobs=12, output=tmp_path, seed=3) == 0
    printed = capsys.readouterr().out
    pages = [
        tmp_path / "test-mode" / "metrics.html",
        tmp_path / "metrics.html",
        tmp_path / "metrics-config" / "metrics.html",
        tmp_path / "report" / "metrics.html",
    ]
    for page in pages:
        assert f"  preview: {page}\n" in printed
        assert page.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    # The config-defined batch metric, with its SQL's gist.
    assert "Mean localization error (SELECT AVG(error) FROM localization): " in printed
    # The example's images are beside its output, so its preview embeds them.
    assert pages[0].read_text(encoding="utf-8").count('<img src="data:image/png') == 3
    # The config-defined "Worst localization frame" names a camera frame the demo draws
    # beside the output, so its preview shows an image, not a placeholder.
    config_page = pages[2].read_text(encoding="utf-8")
    assert config_page.count('<img src="data:image/png') == 1
    assert "is not beside the file" not in config_page
