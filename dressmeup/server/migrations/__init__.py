"""Alembic migrations of the server's database (``dressmeup.server.db.migrate``)."""
