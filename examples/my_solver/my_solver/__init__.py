"""A home-made hand-eye solver, plugged into rasc (see pyproject.toml)."""
