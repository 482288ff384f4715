"""Tables 2 and 3 in Markdown, with success rates, and the plain verdict per row."""

from __future__ import annotations

import math
from collections.abc import Sequence

from .contenders import DEFAULT_KEY, Contender
from .paper_values import PAPER_MATCHING, PAPER_SECONDS
from .study import Study
from .summary import summaries, table_rows, truth_matching


def _header(contenders: Sequence[Contender], first: str) -> list[str]:
    """The table's header and alignment lines: one column per contender."""
    names = [c.label + (f" ({c.paper_label})" if c.paper_label else "") for c in contenders]
    return [f"| {first} | | " + " | ".join(names) + " |", "|---|---|" + "---:|" * len(names)]


def _avg_std(first: str, means: Sequence[str], stds: Sequence[str]) -> list[str]:
    """The two lines of a table row: means after ``first``, standard deviations below."""
    return [
        f"| {first} | Avg. | " + " | ".join(means) + " |",
        "| | Std. Dev. | " + " | ".join(stds) + " |",
    ]


def _paper_row(
    table: dict[str, tuple[float, float]], contenders: Sequence[Contender], group: str
) -> list[str]:
    """The paper's values of ``group`` under our columns (blank where it has no such method)."""
    cells_mean, cells_std = [], []
    for c in contenders:
        value = table.get(c.paper_label) if c.paper_label else None
        cells_mean.append(f"{value[0]:.4f}" if value else "")
        cells_std.append(f"{value[1]:.4f}" if value else "")
    return _avg_std(f"paper, {group}", cells_mean, cells_std)


def markdown_tables(study: Study, contenders: Sequence[Contender]) -> str:
    """Tables 2 and 3 in the paper's layout, the paper's values below ours, and success rates."""
    stats = summaries(study, contenders)
    rows = table_rows(study)
    counts = {row: stats[(row, contenders[0].key)].pairs for row in rows}
    lines = ["**Matching index Ψ (eq. 31), layout of Table 2**", ""]
    lines += _header(contenders, "Type")
    for row in rows:
        means = [f"{stats[(row, c.key)].psi_mean:.4f}" for c in contenders]
        stds = [f"{stats[(row, c.key)].psi_std:.4f}" for c in contenders]
        pairs = "1 pair" if counts[row] == 1 else f"{counts[row]} pairs"
        lines += _avg_std(f"{row} ({pairs})", means, stds)
    for group in ("Sim.", "Exp."):
        lines += _paper_row(PAPER_MATCHING[group], contenders, group)
    truth = {row: truth_matching(study, row) for row in rows}
    lines += [
        "",
        "Ψ of the true (or reference) transform, the ceiling that rasterisation leaves: "
        + ", ".join(f"{row} {value:.4f}" for row, value in truth.items())
        + ".",
        "",
        "**Time per pair in seconds, layout of Table 3**",
        "",
    ]
    lines += _header(contenders, "Type")
    for row in rows:
        means = [f"{stats[(row, c.key)].seconds_mean:.4f}" for c in contenders]
        stds = [f"{stats[(row, c.key)].seconds_std:.4f}" for c in contenders]
        lines += _avg_std(row, means, stds)
    for group in ("Sim.", "Exp."):
        lines += _paper_row(PAPER_SECONDS[group], contenders, group)
    lines += [
        "",
        "**Success (error within the row's tolerance) / accepted / accepted but wrong "
        "(largest RMS error, in cells, of an accepted result)**",
        "",
    ]
    lines += _header(contenders, "Row (tolerance)")
    for row in rows:
        cells = []
        for c in contenders:
            s = stats[(row, c.key)]
            cells.append(
                f"{s.success:.0%} / {s.accepted:.0%} / {s.accepted_wrong:.0%} "
                f"({s.worst_accepted:.1f})"
            )
        first = stats[(row, contenders[0].key)]
        judged = "" if first.judged == first.pairs else f"; {first.judged} of {first.pairs} judged"
        lines.append(f"| {row} | {study.tolerances[row]}{judged} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def verdict_lines(study: Study, contenders: Sequence[Contender]) -> list[str]:
    """Per row: does the default method beat every baseline on success rate? Stated plainly."""
    stats = summaries(study, contenders)
    lines = []
    for row in table_rows(study):
        ours = stats[(row, DEFAULT_KEY)].success
        if math.isnan(ours):  # no pair of the row could be judged: no verdict
            lines.append(f"* {row}: no pair could be judged against a reference.")
            continue
        rivals = [c for c in contenders if c.key != DEFAULT_KEY]
        level = [c.label for c in rivals if stats[(row, c.key)].success == ours]
        better = [
            f"{c.label} {stats[(row, c.key)].success:.0%}"
            for c in rivals
            if stats[(row, c.key)].success > ours
        ]
        if better:
            lines.append(
                f"* **{row}: the tomographic method does not beat every baseline.** It merges "
                f"{ours:.0%} of the pairs correctly; better: {', '.join(better)}"
                + (f"; as good: {', '.join(level)}" if level else "")
                + "."
            )
        elif level:
            lines.append(
                f"* **{row}: the tomographic method ({ours:.0%}) does not beat every baseline: "
                f"{', '.join(level)} {'does' if len(level) == 1 else 'do'} as well.**"
            )
        else:
            lines.append(f"* {row}: the tomographic method ({ours:.0%}) beats every baseline.")
    return lines
