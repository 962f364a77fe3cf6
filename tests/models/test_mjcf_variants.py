"""The judges' MJCF after its split (issue 16) and with the joint variants (issue 15).

* The default-joint model of every bundled thesis preset, judges' and exported, is byte-identical to the
  text ``models/mjcf.py`` wrote before the split and the variants (commit 97ff0d8): SHA-256 digests (first
  32 hex digits) of those texts, taken from that commit's code.
* The split modules stay within issue 16's limits (400 lines a module, 60 a function).
* A variant's model has the joints ``case.joints`` says, and MuJoCo compiles it.
"""

from __future__ import annotations

import ast
import copy
import hashlib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from numpy.testing import assert_allclose

from dualmech.cli import main
from dualmech.models.case import case_from_dict, load_case, preset_names, preset_path
from dualmech.models.mjcf import MjcfStart, case_to_mjcf, joint_names, runnable_mjcf, slider_axis

#: {preset: (judges' MJCF, export)} digests of the texts of commit 97ff0d8 (the export at a fixed start).
BEFORE = {
    "thesis/a4-10-s1-3.5": ("7687332659776ee6403a8250e679a38e", "b65c6b77f9e72c763fca09a8ffe55c75"),
    "thesis/a4-20-alpha-232": ("e7f1a44e7b78c54edf7b9fc872df4c6f", "665efce835d47c091256391d7fa2da62"),
    "thesis/a4-20-alpha-310": ("9eec4bd74fe028b54bede00f3d1db98d", "a141eb1a96914a2356c40e0e7b5ed826"),
    "thesis/a4-20-s1-3.5": ("77b9f363fec8b3f309e58fc77eec1c89", "3d533cd2a84ab214a28efc7c627e4aa8"),
    "thesis/a4-30-s1-3.5": ("e5d575d0b6ad394e8f3943e6e7657c04", "9f6a46b5a31433e857dfa10a81e3e423"),
    "thesis/a4-30-s1-3": ("15f9dd8a5825d7609c00200192326f66", "4475aba193be079bdade5054e46d0c47"),
    "thesis/a4-30-s1-6": ("ef8a42631a0d4a7fced9a12729be61d8", "e6f63f9ad2fb89e29c571fc785e6b914"),
    "thesis/a4-30-s1-9": ("e796de77960691c1bcc220d450078eb8", "5e58729b43e17ba5a1614626ef3bae74"),
    "thesis/ideal": ("7be1f4fb3db024d2f9e7c2c4b57c8379", "7255bbea356813c53f5f6792042c0fa1"),
}
#: The start the export digests were taken at (any finite state: only the text is compared).
START = MjcfStart(np.array([0.3, 1.0, 0.9, 0.1, 0.2, 0.3, 40.0]), np.arange(6.0), 5.0)
MODULES = ("models/mjcf.py", "models/mjcf_settings.py", "models/mjcf_export.py")
ROOT = Path(__file__).resolve().parents[2]


def _digest(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def test_every_thesis_preset_is_in_the_digests() -> None:
    assert sorted(BEFORE) == sorted(n for n in preset_names() if n.startswith("thesis/"))


@pytest.mark.parametrize("preset", sorted(BEFORE))
def test_default_joint_models_are_byte_identical_to_before_the_split(preset) -> None:
    case = load_case(preset)
    assert case.joints.is_default
    judges, export = BEFORE[preset]
    assert _digest(case_to_mjcf(case)) == judges
    assert _digest(runnable_mjcf(case, START, 1e-4, "m.xml", ("note",))) == export


def oversized(source: str, max_lines: int = 400, max_function: int = 60) -> list[str]:
    """What in ``source`` breaks issue 16's limits: the module's lines, each function's."""
    out = [f"module: {source.count(chr(10))} lines"] if source.count("\n") > max_lines else []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            length = node.end_lineno - node.lineno + 1
            if length > max_function:
                out.append(f"{node.name}: {length} lines")
    return out


@pytest.mark.parametrize("module", MODULES)
def test_the_split_modules_keep_issue_16s_limits(module) -> None:
    assert oversized((ROOT / module).read_text()) == []


def test_the_limits_check_sees_a_long_module_and_function() -> None:
    body = "\n".join(f"    x{i} = {i}" for i in range(61))
    assert oversized(f"def f():\n{body}\n") == ["f: 62 lines"]
    assert oversized("x = 1\n" * 401) == ["module: 401 lines"]


def _variant(joints: dict[str, str]):
    raw = copy.deepcopy(load_case("thesis/a4-30-s1-3.5").raw)
    raw["joints"] = joints
    return case_from_dict(raw)


@pytest.mark.parametrize("joints, names", [
    ({"crank": "revolute"}, ("crank_angle", "rod_ball", "slider_stroke")),
    ({"rod_slider": "universal"}, ("crank_angle", "crank_axial", "slider_stroke", "rod_k4", "rod_cross")),
    ({"crank": "revolute", "rod_slider": "universal"},
     ("crank_angle", "slider_stroke", "rod_k4", "rod_cross")),
])
def test_a_variants_model_has_its_joints(joints, names) -> None:
    mujoco = pytest.importorskip("mujoco")
    case = _variant(joints)
    assert joint_names(case.joints) == names
    model = mujoco.MjModel.from_xml_string(case_to_mjcf(case))
    assert tuple(model.joint(j).name for j in range(model.njnt)) == names
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    crank = model.body("crank").id
    assert_allclose(data.xpos[crank], [0.0, 0.0, 0.0 if "crank_axial" in names else 3.5], rtol=0, atol=0)
    if "rod_k4" in names:  # qpos = 0: slider-side axis k4, rod-side axis normal to the rod and to k4
        k4 = slider_axis(case)
        first, second = (data.xaxis[model.joint(n).id] for n in ("rod_k4", "rod_cross"))
        u0 = data.xmat[model.body("rod").id].reshape(3, 3)[:, 0]
        assert_allclose(first, k4, rtol=0, atol=1e-15)
        assert_allclose(second, np.cross(u0, k4) / np.linalg.norm(np.cross(u0, k4)), rtol=0, atol=1e-15)


def test_a_variant_is_not_exported_yet(tmp_path) -> None:
    with pytest.raises(ValueError, match="^joints: crank = 'revolute'"):
        runnable_mjcf(_variant({"crank": "revolute"}), START, 1e-4)
    pytest.importorskip("mujoco")
    path = tmp_path / "u.toml"
    text = Path(preset_path("thesis/a4-30-s1-3.5")).read_text()
    path.write_text(text + '\n[joints]\nrod_slider = "universal"\n')
    result = CliRunner().invoke(main, ["mjcf", str(path), "-o", str(tmp_path / "u.xml")])
    assert result.exit_code == 2
    assert result.output.strip().splitlines() == [
        "dualmech: error: joints: crank = 'cylindrical', rod_slider = 'universal' cannot be exported yet "
        "(valid: the default cylindrical crank and ball-ball rod)"]
