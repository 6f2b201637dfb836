"""Preview: metrics.binproto files drawn into one self-contained HTML page.

    from stook.service.preview import render_html
    html = render_html(["outputs/metrics.binproto"])

The page works offline (plotly.js is embedded once, images are embedded from the file's
folder) and shows every metric as the dashboard would, in its order, with the validator's
findings; several files go side by side, one column each. `summary_lines` is the same
file as a text table, one line per metric (`stook show`). This layer reads files through
stook.sdk's reader only and imports no other layer of stook.service: `stook preview`
(cli) and `stook run --preview` use it.
"""

from stook.service.preview._render import PREVIEW_NAME, render_html, write_preview
from stook.service.preview._sources import PreviewInput
from stook.service.preview._table import summary_lines

__all__ = ["PREVIEW_NAME", "PreviewInput", "render_html", "summary_lines", "write_preview"]
