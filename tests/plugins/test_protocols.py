"""Every built-in plug-in's part follows its role's protocol (coopsat.plugins.protocols), and the
registry knows where each kind comes from.

Builds (does not simulate) every bundled scenario, plus a few variants for the kinds no bundled
scenario uses, and checks each part with ``isinstance`` against its role's runtime-checkable
protocol and with :func:`~coopsat.plugins.protocols.protocol_problems` (members and call
signatures).
"""

import warnings
from typing import Literal

import pytest

import coopsat
from coopsat.plugins import ROLES, Plugin, PluginError, Table, plugins, protocols, register
from coopsat.scenarios.build import build, scenario_tables
from coopsat.scenarios.load import bundled_names

VARIANTS = {
    "attitude-pid": ("rigid-body-free", {
        "controller": {"kind": "attitude-pid", "period_s": 0.01, "k_p": 1.0, "k_d": 1.0},
    }),
    "lvlh-pd-navigation": ("orbit-two-body", {
        "controller": {"kind": "lvlh-pd", "period_s": 10.0, "k_p": 1e-4, "k_d": 1e-2, "rho_target_lvlh_m": [0.0, 0.0, 0.0]},
        "spacecraft.0.mass_kg": 10.0,
        "actuators": {"kind": "proportional-thrusters"},
        "sensors": [{"kind": "position-noise", "sigma_m": 1.0}, {"kind": "velocity-noise", "sigma_m_s": 0.01}],
    }),
    "leo-pair-navigation-bearing": ("leo-pair-navigation", {
        "sensors": [{"kind": "gnss", "sigma_m": 0.02, "sigma_m_s": 5e-4},
                    {"kind": "camera-bearing", "to": "chief", "sigma_rad": 1e-4, "fov_half_angle_deg": 12.0}],
        "navigation.measurements": ["gnss", "camera-bearing"],
    }),
    "observation-orbit-ekf": ("observation-cooperative", {
        "sensors": coopsat.Scenario.load("observation-cooperative")["sensors"] + [{"kind": "gnss", "sigma_m": 0.5, "sigma_m_s": 0.005}],
        "navigation": {"kind": "orbit-ekf", "accel_psd_m2_s3": 1e-8, "initial_sigma_m": 5.0, "initial_sigma_m_s": 0.05},
    }),
}
"""Bundled scenarios changed to use the kinds no bundled scenario uses."""


def _scenario(case):
    if case in VARIANTS:
        base, changes = VARIANTS[case]
        return coopsat.Scenario.load(base).update(changes).model
    return coopsat.Scenario.load(case).model


def _parts(system):
    return [
        ("controller", system.controller), ("network", system.network),
        *[("sensor", p) for p in system.sensors], *[("actuator", p) for p in system.actuators],
        *[("disturbance", p) for p in system.disturbances],
        *[("navigation", p) for p in [getattr(system.controller, "navigation", None)] if p is not None],
    ]


CASES = [*bundled_names(), *VARIANTS]


@pytest.fixture(scope="module")
def built():
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # design warnings of the scenarios that show an unstable case
        for case in CASES:
            scenario = _scenario(case)
            out[case] = (scenario, build(scenario))
    return out


@pytest.mark.parametrize("case", CASES)
def test_every_part_follows_its_roles_protocol(built, case):
    _, b = built[case]
    for role, part in _parts(b.system):
        protocol = protocols.protocol_of(part, role)
        assert isinstance(part, protocol), f"{case}: {type(part).__name__} is not a {protocol.__name__}"
        assert protocols.protocol_problems(part, role) == [], case


def test_every_builtin_kind_is_checked(built):
    used = {(role, table.kind) for scenario, _ in built.values() for role, _, table in scenario_tables(scenario)}
    builtin = {(role, kind) for role in ROLES for kind, p in plugins(role).items() if p.origin.distribution == "coopsat"}
    assert builtin - used == set(), "a built-in kind is used by no bundled scenario: add a variant to VARIANTS"


def test_the_local_flight_software_follows_the_local_protocol(built):
    part = built["cartwheel-keeping-ground"][1].system.controller
    assert protocols.protocol_of(part, "controller") is protocols.LocalController
    assert not isinstance(part, protocols.Controller)  # no global outbox/step: the engine wraps it


def test_problems_name_what_is_missing_or_miscalled():
    from coopsat.plugins import part as part_decorator

    class NotADataclass:
        pass

    @part_decorator()
    class Miscalled:
        command = "torque_b"
        channel = "torque_b"
        pulsed = False
        mean_output = ("torque", "angular_impulse")

        def init(self, n):
            return ()

        def plan(self, command, x, state):  # misses period_s, key, t
            return None, state

        def account(self, pulse):
            return {}

        def output_specs(self):
            return {}

    assert protocols.protocol_problems(NotADataclass(), "disturbance")[0] == (
        "NotADataclass is not a frozen dataclass (decorate it with coopsat.plugins.part)"
    )
    problems = protocols.protocol_problems(Miscalled(), "actuator")
    assert problems == [
        "Miscalled.plan(command, x, state) cannot be called as plan(command, x, state, period_s, key, t)",
        "Miscalled has no record (Actuator protocol)",
    ]
    assert not isinstance(Miscalled(), protocols.Actuator)


def test_protocols_are_reexported_and_document_every_method():
    import coopsat.plugins as p

    for name in ("Controller", "LocalController", "NetworkDelivery", "Sensor", "Actuator", "Disturbance", "Builder", "Check"):
        assert getattr(p, name) is getattr(protocols, name)
    assert p.BuildContext is protocols.BuildContext
    for protocol in (*protocols.PROTOCOLS.values(), protocols.LocalController):
        for member in protocols.members(protocol):
            value = vars(protocol).get(member)
            if callable(value):
                assert value.__doc__, f"{protocol.__name__}.{member} has no docstring"


def test_every_kind_knows_its_origin():
    origin = plugins("controller")["consensus-sync"].origin
    assert (origin.distribution, origin.module, origin.entry_point) == ("coopsat", "coopsat.plugins.consensus", None)
    assert str(origin) == "coopsat (coopsat.plugins.consensus)"
    for role in ROLES:
        for kind, p in plugins(role).items():
            assert p.origin is not None and p.origin.module, (role, kind)


def test_a_second_registration_names_both_and_changes_nothing():
    class Clash(Table):
        kind: Literal["consensus-sync"]

    before = plugins("controller")["consensus-sync"]
    with pytest.raises(PluginError) as err:
        register(Plugin("controller", "consensus-sync", Clash, lambda table, ctx: None))
    assert str(err.value) == (
        f"plug-in controller 'consensus-sync' is registered by coopsat (coopsat.plugins.consensus) and by {__name__}"
    )
    assert plugins("controller")["consensus-sync"] is before
    with pytest.raises(PluginError, match="unknown role 'planner'"):
        register(Plugin("planner", "x", Clash, lambda table, ctx: None))


def test_a_kind_registered_after_the_schema_was_composed_is_refused():
    class Late(Table):
        kind: Literal["late-kind"]

    plugins("controller")  # read, as the scenario schema reads it when first imported
    with pytest.raises(PluginError, match=r"plug-in controller 'late-kind' of .* is registered after the plug-in registry was read"):
        register(Plugin("controller", "late-kind", Late, lambda table, ctx: None))
    assert "late-kind" not in plugins("controller")
