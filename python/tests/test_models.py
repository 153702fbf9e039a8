"""`quadid model` read back by parsers that are not quadid's: xml.etree for MJCF and
URDF, ast for the RotorPy dict, tomllib for the vehicle file. Every value is compared
with the result JSON it came from (the identified set, the vehicle's rotors with the
thrust scale folded in), on a vehicle with non-zero products of inertia, so that a
swapped or negated entry in a conversion fails."""

import ast
import json
import math
import tomllib
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from conftest import run_cli

THETA = ["m", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"]


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    d = tmp_path_factory.mktemp("models")
    log, res = d / "cf.csv", d / "result.json"
    run_cli("simulate", "--vehicle", "crazyflie21", "--trajectory", "table2", "--duration", "30", "-o", str(log))
    run_cli("identify", str(log), "--vehicle", "crazyflie21", "--known-mass", "0.0347", "-q", "-o", str(res))
    j = json.loads(res.read_text())
    s = j["recommended"]["set"]
    reg = "LS" if s in ("LS", "PC") else "FMLS"
    scale = j["real_flight"]["sets"][reg]["parameters"]["thrust_scale"]["value"]
    return res, j, s, scale


def model(res, fmt):
    return run_cli("model", str(res), "--format", fmt).stdout


def tensor(e):
    return np.array([[e["Ixx"], e["Ixy"], e["Ixz"]], [e["Ixy"], e["Iyy"], e["Iyz"]], [e["Ixz"], e["Iyz"], e["Izz"]]])


def test_products_are_not_zero(identified):
    _, j, s, _ = identified
    e = j["estimates"][s]
    for p in ("Ixy", "Ixz", "Iyz"):
        assert abs(e[p]) > 1e-7  # a sign slip in a conversion must show


def test_mjcf_fullinertia_sites_and_motor_gears(identified):
    res, j, s, scale = identified
    root = ET.fromstring(model(res, "mjcf"))
    assert root.tag == "mujoco"
    inertial = root.find("./worldbody/body/inertial")
    e = j["estimates"][s]
    assert float(inertial.get("mass")) == e["m"]
    # MuJoCo's order: ixx iyy izz ixy ixz iyz
    full = [float(x) for x in inertial.get("fullinertia").split()]
    assert full == [e["Ixx"], e["Iyy"], e["Izz"], e["Ixy"], e["Ixz"], e["Iyz"]]
    r = j["rotors"]
    sites = {x.get("name"): [float(v) for v in x.get("pos").split()] for x in root.iter("site")}
    for i, p in enumerate(r["positions"]):
        assert sites[f"rotor{i + 1}"] == p
    for i, mot in enumerate(root.find("actuator").iter("motor")):
        gear = [float(v) for v in mot.get("gear").split()]
        # Thrust along the site's z; reaction torque +torque_ratio for a clockwise rotor (seen from above).
        sign = 1.0 if r["spin"][i] == "cw" else -1.0
        assert gear == [0, 0, 1, 0, 0, sign * r["torque_ratio"]]
        assert float(mot.get("ctrlrange").split()[1]) == pytest.approx(r["thrust_max"] * scale, rel=1e-15)


def test_urdf_inertia_as_ros_reads_it(identified):
    res, j, s, _ = identified
    root = ET.fromstring(model(res, "urdf"))
    inert = root.find("./link[@name='base_link']/inertial")
    e = j["estimates"][s]
    assert float(inert.find("mass").get("value")) == e["m"]
    i = inert.find("inertia")
    got = np.array([[float(i.get("ixx")), float(i.get("ixy")), float(i.get("ixz"))],
                    [float(i.get("ixy")), float(i.get("iyy")), float(i.get("iyz"))],
                    [float(i.get("ixz")), float(i.get("iyz")), float(i.get("izz"))]])
    np.testing.assert_array_equal(got, tensor(e))
    joints = {jn.find("child").get("link"): [float(v) for v in jn.find("origin").get("xyz").split()]
              for jn in root.iter("joint")}
    for k, p in enumerate(j["rotors"]["positions"]):
        name = f"rotor{k + 1}_{j['rotors']['spin'][k]}"
        assert joints[name] == p


def literal(node):
    """ast -> value, with np.array([...]) read as a list (the only call the dict holds)."""
    if isinstance(node, ast.Call):
        assert ast.unparse(node.func) == "np.array" and len(node.args) == 1
        return literal(node.args[0])
    if isinstance(node, ast.Dict):
        return {literal(k): literal(v) for k, v in zip(node.keys, node.values)}
    if isinstance(node, ast.List):
        return [literal(x) for x in node.elts]
    return ast.literal_eval(node)


def test_rotorpy_dict_has_every_key_its_multirotor_reads(identified):
    res, j, s, scale = identified
    tree = ast.parse(model(res, "rotorpy"))
    assign = [n for n in tree.body if isinstance(n, ast.Assign) and n.targets[0].id == "quad_params"][0]
    q = literal(assign.value)
    e = j["estimates"][s]
    for p in ("Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz"):
        assert q[p] == e[p]
    assert q["mass"] == e["m"]
    r = j["rotors"]
    assert q["num_rotors"] == len(r["positions"])
    assert [q["rotor_pos"][f"r{i + 1}"] for i in range(4)] == r["positions"]
    # RotorPy: M_yaw = rotor_dir k_m w^2, +1 = clockwise seen from above.
    assert q["rotor_directions"] == [1 if x == "cw" else -1 for x in r["spin"]]
    k_eta = r["kf"] * scale * (30 / math.pi) ** 2  # N/rpm^2 -> N/(rad/s)^2
    assert q["k_eta"] == pytest.approx(k_eta, rel=1e-15)
    assert q["k_m"] == pytest.approx(r["torque_ratio"] * k_eta, rel=1e-15)
    assert q["tau_m"] == r["time_constant"]
    assert q["k_eta"] * q["rotor_speed_max"] ** 2 == pytest.approx(r["thrust_max"] * scale, rel=1e-12)
    for key in ("rotor_speed_min", "rI"):
        assert key in q


def test_vehicle_file_reads_back_with_tomllib(identified):
    res, j, s, scale = identified
    v = tomllib.loads(model(res, "vehicle"))
    for p in THETA:
        assert v["nominal"][p] == j["estimates"][s][p]
    assert v["rotors"]["kf"] == pytest.approx(j["rotors"]["kf"] * scale, rel=1e-15)
    assert v["rotors"]["spin"] == j["rotors"]["spin"]


def test_python_model_equals_the_command_line_from_a_path_or_identify_s_dict(identified, tmp_path):
    import quadid

    res, j, s, _ = identified
    for fmt in ("vehicle", "mjcf", "rotorpy", "urdf"):
        assert quadid.model(res, fmt) == model(res, fmt)
    # The dict identify() returns (numpy arrays inside) gives the same numbers; only
    # the provenance line names the source differently.
    log = tmp_path / "again.csv"
    run_cli("simulate", "--vehicle", "crazyflie21", "--trajectory", "table2", "--duration", "30", "-o", str(log))
    r = quadid.identify(log, vehicle="crazyflie21", known_mass=0.0347)
    out = tmp_path / "r.json"
    run_cli("identify", str(log), "--vehicle", "crazyflie21", "--known-mass", "0.0347", "-q", "-o", str(out))
    strip = lambda t: "\n".join(l for l in t.splitlines() if "identified by quadid" not in l)
    assert strip(quadid.model(r, "rotorpy")) == strip(model(out, "rotorpy"))
    with pytest.raises(quadid.InputError, match="no estimate named XX"):
        quadid.model(res, "mjcf", set="XX")
    with pytest.raises(ValueError, match="expected one of vehicle, mjcf, rotorpy, urdf"):
        quadid.model(res, "gazebo")


def read_qgc(text):
    """QGroundControl's rules (ParameterManager): '#' lines skipped; a row is exactly five
    tab-separated fields vehicle, component, name, value, MAV_PARAM_TYPE (9 float32, 6 int32)."""
    out = {}
    for line in text.splitlines():
        if not line or line.startswith("#"):
            continue
        f = line.split("\t")
        assert len(f) == 5, line
        assert f[0] == "1" and f[1] == "1"
        assert f[4] in ("9", "6")
        out[f[2]] = float(f[3]) if f[4] == "9" else int(f[3])
    return out


def read_param_set(text):
    """PX4's shell: `param set NAME VALUE` (strtod); '#' lines are comments."""
    out = {}
    for line in text.splitlines():
        if line.startswith("#") or not line.strip():
            continue
        a, b, name, value = line.split()
        assert (a, b) == ("param", "set")
        out[name] = float(value)
    return out


def test_px4_sih_parameters_in_frd_as_qgc_and_the_shell_read_them(identified):
    res, j, s, scale = identified
    q = read_qgc(run_cli("model", str(res), "--format", "px4-sih-qgc").stdout)
    p = read_param_set(model(res, "px4-sih"))
    assert set(q) == set(p)
    for k in p:
        assert q[k] == pytest.approx(p[k], rel=1e-12, abs=1e-18), k  # 18 fixed decimals against shortest text
    e, r = j["estimates"][s], j["rotors"]
    assert p["SIH_MASS"] == e["m"]
    for a in ("Ixx", "Iyy", "Izz"):
        assert p["SIH_" + a.upper()] == e[a]
    # FLU -> FRD, R = diag(1, -1, -1): Ixy and Ixz change sign, Iyz keeps it.
    assert p["SIH_IXY"] == -e["Ixy"] and p["SIH_IXZ"] == -e["Ixz"] and p["SIH_IYZ"] == e["Iyz"]
    assert p["SIH_T_MAX"] == pytest.approx(r["thrust_max"] * scale, rel=1e-15)
    assert p["SIH_Q_MAX"] == pytest.approx(r["torque_ratio"] * r["thrust_max"] * scale, rel=1e-15)
    assert p["SIH_L_ROLL"] == abs(r["positions"][0][1]) and p["SIH_L_PITCH"] == abs(r["positions"][0][0])
    assert p["SIH_T_TAU"] == r["time_constant"]
    assert p["SIH_VEHICLE_TYPE"] == 0


def test_python_model_warns_for_sih_and_the_advised_scale_clears_it(identified):
    import re
    import warnings

    import quadid

    res = identified[0]
    with pytest.warns(UserWarning, match="cannot rotate") as rec:
        quadid.model(res, "px4-sih")
    s = float(re.search(r"--sih-scale ([0-9.]+)", str(rec[0].message)).group(1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        text = quadid.model(res, "px4-sih", sih_scale=s)
    assert "cannot rotate" not in text


def test_mjcf_motor_lag_is_a_filter_actuator_with_the_rotors_time_constant(identified):
    res, j, _, _ = identified
    root = ET.fromstring(run_cli("model", str(res), "--format", "mjcf", "--mjcf-motor-lag").stdout)
    acts = list(root.find("actuator"))
    assert len(acts) == 4 and all(a.tag == "general" for a in acts)
    for i, a in enumerate(acts):
        # MuJoCo's filter dynamics: act' = (ctrl - act) / dynprm[0]; force = gainprm[0] act along the gear.
        assert a.get("dyntype") == "filter"
        assert float(a.get("dynprm")) == j["rotors"]["time_constant"]
        assert a.get("gaintype") == "fixed" and float(a.get("gainprm")) == 1.0 and a.get("biastype") == "none"
        assert a.get("site") == f"rotor{i + 1}"


def test_ardupilot_sitl_frame_json_in_frd_with_derived_hover_and_yaw(identified):
    import re

    res, j, s, scale = identified
    text = model(res, "ardupilot-sitl")
    # SIM_Frame strips '#' comments before parsing the JSON.
    f = json.loads("\n".join(re.sub(r"#.*", "", line) for line in text.splitlines()))
    e, r = j["estimates"][s], j["rotors"]
    assert f["mass"] == e["m"]
    assert f["moment_inertia"] == [e["Ixx"], e["Iyy"], e["Izz"]]  # diagonal only, the file says the products are dropped
    assert "products of inertia" in text
    t_max = r["thrust_max"] * scale
    assert f["hoverThrOut"] * 4 * t_max == pytest.approx(e["m"] * 9.81, rel=1e-14)
    arm = max(math.hypot(p[0], p[1]) for p in r["positions"])
    assert f["diagonal_size"] == pytest.approx(2 * arm, rel=1e-15)
    ex = 0.65  # SITL's default propExpo: (1 - e) c + e c^2 = hoverThrOut at hover
    c_h = (-(1 - ex) + math.sqrt((1 - ex) ** 2 + 4 * ex * f["hoverThrOut"])) / (2 * ex)
    for i, p in enumerate(r["positions"]):
        assert f[f"motor{i + 1}_position"] == [p[0], -p[1], -p[2]]  # FLU -> FRD
        yaw = f[f"motor{i + 1}_yaw"]
        assert math.copysign(1, yaw) == (1 if r["spin"][i] == "ccw" else -1)  # AP_MotorsMatrix: CCW +1
        # SITL's yaw torque yaw 0.05 D c T equals torque_ratio T at hover.
        assert abs(yaw) * 0.05 * f["diagonal_size"] * c_h == pytest.approx(r["torque_ratio"], rel=1e-12)


def test_gym_pybullet_drones_flavour_reads_as_its_positional_parser_does(identified):
    res, j, s, scale = identified
    tree = ET.fromstring(run_cli("model", str(res), "--format", "urdf", "--flavour", "gym-pybullet-drones").stdout)
    # BaseAviary._parseURDFParameters: [0] properties by name; [1][0][1] mass; [1][0][2] inertia;
    # [1][2][1][0] the collision cylinder; [1][2][0] its origin (xyz split on single spaces).
    props = tree[0].attrib
    assert tree[0].tag == "properties"
    for k in ("arm", "kf", "km", "thrust2weight", "max_speed_kmh", "gnd_eff_coeff", "prop_radius", "drag_coeff_xy",
              "drag_coeff_z", "dw_coeff_1", "dw_coeff_2", "dw_coeff_3"):
        float(props[k])
    e, r = j["estimates"][s], j["rotors"]
    m = float(tree[1][0][1].attrib["value"])
    assert m == e["m"]
    assert [float(tree[1][0][2].attrib[a]) for a in ("ixx", "iyy", "izz")] == [e["Ixx"], e["Iyy"], e["Izz"]]
    float(tree[1][2][1][0].attrib["length"]), float(tree[1][2][1][0].attrib["radius"])
    float(tree[1][2][0].attrib["xyz"].split(" ")[2])
    kf, km, t2w = float(props["kf"]), float(props["km"]), float(props["thrust2weight"])
    # kf in N/RPM^2 (crazyflie21's kf is per rpm already, times the thrust scale); km = torque_ratio kf.
    assert kf == pytest.approx(r["kf"] * scale, rel=1e-12)
    assert km == pytest.approx(r["torque_ratio"] * kf, rel=1e-12)
    # gym: MAX_RPM = sqrt(thrust2weight m 9.8 / (4 kf)); kf MAX_RPM^2 is each rotor's largest thrust.
    assert kf * (t2w * m * 9.8 / (4 * kf)) == pytest.approx(r["thrust_max"] * scale, rel=1e-12)
    # prop0..prop3 counter-clockwise from front left, at the rotors' positions.
    props_xyz = [[float(v) for v in tree[2 + 2 * k][0][0].attrib["xyz"].split()] for k in range(4)]
    angles = [math.atan2(p[1], p[0]) for p in props_xyz]
    assert props_xyz[0][0] > 0 and props_xyz[0][1] > 0
    assert sorted(map(tuple, props_xyz)) == sorted(map(tuple, r["positions"]))
    assert all(((angles[k + 1] - angles[k]) % (2 * math.pi)) < math.pi for k in range(3))
    assert tree[10].attrib["name"] == "center_of_mass_link"


def test_python_model_options_equal_the_command_line_s(identified):
    import quadid

    res = identified[0]
    assert quadid.model(res, "urdf", flavour="gym-pybullet-drones") == run_cli(
        "model", str(res), "--format", "urdf", "--flavour", "gym-pybullet-drones").stdout
    assert quadid.model(res, "mjcf", mjcf_motor_lag=True) == run_cli(
        "model", str(res), "--format", "mjcf", "--mjcf-motor-lag").stdout
    assert quadid.model(res, "sdf", gazebo="classic") == run_cli(
        "model", str(res), "--format", "sdf", "--gazebo", "classic").stdout
    with pytest.warns(UserWarning, match="use ixx iyy izz only"):
        quadid.model(res, "urdf", flavour="gym-pybullet-drones")
    with pytest.raises(ValueError, match="flavour='pybullet'"):
        quadid.model(res, "urdf", flavour="pybullet")
