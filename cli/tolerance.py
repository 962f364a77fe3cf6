"""``dualmech tolerance``: distributions of the stroke and joint loads under manufacturing tolerances.

A thin shell over :func:`dualmech.validation.api.tolerance_study` (``dualmech.tolerance_study``);
``docs/conventions.md`` ("Tolerance analysis") defines the SPEC, every column and the summary.
Exit codes: 0 every spot check passed; 1 a judge disagreed, or the exact sensitivities disagree with
central differences of the solver (named on stderr); 2 bad input.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from dualmech.cli.errors import one_line_errors


def _print_summary(summary: dict) -> None:
    y = summary.get("yield")
    if y:
        click.echo(f"yield {y['value']:.4f} (95 % Wilson {y['ci'][0]:.4f}..{y['ci'][1]:.4f}), "
                   f"{y['ok']} of {y['n']} designs assemble over the whole cycle")
    click.echo(f"{'output':20s} {'mean':>13s} {'std':>11s} {'linear std':>11s} {'p99':>13s}")
    for name in summary["nominal"]:
        o = summary["outputs"].get(name, {})
        lin = (summary.get("linear_std") or {}).get(name)
        cells = [o.get("mean"), o.get("std"), lin, o.get("p99")]
        click.echo(f"{name:20s} " + " ".join(f"{'-' if v is None else format(v, '.6g'):>{w}s}"
                                            for v, w in zip(cells, (13, 11, 11, 13))))
    for name, level in (summary.get("round_off") or {}).items():
        click.echo(f"{name}: 0 in every design (the solver's round-off, at most {level:.1e}): not a load")


@click.command()
@click.argument("case")
@click.option("--spec", "spec_file", required=True, type=click.Path(dir_okay=False),
              help="The tolerance SPEC (TOML): a distribution per varied case key.")
@click.option("-n", "n", default=1000, show_default=True, help="Monte Carlo designs.")
@click.option("--seed", default=0, show_default=True, help="Seed of the samples (same seed: same samples).")
@click.option("--method", type=click.Choice(["mc", "linear", "both"]), default="both", show_default=True)
@click.option("-o", "--output", "outdir", default="runs/tolerance", show_default=True,
              type=click.Path(file_okay=False), help="Study folder (samples, summary, report); resumable.")
@click.option("--jobs", default=1, show_default=True, help="Processes solving chunks of designs.")
@click.option("--scheduler", default=None, help="Dask scheduler address (tcp://127.0.0.1:8786).")
@click.option("--judge-samples", default=5, show_default=True,
              help="Sampled designs re-solved by Pinocchio and MuJoCo rigid.")
@one_line_errors
def tolerance(case: str, spec_file: str, n: int, seed: int, method: str, outdir: str, jobs: int,
              scheduler: str | None, judge_samples: int) -> None:
    """Tolerance study of CASE: Monte Carlo of SPEC and exact sensitivities, judged and reported."""
    from dualmech.validation.api import tolerance_study

    done = tolerance_study(case, spec_file, n=n, seed=seed, method=method, outdir=outdir, jobs=jobs,
                           scheduler=scheduler, judge_samples=judge_samples)
    summary, files = done.summary, done.files
    _print_summary(summary)
    click.echo(f"wrote {', '.join(str(Path(outdir) / f) for f in files)}")
    failed = [s for s in summary["judges"] if not s["passed"]]
    for s in failed:
        click.echo(f"FAIL: {s['engine']} disagrees on {s['design']}: {'; '.join(s['failures'])[:300]}",
                   err=True)
    check = summary["sensitivity_check"]
    if check is not None and not check["passed"]:
        click.echo(f"FAIL: d {check['output']} / d {check['key']} = {check['exact']!r} (exact) against "
                   f"{check['central_difference']!r} (central differences of the solver), "
                   f"{check['worst_ratio']:.3g} x the tolerance", err=True)
    if failed or (check is not None and not check["passed"]):
        sys.exit(1)
    checked = "" if check is None else (f"; sensitivities agree with the solver's differences "
                                        f"(worst {check['worst_ratio']:.2g} of the tolerance)")
    click.echo(f"PASS: {len(summary['judges'])} spot checks (judges agree on every sampled design checked)"
               f"{checked}")
