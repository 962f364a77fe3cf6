"""Your first design, built in Python: solve it and print a few rows and the peak loads.

The same design as ``examples/first-design.toml`` (a 50 mm crank, a 200 mm rod, a 10 mm slider offset,
600 rpm against a 200 N slider load, SI units), with no file at all.  Run: ``python first_design.py``.
"""

import numpy as np

import dualmech

case = dualmech.Case(
    "first-design", units="m-kg-s",
    geometry={"crank_length": 0.05, "rod_length": 0.20, "slider_offset": 0.01,
              "slider_twist_deg": 270.0, "crank_axial_shift": 0.0},
    motion={"crank_rpm": 600.0},
    bodies={"crank_radius": 0.008, "rod_radius": 0.005, "slider_side": 0.025, "density": 7850.0},
    loads={"slider_force": 200.0, "gravity": [0.0, -9.81, 0.0]},
)
table = dualmech.solve(case)                      # the in-house engine, one row per crank angle
df = table.to_pandas()
print(df[["theta1_deg", "S4", "S4_dot", "drive_torque", "status"]].head(3).to_string(index=False))

ok = df["status"] == "ok"                         # peaks over the rows whose reactions are given
s4 = df["S4"].to_numpy()
print(f"stroke: {s4.max() - s4.min():.9f} m")
for joint in (1, 2, 3, 4):
    force = np.hypot.reduce([df.loc[ok, f"j{joint}_f{axis}"].to_numpy() for axis in "xyz"])
    print(f"peak |force| at joint {joint}: {force.max():.3f} N "
          f"at {df.loc[ok, 'theta1_deg'].to_numpy()[force.argmax()]:.0f} deg")
torque = df.loc[ok, "drive_torque"].abs()
print(f"peak |drive_torque|: {torque.max():.4f} N·m at {df.loc[torque.idxmax(), 'theta1_deg']:.0f} deg")
