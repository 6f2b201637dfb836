"""Report mode's import of ruptures in a thread: what it imports, and when it gives up."""

from __future__ import annotations

import sys
from types import SimpleNamespace

import pytest

from stook.service.modes import _report_imports


@pytest.fixture
def imported(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    done: list[str] = []
    monkeypatch.setattr(_report_imports, "importlib", SimpleNamespace(import_module=done.append))
    return done


def test_an_idle_process_imports_scipy_a_package_at_a_time_then_ruptures(
    monkeypatch: pytest.MonkeyPatch, imported: list[str]
) -> None:
    monkeypatch.setattr(_report_imports, "_busy", lambda: False)
    _report_imports._import_when_idle()
    assert imported == [*_report_imports._STEPS, "ruptures"]
    assert all(m.startswith("scipy.") for m in _report_imports._STEPS)


def test_a_busy_process_imports_nothing_once_the_search_has_imported_ruptures(
    monkeypatch: pytest.MonkeyPatch, imported: list[str]
) -> None:
    looks = iter([True, True, False])  # busy twice, then the search imports ruptures
    modules = dict(sys.modules)
    modules.pop("ruptures", None)
    monkeypatch.setattr(_report_imports, "sys", SimpleNamespace(modules=modules))

    def busy() -> bool:
        if next(looks):
            return True
        modules["ruptures"] = sys  # any module: the search's import has begun
        return True

    monkeypatch.setattr(_report_imports, "_busy", busy)
    _report_imports._import_when_idle()
    assert imported == []


def test_a_failed_import_ends_the_thread_quietly(monkeypatch: pytest.MonkeyPatch) -> None:
    tried: list[str] = []

    def fail(module: str) -> None:
        tried.append(module)
        raise ImportError(module)

    monkeypatch.setattr(_report_imports, "_busy", lambda: False)
    monkeypatch.setattr(_report_imports, "importlib", SimpleNamespace(import_module=fail))
    _report_imports._import_when_idle()
    assert tried == [_report_imports._STEPS[0]]


def test_the_thread_is_a_daemon() -> None:
    thread = _report_imports.import_change_points_when_idle()
    assert thread.daemon
    thread.join()
    assert "ruptures" in sys.modules
