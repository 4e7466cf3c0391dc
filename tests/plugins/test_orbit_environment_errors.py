"""Bad input to the forces of a real low orbit (``gravity-field``, ``drag``, ``third-body``,
``solar-radiation-pressure`` about the Earth): ``coopsat validate`` and ``coopsat run`` exit 2
with one ``coopsat: error:`` line that names the field or the cause, and no traceback.

Each case is a small scenario written to ``tmp_path``: one spacecraft on a 500 km orbit, one
``[[disturbances]]`` entry, then one thing wrong.
"""

import subprocess
import sys

import pytest

from coopsat.astro.constants import MU_SUN_M3_S2
from coopsat.astro.gravity_field import EGM2008_GM_M3_S2, MAX_DEGREE
from coopsat.cli import EXIT_BAD_INPUT, main

ORBIT = """
[orbit]
gravity = "{gravity}"
mu_m3_s2 = {mu}
epoch_utc = "2024-03-20T00:00:00"
"""

ELEMENTS = """
[spacecraft.elements]
a_m = 6878137.0
e = 0.001
i_deg = 51.6
"""


def scenario(kind, body, *, gravity="two-body", mu=EGM2008_GM_M3_S2, mass="mass_kg = 50.0", orbit=True):
    """A one-spacecraft 500 km orbit with one ``[[disturbances]]`` entry of ``kind``."""
    text = 'name = "leo-bad"\n[sim]\nt_final_s = 60.0\ndt_s = 10.0\n'
    if orbit:
        text += ORBIT.format(gravity=gravity, mu=mu)
    text += f"[[spacecraft]]\ninertia_kgm2 = [1.0, 1.0, 1.0]\n{mass}\n"
    if orbit:
        text += ELEMENTS
    return text + f'[[disturbances]]\nkind = "{kind}"\n{body}\n'


GRAVITY = "degree = 4"
DRAG = "area_m2 = 1.0"
HP = 'area_m2 = 1.0\ndensity = "harris-priester"'
SRP = "area_m2 = 1.0\nreflectivity = 0.3"
FACET = "[1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.1]"

# (id, scenario text, words the one error line must hold)
CASES = [
    # gravity-field
    ("degree-above-the-model", scenario("gravity-field", f"degree = {MAX_DEGREE + 1}"), ["gravity-field", "degree 71", "70"]),
    ("degree-below-two", scenario("gravity-field", "degree = 1"), ["disturbances[0].degree"]),
    ("order-above-the-degree", scenario("gravity-field", "degree = 4\norder = 5"), ["gravity-field", "order 5", "degree (4)"]),
    ("order-negative", scenario("gravity-field", "degree = 4\norder = -1"), ["disturbances[0].order"]),
    ("unknown-gravity-model", scenario("gravity-field", 'degree = 4\nmodel = "EGM96"'), ["disturbances[0].model"]),
    ("gravity-field-with-j2", scenario("gravity-field", GRAVITY, gravity="j2"), ["gravity-field", "[orbit] gravity", "'two-body'"]),
    # drag: the surface
    ("area-zero", scenario("drag", "area_m2 = 0.0"), ["disturbances[0].area_m2", "greater than 0"]),
    ("area-negative", scenario("drag", "area_m2 = -1.0"), ["disturbances[0].area_m2", "greater than 0"]),
    ("area-per-spacecraft-miscounted", scenario("drag", "area_m2 = [1.0, 2.0]"), ["area_m2", "2 values", "1 spacecraft"]),
    ("cd-negative", scenario("drag", "area_m2 = 1.0\ncd = -2.2"), ["disturbances[0].cd"]),
    ("area-and-facets", scenario("drag", f"area_m2 = 1.0\nfacets = [{FACET}]"), ["area_m2", "facets", "one of them"]),
    ("neither-area-nor-facets", scenario("drag", "cd = 2.2"), ["area_m2", "facets", "one of them"]),
    ("facet-zero-normal", scenario("drag", "facets = [[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]]"), ["facets[0]", "normal"]),
    ("facet-negative-area", scenario("drag", "facets = [[1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0]]"), ["facets[0]", "area_m2"]),
    ("facet-six-numbers", scenario("drag", "facets = [[1.0, 0.0, 0.0, 1.0, 0.0, 0.0]]"), ["facets[0]"]),
    ("facet-not-finite", scenario("drag", "facets = [[1.0, 0.0, 0.0, 1.0, nan, 0.0, 0.0]]"), ["facets[0]"]),
    # drag: the mass
    ("mass-zero", scenario("drag", DRAG, mass="mass_kg = 0.0"), ["spacecraft[0].mass_kg", "greater than 0"]),
    ("mass-negative", scenario("drag", DRAG, mass="mass_kg = -5.0"), ["spacecraft[0].mass_kg", "greater than 0"]),
    ("mass-missing", scenario("drag", DRAG, mass=""), ["drag (disturbances) is a force", "mass_kg", "sat1"]),
    # drag: the atmosphere
    ("unknown-density-model", scenario("drag", 'area_m2 = 1.0\ndensity = "jacchia"'), ["density", "'jacchia'", "harris-priester"]),
    ("f107-below-the-tables", scenario("drag", HP + "\nf107 = 60.0"), ["drag", "f107 = 60", "65 <= f107 <= 275"]),
    ("f107-above-the-tables", scenario("drag", HP + "\nf107 = 300.0"), ["drag", "f107 = 300", "65 <= f107 <= 275"]),
    ("f107-missing-with-harris-priester", scenario("drag", HP), ["drag", "harris-priester", "f107"]),
    ("f107-with-exponential", scenario("drag", "area_m2 = 1.0\nf107 = 150.0"), ["f107", "harris-priester"]),
    ("hp-exponent-above-six", scenario("drag", HP + "\nf107 = 150.0\nhp_exponent = 8.0"), ["disturbances[0].hp_exponent"]),
    ("hp-exponent-with-exponential", scenario("drag", "area_m2 = 1.0\nhp_exponent = 6.0"), ["hp_exponent", "harris-priester"]),
    ("density-scale-with-harris-priester", scenario("drag", HP + "\nf107 = 150.0\ndensity_scale = 2.0"), ["density_scale", "exponential"]),
    ("density-scale-zero", scenario("drag", "area_m2 = 1.0\ndensity_scale = 0.0"), ["disturbances[0].density_scale"]),
    # third-body
    ("unknown-third-body", scenario("third-body", 'bodies = ["sun", "jupiter"]'), ["disturbances[0].bodies[1]", "'moon'"]),
    ("body-given-twice", scenario("third-body", 'bodies = ["moon", "moon"]'), ["bodies", "each body once"]),
    ("no-body", scenario("third-body", "bodies = []"), ["disturbances[0].bodies"]),
    # solar-radiation-pressure about the Earth
    ("unknown-shadow", scenario("solar-radiation-pressure", SRP + '\nshadow = "none"'), ["disturbances[0].shadow", "'conical'"]),
    ("srp-mass-missing", scenario("solar-radiation-pressure", SRP, mass=""), ["mass_kg", "sat1"]),
]

# Each kind needs the Earth: about the Sun, or with no [orbit] at all, it is an error naming it.
for kind, body in [("gravity-field", GRAVITY), ("drag", DRAG), ("third-body", 'bodies = ["moon"]')]:
    CASES.append((f"{kind}-about-the-sun", scenario(kind, body, mu=MU_SUN_M3_S2), [kind, "mu_m3_s2", "not the Earth's"]))
for kind, body in [("gravity-field", GRAVITY), ("drag", DRAG), ("third-body", 'bodies = ["moon"]'), ("solar-radiation-pressure", SRP)]:
    CASES.append((f"{kind}-without-orbit", scenario(kind, body, orbit=False), [kind, "[orbit]"]))


def write(tmp_path, text, stem="leo-bad"):
    path = tmp_path / f"{stem}.toml"
    path.write_text(text, encoding="utf-8")
    return path


def error_line(stderr):
    """The one line of ``stderr``, a ``coopsat: error:`` line, with no traceback."""
    assert "Traceback" not in stderr, stderr
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    assert lines[0].startswith("coopsat: error: "), stderr
    return lines[0]


@pytest.mark.parametrize(("text", "words"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_validate_names_the_field(tmp_path, capsys, text, words):
    status = main(["validate", str(write(tmp_path, text))])
    captured = capsys.readouterr()
    assert status == EXIT_BAD_INPUT == 2, captured.err
    line = error_line(captured.err)
    for word in words:
        assert word in line, f"{word!r} not in {line!r}"
    assert captured.out == ""


def test_the_valid_scenarios_validate(tmp_path, capsys):
    """The cases differ from valid scenarios only in the one thing wrong."""
    valid = [
        scenario("gravity-field", f"degree = {MAX_DEGREE}\norder = 0"),
        scenario("drag", HP + "\nf107 = 65.0\nhp_exponent = 6.0"),
        scenario("drag", f"facets = [{FACET}, [-1.0, 0.0, 0.0, 1.0, 0.0, 0.0, -0.1]]\ncd = [2.0]"),
        scenario("third-body", 'bodies = ["moon", "sun"]'),
        scenario("solar-radiation-pressure", SRP + '\nshadow = "cylindrical"'),
        scenario("gravity-field", GRAVITY, mu=3.986004418e14),  # the Earth's μ of another model
    ]
    for k, text in enumerate(valid):
        status = main(["validate", str(write(tmp_path, text, f"ok{k}"))])
        captured = capsys.readouterr()
        assert status == 0, (text, captured.err)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        (scenario("drag", HP + "\nf107 = 300.0"), ["f107 = 300"]),
        (scenario("gravity-field", GRAVITY, gravity="j2"), ["[orbit] gravity"]),
    ],
    ids=["f107", "j2"],
)
def test_run_exits_2_and_writes_nothing(tmp_path, capsys, monkeypatch, text, words):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "runs" / "r"
    status = main(["run", str(write(tmp_path, text)), "--out", str(out), "--no-figures", "-q"])
    captured = capsys.readouterr()
    assert status == 2
    line = error_line(captured.err)
    assert all(word in line for word in words), line
    assert not out.exists() and not (tmp_path / "runs").exists()


def test_subprocess_validate_exits_2_with_one_line(tmp_path):
    """The real exit status and the real stderr of ``python -m coopsat.cli validate``."""
    path = write(tmp_path, scenario("gravity-field", f"degree = {MAX_DEGREE + 1}"))
    proc = subprocess.run(
        [sys.executable, "-m", "coopsat.cli", "validate", str(path)], capture_output=True, text=True, cwd=tmp_path, timeout=300
    )
    assert proc.returncode == 2, proc.stderr
    assert "degree 71" in error_line(proc.stderr)
    assert proc.stdout == ""
