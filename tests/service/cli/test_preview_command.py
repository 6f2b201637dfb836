"""`stook preview` and the previews `stook run` writes, through the command's own entry
(run_cli, in this process: its exit code, what it prints, what it leaves)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from stook.service.cli import run_cli
from stook.service.modes import ConfigError, parse
from tests.service.preview.support import BATCH_OUTPUT, REPORT_OUTPUT, write_example


@dataclass(frozen=True)
class Done:
    returncode: int
    stdout: str
    stderr: str


Stook = Callable[..., Done]


@pytest.fixture
def stook(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> Stook:
    # Failures said as one `stook: ...` line, not a JSON event.
    monkeypatch.setenv("STOOK_LOG_FORMAT", "console")

    def run(*args: str, cwd: Path | None = None) -> Done:
        if cwd is not None:
            monkeypatch.chdir(cwd)
        capsys.readouterr()
        code = run_cli(list(args))
        out, err = capsys.readouterr()
        return Done(code, out, err)

    return run


def test_preview_writes_one_page_and_prints_its_path(tmp_path: Path, stook: Stook) -> None:
    source = write_example(tmp_path)
    done = stook("preview", str(source))
    assert done.returncode == 0, done.stderr
    page = tmp_path / "metrics.html"
    assert done.stdout == f"{page}\n"
    assert page.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")


def test_several_files_into_a_named_page(tmp_path: Path, stook: Stook) -> None:
    target = tmp_path / "two.html"
    done = stook("preview", str(BATCH_OUTPUT), str(REPORT_OUTPUT), "-o", str(target))
    assert done.returncode == 0, done.stderr
    assert "--columns:2" in target.read_text(encoding="utf-8")


def test_several_files_default_to_preview_html_here(tmp_path: Path, stook: Stook) -> None:
    done = stook("preview", str(BATCH_OUTPUT), str(REPORT_OUTPUT), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "preview.html").is_file()


def test_a_missing_file_is_exit_2_before_anything_is_written(tmp_path: Path, stook: Stook) -> None:
    target = tmp_path / "out.html"
    done = stook("preview", str(BATCH_OUTPUT), str(tmp_path / "nope.binproto"), "-o", str(target))
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        f"stook: error: {str(tmp_path / 'nope.binproto')!r}: no such file"
    ]
    assert not target.exists()


def test_not_job_metrics_is_exit_4_in_one_line_naming_it(tmp_path: Path, stook: Stook) -> None:
    junk = tmp_path / "junk.binproto"
    junk.write_bytes(b"\x08\x96\x01 this is not JobMetrics")
    done = stook("preview", str(junk))
    assert done.returncode == 4
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert str(junk) in lines[0]
    assert list(tmp_path.iterdir()) == [junk]  # no page, no temporary file


def test_the_preview_never_overwrites_an_input(tmp_path: Path, stook: Stook) -> None:
    source = write_example(tmp_path)
    done = stook("preview", str(source), "-o", str(source))
    assert done.returncode == 2
    assert "would overwrite an input" in done.stderr


@pytest.fixture
def test_inputs(tmp_path: Path) -> Path:
    inputs = tmp_path / "inputs"
    for folder in ("experience", "logs"):
        (inputs / folder).mkdir(parents=True)
    return inputs


def _run(stook: Stook, tmp_path: Path, inputs: Path, toml: str, *flags: str) -> tuple[int, Path]:
    config = tmp_path / "stook.toml"
    config.write_text(toml)
    outputs = tmp_path / "outputs"
    argv = ["run", "--inputs", str(inputs), "--outputs", str(outputs), "--config", str(config)]
    done = stook(*argv, *flags, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    return done.returncode, outputs


EXAMPLE = '[test]\nmetrics = "stook.sdk.example:every_metric_type"\n'


def test_run_preview_writes_metrics_html_beside_the_output(
    tmp_path: Path, test_inputs: Path, stook: Stook
) -> None:
    code, outputs = _run(stook, tmp_path, test_inputs, EXAMPLE, "--preview")
    assert code == 0
    assert sorted(p.name for p in outputs.iterdir()) == ["metrics.binproto", "metrics.html"]
    assert 'data-metric="Speed over time"' in (outputs / "metrics.html").read_text()


def test_output_preview_in_the_config(tmp_path: Path, test_inputs: Path, stook: Stook) -> None:
    code, outputs = _run(stook, tmp_path, test_inputs, EXAMPLE + "[output]\npreview = true\n")
    assert code == 0
    assert (outputs / "metrics.html").is_file()
    code, outputs = _run(stook, tmp_path, test_inputs, EXAMPLE + "[output]\npreview = false\n")
    assert code == 0


def test_no_preview_unless_asked(tmp_path: Path, test_inputs: Path, stook: Stook) -> None:
    code, outputs = _run(stook, tmp_path, test_inputs, EXAMPLE)
    assert code == 0
    assert sorted(p.name for p in outputs.iterdir()) == ["metrics.binproto"]


def test_output_section_is_checked() -> None:
    assert parse({"output": {"preview": True}}).preview is True
    assert parse({}).preview is False
    with pytest.raises(ConfigError, match="preview must be true or false"):
        parse({"output": {"preview": "yes"}})
    with pytest.raises(ConfigError, match="unknown key 'html'"):
        parse({"output": {"html": True}})
