"""Foundations: components' base classes, configuration schemas, the paper registry,
errors and validation. Imports nothing else of hgo."""
