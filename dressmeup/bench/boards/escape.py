"""Escaping of untrusted text (method names, authors, URLs, categories) in exported tables.

Submission metadata is written by whoever made the submission, so every leaderboard format
escapes it: Markdown renders inline HTML (a ``<script>`` method name would run in a viewer),
spreadsheets run cells that start with ``=``/``+``/``-``/``@`` as formulas (CSV injection),
LaTeX treats ``\\ { } $ & # % _ ^ ~`` as markup, and an HTML link must be a real http(s) URL.

A method name is one line in every format: a submission whose name has a line break or
another control character is refused (:func:`one_line_problem`, at validation, when writing
a submission and when publishing on the server), and the text, CSV and LaTeX cells fold any
run of whitespace into one space (a blank line inside a LaTeX cell would start a paragraph
and break the table), so results written before the rule still render on one line.
"""

from __future__ import annotations

import html
import re
import unicodedata
from urllib.parse import urlsplit

_MD_SPECIAL = re.compile(r"([\\|\[\]])")
_LATEX = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#",
          "_": r"\_", "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}",
          "^": r"\textasciicircum{}", "<": r"\textless{}", ">": r"\textgreater{}"}
_LATEX_RE = re.compile("|".join(re.escape(k) for k in _LATEX))
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r", "\n")


def one_line(text: object) -> str:
    """``text`` on one line: every run of whitespace (line breaks, tabs, Unicode line and
    paragraph separators) becomes one space, and leading and trailing whitespace goes."""
    return " ".join(str(text).split())


def one_line_problem(text: str, field: str) -> str | None:
    """Why ``text`` is not one line of plain text (a line break, a tab or another control
    character, a Unicode line or paragraph separator), naming ``field``; None when it is."""
    bad = sorted({c for c in text if unicodedata.category(c) in ("Cc", "Zl", "Zp")})
    if not bad:
        return None
    return (f"{field} must be one line of text without line breaks or control characters, "
            f"got {text!r} (with {', '.join(repr(c) for c in bad)}); put it on one line")


def md_text(text: object) -> str:
    """Plain text for a Markdown table cell: HTML-escaped (no raw tags reach a renderer),
    ``\\ | [ ]`` backslash-escaped (no broken cells, no injected links), on one line
    (:func:`one_line`)."""
    s = one_line(text)
    return _MD_SPECIAL.sub(r"\\\1", html.escape(s, quote=False))


def csv_text(text: object) -> str:
    """A CSV text cell that a spreadsheet shows as text, never runs as a formula (a leading
    ``= + - @``, tab or CR gets a ``'`` prefix, as OWASP recommends), on one line
    (:func:`one_line`)."""
    s = one_line(text)
    return "'" + s if s.startswith(_FORMULA_START) else s


def latex_text(text: object) -> str:
    """LaTeX text with every special character escaped in one pass (so the braces of
    ``\\textbackslash{}`` are not escaped again), on one line (:func:`one_line`: a blank
    line would start a paragraph inside a table cell)."""
    return _LATEX_RE.sub(lambda m: _LATEX[m.group(0)], one_line(text))


def html_text(text: object) -> str:
    """HTML text or attribute value (quotes escaped)."""
    return html.escape(str(text), quote=True)


def safe_url(url: object) -> str | None:
    """``url`` when it is an absolute http(s) URL with a host and no whitespace, else None
    (then a writer shows the name without a link)."""
    if not isinstance(url, str) or not url or any(c.isspace() for c in url):
        return None
    try:
        parts = urlsplit(url)
    except ValueError:
        return None
    if parts.scheme not in ("http", "https") or not parts.netloc:
        return None
    return url
