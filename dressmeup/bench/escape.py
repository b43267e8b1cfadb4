"""Escaping of untrusted text (method names, authors, URLs, categories) in exported tables.

Submission metadata is written by whoever made the submission, so every leaderboard format
escapes it: Markdown renders inline HTML (a ``<script>`` method name would run in a viewer),
spreadsheets run cells that start with ``=``/``+``/``-``/``@`` as formulas (CSV injection),
LaTeX treats ``\\ { } $ & # % _ ^ ~`` as markup, and an HTML link must be a real http(s) URL.
"""

from __future__ import annotations

import html
import re
from urllib.parse import urlsplit

_MD_SPECIAL = re.compile(r"([\\|\[\]])")
_LATEX = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#",
          "_": r"\_", "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}",
          "^": r"\textasciicircum{}", "<": r"\textless{}", ">": r"\textgreater{}"}
_LATEX_RE = re.compile("|".join(re.escape(k) for k in _LATEX))
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r", "\n")


def md_text(text: object) -> str:
    """Plain text for a Markdown table cell: HTML-escaped (no raw tags reach a renderer),
    ``\\ | [ ]`` backslash-escaped (no broken cells, no injected links), newlines folded."""
    s = " ".join(str(text).split())
    return _MD_SPECIAL.sub(r"\\\1", html.escape(s, quote=False))


def csv_text(text: object) -> str:
    """A CSV text cell that a spreadsheet shows as text, never runs as a formula (a leading
    ``= + - @``, tab or CR gets a ``'`` prefix, as OWASP recommends)."""
    s = str(text)
    return "'" + s if s.startswith(_FORMULA_START) else s


def latex_text(text: object) -> str:
    """LaTeX text with every special character escaped in one pass (so the braces of
    ``\\textbackslash{}`` are not escaped again)."""
    return _LATEX_RE.sub(lambda m: _LATEX[m.group(0)], str(text))


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
