"""One self-contained HTML report: figures embedded, tables inline, no external resources.

:func:`write_report` writes ``report.html`` into a directory from a list of
:class:`Section`. PNG figures are embedded as base64 ``data:`` URIs, tables are rendered by
:func:`hvacflex.report.tables.to_html`, configuration goes in ``<pre>`` blocks and text is
escaped. The page loads nothing from elsewhere and needs no JavaScript, so it can be mailed or
archived as one file. The CSV behind a figure (``<figure>.csv``, see
:mod:`hvacflex.report.plots`) is linked from its caption when the page is written into a
folder that holds it (``link_base``: the report's folder; the link is relative to it). A table
shows the columns that decide in view; the rest of a wide table (``Section.table_details``)
goes into an expandable ``<details>`` below it, its row labels repeated; what is still wider
than the page scrolls sideways inside its own box. A table whose index is pandas' default
0…n shows no index column.
"""

from __future__ import annotations

import base64
import html
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from hvacflex.errors import InputError
from hvacflex.report.tables import to_html
from hvacflex.version import atomic_write_text

REPORT_FILENAME = "report.html"
"""Name of the report written by :func:`write_report`."""

_STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; max-width: 70rem;
       margin: 2rem auto; padding: 0 1rem; color: #222; line-height: 1.45; }
h1 { border-bottom: 2px solid #444; padding-bottom: .3rem; }
h2 { margin-top: 2.5rem; border-bottom: 1px solid #bbb; }
nav ol { columns: 2; }
figure { margin: 1.5rem 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: .9rem; color: #555; }
table.hvacflex { border-collapse: collapse; margin: 1rem 0; font-size: .9rem; }
table.hvacflex caption { text-align: left; font-weight: 600; padding-bottom: .3rem; }
table.hvacflex th, table.hvacflex td { border: 1px solid #ccc; padding: .25rem .6rem; }
table.hvacflex thead th { background: #f0f0f0; }
table.hvacflex tbody th { text-align: left; font-weight: normal; background: #fafafa; }
table.hvacflex td.num { text-align: right; font-variant-numeric: tabular-nums; }
div.table-scroll { overflow-x: auto; max-width: 100%; }
details.table-detail { margin: -.5rem 0 1rem; }
details.table-detail summary { cursor: pointer; color: #345; font-size: .9rem; }
pre { background: #f6f6f6; padding: .8rem; overflow-x: auto; font-size: .85rem; }
footer { margin-top: 3rem; font-size: .8rem; color: #777; }
"""


@dataclass(frozen=True)
class Section:
    """One section of the report, rendered in the order: paragraphs, figures, tables, code.

    Attributes
    ----------
    title : section heading.
    paragraphs : plain-text paragraphs (escaped). A paragraph whose every line starts with
        ``"- "`` becomes a bulleted list.
    figures : PNG files to embed.
    tables : DataFrames to render (index as first column).
    code : preformatted text (e.g. the run configuration as TOML), or None.
    figure_captions : captions for ``figures``, by position (what the figure shows); default
        the file name.
    table_captions : captions for ``tables``, by position; default none.
    links : (text, target) pairs shown as a list of links after the paragraphs: an anchor of
        this page (``#…``) or a relative or absolute URL.
    table_details : for ``tables``, by position: the columns shown not in the table but in an
        expandable detail under it (its row labels repeated); default none (every column in
        the table).
    table_labels : for ``tables``, by position: column → header (human, with units), over
        :data:`hvacflex.report.tables.LABELS`; default none.
    """

    title: str
    paragraphs: list[str] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)
    tables: list[pd.DataFrame] = field(default_factory=list)
    code: str | None = None
    figure_captions: list[str] = field(default_factory=list)
    table_captions: list[str] = field(default_factory=list)
    links: list[tuple[str, str]] = field(default_factory=list)
    table_details: list[Sequence[str]] = field(default_factory=list)
    table_labels: list[Mapping[str, str]] = field(default_factory=list)


def png_data_uri(path: str | Path) -> str:
    """The PNG file at ``path`` as a ``data:image/png;base64,...`` URI.

    Raises
    ------
    InputError
        When the file is missing or not a PNG.
    """
    file = Path(path)
    if not file.is_file():
        raise InputError("figure file not found", source=file, hint="write the figure first")
    data = file.read_bytes()
    if not data.startswith(b"\x89PNG\r\n\x1a\n"):
        raise InputError("figure is not a PNG file", source=file, hint="save figures as PNG")
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def section_anchor(title: str, index: int) -> str:
    """The ``id`` of the ``index``-th (1-based) section titled ``title`` in a page."""
    slug = re.sub(r"[^a-z0-9]+", "-", title.lower()).strip("-")
    return f"s{index}-{slug}" if slug else f"s{index}"


def _paragraph_html(text: str) -> str:
    lines = [line.strip() for line in text.strip().splitlines() if line.strip()]
    if lines and all(line.startswith("- ") for line in lines):
        items = "".join(f"<li>{html.escape(line[2:])}</li>" for line in lines)
        return f"<ul>{items}</ul>"
    return f"<p>{html.escape(text.strip())}</p>"


def _figure_html(path: Path, caption: str | None, link_base: Path | None) -> str:
    text = caption if caption is not None else path.stem.replace("_", " ")
    csv = path.with_suffix(".csv")
    data_note = ""
    if link_base is not None and csv.is_file():
        href = Path(os.path.relpath(csv.resolve(), link_base.resolve())).as_posix()
        data_note = f' Data: <a href="{html.escape(href, quote=True)}">{html.escape(csv.name)}</a>.'
    return (
        f'<figure><img src="{png_data_uri(path)}" alt="{html.escape(text, quote=True)}">'
        f"<figcaption>{html.escape(text)}{data_note}</figcaption></figure>"
    )


def _shown_table(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` with its first column as index when its index is pandas' default 0…n."""
    default = isinstance(table.index, pd.RangeIndex) and table.index.name is None
    if default and len(table.columns) > 0:
        return table.set_index(table.columns[0])
    return table


def _table_html(
    table: pd.DataFrame, caption: str | None, details: Sequence[str], labels: Mapping[str, str]
) -> str:
    """The table with the columns ``details`` moved into an expandable ``<details>`` below,
    which repeats the row label and the table's first column (e.g. rank and controller)."""
    hidden = [column for column in table.columns if column in set(details)]
    shown = table.drop(columns=hidden)
    main = to_html(shown, caption=caption, labels=labels)
    html_text = f'<div class="table-scroll">{main}</div>'
    if hidden:
        rest = to_html(table[[*shown.columns[:1], *hidden]], labels=labels)
        html_text += (
            f'<details class="table-detail"><summary>More columns ({len(hidden)})</summary>'
            f'<div class="table-scroll">{rest}</div></details>'
        )
    return html_text


def _links_html(links: Sequence[tuple[str, str]]) -> str:
    items = "".join(
        f'<li><a href="{html.escape(target, quote=True)}">{html.escape(text)}</a></li>'
        for text, target in links
    )
    return f"<ul>{items}</ul>"


def _section_html(section: Section, anchor: str, link_base: Path | None) -> str:
    parts = [f'<section id="{anchor}">', f"<h2>{html.escape(section.title)}</h2>"]
    parts += [_paragraph_html(text) for text in section.paragraphs]
    if section.links:
        parts.append(_links_html(section.links))
    for i, figure in enumerate(section.figures):
        caption = section.figure_captions[i] if i < len(section.figure_captions) else None
        parts.append(_figure_html(Path(figure), caption, link_base))
    for i, table in enumerate(section.tables):
        caption = section.table_captions[i] if i < len(section.table_captions) else None
        details = section.table_details[i] if i < len(section.table_details) else ()
        labels = section.table_labels[i] if i < len(section.table_labels) else {}
        parts.append(_table_html(_shown_table(table), caption, details, labels))
    if section.code is not None:
        parts.append(f"<pre><code>{html.escape(section.code)}</code></pre>")
    parts.append("</section>")
    return "\n".join(parts)


def render_report(*, title: str, sections: Sequence[Section], link_base: Path | None = None) -> str:
    """The report as one HTML5 document (see :func:`write_report`); figure captions link
    their CSV relative to ``link_base`` (None: no links)."""
    from hvacflex import __version__

    anchors = [section_anchor(section.title, i + 1) for i, section in enumerate(sections)]
    toc = "".join(
        f'<li><a href="#{anchor}">{html.escape(section.title)}</a></li>'
        for anchor, section in zip(anchors, sections, strict=True)
    )
    body = "\n".join(
        _section_html(section, anchor, link_base)
        for anchor, section in zip(anchors, sections, strict=True)
    )
    return (
        "<!DOCTYPE html>\n"
        '<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<title>{html.escape(title)}</title>\n<style>{_STYLE}</style>\n</head>\n<body>\n"
        f"<h1>{html.escape(title)}</h1>\n"
        f"<nav><h2>Contents</h2><ol>{toc}</ol></nav>\n"
        f"{body}\n"
        f"<footer>Generated by hvacflex {html.escape(__version__)}.</footer>\n"
        "</body>\n</html>\n"
    )


def write_report(out_dir: str | Path, *, title: str, sections: Sequence[Section]) -> Path:
    """Write ``report.html`` into ``out_dir`` (created if needed) and return its path.

    The file is self-contained: figures are embedded as base64 PNG data URIs, tables and
    text are inline, styles are in a ``<style>`` element, and there is no script. Figure
    captions link the CSV beside each figure, relative to ``out_dir``.

    Raises
    ------
    InputError
        When a figure file is missing or not a PNG.
    """
    directory = Path(out_dir)
    directory.mkdir(parents=True, exist_ok=True)
    document = render_report(title=title, sections=sections, link_base=directory)
    return atomic_write_text(directory / REPORT_FILENAME, document)
