"""Record the golden outputs of tests/golden/cases.py with the stook that is importable.

    python -m tools.record_golden_outputs                 # the current checkout
    PYTHONPATH=/old/proto/src:/old/sdk/src:/old/service/src \\
        python -m tools.record_golden_outputs             # an older version

Only for a deliberate change of output (or to record before a refactor); say so in the
commit that changes tests/golden/*.binproto.
"""

from __future__ import annotations

import hashlib
import tempfile
from pathlib import Path

from tests.golden.cases import CASES, run_case


def main() -> None:
    for case in CASES:
        with tempfile.TemporaryDirectory() as tmp:
            payload = run_case(case, Path(tmp))
        case.recorded.write_bytes(payload)
        digest = hashlib.sha256(payload).hexdigest()[:16]
        print(f"{case.recorded}: {len(payload):,} bytes, sha256 {digest}")


if __name__ == "__main__":
    main()
