"""The gravity field conserves the Jacobi integral of the Earth-fixed frame.

With the point mass and the field's degrees 2…20 only, the potential is fixed in a frame that
turns at the constant rate ω = ω_E ẑ, so the inertial energy is not conserved but the Jacobi
integral is (the Hamiltonian in the turning frame):

    J = ½|v − ω×r|² − ½|ω×r|² − GM/r − U_h(R(θ) r) = ½|v|² − ω·(r×v) − GM/r − U_h

with r, v inertial (ECI), θ(t) = θ0 + ω_E t the Greenwich angle of the run, and the positive
convention of :mod:`coopsat.astro.gravity_field`: the point mass pulls with ``∇(GM/r)`` and the
field with ``a = ∇U_h``. Proof: along the motion dE/dt = −∂U/∂t for E = ½v² − U(r, t); with
U(r, t) = U_f(R(θ(t)) r), ∂U/∂t = −ω·(r × ∇U) = −ω·(r × a), which is −ω·dL/dt, so E − ω·L is
constant.

A 500 km orbit for a day at dt = 10 s (RK4): the measured relative drift of J is 3.9e-10
(1.25e-8 at 20 s, 1.2e-11 at 5 s: it falls as dt⁵, so it is the integrator's truncation error,
not a modelling error), and the bound is 1e-9. The test can fail: over the same run the
two-body energy ½v² − GM/r moves by 1e-3 of itself, the inertial energy E by 6e-6, and J with
the field's potential given the wrong sign by 2e-3. About 12 s of compiling and 2 s of running.
"""

import numpy as np

from coopsat.astro.earth import OMEGA_EARTH_RAD_S, gmst_rad, julian_date_utc
from coopsat.astro.gravity_field import EGM2008_GM_M3_S2, egm2008, harmonic_potential
from coopsat.scenarios.load import load_scenario
from coopsat.workflows.pipeline import prepare, simulate_built

EPOCH_UTC = "2024-03-20T00:00:00"
DEGREE = 20
BOUND = 1e-9
"""Relative drift of J allowed after a day at dt = 10 s: 2.5 times the 3.9e-10 measured."""

SCENARIO = f"""
name = "leo-jacobi"
[sim]
t_final_s = 86400.0
dt_s = 10.0
record_interval_s = 60.0
[orbit]
gravity = "two-body"
mu_m3_s2 = {EGM2008_GM_M3_S2}
epoch_utc = "{EPOCH_UTC}"
# The Jacobi integral is conserved in a frame turning uniformly about a fixed axis: the papers'
# Earth. In the real one, which precesses and nods, it drifts by 1.7e-5 in this day (measured).
earth_orientation = "gmst82"
[[spacecraft]]
inertia_kgm2 = [1.0, 1.0, 1.0]
[spacecraft.elements]
a_m = 6878137.0
e = 0.001
i_deg = 51.6
raan_deg = 30.0
argp_deg = 40.0
mean_anomaly_deg = 10.0
[[disturbances]]
kind = "gravity-field"
degree = {DEGREE}
"""


def relative_drift(q):
    return float(np.abs(q / q[0] - 1.0).max())


def test_gravity_field_conserves_the_jacobi_integral(tmp_path):
    path = tmp_path / "leo-jacobi.toml"
    path.write_text(SCENARIO, encoding="utf-8")
    ds, _ = simulate_built(prepare(load_scenario(path)))
    t = ds.time.values
    r, v = ds.r_eci.values[:, 0], ds.v_eci.values[:, 0]
    assert t[-1] == 86400.0 and len(t) == 1441

    theta = gmst_rad(julian_date_utc(EPOCH_UTC)) + OMEGA_EARTH_RAD_S * t
    field = egm2008(DEGREE)
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    r_ecef = np.concatenate([c * r[:, :1] + s * r[:, 1:2], -s * r[:, :1] + c * r[:, 1:2], r[:, 2:]], axis=1)  # R3(θ) r
    u_h = np.asarray(harmonic_potential(r_ecef, field.c, field.s, field.gm_m3_s2, field.radius_m))
    omega_x_r = np.cross([0.0, 0.0, OMEGA_EARTH_RAD_S], r)
    point_mass = EGM2008_GM_M3_S2 / np.linalg.norm(r, axis=1)
    rotating = 0.5 * np.sum((v - omega_x_r) ** 2, axis=1) - 0.5 * np.sum(omega_x_r**2, axis=1)

    jacobi = rotating - point_mass - u_h
    drift = relative_drift(jacobi)
    assert drift <= BOUND, f"Jacobi integral drifts by {drift:.3g} (bound {BOUND:g})"

    # What it would be without the right physics: each moves by far more than the bound.
    two_body = 0.5 * np.sum(v * v, axis=1) - point_mass
    inertial = two_body - u_h
    wrong_sign = rotating - point_mass + u_h
    for name, quantity, at_least in [("two-body energy", two_body, 1e5), ("inertial energy", inertial, 1e3),
                                     ("J with +U_h", wrong_sign, 1e5)]:
        moved = relative_drift(quantity)
        assert moved >= at_least * BOUND, f"{name} moved only {moved:.3g}: the check would not see a wrong field"
