"""Tables, figures and provenance files."""

from .tables import write_json, write_table

__all__ = ["write_table", "write_json"]
