"""The MuJoCo judge generated from a loop table against the in-house engine on the same table.

The judge starts from the joints' ``start`` values written into the table (as a user writes them in a
file), rounded to 1e-3: a start estimate on the branch, never the in-house answer.  Each column is
compared relative to the peak of its unit group (angles in rad, lengths over the table's length, angular
and linear rates and accelerations, forces, moments) at the positions both call ``ok``:
:data:`~dualmech.validation.tolerances.MUJOCO_RIGID_KINEMATICS` (1e-10) for the coordinates and their rates,
:data:`~dualmech.validation.tolerances.MUJOCO_RIGID_REACTIONS` (1e-9) for the efforts and wrenches, the
tolerances the hand-written rigid MuJoCo judges are held to: both close the loop to ~1e-14 of its length
and solve linear systems on the closed pose, so round-off amplified by the pose's conditioning (1/transmission
near a dead centre: ~5e-11 measured on a4-30-s1-3.5, whose slider forces reach 1e3 times the drive's scale)
is all that is left.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from dualmech.core.continuation import search_assembly
from dualmech.core.loop import LoopState
from dualmech.models.case import load_case, preset_names
from dualmech.models.linkages import read_linkage
from dualmech.models.linkages.rccc_case import rccc_from_dict
from dualmech.models.linkages.rssr_case import rssr_from_dict
from dualmech.models.loop.description import LoopMechanism
from dualmech.models.loop.engine import LoopAnalysis, analyze_loop
from dualmech.models.loop.presets import (
    rccc_start,
    rccc_table,
    rssr_start,
    rssr_table,
    slider_crank_start,
    slider_crank_table,
)
from dualmech.models.loop.translate import drive_state, to_loop
from dualmech.models.slider_crank.analysis import analyze
from dualmech.validation.judges.mujoco_loop import loop_mjcf, solve_loop
from dualmech.validation.judges.mujoco_loop.closure import CLOSURE_TOL
from dualmech.validation.judges.mujoco_loop.engine import LoopTable, column_names
from dualmech.validation.judges.mujoco_slider_crank.engine import solve_case
from dualmech.validation.tolerances import MUJOCO_RIGID_KINEMATICS, MUJOCO_RIGID_REACTIONS
from tests.models.loop.test_random_tables import TOPOLOGIES, random_table
from tests.tolerances import LOOP_REACTIONS_ROUNDING

#: Decimals of the start values written into the table (a user's estimate, not the in-house answer).
START_DECIMALS = 3
_VARIABLES = {"R": ("theta",), "P": ("s",), "C": ("theta", "s"), "U": ("theta", "eta"), "S": ()}


def _rotation_vector(rot: np.ndarray) -> np.ndarray:
    quat, vec = np.empty(4), np.empty(3)
    mujoco.mju_mat2Quat(quat, rot.reshape(-1))
    mujoco.mju_quat2Vel(vec, quat, 1.0)
    return vec


def with_start(mech: LoopMechanism, state: LoopState) -> LoopMechanism:
    """``mech`` with every joint's ``start`` from a one-position pose, rounded to START_DECIMALS."""
    values = dict(zip(to_loop(mech).unknowns, state.scalars[0]))
    rotations = list(state.rotations[0])
    joints = []
    for i, joint in enumerate(mech.joints):
        if joint.type == "S":
            start = tuple(np.round(_rotation_vector(rotations.pop(0)), START_DECIMALS).tolist())
        else:
            start = tuple(round(float(values.get(f"{c}{i + 1}", 0.0)), START_DECIMALS)
                          for c in _VARIABLES[joint.type])
        joints.append(dataclasses.replace(joint, start=start))
    return dataclasses.replace(mech, joints=tuple(joints))


def in_house_columns(an: LoopAnalysis, names: list[str]) -> dict[str, np.ndarray]:
    """The in-house analysis as the judge's columns (:func:`~.engine.column_names`)."""
    out = {}
    for name in names:
        if name.startswith("effort_"):
            out[name] = an.wrenches.efforts[name[len("effort_"):]]
        elif name.startswith("joint"):
            joint, kind = name[len("joint"):].split("_")
            field = an.wrenches.force if kind[0] == "f" else an.wrenches.moment
            out[name] = field[:, int(joint) - 1, "xyz".index(kind[1])]
        else:
            base, _, order = name.partition("_")
            coordinate = base.rstrip("0123456789")
            value = an.coordinate(int(base[len(coordinate):]) - 1, coordinate)
            out[name] = value[{"": 0, "dot": 1, "ddot": 2}[order]]
    return out


def _group(name: str) -> str:
    """The unit group of a column (module docstring)."""
    if name.startswith("joint"):
        return "force" if name[-2] == "f" else "moment"
    if name.startswith("effort_"):
        return "force" if name[len("effort_")] == "s" else "moment"
    base, _, order = name.partition("_")
    return ("slide" if base.startswith("s") else "angle") + order


def differences(mine: LoopTable, an: LoopAnalysis, size: float) -> dict[str, float]:
    """Each column's largest difference over its unit group's peak, on the positions both call ok."""
    names = column_names(an.mechanism)
    ref = in_house_columns(an, names)
    ok = (mine.status == "ok") & (an.status == "ok")
    assert ok.any()
    peaks: dict[str, float] = {}
    for name in names:
        peaks[_group(name)] = max(peaks.get(_group(name), 0.0), float(np.abs(ref[name][ok]).max()))
    peaks["slide"], peaks["angle"] = size, 1.0
    out = {}
    for name in names:
        diff = mine.columns[name][ok] - ref[name][ok]
        if _group(name) == "angle":
            diff = np.angle(np.exp(1j * diff))
        out[name] = float(np.abs(diff).max()) / max(peaks[_group(name)], np.finfo(float).tiny)
    return out


def past_a_gap(status: np.ndarray) -> np.ndarray:
    """Positions after a ``no_assembly`` one (in either direction from the first ``ok``)."""
    failed = status == "no_assembly"
    start = int(np.argmax(status == "ok"))
    forward = np.maximum.accumulate(failed[start:])
    backward = np.maximum.accumulate(failed[:start][::-1])[::-1]
    return np.r_[backward, forward]


def assert_agrees(mine: LoopTable, an: LoopAnalysis, size: float) -> None:
    """Same statuses; kinematics within MUJOCO_RIGID_KINEMATICS, dynamics within MUJOCO_RIGID_REACTIONS.

    Two differences are allowed, both where the judge proves an assembly the in-house engine did not find:
    past a gap of no assembly the in-house engine may report ``branch_jump`` where the judge, searching
    there for a pose on the start's branch, found one (its pose closes and has the start's branch sign: seen
    on a random CSSP table); and ``no_assembly`` (its DFP stopped at a local minimum of the closure error,
    0.12 on a random RSCR table) where the judge's pose closes (residual 2.6e-15 there).  A third is the
    gate's :data:`~dualmech.validation.compare.tables.BRANCH_GONE`: past the end of the followed branch, the
    in-house ``branch_jump`` (closed on another assembly) where the judge found no pose (a random RRRSR).
    """
    mine_status, status = mine.status.astype(str), an.status.astype(str)
    closed = (mine_status == "ok") & (mine.residual <= CLOSURE_TOL)
    found = closed & ((past_a_gap(status) & (status == "branch_jump")) | (status == "no_assembly"))
    found |= (status == "branch_jump") & (mine_status == "no_assembly")
    np.testing.assert_array_equal(mine_status[~found], status[~found])
    for name, diff in differences(mine, an, size).items():
        kinematic = not (name.startswith("joint") or name.startswith("effort_"))
        bound = (MUJOCO_RIGID_KINEMATICS if kinematic else MUJOCO_RIGID_REACTIONS).value
        assert diff <= bound, f"{name}: {diff:.3e} > {bound:g}"


def _size(mech: LoopMechanism) -> float:
    return max(abs(v) for j in mech.joints for v in (j.a, j.s))


#: A slider crank whose offset leaves 131 of 360 positions unassembled: past the gap the judge must close the
#: loop again on the start's branch (``test_engine.py``'s variant of the in-house engine).
NO_ASSEMBLY_GAP = "no-assembly-gap"


def _slider_crank(preset: str) -> tuple[LoopMechanism, LoopState]:
    case = load_case("thesis/ideal").with_values({
        "geometry.slider_offset": 45.0, "motion.angles_deg": {"start": 180.0, "stop": 540.0, "step": 1.0}}) \
        if preset == NO_ASSEMBLY_GAP else load_case(preset)
    return slider_crank_table(case), slider_crank_start(case, analyze(case).s4[0])


def _preset(name: str) -> tuple[LoopMechanism, LoopState]:
    if name.startswith("rssr"):
        data = read_linkage("rssr")
        if name == "rssr-torque":  # the drive torque given, the output torque solved
            data = {**data, "loads": {**{k: v for k, v in data["loads"].items() if k != "output_torque"},
                                      "drive_torque": 3.0}}
        case = rssr_from_dict(data)
        return rssr_table(case), rssr_start(case)
    if name == "rccc":
        case = rccc_from_dict(read_linkage("rccc"))
        return rccc_table(case), rccc_start(case)
    return _slider_crank(name)


PRESETS = ("thesis/ideal", "thesis/a4-30-s1-3.5", "iftomm/spatial-slider-crank", "rssr", "rssr-torque",
           "rccc", NO_ASSEMBLY_GAP)


@pytest.mark.parametrize("name", PRESETS)
def test_presets_agree_with_the_in_house_engine(name: str) -> None:
    mech, start = _preset(name)
    assert_agrees(solve_loop(with_start(mech, start)), analyze_loop(mech, start), _size(mech))


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), topology=st.sampled_from(TOPOLOGIES))
@example(seed=5894, topology="RRRSR")  # past its fold: the in-house branch_jump, the judge's no_assembly
@example(seed=110, topology="RRSRR")  # closes again 5 positions past a gap: searched only if closed
def test_random_tables_agree_with_the_in_house_engine(seed: int, topology: str) -> None:
    mech = random_table(seed, topology)
    found = search_assembly(to_loop(mech), drive_state(mech).take(slice(0, 1)).values, seed % 1000)
    assume(found.scalars.shape[0] > 0)
    start = found.take(slice(0, 1))
    an = analyze_loop(mech, start)
    assume(an.status[0] == "ok")
    assert_agrees(solve_loop(with_start(mech, start)), an, _size(mech))


def test_a_flipped_axis_is_caught() -> None:
    """The comparison is not vacuous: the RCCC's MJCF with joint 2's hinge about -z instead of +z (a slip
    a writer could make) disagrees with the in-house answer by far more than the tolerance."""
    mech, start = _preset("rccc")
    xml = loop_mjcf(mech)
    root = ET.fromstring(xml)
    hinge = next(j for j in root.iter("joint") if j.get("name") == "joint2_theta")
    hinge.set("axis", "0 0 -1")
    faulty = solve_loop(with_start(mech, start), xml=ET.tostring(root, encoding="unicode"))
    an = analyze_loop(mech, start)
    ok = (faulty.status == "ok") & (an.status == "ok")
    if ok.any():
        assert max(differences(faulty, an, _size(mech)).values()) > 1e3 * MUJOCO_RIGID_KINEMATICS.value
    else:
        assert (faulty.status != an.status).any()


def test_the_judge_finds_its_own_start() -> None:
    """Without start values the judge searches (its branch is arbitrary): every position closes."""
    mech, _ = _preset("rccc")
    table = solve_loop(mech)
    assert (table.status == "ok").all()
    np.testing.assert_array_less(table.residual, 1e-12)


ADVERSARIAL = '--><mujoco model="x"/><!--'


@settings(max_examples=30, deadline=None)
@given(name=st.one_of(st.just(ADVERSARIAL), st.text(
    alphabet=st.characters(blacklist_categories=("Cs", "Cc")), max_size=40)))
def test_a_name_cannot_inject_markup(name: str) -> None:
    """Any table name (``<``, ``&``, quotes, a closing comment) is escaped: the MJCF has one ``<mujoco>``
    whose model name is the table's, and MuJoCo compiles it."""
    mech, _ = _preset("rssr")
    xml = loop_mjcf(dataclasses.replace(mech, name=name))
    root = ET.fromstring(xml)
    assert root.tag == "mujoco" and root.get("model") == name
    assert sum(1 for _ in root.iter("mujoco")) == 1
    assert mujoco.MjModel.from_xml_string(xml).nbody == len(mech.joints)


def test_the_mjcf_loads_with_the_table_mass() -> None:
    mech, _ = _preset("thesis/a4-30-s1-3.5")
    model = mujoco.MjModel.from_xml_string(loop_mjcf(mech))
    np.testing.assert_allclose(model.body_mass[1:], [b.mass for b in mech.bodies], rtol=1e-15, atol=0)
    assert model.neq == 1 and model.eq_type[0] == mujoco.mjtEq.mjEQ_WELD


@pytest.mark.parametrize("module", ["dualmech.validation.judges.mujoco_loop",
                                    "dualmech.validation.judges.mujoco_loop.simulation"])
def test_the_judge_never_imports_the_in_house_engine(module: str) -> None:
    """Independence: importing the rigid or the simulated judge loads none of the in-house engines'
    modules (the loop's, nor the slider crank's)."""
    code = (f"import sys; import {module}; "
            "bad = [m for m in ('dualmech.models.loop.engine', 'dualmech.core.continuation', "
            "'dualmech.core.loop_reactions', 'dualmech.core.closure', 'dualmech.core.rates', "
            "'dualmech.models.slider_crank.analysis') if m in sys.modules]; print(bad); "
            "sys.exit(1 if bad else 0)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stdout + done.stderr


#: The issue's bar for retiring a hand-written judge (issue 32, point 4): the generated one agrees with it to
#: 1e-12 of the peak; reactions near a dead centre carry round-off over the transmission |t| (as the in-house
#: loop engine against the slider crank's, ``tests/models/loop/test_engine.py``).
HAND_WRITTEN_AGREEMENT = 1e-12


@pytest.mark.parametrize("preset", preset_names())
def test_the_hand_written_slider_crank_judge_agrees(preset: str) -> None:
    """Every slider-crank preset: the generated judge against
    ``validation/judges/mujoco_slider_crank/engine.py`` (same
    statuses; ``S4`` and its rates, every reaction column and the efforts, mapped as in
    ``docs/conventions.md``, "Loop tables": ``j4`` and the slider load are minus joint 4's)."""
    mech, start = _slider_crank(preset)
    mine, hand = solve_loop(with_start(mech, start)), solve_case(load_case(preset))
    np.testing.assert_array_equal(mine.status.astype(str), np.asarray(hand.status).astype(str))
    ok = mine.status == "ok"
    c, col = hand.columns, mine.columns
    pairs = {"S4": col["s4"], "S4_dot": col["s4_dot"], "S4_ddot": col["s4_ddot"],
             "drive_torque": col["effort_theta1"], "slider_load": -col["effort_s4"]}
    for j, sign in ((1, 1.0), (2, 1.0), (3, 1.0), (4, -1.0)):
        for kind in "fm":
            for axis in "xyz":
                if f"j{j}_{kind}{axis}" in c:
                    pairs[f"j{j}_{kind}{axis}"] = sign * col[f"joint{j}_{kind}{axis}"]
    with np.errstate(divide="ignore"):
        bound = np.maximum(HAND_WRITTEN_AGREEMENT, LOOP_REACTIONS_ROUNDING / np.abs(c["transmission"]))
    for name, mine_column in pairs.items():
        family = "S4" if name.startswith("S4") else "m" if name[-2] == "m" or name == "drive_torque" else "f"
        group = [k for k in pairs if (k.startswith("S4") if family == "S4" else k[-2:-1] == family)] or [name]
        scale = max(np.abs(c[k][ok]).max() for k in group + [name])
        err = np.abs(mine_column[ok] - c[name][ok]) / scale
        limit = HAND_WRITTEN_AGREEMENT if family == "S4" else bound[ok]
        np.testing.assert_array_less(err, limit, err_msg=name)
