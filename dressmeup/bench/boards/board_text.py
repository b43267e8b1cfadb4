"""Leaderboards as Markdown, CSV and LaTeX text."""

from __future__ import annotations

import csv
import html
import io
import math
from typing import Any

from dressmeup.bench.boards.board import Column, Leaderboard
from dressmeup.bench.boards.escape import csv_text, latex_text, md_text


def to_markdown(board: Leaderboard) -> str:
    """GitHub-flavoured Markdown table with a caption line."""
    head = ["#", "Method",
            *[c.spec.header() + (f" · {md_text(c.group)}" if c.group else "")
              for c in board.columns], "Failed",
            "Runtime [s/sample]"] + (["vs #1", "Sep."] if board.show_ci else [])
    lines = ["| " + " | ".join(head) + " |",
             "|" + "|".join([":-:", ":--"] + ["--:"] * (len(head) - 2)) + "|"]
    for i, row in enumerate(board.rows):
        cells = [board.rank(i), md_text(board.method_text(row))]
        for c in board.columns:
            t = board.cell(row, c)
            cells.append(f"**{t}**" if i in board.best.get(c.key, ()) else t)
        cells += [f"{row.failed}/{row.items}", board.runtime(row)]
        if board.show_ci:
            cells += [board.versus_leader(i), board.separated(i)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n\n" + html.escape(board.caption(), quote=False) + "\n"

def to_csv(board: Leaderboard) -> str:
    """CSV: numbers in display units (std columns when asked), ``best_in`` lists the
    columns where the row is best."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    head = ["rank", "method"]
    for c in board.columns:
        head.append(c.header())
        if board.show_std:
            head.append(c.header() + " std")
        if board.show_ci:
            head += [c.header() + " ci95 lo", c.header() + " ci95 hi"]
    head += ["failed", "items", "runtime_s_per_sample", "best_in", "comparable",
             "separated_from_next", "schema_version", "pareto", "group",
             "diff_to_leader", "diff_to_leader_lo", "diff_to_leader_hi",
             "separated_from_leader"]
    w.writerow([csv_text(h) for h in head])
    for i, row in enumerate(board.rows):
        rank = board.rank(i)
        vals: list[Any] = [rank if rank != "–" else "", csv_text(row.method)]
        best_in = []
        for c in board.columns:
            mean, std, _ = row.values.get(c.key, (None, None, 0))
            ok = mean is not None and math.isfinite(mean)
            fmt_ = f".{c.spec.digits + 2}f"
            vals.append(f"{c.spec.display(mean):{fmt_}}" if ok else "")
            if board.show_std:
                vals.append(f"{c.spec.display(std):{fmt_}}"
                            if ok and std is not None else "")
            if board.show_ci:
                ci = row.ci.get(c.key)
                vals += ([f"{v:{fmt_}}" for v in sorted(c.spec.display(x) for x in ci)]
                         if ci else ["", ""])
            if i in board.best.get(c.key, ()):
                best_in.append(c.key)
        rt = row.runtime
        sep = row.vs_next
        lead = row.vs_leader
        vals += [row.failed, row.items,
                 "" if rt is None else f"{rt:.4f}", ";".join(best_in),
                 str(bool(row.comparable)).lower(),
                 "" if sep is None else str(bool(board.wins(sep))).lower(),
                 row.schema_version,
                 str(bool(row.pareto)).lower() if board.pareto else "",
                 csv_text(row.group or ""),
                 *(["", "", "", ""] if lead is None else
                   [_disp(board, lead.diff),
                    *sorted([_disp(board, lead.lo), _disp(board, lead.hi)], key=float),
                    str(bool(board.wins(lead))).lower()])]
        w.writerow(vals)
    return buf.getvalue()

def to_latex(board: Leaderboard) -> str:
    """A ``booktabs`` LaTeX table (``\\usepackage{booktabs}``)."""
    esc = latex_text

    def head(c: Column) -> str:
        arrow = r"$\downarrow$" if c.spec.better == "lower" else r"$\uparrow$"
        unit = {"mm²": r"mm$^2$"}.get(c.spec.unit, esc(c.spec.unit))
        h = f"{esc(c.spec.label)} {arrow}" + (f" [{unit}]" if unit else "")
        return h + (f" {esc(c.group)}" if c.group else "")

    cols = "l" + "r" * (len(board.columns) + 2 + 2 * int(board.show_ci))
    lines = [r"\begin{table}[t]", r"\centering", r"\small",
             rf"\begin{{tabular}}{{{cols}}}", r"\toprule",
             " & ".join(["Method", *[head(c) for c in board.columns], "Failed",
                         "Time [s]"] + ([r"vs \#1", "Sep."] if board.show_ci else [])) + r" \\",
             r"\midrule"]
    for i, row in enumerate(board.rows):
        cells = [esc(board.method_text(row)).replace("◆", r"$\diamond$")]
        for c in board.columns:
            t = board.cell(row, c).replace("±", r"$\pm$").replace("–", "--")
            cells.append(rf"\textbf{{{t}}}" if i in board.best.get(c.key, ()) else t)
        cells += [f"{row.failed}/{row.items}", board.runtime(row).replace("–", "--")]
        if board.show_ci:
            cells += [board.versus_leader(i).replace("–", "--"),
                      board.separated(i).replace("–", "--")]
        lines.append(" & ".join(cells) + r" \\")
    lines += [r"\bottomrule", r"\end{tabular}",
              rf"\caption{{{esc(board.caption(ascii_only=True))}}}".replace(
                  "◆", r"$\diamond$"),
              rf"\label{{tab:{esc(board.edition.name)}}}", r"\end{table}"]
    return "\n".join(lines) + "\n"


def _disp(board: Leaderboard, x: float) -> str:
    """A primary-column value in display units with two more digits than the table."""
    prim = next((c for c in board.columns if c.key == board.primary), None)
    if prim is None:
        return f"{x:.6g}"
    return f"{prim.spec.display(x):.{prim.spec.digits + 2}f}"
