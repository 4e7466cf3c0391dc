"""JAX set-up shared by every module that runs compiled code.

Importing this module turns on float64 (the closed loop integrates attitude to 1e-12) and the
persistent compilation cache, so a second ``coopsat run`` of the same model structure skips
XLA compilation. The cache lives in ``$COOPSAT_JAX_CACHE`` or ``~/.cache/coopsat/jax``.
"""

import os
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

_cache_dir = os.environ.get("COOPSAT_JAX_CACHE") or str(Path.home() / ".cache" / "coopsat" / "jax")
jax.config.update("jax_compilation_cache_dir", _cache_dir)
# Cache every compiled program, not only slow ones: the closed loop compiles in about a second,
# which is below JAX's default threshold but still most of a short run's wall time.
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
