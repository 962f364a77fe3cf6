"""Speed of the in-house solver, quoted against Pinocchio (and MuJoCo) measured in the same run.

Not a test: timings depend on the machine.  ``dualmech benchmark`` prints a
Markdown table; the README quotes one run.  Every engine solves the same
seeded random cases (the thesis example with random offsets, twist and axial
shift), so the ratios compare like with like.
"""

from __future__ import annotations

import cProfile
import io
import platform
import pstats
import resource
import time
from dataclasses import dataclass
from importlib import import_module

import numpy as np

from dualmech.models.case import Case, load_case
from dualmech.models.slider_crank import CHUNK_POSITIONS, Batch, close_loop, iter_analyses


@dataclass(frozen=True)
class Timing:
    """One measured figure: what was timed, positions, seconds, positions per second."""

    label: str
    positions: int
    seconds: float

    @property
    def rate(self) -> float:
        return self.positions / self.seconds

    @property
    def micro_per_position(self) -> float:
        return 1e6 * self.seconds / self.positions


def random_cases(count: int, step_deg: float = 1.0, seed: int = 0) -> list[Case]:
    """``count`` seeded variations of the thesis example (a4, alpha4, S1 within assemblable ranges)."""
    rng = np.random.default_rng(seed)
    base = load_case("a4-30-s1-3.5")
    return [
        base.with_values({
            "name": f"bench-{i}",
            "geometry.slider_offset": float(rng.uniform(0.0, 30.0)),
            "geometry.slider_twist_deg": float(rng.uniform(240.0, 300.0)),
            "geometry.crank_axial_shift": float(rng.uniform(0.0, 5.0)),
            "motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": step_deg},
        })
        for i in range(count)
    ]


def _timed(label: str, positions: int, func) -> Timing:
    start = time.perf_counter()
    func()
    return Timing(label, positions, time.perf_counter() - start)


def time_inhouse(cases: list[Case]) -> tuple[Timing, Timing]:
    """Kinematics only (closure + rates) and the full analysis, all cases in one process."""
    cranks = [c.motion.state(c.geometry.crank_axial_shift) for c in cases]
    n = sum(len(c) for c in cranks)

    per_chunk = max(1, CHUNK_POSITIONS // max(len(c) for c in cranks))

    def kinematics():  # closure only, in the same chunks as the full analysis
        for lo in range(0, len(cases), per_chunk):
            close_loop(Batch.of(cases[lo:lo + per_chunk], cranks[lo:lo + per_chunk]))

    def full():
        for _ in iter_analyses(cases, cranks):
            pass

    return _timed("dualmech kinematics (closure)", n, kinematics), _timed("dualmech full analysis", n, full)


_JUDGES = {"pinocchio": "pinocchio_engine", "mujoco": "mujoco_engine", "mujoco-sim": "mujoco_sim"}


def time_engine(engine: str, cases: list[Case]) -> Timing | None:
    """Time a judge's ``solve_case`` over ``cases``; ``None`` if the engine cannot be imported."""
    try:
        module = import_module(f"dualmech.validation.{_JUDGES[engine]}")
    except ImportError:
        return None
    n = sum(len(c.motion.angles_deg) for c in cases)
    return _timed(f"{engine} full analysis", n, lambda: [module.solve_case(c) for c in cases])


def profile_inhouse(cases: list[Case], top: int = 12) -> str:
    """cProfile of the full analysis: where the time goes, by cumulative time."""
    prof = cProfile.Profile()
    prof.enable()
    for _ in iter_analyses(cases):
        pass
    prof.disable()
    out = io.StringIO()
    pstats.Stats(prof, stream=out).sort_stats("tottime").print_stats(top)
    return out.getvalue()


def peak_memory_mb() -> float:
    """Peak resident memory of this process so far, MiB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def streaming_run(total_positions: int, chunk_positions: int) -> tuple[Timing, float]:
    """Analyse ``total_positions`` in chunks, keeping only a running maximum: time and peak memory."""
    per_case = 3600  # 0.1 degree steps
    cases = random_cases(max(1, total_positions // per_case), step_deg=0.1, seed=1)
    worst = 0.0

    def run():
        nonlocal worst
        for an in iter_analyses(cases, chunk_positions=chunk_positions):
            worst = max(worst, float(np.nanmax(np.abs(an.reactions.j2))))

    t = _timed(f"dualmech streaming, chunks of {chunk_positions}", len(cases) * per_case, run)
    return t, peak_memory_mb()


def run_benchmark(cases: int = 1000, judge_cases: int = 5, big: int = 0, profile: bool = True) -> str:
    """Run the benchmark and return a Markdown report."""
    bench = random_cases(cases)
    kin, full = time_inhouse(bench)
    mem_after_full = peak_memory_mb()
    judges = [t for t in (time_engine(e, bench[:judge_cases]) for e in ("pinocchio", "mujoco", "mujoco-sim")) if t]
    lines = [
        f"machine: {platform.machine()}, {platform.processor() or 'cpu'}, Python {platform.python_version()}, "
        f"numpy {np.__version__}",
        "",
        "| what | positions | seconds | positions/s | µs/position | speed relative to Pinocchio |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    pin = next((t for t in judges if t.label.startswith("pinocchio")), None)
    for t in (kin, full, *judges):
        comparable = pin is not None and t.label.endswith("full analysis")  # like for like
        ratio = f"{pin.micro_per_position / t.micro_per_position:.2g}×" if comparable else ""
        lines.append(f"| {t.label} | {t.positions} | {t.seconds:.3f} | {t.rate:,.0f} | {t.micro_per_position:.2f} | {ratio} |")
    lines += ["", f"peak memory after the full analysis of {full.positions} positions: {mem_after_full:.0f} MiB"]
    if big:
        t, mem = streaming_run(big, CHUNK_POSITIONS)
        lines.append(f"streaming {t.positions} positions: {t.seconds:.1f} s ({t.rate:,.0f}/s), peak memory {mem:.0f} MiB")
    if profile:
        lines += ["", "Profile of the full analysis (100 cases, by own time):", "```",
                  profile_inhouse(bench[:100]).strip(), "```"]
    return "\n".join(lines)
