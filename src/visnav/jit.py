"""The optional compiler of the per-step kernels (issue #31 item 2): numba's ``njit`` where numba is installed
(the ``fast`` extra, which ``make install`` installs) and ``VISNAV_JIT`` is not ``0``, else ``None``.

``compiled(fn)`` is ``njit(cache=True)(fn)`` (compiled once per installation, loaded from numba's cache after) or
``fn`` itself. A kernel that only pays compiled (a loop over array elements) is used by its caller only where
``njit`` is not ``None``; one written on Python floats runs either way.
"""

from __future__ import annotations

import os

try:  # optional: without it the readable paths (or the same kernel source on Python floats) run
    from numba import njit
except ImportError:  # exercised by the kernel tests with VISNAV_JIT=0
    njit = None
if os.environ.get("VISNAV_JIT", "1") == "0":  # the kernels off even where numba is installed
    njit = None


def compiled(fn):
    """``fn`` compiled by numba (cached on disk) where it is available, ``fn`` unchanged otherwise."""
    return njit(cache=True)(fn) if njit is not None else fn
