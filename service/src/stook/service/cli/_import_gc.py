"""No cyclic garbage collection while `stook run` imports its modules.

Importing aiohttp and the run's own modules makes ~100,000 objects (modules, classes,
functions) that live as long as the process. At the default thresholds the collector ran
over them again and again while they were being made: ~15 M instructions before the first
request. So `stook run` imports them with the collector off, then freezes what they made
(``gc.freeze``: left out of every later collection, as a fetch does for its own duration,
see stook.service.fetch._collector) and turns the collector back on; the objects are
unfrozen when the run ends. Objects someone else froze stay theirs: then nothing is frozen
or unfrozen here.
"""

from __future__ import annotations

import gc

TYPE_CHECKING = False
if TYPE_CHECKING:
    from types import TracebackType

__all__ = ["ImportsUncollected"]


class ImportsUncollected:
    """``with ImportsUncollected() as imports: <import>; imports.done(); <run>``."""

    def __init__(self) -> None:
        self._was_enabled = False
        self._importing = False
        self._froze = False

    def __enter__(self) -> ImportsUncollected:
        self._was_enabled = gc.isenabled()
        gc.disable()
        self._importing = True
        return self

    def done(self) -> None:
        """The imports are done: freeze what they made, and collect again as before."""
        if not self._importing:
            return
        self._importing = False
        if gc.get_freeze_count() == 0:
            gc.freeze()
            self._froze = True
        if self._was_enabled:
            gc.enable()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.done()
        if self._froze:
            gc.unfreeze()
            self._froze = False
