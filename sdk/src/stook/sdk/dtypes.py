"""The polars dtypes of the frames stook's views build (importing this imports polars).

``STATUS_DTYPE`` is the dtype of status values; ``KIND_DTYPE`` that of the ``kind`` column
of `JobMetricsView.series_frame`.
"""

from stook.sdk._series import KIND_DTYPE, STATUS_DTYPE

__all__ = ["KIND_DTYPE", "STATUS_DTYPE"]
