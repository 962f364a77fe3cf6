"""A sweep of the slider offset a4 in Python, no temporary files: the stroke per offset.

The design is ``examples/first-design.toml``; each offset is a changed copy of it in memory.  With a4 = 0
the slider crank is centred and its stroke is exactly twice the crank (2 a1 = 0.1 m); an offset
lengthens it.  Run: ``python offset_sweep.py``.
"""

from pathlib import Path

import dualmech

case = dualmech.load_case(Path(__file__).with_name("first-design.toml"))
for a4 in (0.0, 0.005, 0.01, 0.02, 0.04):
    s4 = dualmech.solve(case.with_values({"geometry.slider_offset": a4}))["S4"]
    print(f"a4 = {a4:.3f} m: stroke {s4.max() - s4.min():.9f} m")
