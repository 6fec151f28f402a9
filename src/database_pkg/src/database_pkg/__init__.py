"""Data layer: local SQLite store of observations and mission records."""
