"""Speed of the in-house solver in one run beside a compiled closed-form yardstick, Pinocchio and MuJoCo.

Not a test: timings depend on the machine.  ``dualmech benchmark`` prints a Markdown
table, or writes it as the page ``docs/performance.md`` (``-o``), with the command that produced it,
so the page always holds one run's current figures.  Every figure is
the median of ``repeats`` runs after one warm-up run (compilation, caches), with the
process CPU time (all threads) beside the wall time.  Every engine solves the same
seeded random cases (the thesis example with random offset, twist and axial shift).

* **dualmech** -- the compiled kernel (:mod:`dualmech.models.slider_crank.kernel`),
  in-process, all cores; and ``dualmech solve`` of one long case streamed into Parquet
  (:func:`dualmech.validation.solve_output.stream_solve`, start-up excluded).
* **closed-form yardstick** -- :mod:`dualmech.validation.benchmark.yardstick`, the same outputs in
  closed form, compiled, on the same cores: the machine's limit for this mechanism.  Its inputs
  (crank states, case arrays) are made before the timing: ~80 µs of Python a case, a quarter of
  the closed form's own time on the 1° grid, is not the machine's limit.
* **dualmech loop kernel** -- the generic loop engine compiled (:mod:`dualmech.core.kernel.loop_engine`)
  on the slider crank's joint table (:func:`dualmech.models.loop.presets.slider_crank_table`): some of the
  cases, and one long case (a tenth of the Parquet row's positions), through ``analyze_loop``; and
  ``dualmech solve`` of such a table of as many positions as the slider crank's Parquet row into Parquet
  (:func:`dualmech.validation.solve_output.stream_loop_solve`: chunk by chunk, the table's every column
  with the closure condition and the status rule), as ``solve -o`` does.
* **Pinocchio, MuJoCo, Exudyn** -- best-effort drivers: the model built once per case outside the
  timing (Pinocchio: :func:`~dualmech.validation.judges.pinocchio_slider_crank.engine.solve` with a prebuilt
  model; MuJoCo rigid: the per-position loop of
  :func:`~dualmech.validation.judges.mujoco_slider_crank.engine.solve_case` on a prebuilt model).  Beside the
  driver's total, the time inside the engine: the seconds spent in the library's own
  functions (:func:`library_time`), measured in separate runs so that the timers do not
  slow the total.  The Exudyn judge (:func:`time_exudyn`) has nothing to prebuild: its systems are
  built inside its runs; it runs on fewer cases (``exudyn_cases``), ~20 s each.
* **the main job** -- ``dualmech validate`` of the default matrix with its report, as a user runs it: a
  fresh process into a fresh folder each time (:func:`~dualmech.validation.benchmark.main_job.time_main_job`),
  its wall time and the CPU time of the process and its workers.
"""

from __future__ import annotations

import contextlib
import datetime
import platform
import statistics
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Callable, Iterator

import numpy as np

from dualmech.models.case import Case, load_case
from dualmech.models.slider_crank.kernel import _pool, case_arrays, solve_cases, threads
from dualmech.validation.benchmark.main_job import time_main_job
from dualmech.validation.solve_output import stream_loop_solve, stream_solve

#: Crank-state fields in the kernel's order.
CRANK_FIELDS = ("theta", "s", "theta_dot", "s_dot", "theta_ddot", "s_ddot")


@dataclass(frozen=True)
class Timing:
    """One figure: medians over the repetitions of wall and process CPU seconds (``engine``: the part
    spent inside the engine, where the driver can tell)."""

    label: str
    positions: int
    wall: float
    cpu: float
    engine: float | None = None

    @property
    def rate(self) -> float:
        return self.positions / self.wall

    def row(self, yardstick: "Timing | None") -> str:
        ratio = (
            f"{(yardstick.wall / yardstick.positions) / (self.wall / self.positions):.1%}"
            if yardstick
            else ""
        )
        engine = f"{1e6 * self.engine / self.positions:.2f}" if self.engine is not None else ""
        return (
            f"| {self.label} | {self.positions:,} | {self.wall:.3f} | {self.cpu:.3f} | {self.rate:,.0f} | "
            f"{1e6 * self.wall / self.positions:.2f} | {engine} | {ratio} |"
        )


def measure(label: str, positions: int, run: Callable[[], object], repeats: int,
            inside: Callable[[], float] | None = None) -> Timing:
    """Median wall and CPU time of ``run()`` over ``repeats`` runs after a warm-up run; ``inside``, a run
    that returns the seconds it spent inside the engine, is repeated as often after them (its median is
    the figure's ``engine``)."""
    run()
    walls, cpus = [], []
    for _ in range(repeats):
        w, c = time.perf_counter(), time.process_time()
        run()
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - c)
    engine = statistics.median(inside() for _ in range(repeats)) if inside is not None else None
    return Timing(label, positions, statistics.median(walls), statistics.median(cpus), engine)


@contextlib.contextmanager
def library_time(module: ModuleType, like: Callable) -> Iterator[list[float]]:
    """While inside, every function of ``module`` of the type of ``like`` (the library's own compiled
    functions, not its classes) is timed: the seconds spent in them add up in the one-element list
    yielded.  Attribute reads of the library's objects are not calls and are not counted."""
    spent = [0.0]

    def timed(function: Callable) -> Callable:
        def call(*args: object, **kwargs: object) -> object:
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                spent[0] += time.perf_counter() - start

        return call

    functions = {n: f for n, f in vars(module).items() if type(f) is type(like)}
    for name, function in functions.items():
        setattr(module, name, timed(function))
    try:
        yield spent
    finally:
        for name, function in functions.items():
            setattr(module, name, function)


def random_cases(count: int, step_deg: float = 1.0, seed: int = 0) -> list[Case]:
    """``count`` seeded variations of the thesis example (a4, alpha4, S1 within assemblable ranges)."""
    rng = np.random.default_rng(seed)
    base = load_case("a4-30-s1-3.5")
    return [
        base.with_values(
            {
                "name": f"bench-{i}",
                "geometry.slider_offset": float(rng.uniform(0.0, 30.0)),
                "geometry.slider_twist_deg": float(rng.uniform(240.0, 300.0)),
                "geometry.crank_axial_shift": float(rng.uniform(0.0, 5.0)),
                "motion.angles_deg": {"start": 0.0, "stop": 360.0, "step": step_deg},
            }
        )
        for i in range(count)
    ]


def _positions(cases: list[Case]) -> int:
    return sum(len(c.motion.angles_deg) for c in cases)


def closed_form_inputs(cases: list[Case]) -> list[tuple]:
    """The yardstick's arguments per case (crank states, geometry, bodies, loads, an output array): made
    before the timing, so the yardstick's figure is the compiled closed form alone, the machine's limit."""
    from dualmech.validation.benchmark.yardstick import YARDSTICK_COLUMNS

    out = []
    for case in cases:
        state = case.own_crank_states()
        crank = np.stack([getattr(state, f) for f in CRANK_FIELDS])
        geo, (mass, com, inertia, gravity, torque, load) = case_arrays([case])
        out.append((crank, geo[0], mass[0], com[0], inertia[0], gravity[0], torque[0], load[0],
                    np.empty((len(YARDSTICK_COLUMNS), crank.shape[1]))))
    return out


def run_closed_form(inputs: list[tuple]) -> list[np.ndarray]:
    """The yardstick over prepared ``inputs`` (:func:`closed_form_inputs`), cases spread over the kernel's
    threads; its outputs ``(26, n)`` per case."""
    from dualmech.validation.benchmark.yardstick import closed_form_range

    def one(args: tuple) -> np.ndarray:
        closed_form_range(0, args[0].shape[1], *args)
        return args[-1]

    return list(_pool().map(one, inputs))


def closed_form(cases: list[Case]) -> list[np.ndarray]:
    """The yardstick's outputs ``(26, n)`` per case."""
    return run_closed_form(closed_form_inputs(cases))


def agreement(cases: list[Case]) -> float:
    """Largest difference of the kernel from the yardstick over ``cases``, relative to each column's peak
    over the case's force (or moment, or kinematic) columns."""
    from dualmech.validation.benchmark.yardstick import YARDSTICK_COLUMNS

    worst = 0.0
    for case, ref, table in zip(cases, closed_form(cases), solve_cases(cases)):
        got = np.stack([table[c] for c in YARDSTICK_COLUMNS])
        for rows in ((0,), (1,), (2,), tuple(range(3, 26))):
            peak = np.nanmax(np.abs(ref[list(rows)]))
            worst = max(worst, float(np.nanmax(np.abs(got[list(rows)] - ref[list(rows)])) / peak))
    return worst


def time_pinocchio(cases: list[Case], repeats: int) -> Timing:
    """Pinocchio with its model built once per case outside the timing; engine = time in Pinocchio's
    functions."""
    import pinocchio as pin

    from dualmech.validation.judges.pinocchio_slider_crank import engine as pe
    from dualmech.validation.judges.pinocchio_slider_crank.model import build_model

    models = [build_model(c) for c in cases]

    def run() -> None:
        for case, pm in zip(cases, models):
            pe.to_table(case, pe.solve(case, pm)[0])

    return measure("Pinocchio full analysis (model prebuilt)", _positions(cases), run, repeats,
                   _inside(pin, pin.forwardKinematics, run))


def time_mujoco(cases: list[Case], repeats: int) -> Timing:
    """MuJoCo rigid: the per-position driver loop on a model built once per case outside the timing;
    engine = time in MuJoCo's functions."""
    import mujoco

    from dualmech.validation.judges.mujoco_slider_crank import engine as me

    loops = [me.build(c) for c in cases]

    def run() -> None:
        for case, lp in zip(cases, loops):
            state = case.own_crank_states()
            mode, given = me._given(case)
            fields = [getattr(state, f) for f in CRANK_FIELDS]
            warm = False
            for i in range(len(state)):
                pos = me.solve_position(lp, tuple(float(f[i]) for f in fields), mode, given, warm)
                warm = pos.status in ("ok", "dead_centre")

    return measure("MuJoCo rigid full analysis (model prebuilt)", _positions(cases), run, repeats,
                   _inside(mujoco, mujoco.mj_step, run))


def time_exudyn(cases: list[Case], repeats: int) -> Timing:
    """The Exudyn judge on the slider crank (``dualmech solve --engine exudyn``:
    :func:`~dualmech.validation.judges.presets.slider_crank.solve_case`): nothing to prebuild, its
    systems are built inside each of its runs (a run's drive law is part of its system) and the case's
    joint table in microseconds; no time inside the engine (each run is one library call with the judge's
    Python in it: the law and the read-out at every step)."""
    from dualmech.validation.engines import run_engine

    def run() -> None:
        for case in cases:
            run_engine("exudyn", case)

    return measure("Exudyn judge full analysis (its runs build their systems)", _positions(cases), run,
                   repeats)


def _inside(module: ModuleType, like: Callable, run: Callable[[], None]) -> Callable[[], float]:
    """A run of ``run`` that returns the seconds spent in ``module``'s functions (:func:`library_time`)."""
    def timed_run() -> float:
        with library_time(module, like) as spent:
            run()
        return spent[0]

    return timed_run


def as_joint_table(cases: list[Case]) -> list[tuple]:
    """Each case as the slider crank's joint table with its start pose (the kernel's ``S4`` at the first
    angle), for :func:`~dualmech.models.loop.engine.analyze_loop`."""
    from dualmech.models.loop.presets import slider_crank_start, slider_crank_table

    first = solve_cases([c.with_values({"motion.angles_deg": {"start": 0.0, "stop": 1.0, "step": 1.0}})
                         for c in cases])
    return [(slider_crank_table(c), slider_crank_start(c, t["S4"][0])) for c, t in zip(cases, first)]


def time_loop_kernel(cases: list[Case], positions: int, repeats: int) -> list[Timing]:
    """The generic loop engine, compiled (:func:`dualmech.models.loop.engine.analyze_loop`), on the slider
    crank as a joint table (:func:`as_joint_table`, outside the timing): ``cases`` one call each, and one case
    of ``positions`` crank angles."""
    from dualmech.models.loop.engine import analyze_loop

    long = random_cases(1, step_deg=360.0 / positions, seed=2)
    prepared = {"cases": as_joint_table(cases), "long": as_joint_table(long)}

    def run(label: str) -> Callable[[], object]:
        return lambda: [analyze_loop(mech, start) for mech, start in prepared[label]]

    n = len(long[0].motion.angles_deg)
    return [measure(f"dualmech loop kernel, the slider crank as a joint table ({len(cases)} cases)",
                    _positions(cases), run("cases"), repeats),
            measure(f"dualmech loop kernel, one case ({n:,} positions)", n, run("long"), repeats)]


def time_solve_parquet(positions: int, repeats: int, joint_table: bool = False) -> Timing:
    """``dualmech solve`` of one case of ``positions`` crank angles into Parquet, streamed chunk by chunk
    (start-up excluded); ``joint_table``: the case as the slider crank's joint table (:func:`as_joint_table`,
    outside the timing; :func:`~dualmech.validation.solve_output.stream_loop_solve`)."""
    from dualmech.models.loop.presets import started

    case = random_cases(1, step_deg=360.0 / positions, seed=2)[0]
    n, table = len(case.motion.angles_deg), started(*as_joint_table([case])[0]) if joint_table else None
    what = "the slider crank as a joint table" if joint_table else "one case"
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out.parquet"
        solve = (lambda: stream_loop_solve(table, out)) if joint_table else (lambda: stream_solve(case, out))
        return measure(f"dualmech solve, {what} into Parquet ({n:,} positions)", n, solve, repeats)


def performance_page(table: str, command: str) -> str:
    """``docs/performance.md``: the benchmark's ``table`` (Markdown) with the command that produced it."""
    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return (f"# Performance\n\nCurrent figures: one run of `{command}` on {when}, written by that "
            "command; run it again to regenerate this page. What each row measures: the module docstring of "
            "`validation/benchmark/rows.py`; the ratio column is each row's speed over the compiled "
            "closed-form yardstick's, the machine's limit for the mechanism.\n\n" + table + "\n")


def run_benchmark(cases: int = 1000, judge_cases: int = 5, big: int = 2_000_000, repeats: int = 3,
                  main_job: int = 0, loop_cases: int = 50, exudyn_cases: int = 1) -> str:
    """Run the benchmark and return a Markdown report (``main_job`` > 0: that many timed runs of the main
    job too; ``loop_cases``: the generic loop kernel on that many of the cases and on a tenth of ``big``
    positions, :func:`time_loop_kernel`; ``exudyn_cases``: the Exudyn judge on that many of the judges'
    cases, :func:`time_exudyn`: ~20 s a case of 360 positions, each of the runs)."""
    bench = random_cases(cases)
    n = _positions(bench)
    prepared = closed_form_inputs(bench)
    yard = measure(
        "closed-form yardstick, compiled (this machine's limit for the mechanism)",
        n,
        lambda: run_closed_form(prepared),
        repeats,
    )
    rows = [
        measure("dualmech full analysis (compiled kernel)", n, lambda: solve_cases(bench), repeats),
        yard,
    ]
    if big:
        rows.append(time_solve_parquet(big, repeats))
    if loop_cases:
        rows += time_loop_kernel(bench[:loop_cases], max(big // 10, 360), repeats)
        rows += [time_solve_parquet(big, repeats, joint_table=True)] if big else []
    judges = bench[:judge_cases]
    timers = ((time_pinocchio, judges), (time_mujoco, judges), (time_exudyn, judges[:exudyn_cases]))
    for timer, chosen in timers:
        if not chosen:
            continue
        try:
            rows.append(timer(chosen, repeats))
        except ImportError:
            continue
    lines = [
        f"machine: {platform.machine()}, {threads()} threads, Python {platform.python_version()}, "
        f"numpy {np.__version__}; median of {repeats} runs after a warm-up",
        "",
        "| what | positions | wall s | CPU s | positions/s | µs/position (wall) | µs/position in engine "
        "| speed / yardstick |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    lines += [t.row(yard) for t in rows]
    lines += [
        "",
        f"kernel vs yardstick on 20 cases: largest difference {agreement(bench[:20]):.1e} of the peak",
    ]
    if main_job:
        lines += ["", *time_main_job(main_job).lines()]
    return "\n".join(lines)
