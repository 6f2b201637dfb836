"""polars and numpy are imported off the event loop's thread: the loop runs on meanwhile."""

from __future__ import annotations

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent(
    """
    import asyncio, sys
    from stook.service.fetch._decoders import decoders_loaded, decoders_ready, start_importing

    async def main():
        assert "polars" not in sys.modules
        ticks = 0
        async def tick():
            nonlocal ticks
            while True:
                await asyncio.sleep(0)
                ticks += 1
        ticker = asyncio.create_task(tick())
        await asyncio.sleep(0)
        start_importing()
        start_importing()  # one import, however many ask
        assert not decoders_loaded()
        before = ticks
        await asyncio.gather(decoders_ready(), decoders_ready())
        during = ticks - before
        ticker.cancel()
        # What polars imports on its first Series from a numpy array, off the loop too.
        assert "numpy.ma" in sys.modules
        import polars, numpy
        await decoders_ready()  # once imported, at once
        assert decoders_loaded()
        print(during, polars.Series([1.0]).sum())

    asyncio.run(main())
    # A second loop (as in a second run in one process) finds them imported.
    asyncio.run(decoders_ready())
    """
)


def test_the_loop_runs_while_the_decoders_are_imported() -> None:
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 0, done.stderr
    during, total = done.stdout.split()
    assert int(during) > 0  # imported on the loop's thread, the ticker could not run
    assert float(total) == 1.0
