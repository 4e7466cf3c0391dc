"""Observer-based linear formation flight software (SPEC §4): one computer per spacecraft.

Each spacecraft measures only relative positions (:class:`~coopsat.sensors.parts.
RelativePosition`), so it runs its own copy of the formation observer and law and executes
its own rows of the formation's force vector (``û_i = E_i K T_i …``, paper §2.2 and eq. 16).
The part is ``local`` (:mod:`coopsat.sim.flight_software`): the engine hands spacecraft i its
own measurement row and the messages addressed to it, nothing else.

Measurement transform T_i. Spacecraft s's row holds ``ρ_sj = r_j − r_s`` for every j; the
formation's relative coordinates are ``y = (D ⊗ I_d) p`` with ``D 1 = 0``
(:func:`coopsat.design.formation_model.relative_basis`), so ``y = (D ⊗ I_d) [ρ_s1 … ρ_sn]`` from
one row alone: this is T_i for the hub or any other choice of coordinates. A line of sight
``s–j`` that is blocked is rebuilt as ``ρ_sj = ρ_sk + ρ_kj`` from the row of a spacecraft k
received over the network (paper Fig. 6), averaged over every k that can supply it. When a
vector can be rebuilt by nobody, the observer runs without a measurement update that period.

Which row: ``source[i] = i`` (decentralized: every spacecraft from its own measurements), or
the hub's row received over the network (centralized: equivalent to the hub computing every
command and sending it, with the same latency).

Discrete-time form of eqs. (12) and (16), exact for inputs held over the period T:

    z⁺ = Φ z + Γ_y y + Γ_u ũ,      u = C_u z + u_ff,      ũ = sat(u),

where z is the observer's estimate of the observable (relative) state plus, for centroid
holding, an open-loop estimate of the centroid's displacement; ``sat`` is the flight
software's model of its thrusters (dead zone and limit), so the estimators are driven by the
force expected to act rather than the one asked for. All matrices come from the design
(:mod:`coopsat.plugins.formation`).
"""


import jax.numpy as jnp

from coopsat.core.parts import OutputSpec, part
from coopsat.actuators.thrusters import deadzone_thrust


def fill_blocked(row_s, rows, senders, ok):
    """Rebuild the vectors of a measurement row whose line of sight is blocked, by relay.

    Parameters
    ----------
    row_s : (4, n)
        Spacecraft s's row: ``ρ_sj`` (m, rows x, y, z) and ``valid`` (1/0) for every target j.
    rows : (4, n, m)
        Rows of other spacecraft available to the computer (own, received).
    senders : int (m,)
        Whose row each is.
    ok : (m,)
        1.0 where the row is actually available (a live link), else 0.0.

    Returns
    -------
    (filled (4, n), relayed (n,))
        The row with every vector that can be rebuilt as ``ρ_sk + ρ_kj`` filled in (mean over
        the k that can), its ``valid`` updated; ``relayed`` 1.0 where a vector was rebuilt.
    """
    rho_sk = row_s[:3, senders]  # (3, m): s to each sender k
    use = ok * row_s[3, senders]  # (m,) s sees k and k's row is here
    cand_valid = rows[3] * use[None, :]  # (n, m): k sees j
    count = jnp.sum(cand_valid, axis=-1)  # (n,)
    cand = rho_sk[:, None, :] + rows[:3]  # (3, n, m)
    rebuilt = jnp.sum(cand * cand_valid[None], axis=-1) / jnp.maximum(count, 1.0)
    missing = row_s[3] == 0.0
    relayed = jnp.where(missing & (count > 0), 1.0, 0.0)
    vec = jnp.where(missing[None] & (count > 0)[None], rebuilt, row_s[:3])
    return jnp.concatenate([vec, jnp.maximum(row_s[3], relayed)[None]], axis=0), relayed


@part(static=("axes",))
class LinearFormationSoftware:
    """One spacecraft's observer-based formation controller (``local`` flight software).

    Attributes
    ----------
    phi : (nz, nz)
        Estimator transition over one period.
    gamma_y : (nz, ny)
        Input matrix of the relative-position coordinates y, m.
    gamma_u : (nz, nu)
        Input matrix of the expected applied forces ũ (nu = n·d, spacecraft-major), N.
    c_u : (nu, nz)
        Force law on the estimate, N per unit of z.
    u_ff : (nu,)
        Constant feed-forward (the reference gain's term, F ρ_cmd or the set-point term of
        eq. 17), N.
    c_y : (ny, nz)
        The estimate's prediction of y (used when the measurement is incomplete).
    y_map : (ny, n·d)
        ``D ⊗ I_d``: a row's vectors (design axes, spacecraft-major) to the coordinates y.
    z0_map : (nz, ny)
        Initial estimate from the first measurement (relative positions, zero velocities, no
        centroid displacement).
    force_min_n, force_max_n : scalar
        The thrusters' dead zone and limit per axis as the software models them, N.
    source : int (n,)
        Whose measurement row spacecraft i uses (itself, or the hub).
    axes : tuple of int
        Static: the inertial axes of the design (``(0, 1)`` in the plane, ``(0, 1, 2)``).
    """

    phi: jnp.ndarray
    gamma_y: jnp.ndarray
    gamma_u: jnp.ndarray
    c_u: jnp.ndarray
    u_ff: jnp.ndarray
    c_y: jnp.ndarray
    y_map: jnp.ndarray
    z0_map: jnp.ndarray
    force_min_n: jnp.ndarray
    force_max_n: jnp.ndarray
    source: jnp.ndarray
    axes: tuple = (0, 1)

    local = True
    reads = ("rho",)
    commands = ("force_eci",)

    def init(self, n):
        return {"z": jnp.zeros((self.phi.shape[0], n)), "started": jnp.zeros((n,))}

    def outbox_one(self, i, y_i, state_i):
        """Spacecraft i broadcasts its measurement row (4, n) and who it is."""
        return {"rho": y_i["rho"], "sender": jnp.asarray(i, dtype=float)}

    def step_one(self, i, t, y_i, inbox_i, state_i, key):
        """Spacecraft i's command ``force_eci`` (3,), N, and its new state."""
        own = y_i["rho"]
        n = own.shape[-1]
        rows = jnp.concatenate([own[:, :, None], inbox_i.msg["rho"]], axis=-1)
        senders = jnp.concatenate([jnp.asarray([i]), jnp.round(inbox_i.msg["sender"]).astype(int)])
        ok = jnp.concatenate([jnp.ones((1,)), (inbox_i.weight > 0.0).astype(float)])
        s = self.source[i]
        pick = ok * (senders == s)
        have_source = jnp.sum(pick) > 0.0
        row_s = jnp.sum(rows * pick, axis=-1) / jnp.maximum(jnp.sum(pick), 1.0)
        row, relayed = fill_blocked(row_s, rows, senders, ok)
        complete = have_source & jnp.all(row[3] > 0.0)
        vec = row[jnp.asarray(self.axes)].T.reshape(-1)  # (n·d,), spacecraft-major
        z = state_i["z"]
        y = jnp.where(complete, self.y_map @ vec, self.c_y @ z)
        z = jnp.where(state_i["started"] > 0.0, z, self.z0_map @ y)
        u = self.c_u @ z + self.u_ff
        applied = deadzone_thrust(u, self.force_min_n, self.force_max_n)
        z_next = self.phi @ z + self.gamma_y @ y + self.gamma_u @ applied
        d = len(self.axes)
        force = jnp.zeros((3,)).at[jnp.asarray(self.axes)].set(u.reshape(n, d)[i])
        record = {"force_command": force, "relayed_lines": jnp.sum(relayed), "measurement_complete": complete.astype(float)}
        return {"force_eci": force}, {"z": z_next, "started": jnp.ones(())}, record

    def output_specs(self):
        return {
            "force_command": OutputSpec(("component",), "N", "ECI", "force commanded by the spacecraft's flight software"),
            "relayed_lines": OutputSpec((), "1", "", "relative positions rebuilt from relayed measurements this period"),
            "measurement_complete": OutputSpec(
                (), "1", "", "1 when the flight software had every relative position (measured or relayed), else 0"
            ),
        }
