"""RSSR case tables for the tests: the bundled one and seeded random ones."""

from __future__ import annotations

import copy

import numpy as np

from dualmech.models.linkages import read_linkage


def bundled() -> dict:
    """A fresh copy of the bundled RSSR case table."""
    return copy.deepcopy(read_linkage("rssr"))


def random_rssr(rng: np.random.Generator, mode: str = "output", step: float = 5.0) -> dict:
    """A random crank-rocker RSSR (short input crank), random twist, offsets, bodies with products of inertia
    (so the gyroscopic terms are not zero), random gravity, load ``mode`` ("torque" or "output")."""
    a3, a2 = rng.uniform(0.8, 1.5), rng.uniform(1.5, 2.5)
    data = {
        "name": "random-rssr", "units": "m-N-s",
        "mechanism": {"kind": "rssr", "branch": int(rng.choice([1, -1]))},
        "geometry": {"input_crank": rng.uniform(0.1, 0.3), "input_offset": rng.uniform(-0.5, 0.5),
                     "coupler": a2, "output_crank": a3, "output_offset": rng.uniform(-0.5, 0.5),
                     "frame_offset": rng.uniform(1.0, 1.8), "frame_twist_deg": rng.uniform(-80.0, 80.0)},
        "motion": {"crank_rpm": rng.uniform(-300.0, 300.0), "crank_accel": rng.uniform(-50.0, 50.0),
                   "angles_deg": {"start": 0.0, "stop": 360.0, "step": step}},
        "bodies": {
            "input_crank": {"mass": rng.uniform(0.5, 2.0), "com": rng.uniform(-0.1, 0.2, 3).tolist(),
                            "inertia": [[0.02, 0.003, -0.002], [0.003, 0.03, 0.001], [-0.002, 0.001, 0.04]]},
            "coupler": {"mass": rng.uniform(0.5, 2.0), "radius": 0.03},
            "output_crank": {"mass": rng.uniform(0.5, 2.0), "com": rng.uniform(-0.1, 0.5, 3).tolist(),
                             "inertia": [[0.05, -0.004, 0.006], [-0.004, 0.07, 0.002], [0.006, 0.002, 0.09]]},
        },
        "loads": {"gravity": rng.uniform(-10.0, 10.0, 3).tolist()},
    }
    data["loads"]["drive_torque" if mode == "torque" else "output_torque"] = rng.uniform(-20.0, 20.0)
    return data


def random_rccc(rng: np.random.Generator, step: float = 10.0) -> dict:
    """A random RCCC: input link short against the others, twists 20..160 deg, full inertia tensors."""
    twist = lambda: float(rng.uniform(20.0, 160.0) * rng.choice([-1.0, 1.0]))  # noqa: E731
    return {
        "name": "random-rccc", "units": "m-N-s",
        "mechanism": {"kind": "rccc", "branch": int(rng.choice([1, -1]))},
        "geometry": {"input_offset": rng.uniform(-0.2, 0.2), "input_link": rng.uniform(0.05, 0.2),
                     "input_twist_deg": twist(), "coupler": rng.uniform(0.3, 0.6),
                     "coupler_twist_deg": twist(),
                     "output_link": rng.uniform(0.2, 0.5), "output_twist_deg": twist(),
                     "frame_offset": rng.uniform(0.2, 0.5), "frame_twist_deg": twist()},
        "motion": {"crank_rpm": rng.uniform(-200.0, 200.0), "crank_accel": rng.uniform(-30.0, 30.0),
                   "angles_deg": {"start": 0.0, "stop": 360.0, "step": step}},
        "bodies": {name: {"mass": rng.uniform(0.5, 2.0), "com": rng.uniform(-0.1, 0.3, 3).tolist(),
                          "inertia": [[0.02, 0.003, -0.002], [0.003, 0.03, 0.001], [-0.002, 0.001, 0.04]]}
                   for name in ("input_link", "coupler", "output_link")},
        "loads": {"output_torque": rng.uniform(-5.0, 5.0), "gravity": rng.uniform(-10.0, 10.0, 3).tolist()},
    }
