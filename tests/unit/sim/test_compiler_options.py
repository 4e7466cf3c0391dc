"""The engine's per-program XLA options: reductions stay in XLA on the CPU, a jaxlib that
refuses the options compiles with its defaults, and nothing else is swallowed."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.sim import compiler_options
from coopsat.sim.compiler_options import CPU_OPTIONS, compile_program


def _slot_sum(per_link):
    """The consensus law's sum over padded neighbour slots of a batch: (B, 3, d, n) -> (B, 3, n)."""
    return (2.0 * per_link).sum(axis=2)


@pytest.fixture
def fresh(monkeypatch):
    monkeypatch.setattr(compiler_options, "_refused", [])


def test_a_small_middle_axis_sum_is_compiled_by_xla_not_ynnpack(fresh):
    lowered = jax.jit(_slot_sum).lower(jnp.ones((200, 3, 2, 5)))
    compiled = compile_program(lowered, "cpu")
    if compiler_options.options_refused():
        pytest.skip(f"this jaxlib refuses the options: {compiler_options.options_refused()}")
    assert "__ynn_fusion" not in compiled.as_text()
    x = np.random.default_rng(0).normal(size=(200, 3, 2, 5))
    np.testing.assert_array_equal(np.asarray(compiled(jnp.asarray(x))), 2.0 * x[:, :, 0] + 2.0 * x[:, :, 1])


def test_the_option_is_the_owned_processes_choice_not_a_second_one(fresh):
    """A per-program option wins over XLA_FLAGS: in a process coopsat owns (this one: the test
    set-up is the command's), the engine's programs must not hand dots back to YNNPACK."""
    from coopsat.core import runtime

    assert CPU_OPTIONS == {"xla_cpu_experimental_ynn_fusion_type": runtime.YNN_FUSION_TYPES}
    lowered = jax.jit(lambda a, b: (a @ b).sum(axis=1)).lower(jnp.ones((64, 64, 64)), jnp.ones((64, 64)))
    compiled = compile_program(lowered, "cpu")
    if compiler_options.options_refused():
        pytest.skip(f"this jaxlib refuses the options: {compiler_options.options_refused()}")
    assert "__ynn_fusion" not in compiled.as_text()


class _Lowered:
    """A stand-in for ``jax.stages.Lowered`` whose compile with options fails as told."""

    def __init__(self, error):
        self.error, self.calls = error, []

    def compile(self, options=None):
        self.calls.append(options)
        if options is not None:
            raise self.error
        return "compiled with defaults"


def test_a_jaxlib_that_refuses_the_option_compiles_with_its_defaults_and_is_not_asked_again(fresh):
    name = next(iter(CPU_OPTIONS))
    first = _Lowered(RuntimeError(f"INVALID_ARGUMENT: No such compile option: '{name}'"))
    assert compile_program(first, "cpu") == "compiled with defaults"
    assert first.calls == [dict(CPU_OPTIONS), None]
    assert name in compiler_options.options_refused()
    second = _Lowered(AssertionError("must not be called with options"))
    assert compile_program(second, "cpu") == "compiled with defaults"
    assert second.calls == [None]


def test_any_other_compile_error_is_raised(fresh):
    with pytest.raises(RuntimeError, match="out of memory"):
        compile_program(_Lowered(RuntimeError("RESOURCE_EXHAUSTED: out of memory")), "cpu")
    assert compiler_options.options_refused() is None


def test_other_platforms_compile_with_their_defaults(fresh):
    lowered = _Lowered(AssertionError("must not be called with options"))
    assert compile_program(lowered, "gpu") == "compiled with defaults"
    assert lowered.calls == [None]
