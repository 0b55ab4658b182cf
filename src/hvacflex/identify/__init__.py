"""Identify a controller model (grey-box RC) from measured trend data (docs/guide/identify.md)."""
