"""Alembic environment of the server's database: online migrations only, the URL from the
configuration :func:`dressmeup.server.db.alembic_config` builds."""

from __future__ import annotations

from alembic import context
from sqlalchemy import create_engine

from dressmeup.server.db import Base

config = context.config
url = config.get_main_option("sqlalchemy.url")
engine = create_engine(url)
with engine.connect() as connection:
    context.configure(connection=connection, target_metadata=Base.metadata,
                      render_as_batch=url.startswith("sqlite"))
    with context.begin_transaction():
        context.run_migrations()
engine.dispose()
