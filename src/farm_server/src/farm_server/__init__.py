"""The farm server: collects every robot's records, fuses them and plans each robot's day.

Modules: ``db`` (SQLAlchemy storage, SQLite or PostgreSQL, versioned migrations), ``schemas``
(pydantic wire format), ``fusion`` (fruit matching, ripening model, plans, yields; pure Python),
``app`` (FastAPI application), ``page`` (the web page), ``cli`` (the ``farm_server`` command).
"""
