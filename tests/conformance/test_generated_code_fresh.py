"""The committed generated code is exactly what `make proto` produces now."""

from __future__ import annotations

from pathlib import Path

from tools.generate_proto import GENERATED_ROOT, generate


def test_generated_code_matches_committed(tmp_path: Path) -> None:
    generated = generate(tmp_path)
    assert generated, "protoc generated nothing"
    committed = sorted(p.relative_to(GENERATED_ROOT) for p in GENERATED_ROOT.rglob("*_pb2.py*"))
    assert generated == committed, "generated and committed files differ in name"
    stale = [
        str(rel)
        for rel in generated
        if (tmp_path / rel).read_bytes() != (GENERATED_ROOT / rel).read_bytes()
    ]
    assert not stale, f"stale generated code (run `make proto`): {stale}"
