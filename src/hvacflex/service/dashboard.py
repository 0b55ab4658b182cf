"""The service's own pages: the operator dashboard at ``/`` and the API reference at
``/v1/docs``, both self-hosted (no CDN, no external request) and out of the OpenAPI schema.

The pages are static HTML with their script and styles inline (``pages/*.html``, shipped
with the package). The dashboard asks for the operator key in the page and keeps it in the
page's memory only: it is sent in the ``X-API-Key`` header of the page's requests to the
``/v1`` API, never in a URL. The responses forbid framing and any origin but the service
(Content-Security-Policy), so the page can load nothing from elsewhere.
"""

from __future__ import annotations

import functools
from importlib.resources import files

from fastapi import FastAPI
from fastapi.responses import HTMLResponse

from hvacflex.constants import TIMEZONE

DASHBOARD_PAGE = "dashboard.html"
"""The operator dashboard, served at ``/``."""

API_DOCS_PAGE = "api_docs.html"
"""The API reference rendered from ``/v1/openapi.json``, served at ``/v1/docs``."""

REFRESH_S = 5
"""Seconds between the dashboard's refreshes (the page reads it from a meta element)."""

CONTENT_SECURITY_POLICY = (
    "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; "
    "img-src data:; connect-src 'self'; base-uri 'none'; form-action 'none'; "
    "frame-ancestors 'none'"
)
"""What the pages may load: their own inline script and styles, and the service's API."""


@functools.cache
def page_html(name: str) -> str:
    """The text of a shipped page (``pages/<name>``), with ``{{REFRESH_S}}`` and
    ``{{TIME_ZONE}}`` (the buildings' time zone, in which the dashboard shows every time)
    filled in."""
    text = (files("hvacflex.service") / "pages" / name).read_text(encoding="utf-8")
    return text.replace("{{REFRESH_S}}", str(REFRESH_S)).replace("{{TIME_ZONE}}", TIMEZONE)


def _page(name: str) -> HTMLResponse:
    return HTMLResponse(
        page_html(name),
        headers={
            "Content-Security-Policy": CONTENT_SECURITY_POLICY,
            "X-Content-Type-Options": "nosniff",
            "Referrer-Policy": "no-referrer",
            "Cache-Control": "no-store",
        },
    )


def add_page_routes(app: FastAPI) -> None:
    """``GET /`` (the dashboard) and ``GET /v1/docs`` (the API reference); both are left out
    of the OpenAPI schema and need no key (the data they show is fetched with one)."""

    @app.get("/", include_in_schema=False)
    def dashboard() -> HTMLResponse:
        return _page(DASHBOARD_PAGE)

    @app.get("/v1/docs", include_in_schema=False)
    def api_docs() -> HTMLResponse:
        return _page(API_DOCS_PAGE)
