"""The plug-in registry as a library component: where a registration comes from (no frame
inspection), its lock, a load that fails, ``refresh()``, entry points naming ``Plugin`` objects
and the typed fields of ``Plugin``.

Each scenario that loads the registry runs in a fresh interpreter (the test process's registry
is loaded and read once for all), with packages made by ``fake_distribution`` on its
PYTHONPATH, as installed packages are found.
"""

import json
import os
import subprocess
import sys
import textwrap
import typing
from pathlib import Path

import pytest

from coopsat.plugins import Plugin, PluginError, refresh
from coopsat.plugins.protocols import Builder, Check, Tunables
from plugins.test_entry_points import coopsat_cmd, fake_distribution

PAGE = Path(__file__).resolve().parents[2] / "docs" / "plugins.md"


def kind_module(kind, register=True):
    """A plug-in module's text: a controller table of ``kind`` and, if ``register``, its
    registration; ``PLUGIN`` is the Plugin in any case."""
    text = textwrap.dedent(f'''
        from typing import Literal
        from coopsat.plugins import Plugin, Table, register

        class Table_(Table):
            kind: Literal["{kind}"]

        PLUGIN = Plugin("controller", "{kind}", Table_, lambda table, ctx: None)
    ''')
    return text + ("register(PLUGIN)\n" if register else "")


def python(script, *paths):
    """Run ``script`` in a fresh interpreter with ``paths`` first on PYTHONPATH; its stdout."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([*(str(p) for p in paths), *filter(None, [env.get("PYTHONPATH")])])
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(script)], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout


def test_the_origin_is_the_module_that_defines_the_table_whoever_calls_register(tmp_path):
    # coopsat_helper calls register for coopsat_tables: the origin is where the plug-in is
    # defined, not the caller (which frame inspection would have named).
    site = fake_distribution(
        tmp_path / "site", "coopsat-helped", {"helped": "coopsat_tables"},
        {"coopsat_helper": "from coopsat.plugins import register\n\ndef add(plugin):\n    return register(plugin)\n",
         "coopsat_tables": kind_module("helped-sync", register=False) + "import coopsat_helper\ncoopsat_helper.add(PLUGIN)\n"},
    )
    out = python('''
        from coopsat.plugins import plugins
        o = plugins("controller")["helped-sync"].origin
        print(o.distribution, o.module, o.entry_point, str(o), sep="|")
    ''', site)
    assert out.strip() == "coopsat-helped|coopsat_tables|helped|coopsat-helped (coopsat_tables)"


def test_a_second_thread_waits_for_the_load_and_sees_every_kind(tmp_path):
    # The entry point's import sleeps; a second thread asks for the registry meanwhile. Without
    # the lock it got "the plug-in registry was read while it loads" (meant for a plug-in
    # module reading it at import time, in the loading thread).
    slow = textwrap.dedent('''
        import time
        import __main__

        __main__.importing.set()
        time.sleep(0.5)
        __main__.imported_at = time.monotonic()
    ''') + kind_module("slow-sync")
    site = fake_distribution(tmp_path / "site", "coopsat-slow", {"slow": "coopsat_slow"}, {"coopsat_slow": slow})
    out = python('''
        import json, threading, time

        from coopsat.plugins import plugins

        importing = threading.Event()
        seen = {}

        def ask(name, wait):
            if wait:
                importing.wait(30)
            seen[name + "_asked_at"] = time.monotonic()
            try:
                seen[name] = "slow-sync" in plugins("controller") and "consensus-sync" in plugins("controller")
            except Exception as err:
                seen[name] = f"{type(err).__name__}: {err}"

        threads = [threading.Thread(target=ask, args=("first", False)), threading.Thread(target=ask, args=("second", True))]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        seen["imported_at"] = imported_at
        print(json.dumps(seen))
    ''', site)
    seen = json.loads(out)
    assert seen["second_asked_at"] < seen["imported_at"]  # it asked while the first thread loaded
    assert seen["first"] is True and seen["second"] is True


def test_a_coopsat_module_that_fails_leaves_the_registry_unloaded_and_the_next_call_tries_again(tmp_path):
    # A module of coopsat's list (one more, after coopsat's own) fails on the first load: the
    # error propagates, nothing registered stays, and the next call loads every kind, those of
    # the modules imported by the failed load included.
    (tmp_path / "coopsat_flaky.py").write_text(
        "import __main__\n\nif __main__.fail:\n    raise RuntimeError('flaky')\n" + kind_module("flaky-sync")
    )
    out = python('''
        import coopsat.plugins as registry

        registry.PLUGIN_MODULES += ("coopsat_flaky",)
        fail = True
        for attempt in range(2):
            try:
                registry.plugins("controller")
            except RuntimeError as err:
                print("raised", err, registry._state, sum(len(reg) for reg in registry._REGISTRY.values()))
        fail = False
        kinds = registry.plugins("controller")
        print(registry._state, "consensus-sync" in kinds, kinds["flaky-sync"].origin)
    ''', tmp_path)
    assert out.splitlines() == [
        "raised flaky unloaded 0",
        "raised flaky unloaded 0",
        "loaded True coopsat (coopsat_flaky)",
    ]


def test_refresh_loads_the_entry_points_installed_since_until_the_registry_is_read(tmp_path):
    early = fake_distribution(tmp_path / "early", "coopsat-early", {"early": "coopsat_early"},
                              {"coopsat_early": kind_module("early-sync")})
    late = fake_distribution(tmp_path / "late", "coopsat-late", {"late": "coopsat_late"},
                             {"coopsat_late": kind_module("late-sync")})
    out = python(f'''
        import sys

        from coopsat.plugins import PluginError, plugins, refresh

        print(sorted(p.kind for p in refresh() if p.origin.distribution != "coopsat"))  # the first load
        print(refresh())  # nothing new
        sys.path.append({str(late)!r})  # coopsat-late installed now
        print([(p.kind, str(p.origin), p.origin.entry_point) for p in refresh()])
        print("early-sync" in plugins("controller"), "late-sync" in plugins("controller"))
        try:
            refresh()
        except PluginError as err:
            print(err)
    ''', early)
    assert out.splitlines() == [
        "['early-sync']",
        "()",
        "[('late-sync', 'coopsat-late (coopsat_late)', 'late')]",
        "True True",
        "the plug-in registry cannot be refreshed after it was read (scenarios are validated against the kinds "
        "registered then): call coopsat.plugins.refresh() before loading any scenario, or start a new Python process",
    ]


def test_refresh_after_the_registry_was_read_is_one_line_and_changes_nothing():
    from coopsat.plugins import all_kinds

    before = all_kinds()  # read, as the scenario schema reads it
    with pytest.raises(PluginError, match=r"^the plug-in registry cannot be refreshed after it was read \(") as err:
        refresh()
    assert "\n" not in str(err.value)
    assert all_kinds() == before


def test_an_entry_point_may_name_a_plugin_or_a_list_of_them(tmp_path):
    named = kind_module("one-sync", register=False) + textwrap.dedent('''
        class Two(Table):
            kind: Literal["two-sync"]

        class Three(Table):
            kind: Literal["three-sync"]

        MORE = [Plugin("controller", "two-sync", Two, lambda table, ctx: None),
                Plugin("controller", "three-sync", Three, lambda table, ctx: None)]
    ''')
    site = fake_distribution(tmp_path / "site", "coopsat-named", {"one": "coopsat_named:PLUGIN", "more": "coopsat_named:MORE"},
                             {"coopsat_named": named})
    out = python('''
        from coopsat.plugins import plugins

        for kind in ("one-sync", "two-sync", "three-sync"):
            print(kind, plugins("controller")[kind].origin)
        print(plugins("controller")["two-sync"].origin.entry_point)
    ''', site)
    assert out.splitlines() == [
        "one-sync coopsat-named (coopsat_named)",
        "two-sync coopsat-named (coopsat_named)",
        "three-sync coopsat-named (coopsat_named)",
        "more",
    ]


def test_an_entry_point_naming_anything_else_is_the_pages_line(tmp_path):
    odd = fake_distribution(tmp_path / "odd", "coopsat-odd", {"callable": "coopsat_odd:plugins"},
                            {"coopsat_odd": "def plugins():\n    return []\n"})
    proc = coopsat_cmd(["validate", "rigid-body-free"], odd)
    assert proc.returncode == 2
    (line,) = [line for line in PAGE.read_text(encoding="utf-8").splitlines() if "(coopsat_odd:plugins)" in line]
    assert proc.stderr.strip() == line
    assert "names an object that is not a Plugin (function)" in line


def test_plugin_fields_are_typed_with_the_protocols():
    hints = typing.get_type_hints(Plugin)
    assert hints["build"] is Builder
    assert hints["checks"] == tuple[Check, ...]
    assert hints["tunables"] == Tunables | None
    assert Tunables.__call__.__doc__
