"""The self-contained HTML report: every figure embedded, valid markup, nothing external."""

from __future__ import annotations

import base64
from collections.abc import Callable
from html.parser import HTMLParser
from pathlib import Path

import pandas as pd
import pytest

from hvacflex.errors import InputError
from hvacflex.report import plots, tables
from hvacflex.report.html import Section, png_data_uri, write_report

Factory = Callable[..., pd.DataFrame]
VOID_ELEMENTS = {"meta", "img", "br", "hr", "link", "input", "col", "area", "base", "wbr"}


class StrictChecker(HTMLParser):
    """Records tags, attributes and nesting errors (html.parser itself never raises)."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.tags: list[tuple[str, dict[str, str | None]]] = []
        self.doctype = False

    def handle_decl(self, decl: str) -> None:
        self.doctype = decl.lower() == "doctype html"

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append((tag, dict(attrs)))
        if tag not in VOID_ELEMENTS:
            self.stack.append(tag)

    def handle_endtag(self, tag: str) -> None:
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"unexpected </{tag}> with open {self.stack[-3:]}")
            return
        self.stack.pop()


@pytest.fixture
def report_inputs(tmp_path: Path, make_results: Factory) -> tuple[list[Section], list[Path]]:
    results = {"(a) NMPC": make_results(seed=1, temp_offset_k=0.8), "(b) RMPC": make_results()}
    figures = [
        plots.plot_prices(results["(b) RMPC"], tmp_path / "fig" / "fig2_prices.png"),
        plots.plot_temperatures(results, tmp_path / "fig" / "fig5_temperatures.png"),
        plots.plot_discomfort(results, tmp_path / "fig" / "discomfort.png"),
    ]
    sections = [
        Section(
            title="Figures & <data>",
            paragraphs=["Prices are USEP 2014; the reserve price is synthetic.", "A < B & C"],
            figures=figures[:2],
            figure_captions=["Fig. 2: prices"],
        ),
        Section(
            title="Table 1",
            tables=[tables.paper_table1()],
            table_captions=["Published values"],
            figures=figures[2:],
        ),
        Section(
            title="Differences from the paper",
            paragraphs=["- synthetic reserve prices\n- typical-year weather"],
            code='[scenario]\nname = "rmpc-ppp"\npeak_price_sgd_per_kw = 1.5\n',
        ),
    ]
    return sections, figures


def test_report_embeds_every_figure_and_parses_cleanly(
    tmp_path: Path, report_inputs: tuple[list[Section], list[Path]]
) -> None:
    sections, figures = report_inputs
    path = write_report(tmp_path / "out", title="hvacflex reproduction", sections=sections)
    assert path == tmp_path / "out" / "report.html"
    text = path.read_text(encoding="utf-8")
    for figure in figures:
        encoded = base64.b64encode(figure.read_bytes()).decode("ascii")
        assert f'src="data:image/png;base64,{encoded}"' in text
    checker = StrictChecker()
    checker.feed(text)
    checker.close()
    assert checker.doctype
    assert checker.errors == []
    assert checker.stack == []
    # self-contained: no external resource, no script
    for tag, attrs in checker.tags:
        assert tag not in {"script", "link", "iframe"}
        value = attrs.get("src")
        assert value is None or value.startswith("data:")
        href = attrs.get("href")  # links only: to this page or the CSV beside the report
        assert href is None or href.startswith("#") or href.endswith(".csv")
        assert href is None or "://" not in href
    assert "A &lt; B &amp; C" in text
    assert "<li>typical-year weather</li>" in text
    assert "peak_price_sgd_per_kw = 1.5" in text
    assert "<caption>Published values</caption>" in text
    assert "1,471.00" in text
    assert 'Data: <a href="../fig/fig2_prices.csv">fig2_prices.csv</a>.' in text
    assert '<div class="table-scroll"><table class="hvacflex">' in text
    assert [t for t, a in checker.tags if t == "section"] == ["section"] * 3


def test_missing_or_non_png_figure_is_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not found"):
        png_data_uri(tmp_path / "missing.png")
    fake = tmp_path / "fake.png"
    fake.write_text("not a png")
    with pytest.raises(InputError, match="not a PNG"):
        write_report(tmp_path, title="t", sections=[Section(title="s", figures=[fake])])


def test_a_default_index_is_not_shown(tmp_path: Path) -> None:
    table = pd.DataFrame({"controller": ["nmpc", "rmpc"], "rank": [1, 2]})
    path = write_report(tmp_path, title="t", sections=[Section(title="s", tables=[table])])
    text = path.read_text(encoding="utf-8")
    assert "<th>Controller</th><th>Rank</th>" in text and "<th>0</th>" not in text
    assert "<th>nmpc</th>" in text  # the first column became the row label


def test_detail_columns_go_into_an_expandable_detail_with_the_row_labels(tmp_path: Path) -> None:
    table = pd.DataFrame(
        {"controller": ["nmpc", "rmpc"], "pays": [True, False], "energy_kwh": [1.0, 2.0]}
    )
    section = Section(title="s", tables=[table], table_details=[["energy_kwh"]])
    text = write_report(tmp_path, title="t", sections=[section]).read_text(encoding="utf-8")
    main, detail = text.split("<details", 1)
    assert "<th>Pays</th>" in main and "energy_kwh" not in main
    assert "<td>yes</td>" in main and "<td>no</td>" in main  # booleans as yes / no
    assert "<summary>More columns (1)</summary>" in detail
    assert "<th>energy_kwh</th>" in detail and "<th>rmpc</th>" in detail
    assert "<th>Pays</th>" in detail  # the first column is repeated with the row label
