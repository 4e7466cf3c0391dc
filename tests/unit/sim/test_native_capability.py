"""Issue 25: the native kernels are used only where they were tested, fall back to the XLA path
otherwise (one notice), obey COOPSAT_NATIVE, and refuse wrongly shaped buffers."""

import ctypes
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from coopsat.sim.native import capability, ffi


# The tests of a probe's verdict need the kernels' jax range: CI's environments are inside it
# (.ci/run checks); a newer jax (Python 3.12 and later get 0.12) is not, and its runs never probe.
OUTSIDE_RANGE = capability.version_problem()
OUTSIDE_REASON = f"{OUTSIDE_RANGE}: no verdict is probed or kept outside the native kernels' range"
in_range = pytest.mark.skipif(OUTSIDE_RANGE is not None, reason=OUTSIDE_REASON)


@pytest.fixture(autouse=True)
def fresh_verdict():
    capability.reset()
    yield
    capability.reset()


# --- the switch -----------------------------------------------------------------------------


@pytest.mark.parametrize("value, mode", [("0", "0"), ("1", "1"), ("auto", "auto"), (" AUTO ", "auto"), ("", "auto")])
def test_environment_switch(monkeypatch, value, mode):
    monkeypatch.setenv(capability.ENV, value)
    assert capability.requested() == mode


def test_argument_wins_over_the_environment(monkeypatch):
    monkeypatch.setenv(capability.ENV, "0")
    assert capability.requested(True) == "1"
    monkeypatch.setenv(capability.ENV, "1")
    assert capability.requested(False) == "0"


def test_unknown_switch_value_is_one_clear_line(monkeypatch):
    monkeypatch.setenv(capability.ENV, "yes")
    with pytest.raises(capability.NativeUnavailableError, match=r"COOPSAT_NATIVE='yes': expected 0, 1 or auto$"):
        capability.requested()


def test_off_decides_nothing(monkeypatch):
    monkeypatch.setattr(capability, "_checked", lambda: pytest.fail("no check when the kernels are off"))
    assert capability.use_native(False) is False


# --- platforms and versions -----------------------------------------------------------------


@pytest.mark.parametrize("system, machine", [("linux", "x86_64"), ("linux", "aarch64"), ("linux", "arm64"), ("linux", "AMD64")])
def test_tested_platforms(system, machine):
    assert capability.platform_problem(system, machine) is None


@pytest.mark.parametrize("system, machine", [("win32", "AMD64"), ("darwin", "arm64"), ("darwin", "x86_64"), ("linux", "i686"),
                                             ("linux", "ppc64le")])
def test_other_platforms_fall_back_without_raising(monkeypatch, system, machine):
    monkeypatch.setattr(capability.sys, "platform", system)
    monkeypatch.setattr(capability.platform, "machine", lambda: machine)
    monkeypatch.delenv(capability.ENV, raising=False)
    reason = capability.platform_problem()
    assert reason and system in reason
    with pytest.warns(capability.NativeFallbackWarning, match="running the XLA path"):
        assert capability.use_native() is False


def test_a_fallback_notice_is_given_once_per_process(monkeypatch):
    monkeypatch.setattr(capability.sys, "platform", "win32")
    monkeypatch.delenv(capability.ENV, raising=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert [capability.use_native() for _ in range(3)] == [False] * 3
    assert len([w for w in caught if issubclass(w.category, capability.NativeFallbackWarning)]) == 1


def test_required_but_unavailable_is_an_error(monkeypatch):
    monkeypatch.setattr(capability.sys, "platform", "darwin")
    with pytest.raises(capability.NativeUnavailableError, match="native kernels required .* 64-bit Linux only"):
        capability.use_native(True)


@pytest.mark.parametrize("versions, ok", [
    ({"jax": "0.10.2", "jaxlib": "0.10.2"}, True),
    ({"jax": "0.9.1", "jaxlib": "0.10.1.dev20261101"}, True),
    ({"jax": "0.9.0", "jaxlib": "0.9.0"}, False),  # XLA FFI API 0.2: refuses the handlers
    ({"jax": "0.5.3", "jaxlib": "0.5.3"}, False),
    ({"jax": "0.11.0", "jaxlib": "0.11.0"}, False),
    ({"jax": "0.10.2", "jaxlib": "1.0"}, False),
])
def test_jax_version_range(monkeypatch, versions, ok):
    monkeypatch.setattr(capability, "TESTED_JAX", ((0, 9, 1), (0, 11, 0)))
    reason = capability.version_problem(versions)
    assert (reason is None) == ok
    if not ok:
        assert "is outside >=0.9.1,<0.11.0, the range the native kernels are tested on" in reason


def test_missing_numba_is_a_reason_to_fall_back(monkeypatch):
    import builtins

    real = builtins.__import__

    def no_numba(name, *args, **kwargs):
        if name == "numba":
            raise ImportError("No module named 'numba'", name="numba")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_numba)
    assert capability.import_problem().startswith("numba cannot be imported (No module named 'numba')")


# --- the C library lookup of the thread pool ------------------------------------------------


@pytest.mark.parametrize("error", [TypeError, OSError, AttributeError])
def test_pool_c_library_lookup_never_raises(error):
    """Windows' ctypes.CDLL(None) raises TypeError; macOS's libc has no sched_getcpu."""
    from coopsat.sim.native import pool

    def loader(name):
        raise error("no C library here")

    assert pool._sched_getcpu_address(loader) == pool._no_cpu.address
    assert pool._sched_getcpu_address(lambda name: ctypes.CDLL(None)) not in (None, 0)


# --- buffers --------------------------------------------------------------------------------


def _tick_args(m, omega_rows=3, dtype=np.float64):
    rows = lambda k: jnp.ones((k, m), dtype)  # noqa: E731
    return (rows(4), rows(omega_rows), rows(3), rows(3), rows(3), rows(3), jnp.float64(0.01), np.int64(1), np.int64(1))


def test_kernel_refuses_a_wrongly_shaped_buffer():
    from coopsat.sim.native import attitude
    from coopsat.sim.native.rigid_body import TARGET

    attitude._register()
    results = (jax.ShapeDtypeStruct((4, 5), np.float64), jax.ShapeDtypeStruct((3, 5), np.float64))
    q, w = jax.jit(lambda *a: ffi.call(TARGET, attitude._spec(), results, a, vmap_method="broadcast_all"))(*_tick_args(5))
    assert np.all(np.isfinite(q)) and q.shape == (4, 5)  # the right layout runs
    with pytest.raises(ffi.KernelArgumentError, match=r"argument omega_b is float64 \(4, 5\), its handler reads float64 \(3, M\)"):
        ffi.call(TARGET, attitude._spec(), results, _tick_args(5, omega_rows=4))


def test_kernel_refuses_another_dtype_or_mismatched_sizes():
    from coopsat.sim.native import attitude

    args = list(_tick_args(5))
    args[1] = jnp.ones((3, 5), np.float32)
    with pytest.raises(ffi.KernelArgumentError, match="argument omega_b is float32"):
        ffi.check_arguments("t", attitude._spec(), args)
    args = list(_tick_args(5))
    args[3] = jnp.ones((3, 6))  # a torque for 6 spacecraft, a state for 5
    with pytest.raises(ffi.KernelArgumentError, match=r"argument torque_b is float64 \(3, 6\)"):
        ffi.check_arguments("t", attitude._spec(), args)
    with pytest.raises(ffi.KernelArgumentError, match="8 arguments, its handler reads 9"):
        ffi.check_arguments("t", attitude._spec(), _tick_args(5)[:-1])


def test_law_kernel_layout():
    from coopsat.sim.native.laws import SPEC

    t, n, e = 7, 5, 10
    f, i4 = np.float64, np.int32
    good = [np.ones((4, t)), np.ones((3, t)), np.ones((4, n)), np.ones((3, n)), np.ones((1, e), i4), np.ones((1, e), i4),
            np.ones((1, e)), np.ones((1, SPEC[7][2][1]), f), np.ones((1, 4), np.int64)]
    ffi.check_arguments("law", SPEC, good)
    bad = list(good)
    bad[5] = np.ones((1, e + 1), i4)
    with pytest.raises(ffi.KernelArgumentError, match="argument dst"):
        ffi.check_arguments("law", SPEC, bad)


# --- the decision in the engine, the API and the command line ----------------------------


@in_range
def test_probe_passes_here_and_the_verdict_is_native(monkeypatch):
    monkeypatch.delenv(capability.ENV, raising=False)
    assert capability.probe_problem() is None
    assert capability.use_native() is True


def test_a_failing_probe_falls_back_with_its_reason(monkeypatch):
    from coopsat.sim import engine

    real = engine.simulate_as_built

    def broken_kernels(system, *args, **kwargs):
        if system.structure.native:
            raise RuntimeError("INVALID_ARGUMENT: handler's API version (0.3) is incompatible with the framework's (0.1)")
        return real(system, *args, **kwargs)

    monkeypatch.setattr(engine, "simulate_as_built", broken_kernels)
    reason = capability.probe_problem()
    assert reason.startswith("the probe run (rigid-body tick and consensus law) failed: RuntimeError: INVALID_ARGUMENT")


def _metrics(native, t_final_s):
    import coopsat

    scenario = coopsat.Scenario.load("rigid-body-free").set("sim.t_final_s", t_final_s)
    return coopsat.run(scenario, native=native).metrics


@in_range
def test_switch_off_gives_the_native_metrics(monkeypatch):
    """The rigid-body plant kernel does XLA:CPU's arithmetic in XLA's order: on the jax it was
    written against (0.10) the metrics are bit-identical; older XLAs fuse differently, and agree
    to rounding (CI's lowest-versions job)."""
    import jax

    native = _metrics(True, 2.0)
    monkeypatch.setenv(capability.ENV, "0")
    for xla in (_metrics(False, 2.0), _metrics(None, 2.0)):
        assert xla.keys() == native.keys()
        if jax.__version__.startswith("0.10."):
            assert xla == native
        else:
            assert all(xla[k] == pytest.approx(native[k], rel=1e-12, abs=1e-300) for k in native if native[k] is not None)


def test_cli_prints_the_fallback_as_one_notice_line(monkeypatch, tmp_path, capsys):
    import dask  # noqa: F401  (imported before sys.platform is faked: psutil, which it loads, refuses win32)

    from coopsat.cli import main

    monkeypatch.setattr(capability.sys, "platform", "win32")
    monkeypatch.delenv(capability.ENV, raising=False)
    assert main(["run", "rigid-body-free", "--set", "sim.t_final_s=1", "--out", str(tmp_path / "r"), "-q", "--no-figures"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("coopsat: notice: native CPU kernels off: the native kernels are built and tested on 64-bit "
                             "Linux only, not on win32 ")
    assert err[0].endswith("; running the XLA path (same results, slower)")


def test_cli_native_required_but_unavailable_exits_2(monkeypatch, tmp_path, capsys):
    from coopsat.cli import main

    monkeypatch.setattr(capability.sys, "platform", "darwin")
    monkeypatch.setenv(capability.ENV, "1")
    assert main(["run", "rigid-body-free", "--set", "sim.t_final_s=1", "--out", str(tmp_path / "r"), "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("coopsat: error: native kernels required (COOPSAT_NATIVE=1 or native=True)")
    assert not (tmp_path / "r").exists()


# --- the verdict kept between processes, and runs too small to pay for the probe -------------


@pytest.fixture
def verdict_dir(tmp_path, monkeypatch):
    from coopsat.core import runtime

    if OUTSIDE_RANGE is not None:
        pytest.skip(OUTSIDE_REASON)

    monkeypatch.setattr(runtime, "persistent_cache_dir", lambda kind: tmp_path / f"coopsat-{kind}")
    monkeypatch.delenv(capability.ENV, raising=False)
    return tmp_path / "coopsat-native"


def test_a_probed_verdict_is_kept_and_a_new_process_does_not_probe_again(verdict_dir, monkeypatch):
    monkeypatch.setattr(capability, "probe_problem", lambda: None)
    assert capability.use_native() is True
    (path,) = verdict_dir.glob("*.json")
    assert path.name == f"{capability.install_key()}.json"
    capability.reset()  # a new process
    monkeypatch.setattr(capability, "probe_problem", lambda: pytest.fail("the kept verdict is enough"))
    assert capability.use_native(sc_steps=1) is True


def test_a_kept_failure_falls_back_with_its_reason(verdict_dir, monkeypatch):
    monkeypatch.setattr(capability, "probe_problem", lambda: "the probe run (x) differs from the XLA path in 'q'")
    with pytest.warns(capability.NativeFallbackWarning, match="differs from the XLA path"):
        assert capability.use_native() is False
    capability.reset()
    monkeypatch.setattr(capability, "probe_problem", lambda: pytest.fail("the kept verdict is enough"))
    with pytest.warns(capability.NativeFallbackWarning, match="differs from the XLA path"):
        assert capability.use_native() is False


def test_a_small_run_with_no_verdict_takes_xla_and_decides_nothing(verdict_dir, monkeypatch):
    monkeypatch.setattr(capability, "probe_problem", lambda: pytest.fail("too small to probe"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no notice: nothing failed
        assert capability.use_native(sc_steps=capability.PROBE_WORTH_SC_STEPS - 1) is False
    assert not capability._verdict and not verdict_dir.exists()
    monkeypatch.setattr(capability, "probe_problem", lambda: None)
    assert capability.use_native(sc_steps=capability.PROBE_WORTH_SC_STEPS) is True  # a large run decides
    assert capability.use_native(sc_steps=1) is True  # and the process keeps the verdict


def test_required_kernels_are_probed_whatever_the_run(verdict_dir, monkeypatch):
    probed = []
    monkeypatch.setattr(capability, "probe_problem", lambda: probed.append(1))
    assert capability.use_native(True, sc_steps=1) is True and probed == [1]


@pytest.mark.parametrize("text", ["", "{", '{"native": true}', "[1, 2]"])
def test_a_damaged_verdict_file_is_probed_again(verdict_dir, monkeypatch, text):
    verdict_dir.mkdir(parents=True)
    (verdict_dir / f"{capability.install_key()}.json").write_text(text)
    probed = []
    monkeypatch.setattr(capability, "probe_problem", lambda: probed.append(1))
    assert capability.use_native() is True and probed == [1]


def test_the_key_changes_with_a_version(monkeypatch):
    key = capability.install_key()
    real = capability.metadata.version
    monkeypatch.setattr(capability.metadata, "version", lambda name: "9.9" if name == "numba" else real(name))
    assert capability.install_key() != key


def test_on_a_gpu_the_kernels_are_off_in_one_line(monkeypatch):
    """JAX's default device a GPU: the CPU kernels do not apply, said once, the loop in XLA."""
    import jax

    assert capability.device_problem("cpu") is None
    assert capability.device_problem() is None  # this machine: JAX on the CPU
    monkeypatch.delenv(capability.ENV, raising=False)  # auto: CI runs the suite under COOPSAT_NATIVE=0 too
    monkeypatch.setattr(jax, "default_backend", lambda: "gpu")
    capability.reset()
    try:
        with pytest.warns(capability.NativeFallbackWarning, match=r"native CPU kernels off: JAX runs on the gpu here, "
                                                                   r"so the whole loop runs there in XLA"):
            assert capability.use_native(None, 10**9) is False
        with pytest.raises(capability.NativeUnavailableError, match="JAX runs on the gpu"):
            capability.use_native(True)
    finally:
        capability.reset()


def test_a_batch_is_counted_whole_for_the_probe(verdict_dir, monkeypatch):
    """A campaign's runs are each too small to pay for the probe; a batch of them is not, and
    decides the process's path (its workers ran 1.5× slower on XLA for want of a verdict)."""
    import math

    from coopsat.scenarios.load import load_scenario
    from coopsat.sim.engine import with_native_decided
    from coopsat.workflows.pipeline import prepare

    built = prepare(load_scenario("consensus-sync-a-stable", ["sim.t_final_s=20"]), check_published=False)
    s = built.system.structure
    assert s.native
    per_run = built.n_records * s.periods_per_record * s.ticks_per_period * s.substeps * s.n_spacecraft
    monkeypatch.setattr(capability, "probe_problem", lambda: None)
    assert with_native_decided(built.system, built.n_records).structure.native is False
    assert not capability._verdict  # one run decided nothing
    runs = math.ceil(capability.PROBE_WORTH_SC_STEPS / per_run)
    assert with_native_decided(built.system, built.n_records, runs=runs).structure.native is True
    assert with_native_decided(built.system, built.n_records).structure.native is True  # the process keeps it


def test_a_float32_process_neither_probes_nor_keeps_a_verdict(tmp_path):
    """The kernels read float64: a process that declined x64 is refused before the probe, and
    keeps nothing on disk (its failed probe was kept and read by every float64 process of the
    same install, which then ran XLA)."""
    import os
    import subprocess
    import sys

    assert capability.precision_problem(True) is None
    assert capability.precision_problem(False) == "jax_enable_x64 is off in this process and the kernels read float64 arrays"
    script = f"""
import coopsat
from coopsat.sim.native import capability
coopsat.configure(float64=False, compilation_cache={str(tmp_path)!r})
capability.probe_problem = lambda: print("probed")
s = coopsat.Scenario.load("consensus-sync-a-stable").set("sim.t_final_s", 1.0)
try:
    coopsat.run(s, native=True)
except capability.NativeUnavailableError as err:
    print(err)
"""
    env = {k: v for k, v in os.environ.items() if k != capability.ENV}
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=300)
    assert out.stdout.strip() == ("native kernels required (COOPSAT_NATIVE=1 or native=True) but jax_enable_x64 is off "
                                  "in this process and the kernels read float64 arrays"), out.stderr[-2000:]
    assert not list(tmp_path.rglob("*.json"))
