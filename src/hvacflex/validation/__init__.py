"""Validation of the building model: ideal loads, free float, ASHRAE Standard 140 (BESTEST)."""
