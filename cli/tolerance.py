"""``dualmech tolerance``: distributions of a mechanism's outputs and loads under manufacturing tolerances.

A thin shell over :func:`dualmech.verbs.tolerance_study` (``dualmech.tolerance_study``);
``docs/conventions.md`` ("Tolerance analysis") defines the SPEC, every column and the summary.
Exit codes: 0 every spot check passed; 1 a judge disagreed, or the exact sensitivities disagree with
central differences of the solver (named on stderr); 2 bad input (a folder that is not dualmech's, or
one another study is writing: :mod:`dualmech.validation.rundir`); 4 a worker process died; 130
interrupted (Ctrl-C; finished chunks are kept and the same command finishes the study).
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import click

from dualmech.cli.errors import on_interrupt, one_line_errors
from dualmech.cli.progress import progress
from dualmech.cli.solve import warn_units
from dualmech.models.tolerance.plan import StudyCase, plan_of, record_of, study_case
from dualmech.validation.arguments import MAX_JOBS


def _print_summary(summary: dict, case: StudyCase) -> None:
    click.echo(f"nominal design: {plan_of(case).masses(case)}")
    y = summary.get("yield")
    if y:
        click.echo(f"yield {y['value']:.4f} (95 % Wilson {y['ci'][0]:.4f}..{y['ci'][1]:.4f}), "
                   f"{y['ok']} of {y['n']} designs assemble over the whole cycle")
    units = summary["units"]
    click.echo(f"{'output':20s} {'unit':>9s} {'mean':>13s} {'std':>11s} {'linear std':>11s} {'p99':>13s}")
    for name in summary["nominal"]:
        o = summary["outputs"].get(name, {})
        lin = (summary.get("linear_std") or {}).get(name)
        cells = [o.get("mean"), o.get("std"), lin, o.get("p99")]
        click.echo(f"{name:20s} {units.get(name, ''):>9s} "
                   + " ".join(f"{'-' if v is None else format(v, '.6g'):>{w}s}"
                              for v, w in zip(cells, (13, 11, 11, 13))))
    for name, level in (summary.get("round_off") or {}).items():
        click.echo(f"{name}: 0 in every design (the solver's round-off, at most {level:.1e}): not a load")
    for name, spread in (summary.get("constant") or {}).items():
        click.echo(f"{name}: constant over the designs (spread {spread:.1e}): no distribution")


@click.command()
@click.argument("case")
@click.option("--spec", "spec_file", required=True, type=click.Path(dir_okay=False),
              help="The tolerance SPEC (TOML): a distribution per varied case key.")
@click.option("-n", "n", default=1000, show_default=True, help="Monte Carlo designs.")
@click.option("--seed", default=0, show_default=True, help="Seed of the samples (same seed: same samples).")
@click.option("--method", type=click.Choice(["mc", "linear", "both"]), default="both", show_default=True)
@click.option("-o", "--output", "outdir", default="runs/tolerance", show_default=True,
              type=click.Path(file_okay=False), help="Study folder (samples, summary, report); resumable.")
@click.option("--jobs", type=click.IntRange(1, MAX_JOBS), default=1, show_default=True,
              help="Processes solving chunks of designs.")
@click.option("--scheduler", default=None, help="Dask scheduler address (tcp://127.0.0.1:8786).")
@click.option("--judge-samples", default=5, show_default=True,
              help="Sampled designs re-solved by Pinocchio and MuJoCo rigid.")
@one_line_errors
def tolerance(case: str, spec_file: str, n: int, seed: int, method: str, outdir: str, jobs: int,
              scheduler: str | None, judge_samples: int) -> None:
    """Tolerance study of CASE (any kind): Monte Carlo of SPEC and sensitivities, judged and reported."""
    from dualmech.models.plausibility import ImplausibleUnitsWarning
    from dualmech.verbs import tolerance_study

    on_interrupt(f"finished chunks are kept in {outdir}; re-run the same command to finish")
    nominal = study_case(case)
    warn_units(record_of(nominal))  # the command's own one line each; the API's same warning is not repeated
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImplausibleUnitsWarning)
        done = tolerance_study(nominal, spec_file, n=n, seed=seed, method=method, outdir=outdir, jobs=jobs,
                               scheduler=scheduler, judge_samples=judge_samples, progress=progress)
    summary, files = done.summary, done.files
    _print_summary(summary, nominal)
    click.echo(f"wrote {', '.join(str(Path(outdir) / f) for f in files)}")
    failed = [s for s in summary["judges"] if not s["passed"]]
    for s in failed:
        click.echo(f"FAIL: {s['engine']} disagrees on {s['design']}: {'; '.join(s['failures'])[:300]}",
                   err=True)
    check = summary["sensitivity_check"]
    if check is not None and not check["passed"]:
        ratio = check["worst_ratio"]  # None in JSON when not finite
        times = "an unbounded multiple of" if ratio is None else f"{ratio:.3g} x"
        click.echo(f"FAIL: d {check['output']} / d {check['key']} = {check['exact']!r} (exact) against "
                   f"{check['central_difference']!r} (central differences of the solver), "
                   f"{times} its bound",
                   err=True)
    if failed or (check is not None and not check["passed"]):
        sys.exit(1)
    checked = "" if check is None else (f"; sensitivities agree with the solver's differences "
                                        f"(worst {check['worst_ratio']:.2g} of their bound)")
    click.echo(f"PASS: {len(summary['judges'])} spot checks (judges agree on every sampled design checked)"
               f"{checked}")
