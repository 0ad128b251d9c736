"""The sweep report: JSON, Markdown with failure categories, time-to-goal plot.

``navstack bench navigation --scenarios N --report DIR`` writes ``DIR/sweep.json`` (the
bench result: metrics, one row per scenario, notes), ``DIR/sweep.md`` (summary, success
per fault, failure categories, every failed scenario with its reason) and
``DIR/time_to_goal.png`` (histogram of the simulated time to reach the goal of the
scenarios that succeeded, one series per fault).
"""

from __future__ import annotations

import json
from collections import Counter, defaultdict
from collections.abc import Sequence
from pathlib import Path

from navstack.benchmarks.common import BenchResult
from navstack.benchmarks.navigation import Outcome, failure_category, failure_reason


def _fault_name(o: Outcome) -> str:
    return o.scenario.fault.kind if o.scenario.fault is not None else "nominal"


def chaos_metrics(outcomes: Sequence[Outcome]) -> dict[str, float]:
    """Success rate per fault kind and the number of failures without a reason."""
    by: dict[str, list[Outcome]] = defaultdict(list)
    for o in outcomes:
        by[_fault_name(o)].append(o)
    out = {f"success_rate_{k}": sum(o.passed for o in v) / len(v)
           for k, v in sorted(by.items())}
    out["failures"] = float(sum(not o.passed for o in outcomes))
    out["failures_without_reason"] = float(sum(not o.passed and not failure_reason(o)
                                               for o in outcomes))
    return out


def failure_categories(outcomes: Sequence[Outcome]) -> Counter[str]:
    return Counter(failure_category(o) for o in outcomes if not o.passed)


def markdown(result: BenchResult, outcomes: Sequence[Outcome]) -> str:
    """The Markdown report."""
    m = result.metrics
    lines = [f"# navstack bench {result.suite}", "",
             f"{len(outcomes)} scenarios; success rate {m['success_rate']:.3f}; "
             f"collisions {m['collisions']:g}; real-time factor "
             f"{m['real_time_factor']:.1f}; wall {m.get('sweep_wall_s', 0.0):.1f} s.", ""]
    lines += [f"- {note}" for note in result.notes if not note.startswith("not passed")]
    lines += ["", "## Success per fault", "", "| fault | scenarios | passed | rate |",
              "| --- | ---: | ---: | ---: |"]
    by: dict[str, list[Outcome]] = defaultdict(list)
    for o in outcomes:
        by[_fault_name(o)].append(o)
    for kind, group in sorted(by.items()):
        ok = sum(o.passed for o in group)
        lines.append(f"| {kind} | {len(group)} | {ok} | {ok / len(group):.3f} |")
    cats = failure_categories(outcomes)
    lines += ["", "## Failure categories", ""]
    if not cats:
        lines.append("None: every scenario passed.")
    else:
        lines += ["| category | count |", "| --- | ---: |"]
        lines += [f"| {cat} | {n} |" for cat, n in cats.most_common()]
        lines += ["", "## Failed scenarios", "", "| scenario | fault | status | reason |",
                  "| --- | --- | --- | --- |"]
        for o in outcomes:
            if not o.passed:
                fault = o.scenario.fault.label() if o.scenario.fault else "nominal"
                reason = (failure_reason(o) or "(no reason given)").replace("|", "/")
                lines.append(f"| {o.scenario.name} | {fault} | {o.status} | {reason} |")
    return "\n".join(lines) + "\n"


def plot_time_to_goal(outcomes: Sequence[Outcome], path: Path) -> None:
    """Histogram of the time to goal [s] of the successful scenarios, per fault."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    by: dict[str, list[float]] = defaultdict(list)
    for o in outcomes:
        if o.status == "SUCCEEDED":
            by[_fault_name(o)].append(o.sim_time_s)
    fig, ax = plt.subplots(figsize=(7, 4))
    if by:
        names = sorted(by)
        ax.hist([by[k] for k in names], bins=20, stacked=True, label=names)
        ax.legend(fontsize=8)
    ax.set_xlabel("time to goal [s, simulated]")
    ax.set_ylabel("scenarios")
    ax.set_title(f"time to goal, {sum(len(v) for v in by.values())} successful runs")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def write_report(result: BenchResult, outcomes: Sequence[Outcome], folder: Path
                 ) -> list[Path]:
    """Write ``sweep.json``, ``sweep.md`` and ``time_to_goal.png`` into ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    js, md, png = folder / "sweep.json", folder / "sweep.md", folder / "time_to_goal.png"
    js.write_text(json.dumps(result.to_json(), indent=1, default=str) + "\n")
    md.write_text(markdown(result, outcomes))
    plot_time_to_goal(outcomes, png)
    return [js, md, png]
