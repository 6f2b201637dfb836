"""Generate stook.proto's Python code and typing stubs from proto/protos.

Used by `make proto` and by the test that checks the committed code is fresh.
grpcio-tools and mypy-protobuf are pinned in the root pyproject.toml so that
the output is reproducible.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from importlib import resources
from pathlib import Path

from grpc_tools import protoc

ROOT = Path(__file__).resolve().parent.parent
PROTO_SOURCES = ROOT / "proto" / "protos"
GENERATED_ROOT = ROOT / "proto" / "src"
GENERATED_PACKAGE = Path("stook") / "proto"


def proto_files() -> list[Path]:
    return sorted((PROTO_SOURCES / GENERATED_PACKAGE).glob("*.proto"))


def generate(out_dir: Path) -> list[Path]:
    """Run protoc into out_dir; return the generated files relative to out_dir."""
    plugin = shutil.which("protoc-gen-mypy", path=str(Path(sys.executable).parent))
    if plugin is None:
        raise SystemExit("protoc-gen-mypy not found next to this Python: install the dev group")
    well_known = resources.files("grpc_tools") / "_proto"
    args = [
        "grpc_tools.protoc",
        f"--proto_path={PROTO_SOURCES}",
        f"--proto_path={well_known}",
        f"--plugin=protoc-gen-mypy={plugin}",
        f"--python_out={out_dir}",
        f"--mypy_out={out_dir}",
        *(str(p.relative_to(PROTO_SOURCES)) for p in proto_files()),
    ]
    code = protoc.main(args)
    if code != 0:
        raise SystemExit(f"protoc failed with exit code {code}")
    return sorted(p.relative_to(out_dir) for p in (out_dir / GENERATED_PACKAGE).glob("*_pb2.py*"))


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        for rel in generate(out):
            target = GENERATED_ROOT / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(out / rel, target)
            print(f"wrote {target.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
