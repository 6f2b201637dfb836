"""The sweep's two pictures, as PNG: throughput against concurrency, memory against size.

matplotlib is an optional extra (`stook-testing[bench]`); without it the numbers are still
written and the plots are skipped with a note.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from stook.bench._measure import BARE_LOOP, LATENCY_BOUND, RESIM, STOOK

_STYLE: dict[str, dict[str, Any]] = {
    STOOK: {"linestyle": "-", "marker": "o"},
    BARE_LOOP: {"linestyle": "--", "marker": "s"},
    LATENCY_BOUND: {"linestyle": ":", "marker": None},
}


def plots_available() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def write_plots(rows: Sequence[dict[str, Any]], out_dir: Path, prefix: str) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")  # files only; no display needed
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    written = []
    latencies = sorted({r["latency_ms"] for r in rows})
    sizes = sorted({r["jobs"] for r in rows})
    colours = dict(zip(sizes, ("tab:blue", "tab:orange", "tab:green", "tab:red"), strict=False))

    fig, axes = plt.subplots(1, len(latencies), figsize=(5 * len(latencies), 4.2), sharey=True)
    for ax, latency in zip(axes if len(latencies) > 1 else [axes], latencies, strict=True):
        for client, style in _STYLE.items():
            for jobs in sizes:
                points = sorted(
                    (r["concurrency"], r["requests_per_second"])
                    for r in rows
                    if r["client"] == client
                    and r["latency_ms"] == latency
                    and r["jobs"] == jobs
                    and r["requests_per_second"]
                )
                if points:
                    xs, ys = zip(*points, strict=True)
                    ax.plot(xs, ys, color=colours[jobs], label=f"{client}, {jobs} jobs", **style)
        for r in rows:
            if r["client"] == RESIM and r["latency_ms"] == latency:
                ax.plot(64, r["requests_per_second"], "k*", markersize=11)
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_xlabel("concurrency (requests in flight)")
        ax.set_title(f"{latency:g} ms per request")
        ax.grid(True, which="both", alpha=0.3)
    panels = list(axes) if len(latencies) > 1 else [axes]
    panels[0].set_ylabel("requests / s")
    legend: dict[str, Any] = {}
    for panel in panels:  # the bound has no line at 0 ms: gather labels from every panel
        for handle, label in zip(*panel.get_legend_handles_labels(), strict=True):
            legend.setdefault(label, handle)
    handles, labels = list(legend.values()), list(legend)
    handles.append(Line2D([], [], color="k", marker="*", linestyle="", markersize=11))
    labels.append("ReSim fetch_job_metrics_by_batch (thread per request)")
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=8)
    fig.tight_layout(rect=(0, 0.17, 1, 1))
    path = out_dir / f"{prefix}throughput.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    written.append(path)

    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    stook = [r for r in rows if r["client"] == STOOK]
    for latency in latencies:
        for c in sorted({r["concurrency"] for r in stook}):
            points = sorted(
                (r["jobs"], r["peak_rss_mb"])
                for r in stook
                if r["latency_ms"] == latency and r["concurrency"] == c
            )
            if len(points) > 1:
                xs, ys = zip(*points, strict=True)
                ax.plot(xs, ys, marker="o", alpha=0.8, label=f"c={c}, {latency:g} ms")
    ax.set_xscale("log")
    ax.set_ylim(bottom=0)
    ax.set_xlabel("jobs in the batch")
    ax.set_ylabel("peak RSS of the stook process (MB)")
    ax.set_title("stook batch mode, streaming aggregations")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=6, ncol=3)
    fig.tight_layout()
    path = out_dir / f"{prefix}memory.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    written.append(path)
    return written
