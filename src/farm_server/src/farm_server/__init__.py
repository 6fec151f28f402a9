"""The farm server: collects every robot's records, fuses them and plans each robot's day.

Modules: ``db`` (SQLAlchemy storage, SQLite or PostgreSQL) and ``db_schema`` (tables, versioned
migrations), ``schemas`` (pydantic wire format), ``fusion`` (``fuse()``; pure Python, as are
``fusion_config`` (parameters, local time), ``ripening`` (a fruit's ripening model), ``matching``
(fruit matching within a row) and ``farm_state`` (plans, yields, fruit report)), ``app`` (FastAPI
application), ``page`` (the web page), ``cli`` (the ``farm_server`` command).
"""
