"""The evaluation server: method authors submit, the server scores against the withheld
answers (``dressmeup serve``; docs/server.md).

- :mod:`~dressmeup.server.config`: :class:`ServerConfig` (folders, database, limits);
- :mod:`~dressmeup.server.db`: the tables (teams, editions, submissions) and their Alembic
  migrations (:func:`~dressmeup.server.db.migrate`); SQLite by default, PostgreSQL by URL;
- :mod:`~dressmeup.server.accounts`: teams and their API tokens (stored only as hashes);
- :mod:`~dressmeup.server.uploads`: streamed uploads with a size limit, safe unpacking,
  validation with the toolkit's validator;
- :mod:`~dressmeup.server.scoring`: the background scorer (exactly once, across restarts);
- :mod:`~dressmeup.server.pages`: the public leaderboard pages (the report site of the
  published results);
- :mod:`~dressmeup.server.app`: the HTTP API and pages (FastAPI on uvicorn).
"""
