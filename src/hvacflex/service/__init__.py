"""hvacflex as a live service between the grid and the building (``hvacflex serve``).

Layers: :mod:`.db` (tables, engine, Alembic migrations), :mod:`.keys` (API keys, hashed),
:mod:`.schemas` (request/response models with units and ranges), :mod:`.runtime` (one
controller per building, the same code as ``simulate``), :mod:`.planner` (planning off the
request path), :mod:`.payload` (a decision as the plan's JSON), :mod:`.http` (envelope,
middleware, error handlers, key checks), :mod:`.app` (the FastAPI routes under ``/v1``),
:mod:`.dashboard` (the self-hosted pages), :mod:`.operations` (metrics, logs, stale
buildings), :mod:`.openadr` with :mod:`.openadr_mapping` and :mod:`.openadr_store` (the
OpenADR 2.0b VEN) and :mod:`.replay` (a client that plays the nonlinear plant as a building
over HTTP).
See ``docs/guide/service.md``.
"""
