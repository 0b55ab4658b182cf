"""hvacflex as a live service between the grid and the building (``hvacflex serve``).

Layers: :mod:`.db` (tables, engine, Alembic migrations), :mod:`.keys` (API keys, hashed),
:mod:`.schemas` (request/response models with units and ranges), :mod:`.runtime` (one
controller per building, the same code as ``simulate``), :mod:`.app` (the FastAPI app under
``/v1``) and :mod:`.replay` (a client that plays the nonlinear plant as a building over HTTP).
See ``docs/service.md``.
"""
