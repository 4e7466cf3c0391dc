"""Standard exports (docs/export.md): every file is read back by the library that wrote it and,
for the OEM, by a second one (``oem``); for the AEM, which no second Python library reads, by
a small KVN parse here. The states read back are compared with the run's.

Tolerances: the OEM holds km and km/s written as the shortest decimal that reads back as the
same float64, so only the m -> km -> m scaling rounds (at most 2 ulp: rtol 1e-15); the AEM
holds the run's quaternions unscaled (exact); the CZML positions are the run's rotated into the
Earth-fixed frame and back here (a few ulp of the radius: 1e-6 m).
"""

import json

import numpy as np
import pytest

import coopsat
from coopsat.exports import export_run
from coopsat.exports.run import ExportError

RTOL_KM = 1e-15


def _run_folder(tmp_path_factory, name, **fields):
    """A run folder as far as an export reads it: its result.nc (no figures, no report)."""
    result = coopsat.run(coopsat.Scenario.load(name).update(fields))
    out = tmp_path_factory.mktemp(name)
    result.dataset.to_netcdf(out / "result.nc", engine="h5netcdf")
    return out


@pytest.fixture(scope="module")
def gravity_gradient(tmp_path_factory):
    """One spacecraft in a J2 orbit with attitude: the issue's done-when run (30 s)."""
    return _run_folder(tmp_path_factory, "rigid-body-gravity-gradient", **{"sim.t_final_s": 30.0})


@pytest.fixture(scope="module")
def attitude_only(tmp_path_factory):
    return _run_folder(tmp_path_factory, "consensus-sync-a-stable", **{"sim.t_final_s": 1.0})


def _dataset(run_dir):
    import xarray as xr

    with xr.open_dataset(run_dir / "result.nc", engine="h5netcdf") as ds:
        return ds.load()


def _epochs(ds):
    epoch = np.datetime64("2000-01-01T12:01:04.184", "us")  # epoch_utc 12:00:00 + 32 leap seconds + 32.184 s, on TT
    return epoch + np.round(ds.time.values * 1e6).astype(np.int64).astype("timedelta64[us]")


def test_the_oem_reads_back_with_both_libraries_to_the_run_states(gravity_gradient):
    import oem as oem_lib
    from ccsds_ndm.ndm_io import NdmIo

    path = export_run(gravity_gradient, "oem")
    assert path == gravity_gradient / "rigid-body-gravity-gradient.oem" and path.is_file()
    ds = _dataset(gravity_gradient)
    r_km, v_km_s = ds.r_eci.values[:, 0] / 1e3, ds.v_eci.values[:, 0] / 1e3

    (segment,) = NdmIo().from_path(path).body.segment
    meta = segment.metadata
    assert (meta.object_name, meta.center_name, meta.ref_frame, meta.time_system) == ("sat1", "EARTH", "GCRF", "TT")
    states = segment.data.state_vector
    r = np.array([[s.x.value, s.y.value, s.z.value] for s in states])
    v = np.array([[s.x_dot.value, s.y_dot.value, s.z_dot.value] for s in states])
    np.testing.assert_allclose(r, r_km, rtol=RTOL_KM, atol=0)
    np.testing.assert_allclose(v, v_km_s, rtol=RTOL_KM, atol=0)
    assert [np.datetime64(s.epoch, "us") for s in states] == list(_epochs(ds))

    (other,) = list(oem_lib.OrbitEphemerisMessage.open(path))
    assert other.metadata["REF_FRAME"] == "GCRF" and other.metadata["CENTER_NAME"] == "EARTH"
    np.testing.assert_allclose(np.array([s.position for s in other]), r_km, rtol=RTOL_KM, atol=0)
    np.testing.assert_allclose(np.array([s.velocity for s in other]), v_km_s, rtol=RTOL_KM, atol=0)
    assert all(s.epoch.scale == "tt" for s in other)
    assert [np.datetime64(s.epoch.isot, "us") for s in other] == list(_epochs(ds))


def _kvn_quaternions(text):
    """An independent reading of an AEM's KVN: the metadata keywords and the data lines."""
    meta, lines, inside = {}, [], False
    for line in text.splitlines():
        if line.strip() in ("DATA_START", "DATA_STOP"):
            inside = line.strip() == "DATA_START"
        elif inside and line.strip():
            epoch, *q = line.split()
            lines.append((epoch, [float(x) for x in q]))
        elif "=" in line:
            key, value = (part.strip() for part in line.split("=", 1))
            meta[key] = value
    return meta, lines


def test_the_aem_reads_back_to_the_run_quaternions_exactly(gravity_gradient):
    from ccsds_ndm.ndm_io import NdmIo

    path = export_run(gravity_gradient, "aem")
    q_bi = _dataset(gravity_gradient).q.values[:, 0]

    (segment,) = NdmIo().from_path(path).body.segment
    q = np.array([[s.quaternion_state.quaternion.qc, s.quaternion_state.quaternion.q1, s.quaternion_state.quaternion.q2,
                   s.quaternion_state.quaternion.q3] for s in segment.data.attitude_state])
    np.testing.assert_array_equal(q, q_bi)

    meta, lines = _kvn_quaternions(path.read_text())
    assert {k: meta[k] for k in ("CCSDS_AEM_VERS", "REF_FRAME_A", "REF_FRAME_B", "ATTITUDE_DIR", "ATTITUDE_TYPE",
                                 "QUATERNION_TYPE", "TIME_SYSTEM")} == {
        "CCSDS_AEM_VERS": "1.0", "REF_FRAME_A": "GCRF", "REF_FRAME_B": "SC_BODY_1", "ATTITUDE_DIR": "A2B",
        "ATTITUDE_TYPE": "QUATERNION", "QUATERNION_TYPE": "FIRST", "TIME_SYSTEM": "TT"}
    np.testing.assert_array_equal(np.array([q for _, q in lines]), q_bi)


def test_the_aem_quaternion_is_the_adm_rotation_from_inertial_to_body(gravity_gradient):
    """ADM's matrix of an A2B quaternion maps frame-A (inertial) components to frame-B (body)
    components: for our q_bi it must be C_bi = quat_to_dcm(q_bi)ᵀ, and must take each body
    axis, as our quat_rotate places it in inertial axes, back to that unit vector."""
    from coopsat.geometry.quaternion import quat_rotate, quat_to_dcm

    q = _dataset(gravity_gradient).q.values[:, 0]
    qc, v = q[:, 0], q[:, 1:]
    cross = np.zeros((len(q), 3, 3))
    cross[:, 0, 1], cross[:, 0, 2], cross[:, 1, 2] = -v[:, 2], v[:, 1], -v[:, 0]
    cross -= np.transpose(cross, (0, 2, 1))
    m_adm = ((qc**2 - np.sum(v * v, axis=1))[:, None, None] * np.eye(3) + 2 * v[:, :, None] * v[:, None, :]
             - 2 * qc[:, None, None] * cross)
    np.testing.assert_allclose(m_adm, np.transpose(quat_to_dcm(q), (0, 2, 1)), atol=1e-15)
    for axis in np.eye(3):
        axis_i = quat_rotate(q, np.broadcast_to(axis, (len(q), 3)))
        np.testing.assert_allclose(np.einsum("tij,tj->ti", m_adm, axis_i), np.broadcast_to(axis, (len(q), 3)), atol=1e-15)


def test_the_czml_holds_the_run_in_earth_fixed_axes(gravity_gradient):
    from czml3 import Document

    import erfa

    from coopsat.astro.timescales import earth_orientation_parameters, run_epoch, utc_from_tt
    from coopsat.geometry.quaternion import quat_rotate

    path = export_run(gravity_gradient, "czml")
    ds = _dataset(gravity_gradient)
    packets = Document.model_validate(json.loads(path.read_text())).packets
    assert [p.id for p in packets] == ["document", "sat1"]
    raw = json.loads(path.read_text())[1]
    assert raw["position"]["referenceFrame"] == "FIXED" and raw["position"]["epoch"] == "2000-01-01T12:00:00.000000Z"
    # SOFA's own GCRS → ITRS at each sample (not the run's interpolated table), the epoch's EOP.
    epoch = run_epoch("2000-01-01T12:00:00")
    utc = utc_from_tt(*epoch.tt)
    eop = earth_orientation_parameters(*utc)
    ut1_offset_d = sum(utc) - epoch.jd_tt + eop.ut1_utc_s[0] / 86400.0
    to_fixed = np.stack([erfa.c2t06a(epoch.tt[0], epoch.tt[1] + t / 86400.0, epoch.tt[0],
                                     epoch.tt[1] + t / 86400.0 + ut1_offset_d, eop.xp_rad[0], eop.yp_rad[0])
                         for t in ds.time.values])

    samples = np.array(raw["position"]["cartesian"]).reshape(-1, 4)
    np.testing.assert_array_equal(samples[:, 0], ds.time.values)
    np.testing.assert_allclose(np.einsum("tji,tj->ti", to_fixed, samples[:, 1:]), ds.r_eci.values[:, 0], rtol=0, atol=1e-3)

    q_xyzw = np.array(raw["orientation"]["unitQuaternion"]).reshape(-1, 5)[:, 1:]
    q_fixed = q_xyzw[:, [3, 0, 1, 2]]
    q_bi = ds.q.values[:, 0]
    for axis in np.eye(3):
        body = np.broadcast_to(axis, (len(q_bi), 3))
        np.testing.assert_allclose(quat_rotate(q_fixed, body), np.einsum("tij,tj->ti", to_fixed, quat_rotate(q_bi, body)),
                                   atol=1e-9)


def test_a_formation_gets_one_message_per_spacecraft(tmp_path_factory):
    """A CCSDS OEM describes one object: a formation is a folder of one OEM each, and the
    deep-space formation's centre is the Sun (its CZML is refused: Cesium draws the Earth)."""
    import oem as oem_lib

    run_dir = _run_folder(tmp_path_factory, "deepspace-square-to-line-lqr", **{"sim.t_final_s": 100.0})
    folder = export_run(run_dir, "oem")
    assert folder == run_dir / "deepspace-square-to-line-lqr-oem"
    assert sorted(p.name for p in folder.iterdir()) == ["sc1.oem", "sc2.oem", "sc3.oem", "sc4.oem"]
    r_km = _dataset(run_dir).r_eci.values / 1e3
    for k, name in enumerate(["sc1", "sc2", "sc3", "sc4"]):
        (segment,) = list(oem_lib.OrbitEphemerisMessage.open(folder / f"{name}.oem"))
        assert segment.metadata["OBJECT_NAME"] == name and segment.metadata["CENTER_NAME"] == "SUN"
        np.testing.assert_allclose(np.array([s.position for s in segment]), r_km[:, k], rtol=RTOL_KM, atol=0)
    with pytest.raises(ExportError, match="central body is the Sun") as err:
        export_run(run_dir, "czml")
    assert "\n" not in str(err.value)
    assert not (run_dir / "deepspace-square-to-line-lqr.czml").exists()


def test_an_attitude_only_run_exports_its_attitude_and_refuses_positions(attitude_only):
    folder = export_run(attitude_only, "aem")
    assert len(list(folder.glob("*.aem"))) == 5
    assert "COMMENT no [orbit]: t = 0 written as the default epoch 2000-01-01T12:00:00 (UTC)" in (folder / "sat1.aem").read_text()
    for fmt in ("oem", "czml"):
        with pytest.raises(ExportError, match="needs positions and this run has none") as err:
            export_run(attitude_only, fmt)
        assert "\n" not in str(err.value)
    assert sorted(p.name for p in attitude_only.iterdir()) == ["consensus-sync-a-stable-aem", "result.nc"]


def test_a_folder_that_is_not_an_export_is_never_replaced(attitude_only, tmp_path):
    keep = tmp_path / "keep.txt"
    keep.write_text("mine")
    with pytest.raises(ExportError, match="is not a folder of .aem files"):
        export_run(attitude_only, "aem", tmp_path)
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]


def test_an_export_from_memory_equals_the_one_from_the_folder(tmp_path):
    result = coopsat.run(coopsat.Scenario.load("orbit-two-body").set("sim.t_final_s", 60.0))
    result.dataset.to_netcdf(tmp_path / "result.nc", engine="h5netcdf")
    from_memory = coopsat.export(result, "oem", tmp_path / "mem.oem").read_text()
    from_folder = coopsat.export(tmp_path, "oem", tmp_path / "dir.oem").read_text()

    def data(text):
        return [line for line in text.splitlines() if not line.startswith("CREATION_DATE")]

    assert data(from_memory) == data(from_folder)


def test_a_missing_writer_library_is_named_with_the_extra_that_installs_it(attitude_only, monkeypatch, tmp_path):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "ccsds_ndm" else real(name, *a))
    with pytest.raises(ExportError, match=r"ccsds-ndm, which is not installed: pip install 'coopsat\[export\]'"):
        export_run(attitude_only, "aem", tmp_path / "x.aem")
    assert not (tmp_path / "x.aem").exists()
