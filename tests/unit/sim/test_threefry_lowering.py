"""coopsat.core.runtime lowers small Threefry hashes unrolled on the CPU: the hash must stay Threefry-2x32
(Random123's known answers, 20 rounds), small hashes must carry no loop, large ones keep JAX's."""

import jax
import numpy as np
import pytest
from jax.extend.random import threefry_2x32

from coopsat.core.runtime import UNROLLED_THREEFRY_MAX

# Random123 known-answer tests for threefry2x32_20: (key, counter) -> output.
KNOWN = [
    ((0x00000000, 0x00000000), (0x00000000, 0x00000000), (0x6B200159, 0x99BA4EFE)),
    ((0xFFFFFFFF, 0xFFFFFFFF), (0xFFFFFFFF, 0xFFFFFFFF), (0x1CB996FC, 0xBB002BE7)),
    ((0x13198A2E, 0x03707344), (0x243F6A88, 0x85A308D3), (0xC4923A9C, 0x483DF7A0)),
]


@pytest.mark.parametrize("copies", [1, UNROLLED_THREEFRY_MAX, 4 * UNROLLED_THREEFRY_MAX])
def test_hash_is_threefry_unrolled_or_not(copies):
    # copies: each hash's element count (both lowerings, either side of the threshold).
    for key, counter, expected in KNOWN:
        count = np.repeat(np.array(counter, np.uint32)[:, None], copies, axis=1).reshape(-1)
        out = np.asarray(jax.jit(threefry_2x32)(np.array(key, np.uint32), count)).reshape(2, copies)
        np.testing.assert_array_equal(out, np.repeat(np.array(expected, np.uint32)[:, None], copies, axis=1))


def test_small_hashes_have_no_loop_large_ones_keep_it():
    key = jax.random.PRNGKey(0)
    lowered = lambda f: jax.jit(f).lower(key).as_text()  # noqa: E731
    assert "while" not in lowered(lambda k: jax.random.fold_in(k, 3))
    assert "while" not in lowered(lambda k: jax.random.normal(k, (3, 2)))  # a few spacecraft's noise
    assert "while" in lowered(lambda k: jax.random.bits(k, (8 * UNROLLED_THREEFRY_MAX,)))
