"""Identification: fitting a scene's parameters to measurements (docs/identify.md)."""
