"""Shared test set-up: a private JAX compilation cache, so tests never touch the user's."""

import os
import tempfile

os.environ.setdefault("COOPSAT_JAX_CACHE", os.path.join(tempfile.gettempdir(), "coopsat-test-jax-cache"))
