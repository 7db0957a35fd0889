"""Where the compiled kernels are cached: kept for callers outside the core that read it from here.

The compile options, the cache guard and its stamp live in kernels/jit.py.
"""

from .kernels.jit import CACHE_DIR, STAMP_NAME

__all__ = ["CACHE_DIR", "STAMP_NAME"]
