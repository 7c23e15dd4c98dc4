"""Rerun blueprints of the operator console (the Python that builds them and the saved .rbl files)."""
