"""What both report pages (a sweep's, a search's or estimate's) are made of: the HTML
document, its style and pieces (tables, figures, paragraphs, bullets), Markdown
tables, and a run's outcome in words."""

from __future__ import annotations

import base64
import html

from analysis.measures.row_columns import RowCol

CSS = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1300px; color: #222; }
table { border-collapse: collapse; margin: 1em 0; }
th, td { border: 1px solid #ccc; padding: 4px 8px; text-align: left; font-size: 14px; }
th { background: #f2f2f2; }
code { background: #f6f6f6; padding: 1px 4px; }
code.command { white-space: nowrap; }  /* a command to copy: one line */
figure { margin: 1.5em 0; }
img { max-width: 100%; }
img.thumb { width: 320px; max-width: none; }
.warn { background: #fff3cd; border: 1px solid #e0c36c; padding: 6px 10px; }
nav.contents { margin: 0.5em 0 1em; }
"""


def html_document(title: str, body: str) -> str:
    """A self-contained page: ``title`` (plain text) and ``body`` (HTML)."""
    return (f"<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{html.escape(title)}</title><style>{CSS}</style></head>"
            f"<body>{body}</body></html>\n")


def is_warning(line: str) -> bool:
    return line.startswith("WARNING")


def _warn_class(line: str) -> str:
    return ' class="warn"' if is_warning(line) else ""


def table_html(rows: list[list[str]], table_id: str | None = None) -> str:
    head = "".join(f"<th>{html.escape(c)}</th>" for c in rows[0])
    body = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>"
                   for row in rows[1:])
    ident = f' id="{html.escape(table_id)}"' if table_id else ""
    return f"<table{ident}><tr>{head}</tr>{body}</table>"


def figure_html(title: str, png: bytes) -> str:
    data = base64.b64encode(png).decode()
    return (f'<figure><img alt="{html.escape(title)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{html.escape(title)}</figcaption></figure>")


def paragraphs(lines: list[str]) -> str:
    """A paragraph per line, a WARNING marked."""
    return "".join(f"<p{_warn_class(line)}>{html.escape(line)}</p>" for line in lines)


def bullets(lines: list[str]) -> str:
    return ("<ul>" + "".join(f"<li>{html.escape(line)}</li>" for line in lines) + "</ul>"
            if lines else "")


def markdown_table(rows: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(rows[0]) + " |", "|" + "---|" * len(rows[0]),
            *("| " + " | ".join(r) + " |" for r in rows[1:])]


def row_outcome(row: dict) -> str:
    """How a run (a record) ended, in words."""
    if row[RowCol.status] != "ok":
        return f"{row[RowCol.status]}: {row[RowCol.error]}"
    outcome = row.get(RowCol.outcome) or ("collided" if row[RowCol.collision] else "no collision")
    if row[RowCol.collision]:
        outcome += (f" with {row[RowCol.collision_with]} at "
                    f"{row[RowCol.collision_time_s]:.2f} s")
    return outcome
